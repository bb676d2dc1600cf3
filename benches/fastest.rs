//! `retime --fastest` against TOPP-RA: on every example of `sequences/`, the moving time keypose's
//! timing profiles give and the time-optimal one TOPP-RA (the `toppra` package, in keypose's
//! Python environment, run in the same process tree beside it) finds on the same path under the
//! same velocity and acceleration limits, and their ratio; then TOPP-RA with each servo's
//! torque-speed line too (the torques by MuJoCo's `mj_inverse`), which `--fastest` plans for.
//! Moving time is that of the paths the profiles time (holds, steps and pauses keep their time
//! in both). The machine's load is printed, and how long each side took to compute (a ratio of
//! times on a shared machine).
//!
//! With jerk limits (each joint's acceleration limit reached in `ruckig::RISE_SECONDS`): the
//! moving time `--fastest` gives with its S-curve profiles, which stop at every key (checked
//! exactly with jerk), against TOPP-RA's optimum without jerk limits from the first table, and
//! point-to-point moves between the example's consecutive keys, keypose's S-curve along the
//! straight line (`plan::scurve::point_to_point`) against Ruckig's time-optimal jerk-limited
//! move (the `ruckig` package) under the same limits, summed per example.
//!
//! `cargo bench --bench fastest` (no criterion: one plan per example, checked exactly before
//! anything is printed).

mod common;
#[path = "common/oracle.rs"]
mod oracle;
#[path = "common/ruckig.rs"]
mod ruckig;
#[path = "common/topp.rs"]
mod topp;

use keypose::plan::{builtin_robot_of, check, fastest, scurve, Trajectory};
use keypose::python::PyConfig;
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use std::time::Instant;

fn main() {
    let session = common::Session::start("fastest");
    let python = PyConfig::from_env()
        .and_then(|config| config.ensure_python())
        .unwrap_or_else(|e| panic!("keypose's Python environment (with toppra) is needed: {e}"))
        .python;
    let mut files: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/sequences"))
        .expect("sequences/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    println!(
        "{:<28} {:>9} {:>9} {:>9} {:>7} {:>10} {:>7} {:>6} {:>9} {:>9}",
        "example",
        "as keyed",
        "fastest",
        "TOPP-RA",
        "ratio",
        "+ lines",
        "ratio",
        "rounds",
        "plan ms",
        "toppra ms"
    );
    let mut line_ratios = Vec::new();
    let mut ratios = Vec::new();
    let mut version = String::new();
    let mut optima = Vec::new();
    for file in &files {
        let sequence = Sequence::load(file).expect("an example loads");
        let robot = builtin_robot_of(&sequence).expect("an example's robot is built in");
        let rate = robot.control_hz;
        let started = Instant::now();
        let outcome = fastest(&sequence, &robot, rate).expect("an example retimes");
        let plan_ms = started.elapsed().as_secs_f64() * 1e3;
        let checked = check(
            &Trajectory::build(&outcome.sequence, &robot).unwrap(),
            &robot,
            rate,
        );
        assert!(
            checked.passed(),
            "{}: {:?}",
            file.display(),
            checked.violations
        );
        let request = topp::request(&outcome, &robot);
        let started = Instant::now();
        let (durations, toppra) =
            topp::toppra_durations(&python, &request).unwrap_or_else(|e| panic!("{e}"));
        let toppra_ms = started.elapsed().as_secs_f64() * 1e3;
        version = toppra;
        let ours: f64 = outcome.runs.iter().map(|r| r.seconds).sum();
        let theirs: f64 = durations.iter().sum();
        let (keyed, _) = outcome.moving_time();
        let ratio = ours / theirs;
        ratios.push(ratio);
        optima.push(theirs);
        // TOPP-RA with each servo's torque-speed line too, the torques by MuJoCo's inverse
        // dynamics: what --fastest plans for.
        let (with_lines, _) =
            topp::toppra_durations(&python, &topp::request_with_torque(&outcome, &robot))
                .unwrap_or_else(|e| panic!("{e}"));
        let lines: f64 = with_lines.iter().sum();
        line_ratios.push(ours / lines);
        println!(
            "{:<28} {:>8.3}s {:>8.3}s {:>8.3}s {:>7.3} {:>9.3}s {:>7.3} {:>6} {:>9.1} {:>9.1}",
            file.file_name().unwrap().to_string_lossy(),
            keyed,
            ours,
            theirs,
            ratio,
            lines,
            ours / lines,
            outcome.rounds,
            plan_ms,
            toppra_ms
        );
    }
    println!(
        "fastest / TOPP-RA (toppra {version}): median {:.3}, worst {:.3}, over {} examples; {}",
        common::median(&ratios),
        ratios.iter().cloned().fold(f64::NAN, f64::max),
        ratios.len(),
        session.load()
    );
    println!(
        "fastest / TOPP-RA with the servos' torque-speed lines: median {:.3}, worst {:.3}",
        common::median(&line_ratios),
        line_ratios.iter().cloned().fold(f64::NAN, f64::max),
    );
    jerk_limited(&python, &files, &optima);
    session.end();
}

