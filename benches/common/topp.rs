//! keypose's `retime --fastest` against TOPP-RA (the `toppra` package, run by
//! `benches/toppra_oracle.py` in keypose's Python environment) on the same path and limits:
//! shared by `benches/fastest.rs` and `tests/commands/fastest.rs`.
#![allow(dead_code)]

use keypose::plan::{FastestOutcome, Trajectory};
use keypose::robot::Robot;
use serde_json::{json, Value};
use std::path::Path;

/// Grid points per second of path time given to TOPP-RA: far finer than keypose's own grid, so
/// its optimum is the path's, not a coarse grid's.
pub const ORACLE_POINTS_PER_SECOND: f64 = 500.0;

/// What TOPP-RA is asked: every run of `outcome` (the paths the arm runs without stopping),
/// sampled with the joints' first and second derivatives along the path, and the limits.
pub fn request(outcome: &FastestOutcome, robot: &Robot) -> Value {
    let trajectory =
        Trajectory::build(&outcome.sequence, robot).expect("the retimed sequence builds");
    let stretches: Vec<Value> = outcome
        .runs
        .iter()
        .map(|run| {
            let (from, to) = run.path;
            let n = ((to - from) * ORACLE_POINTS_PER_SECOND).ceil().max(50.0) as usize;
            let ss: Vec<f64> = (0..=n)
                .map(|k| {
                    if k == n {
                        to
                    } else {
                        from + (to - from) * k as f64 / n as f64
                    }
                })
                .collect();
            let per_joint =
                |f: &dyn Fn(&keypose::curve::Track<f64>, f64, bool) -> f64| -> Vec<Vec<f64>> {
                    ss.iter()
                        .enumerate()
                        .map(|(k, &s)| {
                            trajectory
                                .tracks()
                                .iter()
                                .map(|t| f(t, s, k == n))
                                .collect()
                        })
                        .collect()
                };
            let q = per_joint(&|t, s, _| t.sample(s));
            let qd = per_joint(&|t, s, last| if last { t.rate_before(s) } else { t.rate_at(s) });
            let qdd = per_joint(&|t, s, last| {
                if last {
                    t.second_rate_before(s)
                } else {
                    t.second_rate_at(s)
                }
            });
            let sd = run.from_rest.map(|rest| if rest { 0.0 } else { 1.0 });
            json!({
                "ss": ss, "q": q, "qd": qd, "qdd": qdd, "sd": sd,
                "vlim": robot.joints.iter().map(|j| j.limits.velocity).collect::<Vec<_>>(),
                "alim": robot.joints.iter().map(|j| j.limits.acceleration).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({ "stretches": stretches })
}

/// [`request`] with each servo's torque-speed line on every stretch, and the arms' MuJoCo
/// models for the oracle to weigh them by its own inverse dynamics (`mj_inverse`).
pub fn request_with_torque(outcome: &FastestOutcome, robot: &Robot) -> Value {
    let mut request = request(outcome, robot);
    let model = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("sim/models")
            .join(format!("{name}.xml"))
            .display()
            .to_string()
    };
    let arms: Vec<Value> = if robot.is_cell() {
        robot
            .arms
            .iter()
            .map(|arm| {
                let gravity = arm.base.r.inverse() * glam::DVec3::new(0.0, 0.0, -9.81);
                json!({
                    "mjcf": model(&arm.robot.name),
                    "joints": arm.robot.joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>(),
                    "columns": arm.joints.clone().collect::<Vec<_>>(),
                    "gravity": gravity.to_array(),
                })
            })
            .collect()
    } else {
        vec![json!({
            "mjcf": model(&robot.name),
            "joints": robot.joints.iter().map(|j| j.name.clone()).collect::<Vec<_>>(),
            "columns": (0..robot.joints.len()).collect::<Vec<_>>(),
            "gravity": [0.0, 0.0, -9.81],
        })]
    };
    // A servo without drive data is not limited: a line no path reaches.
    let drive = |j: &keypose::robot::Joint| {
        j.servo.drive().map_or((1e9, 1e9), |d| {
            (d.stall_torque.value, d.no_load_speed.value)
        })
    };
    let torque = json!({
        "arms": arms,
        "transmission": robot.joints.iter().map(|j| j.servo.transmission(j.kind)).collect::<Vec<_>>(),
        "stall": robot.joints.iter().map(|j| drive(j).0).collect::<Vec<_>>(),
        "no_load": robot.joints.iter().map(|j| drive(j).1).collect::<Vec<_>>(),
        "revolute": robot.joints.iter().map(|j| j.kind == keypose::robot::JointKind::Revolute).collect::<Vec<_>>(),
    });
    for stretch in request["stretches"].as_array_mut().expect("stretches") {
        stretch["torque"] = torque.clone();
    }
    request
}

/// TOPP-RA's time for each stretch of `request`, seconds, and toppra's version.
pub fn toppra_durations(python: &Path, request: &Value) -> Result<(Vec<f64>, String), String> {
    let reply = super::oracle::run_oracle(python, "toppra_oracle.py", request)?;
    super::oracle::durations(&reply, "toppra")
}
