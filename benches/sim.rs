//! Simulation speed: simulated seconds per wall-clock second of a 60 s so101 sequence, three
//! ways, in the same run and interleaved:
//!
//! 1. **The CLI, start-up included**: `keypose sim sixty.json`, the built binary, timed from
//!    spawn to exit — loading and checking the sequence, starting Python and MuJoCo, loading the
//!    model, the run in the 1 s chunks its progress line follows, and the verdict. What a user
//!    waits for.
//! 2. **Bare MuJoCo**, the peer: `benches/bare_mujoco.py` with keypose's Python environment, the
//!    same model (`sim/models/so101.xml`) and the same command rows (the stream `keypose sim`
//!    sends: approach ramp, the sequence at 100 Hz, the 0.5 s hold it judges settling by), one
//!    control period of 2 ms physics steps per row, nothing recorded. Timed from spawn to exit
//!    (start-up included, as the CLI), and its stepping loop alone as the script times it.
//! 3. **The library**, to show where the CLI's time goes: harness start-up (Python, MuJoCo
//!    import, model load), the run in one request (as `sim`), and in the 1 s chunks `play`
//!    uses without a port.
//!
//! Each way runs [`REPS`] times after one untimed run (which also builds the Python environment
//! if needed); figures are the median and range over the repeats, ratios taken repeat by repeat.
//! `cargo bench --bench sim` prints the load average and lines starting with `summary:`.

mod common;

use keypose::plan::Trajectory;
use keypose::player::PlayOptions;
use keypose::robot::{JointKind, Robot};
use keypose::sequence::Sequence;
use keypose::sim::verdict::Thresholds;
use keypose::sim::{command_stream, CommandStream, Simulation};
use serde::Deserialize;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Timed repetitions of each way.
const REPS: usize = 5;

/// 60 s of slow waves on four joints, within every so101 limit.
fn sixty_seconds() -> String {
    let keys: Vec<String> = (0..=30)
        .map(|k| {
            let s = if k % 2 == 0 { 1.0 } else { -1.0 };
            let (lift, elbow, wrist, pan) = if k == 0 || k == 30 {
                (0.0, 0.0, 0.0, 0.0)
            } else {
                (-20.0 * s, 30.0 * s, -25.0 * s, 40.0 * s)
            };
            format!(
                r#"{{"time":{},"joints":{{"shoulder_pan":{pan},"shoulder_lift":{lift},"elbow_flex":{elbow},"wrist_flex":{wrist}}}}}"#,
                k as f64 * 2.0
            )
        })
        .collect();
    format!(
        r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[{}]}}"#,
        keys.join(",")
    )
}

/// The rows `keypose sim` sends for `trajectory` (src/commands/sim.rs `simulate`).
fn cli_stream(robot: &Robot, trajectory: &Trajectory) -> CommandStream {
    let options = PlayOptions::new(robot.control_hz);
    let mut stream = command_stream(robot, trajectory, &options.timeline, options.rate_hz);
    stream.hold_at_end(Thresholds::default().settle_time, options.timeline.speed);
    stream
}

/// A joint value in MuJoCo's unit (radians for revolute joints).
fn to_model(robot: &Robot, values: &[f64]) -> Vec<f64> {
    robot
        .joints
        .iter()
        .zip(values)
        .map(|(j, &v)| match j.kind {
            JointKind::Revolute => v.to_radians(),
            JointKind::Prismatic => v,
        })
        .collect()
}

/// The bare script's input file.
fn write_commands(robot: &Robot, stream: &CommandStream, path: &Path) {
    let request = serde_json::json!({
        "mjcf": format!("{}/sim/models/{}.xml", env!("CARGO_MANIFEST_DIR"), robot.name),
        "joints": robot.joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>(),
        "control_hz": stream.rate,
        "initial": to_model(robot, &stream.initial),
        "commands": stream.rows.iter().map(|r| to_model(robot, r)).collect::<Vec<_>>(),
    });
    std::fs::write(path, request.to_string()).expect("write the commands");
}

/// What the bare script says of its own run.
#[derive(Deserialize)]
struct Bare {
    import_s: f64,
    input_s: f64,
    load_s: f64,
    run_s: f64,
    rows: usize,
    simulated_s: f64,
}

/// One repeat of every way, seconds.
struct Repeat {
    cli_wall: f64,
    bare_wall: f64,
    bare: Bare,
    startup: f64,
    one_request: f64,
    chunked: f64,
}

fn cli(sequence: &Path) -> f64 {
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_keypose"))
        .arg("sim")
        .arg(sequence)
        .output()
        .expect("run keypose sim");
    let wall = started.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "keypose sim failed ({}): {}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    wall
}

