//! Point-to-point moves against Ruckig (the `ruckig` package, run by
//! `benches/ruckig_oracle.py` in keypose's Python environment): shared by `benches/scurve.rs`
//! and `tests/motion/jerk.rs`.
#![allow(dead_code)]

use keypose::robot::Robot;
use serde_json::{json, Value};
use std::path::Path;

/// How Ruckig makes the joints end together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// Each joint its own profile, all of the same duration (Ruckig's default).
    Time,
    /// Every joint on the straight line between the poses (a linear segment's path).
    Phase,
}

/// The rise time of the jerk limit the benchmark and the tests give a robot without one:
/// each joint reaches its acceleration limit from zero in a tenth of a second (docs/robots.md).
pub const RISE_SECONDS: f64 = 0.1;

/// `robot` with a jerk limit on every joint: its acceleration limit over `rise` seconds.
pub fn with_jerk(robot: &Robot, rise: f64) -> Robot {
    let mut out = robot.clone();
    for joint in &mut out.joints {
        joint.limits.jerk = Some(joint.limits.acceleration / rise);
    }
    out
}

/// One rest-to-rest move of `robot` from `from` to `to` (joint values in robot order) under
/// its limits, as Ruckig is asked for it. Every joint must have a jerk limit.
pub fn move_request(robot: &Robot, from: &[f64], to: &[f64], sync: Sync) -> Value {
    let limit = |f: &dyn Fn(&keypose::robot::Limits) -> f64| -> Vec<f64> {
        robot.joints.iter().map(|j| f(&j.limits)).collect()
    };
    json!({
        "from": from, "to": to,
        "vlim": limit(&|l| l.velocity),
        "alim": limit(&|l| l.acceleration),
        "jlim": limit(&|l| l.jerk.expect("a jerk limit on every joint")),
        "sync": match sync { Sync::Time => "time", Sync::Phase => "phase" },
    })
}

/// Ruckig's duration of each move, seconds, and ruckig's version.
pub fn ruckig_durations(python: &Path, moves: &[Value]) -> Result<(Vec<f64>, String), String> {
    let reply = super::oracle::run_oracle(python, "ruckig_oracle.py", &json!({ "moves": moves }))?;
    super::oracle::durations(&reply, "ruckig")
}

/// Ruckig's mean time per solve of `moves`, seconds, each solved `repeat` times (its C++
/// `calculate` behind the Python call).
pub fn ruckig_seconds_per_solve(
    python: &Path,
    moves: &[Value],
    repeat: u32,
) -> Result<f64, String> {
    let reply = super::oracle::run_oracle(
        python,
        "ruckig_oracle.py",
        &json!({ "moves": moves, "repeat": repeat }),
    )?;
    reply["seconds_per_solve"]
        .as_f64()
        .ok_or_else(|| "no seconds_per_solve in ruckig's reply".to_string())
}