/// The second table: with jerk limits, `--fastest` against TOPP-RA's optimum without them
/// (`optima`, per file, from the first table), and point-to-point moves against Ruckig.
fn jerk_limited(python: &std::path::Path, files: &[std::path::PathBuf], optima: &[f64]) {
    println!();
    println!(
        "jerk limits: each joint's acceleration limit reached in {} s",
        ruckig::RISE_SECONDS
    );
    println!(
        "{:<28} {:>9} {:>8} {:>9} {:>7} {:>7} {:>6} {:>10} {:>10} {:>7}",
        "example",
        "fastest",
        "check",
        "TOPP-RA",
        "ratio",
        "holds+",
        "moves",
        "S-curves",
        "Ruckig",
        "ratio"
    );
    let mut ratios = Vec::new();
    let mut over_toppra = Vec::new();
    let mut version = String::new();
    // Every example's point-to-point moves, for the solve times after the table.
    let mut all_moves: Vec<(Robot, Vec<f64>, Vec<f64>)> = Vec::new();
    for (file, optimum) in files.iter().zip(optima) {
        let sequence = Sequence::load(file).expect("an example loads");
        let robot = ruckig::with_jerk(
            &builtin_robot_of(&sequence).expect("an example's robot is built in"),
            ruckig::RISE_SECONDS,
        );
        let outcome = fastest(&sequence, &robot, robot.control_hz).expect("an example retimes");
        let seconds: f64 = outcome.runs.iter().map(|r| r.seconds).sum();
        // Holds a joint moves through that had to grow (moving time leaves holds out).
        let longer = (outcome.holds.iter()).fold(0.0, |sum, (_, a, b)| sum + b - a);
        let verdict = if outcome.report.passed() {
            "ok".to_string()
        } else {
            format!("{} left", outcome.report.violations.len())
        };
        // Point to point between the poses at consecutive keys.
        let trajectory = Trajectory::build(&sequence, &robot).expect("an example builds");
        let poses: Vec<Vec<f64>> = trajectory
            .key_times
            .iter()
            .map(|&t| trajectory.sample(t))
            .collect();
        let pairs: Vec<(&Vec<f64>, &Vec<f64>)> = poses
            .windows(2)
            .map(|w| (&w[0], &w[1]))
            .filter(|(a, b)| a != b)
            .collect();
        let ours: f64 = pairs
            .iter()
            .filter_map(|(a, b)| scurve::point_to_point(&robot, a, b, 1.0))
            .map(|c| c.duration())
            .sum();
        let moves: Vec<serde_json::Value> = pairs
            .iter()
            .map(|(a, b)| ruckig::move_request(&robot, a, b, ruckig::Sync::Time))
            .collect();
        let (durations, ruckig_version) =
            ruckig::ruckig_durations(python, &moves).unwrap_or_else(|e| panic!("{e}"));
        version = ruckig_version;
        let theirs: f64 = durations.iter().sum();
        let ratio = ours / theirs;
        all_moves.extend(
            pairs
                .iter()
                .map(|(a, b)| (robot.clone(), a.to_vec(), b.to_vec())),
        );
        ratios.push(ratio);
        over_toppra.push(seconds / optimum);
        println!(
            "{:<28} {:>8.3}s {:>8} {:>8.3}s {:>7.3} {:>6.3}s {:>6} {:>9.3}s {:>9.3}s {:>7.3}",
            file.file_name().unwrap().to_string_lossy(),
            seconds,
            verdict,
            optimum,
            seconds / optimum,
            longer,
            pairs.len(),
            ours,
            theirs,
            ratio
        );
    }
    println!(
        "fastest with jerk / TOPP-RA without: median {:.3}, worst {:.3}",
        common::median(&over_toppra),
        over_toppra.iter().cloned().fold(f64::NAN, f64::max),
    );
    println!(
        "point to point / Ruckig (ruckig {version}, time-synchronised): median {:.3}, worst {:.3}, over {} examples",
        common::median(&ratios),
        ratios.iter().cloned().fold(f64::NAN, f64::max),
        ratios.len(),
    );
    solve_times(python, &all_moves);
}

/// Solves of each point-to-point move timed: keypose's closed form against Ruckig's
/// `calculate` (C++, timed inside its Python binding), the same moves in the same run.
fn solve_times(python: &std::path::Path, moves: &[(Robot, Vec<f64>, Vec<f64>)]) {
    const REPEAT: u32 = 200;
    let start = Instant::now();
    for (robot, a, b) in moves {
        for _ in 0..REPEAT {
            std::hint::black_box(scurve::point_to_point(robot, a, b, 1.0));
        }
    }
    let ours = start.elapsed().as_secs_f64() / (moves.len() as f64 * f64::from(REPEAT));
    let requests: Vec<serde_json::Value> = moves
        .iter()
        .map(|(robot, a, b)| ruckig::move_request(robot, a, b, ruckig::Sync::Time))
        .collect();
    let theirs = ruckig::ruckig_seconds_per_solve(python, &requests, REPEAT)
        .unwrap_or_else(|e| panic!("{e}"));
    println!(
        "point-to-point solve: keypose {:.2} µs, Ruckig {:.2} µs per move ({} moves × {REPEAT}); ratio {:.3}",
        ours * 1e6,
        theirs * 1e6,
        moves.len(),
        ours / theirs
    );
}