fn bare(python: &Path, commands: &Path) -> (f64, Bare) {
    let started = Instant::now();
    let out = Command::new(python)
        .arg(common::bench_script("bare_mujoco.py"))
        .arg(commands)
        .output()
        .expect("run python");
    let wall = started.elapsed().as_secs_f64();
    assert!(
        out.status.success(),
        "bare_mujoco.py failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let line = String::from_utf8_lossy(&out.stdout);
    let figures = serde_json::from_str(line.trim())
        .unwrap_or_else(|e| panic!("bare_mujoco.py said {line:?}: {e}"));
    (wall, figures)
}

/// Harness start-up, one request, and 1 s chunks through the library.
fn library(robot: &Robot, stream: &CommandStream) -> (f64, f64, f64) {
    let started = Instant::now();
    let mut sim = Simulation::start(robot, None, None).expect("simulation");
    let ready = Instant::now();
    let trace = sim
        .run(robot, stream, 0..stream.rows.len(), true)
        .expect("run");
    let done = Instant::now();
    assert_eq!(trace.time.len(), stream.rows.len());
    let chunk = stream.rate as usize;
    let chunked = Instant::now();
    let mut start = 0;
    while start < stream.rows.len() {
        let end = (start + chunk).min(stream.rows.len());
        sim.run(robot, stream, start..end, start == 0)
            .expect("chunk");
        start = end;
    }
    (
        (ready - started).as_secs_f64(),
        (done - ready).as_secs_f64(),
        chunked.elapsed().as_secs_f64(),
    )
}

fn main() {
    if !common::is_bench_run() {
        println!("sim bench: run with `cargo bench --bench sim`");
        return;
    }
    let session = common::Session::start("sim");
    common::use_shared_python_cache();
    let robot = Robot::builtin("so101").expect("so101");
    let text = sixty_seconds();
    let sequence = Sequence::from_json("sixty.json", &text).expect("sequence");
    let trajectory = Trajectory::build(&sequence, &robot).expect("trajectory");
    let stream = cli_stream(&robot, &trajectory);
    let simulated = stream.rows.len() as f64 / stream.rate;

    let dir = tempfile::tempdir().expect("a temporary directory");
    let sequence_path = dir.path().join("sixty.json");
    std::fs::write(&sequence_path, &text).expect("write the sequence");
    let commands = dir.path().join("commands.json");
    write_commands(&robot, &stream, &commands);
    let python = common::python().expect("keypose's Python environment (MuJoCo)");

    // Untimed: builds the environment if needed and the bytecode Python compiles in it (which
    // the bare script then reads too), warms the file cache.
    cli(&sequence_path);
    let (_, first) = bare(&python, &commands);
    assert_eq!(first.rows, stream.rows.len(), "the same rows");
    library(&robot, &stream);

    let repeats: Vec<Repeat> = (0..REPS)
        .map(|_| {
            let cli_wall = cli(&sequence_path);
            let (bare_wall, bare) = bare(&python, &commands);
            let (startup, one_request, chunked) = library(&robot, &stream);
            Repeat {
                cli_wall,
                bare_wall,
                bare,
                startup,
                one_request,
                chunked,
            }
        })
        .collect();

    let seconds = |f: fn(&Repeat) -> f64| common::Spread::over(&repeats, f).show(2);
    let speed =
        |f: fn(&Repeat) -> f64| common::Spread::over(&repeats, |r| simulated / f(r)).show(0);
    let cli_speed: Vec<f64> = repeats.iter().map(|r| simulated / r.cli_wall).collect();
    let bare_speed: Vec<f64> = repeats.iter().map(|r| simulated / r.bare_wall).collect();
    let bare_loop: Vec<f64> = repeats.iter().map(|r| simulated / r.bare.run_s).collect();
    println!();
    println!(
        "summary: so101, {simulated:.1} s simulated ({} rows at {} Hz control, 2 ms physics, the \
         rows `keypose sim` sends); median (range) of {REPS} interleaved repeats; {}",
        stream.rows.len(),
        stream.rate,
        session.load()
    );
    println!("summary: | way | wall | simulated s per wall s |");
    println!("summary: |---|---|---|");
    println!(
        "summary: | `keypose sim` (the CLI), start-up included | {} s | {} |",
        seconds(|r| r.cli_wall),
        speed(|r| r.cli_wall)
    );
    println!(
        "summary: | bare MuJoCo (Python loop of mj_step), start-up included | {} s | {} |",
        seconds(|r| r.bare_wall),
        speed(|r| r.bare_wall)
    );
    println!(
        "summary: | bare MuJoCo, its stepping loop alone | {} s | {} |",
        seconds(|r| r.bare.run_s),
        speed(|r| r.bare.run_s)
    );
    println!(
        "summary: | ratio CLI / bare MuJoCo, both with start-up | | {} |",
        common::Spread::ratio(&cli_speed, &bare_speed).show(2)
    );
    println!(
        "summary: | ratio CLI / bare MuJoCo's loop | | {} |",
        common::Spread::ratio(&cli_speed, &bare_loop).show(2)
    );
    println!(
        "summary: | bare MuJoCo's start-up: import {} s, commands read {} s, model load {} s | | |",
        common::Spread::over(&repeats, |r| r.bare.import_s).show(2),
        common::Spread::over(&repeats, |r| r.bare.input_s).show(2),
        common::Spread::over(&repeats, |r| r.bare.load_s).show(3),
    );
    println!(
        "summary: | library: harness start-up (Python, MuJoCo, model) | {} s | |",
        seconds(|r| r.startup)
    );
    println!(
        "summary: | library: one request, start-up excluded | {} s | {} |",
        seconds(|r| r.one_request),
        speed(|r| r.one_request)
    );
    println!(
        "summary: | library: 1 s chunks (as `play` without a port), start-up excluded | {} s | {} |",
        seconds(|r| r.chunked),
        speed(|r| r.chunked)
    );
    let simulated_by_bare = common::median(
        &repeats
            .iter()
            .map(|r| r.bare.simulated_s)
            .collect::<Vec<_>>(),
    );
    println!("summary: (bare MuJoCo's clock at the end: {simulated_by_bare:.3} s)");
    session.end();
}
