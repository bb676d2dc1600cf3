//! `keypose studio`: the teaching session in the browser, with the arm in 3D. The session is
//! opened as `keypose teach` opens it ([`super::teach::open`]), or without `--port` on a drawn
//! arm (nothing sent anywhere); the page is a second front end to the same state machine.

use super::teach::{self, SessionArgs, WithoutPort};
use super::{CommandError, Verdict};
use keypose::plan::Trajectory;
use keypose::player::PlayOptions;
use keypose::sim::WarmSimulation;
use keypose::studio::engine::Ended;
use keypose::studio::{Simulator, Studio};
use serde_json::json;
use std::io::Write;
use std::net::SocketAddr;
use std::sync::Mutex;

#[derive(Debug, Clone, clap::Args)]
pub struct StudioArgs {
    #[command(flatten)]
    pub session: SessionArgs,
    /// Address to serve the page on; port 0 picks a free one. Anything but a loopback address
    /// lets other machines reach the studio (with the token, which then crosses the network
    /// in clear: plain HTTP); the studio warns about it.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:0")]
    pub listen: SocketAddr,
}

pub fn run(args: &StudioArgs) -> Result<Verdict, CommandError> {
    let listen = |_: &keypose::robot::Robot| {
        Studio::listen(args.listen).map_err(|e| CommandError::Usage(e.to_string()))
    };
    // Without --port the arm is drawn only: the page edits the sequence, nothing is sent.
    let (mut opened, studio) = teach::open(&args.session, WithoutPort::Drawn, listen)?;
    // The URL is the first line of standard output, flushed at once: scripts and tests read
    // it from there.
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{}", studio.url())
        .and_then(|_| stdout.flush())
        .map_err(|e| CommandError::Output {
            path: "standard output".into(),
            source: e,
        })?;
    drop(stdout);
    eprintln!("studio: open the URL above in a browser; Ctrl-C stops the arm and ends the studio");
    if !studio.addr().ip().is_loopback() {
        eprintln!(
            "studio: WARNING: {} is not a loopback address: other machines can reach the studio, \
             and the page's token crosses the network in clear (plain HTTP) with every request; \
             anyone who can see the traffic can drive the arm. Use it on a trusted network only",
            studio.addr()
        );
    }
    let ended = studio
        .run(&mut opened.state, &mut opened.session, Some(simulator()))
        .map_err(|e| match e {
            keypose::studio::StudioError::Teach(e) => CommandError::Teach(e),
            other => CommandError::Hardware(other.to_string()),
        })?;
    let status = opened.state.status().text.clone();
    let unsaved = if opened.state.is_dirty() && opened.state.journal().is_some() {
        " (unsaved changes stay in the journal: the next studio or teach of this file offers them)"
    } else {
        ""
    };
    match ended {
        Ended::Quit => {
            eprintln!(
                "studio: {}",
                keypose::terminal_text::escape_message(&status)
            );
            Ok(Verdict::Pass)
        }
        Ended::Interrupted => Err(CommandError::Interrupted(format!(
            "studio ended by Ctrl-C; the arm holds where it is{unsaved}"
        ))),
        Ended::ServerFault(what) => {
            // What the braked arm did, then why the studio ended.
            eprintln!(
                "studio: {}",
                keypose::terminal_text::escape_controls(&status)
            );
            Err(CommandError::Hardware(format!(
                "the studio's server failed ({}); the arm was braked and holds where it \
                 stopped{unsaved}",
                keypose::terminal_text::escape_controls(&what)
            )))
        }
    }
}

/// Most trace rows sent to the page: a minute at the highest control rate is far fewer.
const MAX_TRACE_ROWS: usize = 20_000;

/// `keypose sim` for the page: the list played in MuJoCo at the robot's control rate, the
/// report `sim --report` writes, and the measured trace to replay on the 3D arm. The session's
/// simulations share one harness, started by the first: pressing Simulate again pays for
/// Python and MuJoCo no more.
fn simulator() -> Simulator {
    let warm = Mutex::new(WarmSimulation::new());
    Box::new(move |sequence, robot| {
        let trajectory = Trajectory::build(sequence, robot)?;
        let options = PlayOptions::new(robot.control_hz);
        let mut warm = warm.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let result = super::sim::simulate(&mut warm, sequence, robot, &trajectory, &options, None)?;
        let trace = &result.trace;
        let rows = trace
            .time
            .len()
            .min(trace.position.len())
            .min(MAX_TRACE_ROWS);
        Ok(json!({
            "report": super::sim::report_json(&sequence.file, robot, &result),
            "trace": {
                "time": &trace.time[..rows],
                "sequence_time": &trace.sequence_time[..rows.min(trace.sequence_time.len())],
                "position": &trace.position[..rows],
                "commanded": &trace.commanded[..rows.min(trace.commanded.len())],
            },
        }))
    })
}
