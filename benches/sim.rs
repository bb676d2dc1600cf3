//! Simulation speed: simulated seconds per wall-clock second for a 60 s so101 sequence, with the
//! harness start-up (Python, MuJoCo import, model load) included and excluded, and the same run
//! in one request and in the 1 s chunks `keypose play` uses for its progress line.
//!
//! `cargo bench --bench sim`. The Python environment is built once in target/ (not timed).

use keypose::plan::{TimelineOptions, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::sim::{command_stream, Simulation};
use std::time::Instant;

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

fn main() {
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        println!("sim bench: run with `cargo bench --bench sim`");
        return;
    }
    if std::env::var_os("KEYPOSE_PYTHON").is_none() && std::env::var_os("KEYPOSE_CACHE").is_none() {
        std::env::set_var(
            "KEYPOSE_CACHE",
            concat!(env!("CARGO_MANIFEST_DIR"), "/target/tmp/bench_sim_cache"),
        );
    }
    let robot = Robot::builtin("so101").expect("so101");
    let sequence = Sequence::from_json("sixty.json", &sixty_seconds()).expect("sequence");
    let trajectory = Trajectory::build(&sequence, &robot).expect("trajectory");
    let stream = command_stream(
        &robot,
        &trajectory,
        &TimelineOptions::default(),
        robot.control_hz,
    );
    let simulated = stream.rows.len() as f64 / stream.rate;

    // Build the environment outside the timing.
    drop(Simulation::start(&robot, None, None).expect("simulation"));

    let mut rows = Vec::new();
    for _ in 0..3 {
        let started = Instant::now();
        let mut sim = Simulation::start(&robot, None, None).expect("simulation");
        let ready = Instant::now();
        let trace = sim
            .run(&robot, &stream, 0..stream.rows.len(), true)
            .expect("run");
        let done = Instant::now();
        assert_eq!(trace.time.len(), stream.rows.len());
        let chunk = stream.rate as usize;
        let chunked_start = Instant::now();
        let mut start = 0;
        while start < stream.rows.len() {
            let end = (start + chunk).min(stream.rows.len());
            sim.run(&robot, &stream, start..end, start == 0)
                .expect("chunk");
            start = end;
        }
        let chunked = chunked_start.elapsed().as_secs_f64();
        rows.push((
            (ready - started).as_secs_f64(),
            (done - ready).as_secs_f64(),
            (done - started).as_secs_f64(),
            chunked,
        ));
    }
    rows.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (startup, run, total, chunked) = rows[1];
    println!("summary: | so101, {simulated:.1} s simulated at 100 Hz control, 2 ms physics | median of 3 |");
    println!("summary: | harness start-up (Python, MuJoCo, model) | {startup:.2} s |");
    println!("summary: | one request, start-up excluded | {run:.2} s wall = {:.1} simulated s per wall s |", simulated / run);
    println!("summary: | one request, start-up included | {total:.2} s wall = {:.1} simulated s per wall s |", simulated / total);
    println!("summary: | 1 s chunks (as `play` for its progress line) | {chunked:.2} s wall = {:.1} simulated s per wall s |", simulated / chunked);
}
