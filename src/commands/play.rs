//! `keypose play`: stream a sequence to the servos.

use super::hardware::BusArgs;
use super::{option_values, parse_rate, CommandError, SequenceInput, Verdict};
use crate::plan::{check_at_speed, Trajectory};
use crate::player::{self, Loops, Outcome, PlayError, PlayOptions, StopSignal};
use crate::report;
use crate::terminal_text::escape_controls;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct PlayArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Control rate [default: the robot's control_hz].
    #[arg(long, value_name = "HZ", value_parser = parse_rate)]
    pub rate: Option<f64>,
    /// Time scale: 0.5 plays at half speed, 2 at double (limits are checked at this speed).
    #[arg(long, value_name = "F", default_value = "1", value_parser = option_values::parse_speed, allow_negative_numbers = true)]
    pub speed: f64,
    /// How many times to play: a number, or "forever".
    #[arg(long = "loop", value_name = "N|forever", default_value = "1", value_parser = parse_loops, allow_negative_numbers = true)]
    pub loops: Loops,
    /// Play forwards then backwards (each pass counts as one loop) instead of ramping back.
    #[arg(long)]
    pub ping_pong: bool,
    /// Start at this key: its index (0-based) or its name.
    #[arg(long, value_name = "KEY", allow_negative_numbers = true)]
    pub from: Option<String>,
    /// Do not ramp from the measured pose to the first pose: the arm JUMPS there at full servo
    /// speed. Needs --i-accept-the-jump.
    #[arg(long)]
    pub no_approach: bool,
    /// Confirms --no-approach.
    #[arg(long, requires = "no_approach")]
    pub i_accept_the_jump: bool,
    /// Release torque at the end, once the final pose is reached.
    #[arg(long)]
    pub release_at_end: bool,
    /// Read present positions every N cycles (0: never).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = option_values::parse_readback, allow_negative_numbers = true)]
    pub readback: u32,
    /// Write commanded and measured positions and cycle lateness to a CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub log: Option<PathBuf>,
    /// No progress line.
    #[arg(long, short)]
    pub quiet: bool,
}

fn parse_loops(s: &str) -> Result<Loops, String> {
    if s == "forever" {
        return Ok(Loops::Forever);
    }
    match s.parse::<u32>() {
        Ok(n) if n >= 1 => Ok(Loops::Count(n)),
        _ => Err(format!(
            "expected a number of loops (1 or more) or \"forever\", found {s:?}"
        )),
    }
}

pub fn run(args: &PlayArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    if args.no_approach && !args.i_accept_the_jump {
        return Err(CommandError::Usage(
            "--no-approach makes the arm jump to the first pose at full speed; add --i-accept-the-jump to confirm".into(),
        ));
    }
    let from_key = match &args.from {
        None => None,
        Some(key) => Some(resolve_key(&trajectory, key).ok_or_else(|| {
            CommandError::Usage(format!(
                "--from {key:?}: no such key; expected an index 0…{} or one of: {}",
                trajectory.key_times.len() - 1,
                trajectory.key_labels.join(", ")
            ))
        })?),
    };
    let rate = args.rate.unwrap_or(robot.control_hz);
    super::check_sample_budget(&sequence.file, &trajectory, rate)?;

    // Refuse what the servos would be asked to do beyond their limits at this speed.
    let report = check_at_speed(&trajectory, &robot, rate, args.speed);
    if !report.passed() {
        let text = report::check_text(&report, &sequence.file, &robot);
        eprint!("{}", escape_controls(&text));
        eprintln!(
            "refusing to play: the sequence breaks the limits above at speed {} (try `keypose retime`, or a lower --speed)",
            args.speed
        );
        return Ok(Verdict::Fail);
    }

    let options = PlayOptions {
        speed: args.speed,
        loops: args.loops,
        ping_pong: args.ping_pong,
        from_key,
        approach: !args.no_approach,
        release_at_end: args.release_at_end,
        readback_every: (args.readback > 0).then_some(args.readback),
        log: args.log.clone(),
        progress: !args.quiet,
        ..PlayOptions::new(rate)
    };
    let Some(port) = &args.bus.port else {
        // No hardware: play in MuJoCo, with the same commands the servos would get.
        if args.loops == Loops::Forever {
            return Err(CommandError::Usage(
                "--loop forever needs servos (--port); in simulation give a number of loops".into(),
            ));
        }
        let result = super::sim::simulate(&sequence, &robot, &trajectory, &options, None)?;
        print!(
            "{}",
            escape_controls(&super::sim::table(&sequence.file, &result))
        );
        return Ok(if result.verdict.passed() {
            Verdict::Pass
        } else {
            Verdict::Fail
        });
    };
    let mut connection = args.bus.connect(&robot, port)?;
    let stop = StopSignal::default();
    let handler_stop = stop.clone();
    // Only the first handler registration in a process succeeds; a second `play` in the same
    // process (tests) keeps the first handler, which is harmless.
    let _ = ctrlc::set_handler(move || handler_stop.request());

    if !args.quiet {
        eprintln!(
            "playing {} on {} at {rate} Hz, speed {}",
            sequence.file,
            connection.bus.describe(),
            args.speed
        );
    }
    match player::play(
        connection.bus.as_mut(),
        &robot,
        &trajectory,
        &options,
        &stop,
    ) {
        Ok((Outcome::Finished, stats)) => {
            if !args.quiet {
                eprintln!(
                    "done: {} cycles, approach {:.2} s, largest tracking error {:.2}",
                    stats.cycles, stats.approach_seconds, stats.max_tracking_error
                );
            }
            Ok(Verdict::Pass)
        }
        Ok((Outcome::Stopped, _)) => Err(CommandError::Interrupted(
            "stopped on request: the arm decelerated along its path and holds there, torque on"
                .into(),
        )),
        Ok((Outcome::Held, _)) => Err(CommandError::Interrupted(
            "held at once on a second request: torque on".into(),
        )),
        Err(e @ PlayError::Log { .. }) => Err(CommandError::Usage(e.to_string())),
        Err(e) => Err(CommandError::Hardware(format!("playback stopped: {e}"))),
    }
}

/// A key by index or by name.
fn resolve_key(trajectory: &Trajectory, key: &str) -> Option<usize> {
    match key.parse::<usize>() {
        Ok(i) if i < trajectory.key_times.len() => Some(i),
        Ok(_) => None,
        Err(_) => trajectory.key_labels.iter().position(|l| l == key),
    }
}
