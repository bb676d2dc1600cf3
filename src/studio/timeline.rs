//! `GET /api/timeline`: what the page's timeline draws — every joint's position and velocity
//! curves with its keys and limits, as `keypose plot` computes them ([`report::plot_data`]),
//! each servo's torque as a share of what its torque-speed line gives at that speed (the
//! check's own samples, [`plan::torques`]), and where `keypose check` finds the limits broken,
//! a contact or a servo over its line ([`plan::check`], at the control rate `teach` checks at).

use crate::dynamics::Dynamics;
use crate::plan::{self, Trajectory};
use crate::report;
use crate::robot::Robot;
use crate::sequence::Sequence;
use serde_json::{json, Value};

/// Samples per second of the curves: smooth at the page's width, and light to send.
const CURVE_RATE: f64 = 50.0;
/// Most curve samples per joint: a long sequence is drawn coarser rather than sent huge.
const MAX_SAMPLES: f64 = 4000.0;

pub(crate) fn timeline(sequence: Option<&Sequence>, robot: &Robot) -> Value {
    let Some(sequence) = sequence.filter(|s| !s.keyframes.is_empty()) else {
        return json!({"empty": true, "reason": "no keys yet"});
    };
    let trajectory = match Trajectory::build(sequence, robot) {
        Ok(t) => t,
        Err(e) => return json!({"empty": true, "reason": e.to_string()}),
    };
    let duration = trajectory.duration().max(1e-3);
    let rate = CURVE_RATE.min(MAX_SAMPLES / duration).max(1.0 / duration);
    let data = report::plot_data("", &trajectory, robot, rate, Vec::new());
    let check = plan::check(&trajectory, robot, robot.control_hz);
    json!({
        "empty": false,
        "start": trajectory.start,
        "end": trajectory.end,
        "times": data.times,
        "joints": data.joints.iter().map(|j| json!({
            "name": j.name,
            "unit": j.unit,
            "min": j.min,
            "max": j.max,
            "velocity_limit": j.velocity_limit,
            "positions": j.positions,
            "velocities": j.velocities,
            "keys": j.keys,
        })).collect::<Vec<_>>(),
        "key_marks": data.key_marks,
        "torque": torque_curves(&trajectory, robot),
        "findings": check.violations.iter().map(|v| json!({
            "joint": v.joint,
            "kind": v.kind.name(),
            "from": v.from,
            "to": v.to,
            "peak_time": v.peak_time,
            "text": format!("{} {} limit broken in {}, {}",
                v.joint, v.kind.name(), v.segment_label, report::violation_measure(v, check.rate)),
        })).chain(check.undeclared_contacts().map(|c| json!({
            // A contact is the whole pose's: marked on every row.
            "joint": null,
            "kind": "contact",
            "from": c.from,
            "to": c.to,
            "peak_time": c.deepest_time,
            "text": format!("{} with {} in {} at {:.3} s ({:.1} mm): {}",
                c.bodies.0, c.bodies.1.as_deref().unwrap_or("the floor"), c.segment_label,
                c.deepest_time, c.distance * 1000.0, c.advice),
        }))).chain(check.overloads().map(|o| json!({
            // A servo asked for more than its torque-speed line gives: its joint's row.
            "joint": o.joint,
            "kind": "torque",
            "from": o.from,
            "to": o.to,
            "peak_time": o.peak_time,
            "text": format!("{}: {}", o.describe(), o.advice),
        }))).collect::<Vec<_>>(),
    })
}

/// Each rated servo's torque over the line along `trajectory`: `{"times", "joints": [share or
/// null per joint]}`, the share signed as the torque (1: on the line; past 1: the overload the
/// check fails), at most [`MAX_SAMPLES`] points, each the largest share of its stretch so that
/// no peak is lost. `null` for a robot without masses.
fn torque_curves(trajectory: &Trajectory, robot: &Robot) -> Value {
    let Ok(dynamics) = Dynamics::for_robot(robot) else {
        return Value::Null;
    };
    let samples = plan::torques(trajectory, &dynamics, 1.0);
    let per_point = (samples.len() as f64 / MAX_SAMPLES).ceil().max(1.0) as usize;
    let starts: Vec<usize> = (0..samples.len()).step_by(per_point).collect();
    let times: Vec<f64> = starts.iter().map(|&k| samples.get(k).time).collect();
    let joints: Vec<Value> = robot
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let Some(drive) = joint.servo.drive() else {
                return Value::Null;
            };
            let share = |k: usize| {
                let s = samples.get(k);
                let (t, w) = (s.torques[j], s.speeds[j]);
                t / drive.available(w, t).max(1e-9)
            };
            let shares: Vec<f64> = starts
                .iter()
                .map(|&k| {
                    (k..(k + per_point).min(samples.len()))
                        .map(share)
                        .fold(0.0, |a: f64, b| if b.abs() > a.abs() { b } else { a })
                })
                .collect();
            json!(shares)
        })
        .collect();
    json!({"times": times, "joints": joints})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_servo_over_its_line_is_a_finding_on_its_joints_row() {
        // The shoulder swings out in 1.3 s carrying 50 g: braking at the end asks the 5 V
        // servo for more than its 1.35 N·m (tests/motion/torque.rs has the same through the
        // binary).
        let mut robot = Robot::builtin("so101").unwrap();
        robot.payload = Some(crate::robot::Payload {
            mass: 0.05,
            com: glam::DVec3::ZERO,
        });
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{"name": "low", "time": 0, "joints": {"shoulder_lift": 0, "elbow_flex": -90}},
                          {"name": "high", "time": 1.3, "joints": {"shoulder_lift": 90, "elbow_flex": -90}}]}"#;
        let sequence = Sequence::from_json("swing.json", text).unwrap();
        let answer = timeline(Some(&sequence), &robot);
        let findings = answer["findings"].as_array().unwrap();
        let torque = findings
            .iter()
            .find(|f| f["kind"] == "torque")
            .unwrap_or_else(|| panic!("an overload among {findings:?}"));
        assert_eq!(torque["joint"], "shoulder_lift");
        // The curve shows it: its peak is past the line, inside the finding's stretch.
        let curves = &answer["torque"];
        let times = curves["times"].as_array().unwrap();
        let shoulder = curves["joints"][1].as_array().unwrap();
        let (from, to) = (
            torque["from"].as_f64().unwrap(),
            torque["to"].as_f64().unwrap(),
        );
        let (peak_time, peak) = times
            .iter()
            .zip(shoulder)
            .map(|(t, s)| (t.as_f64().unwrap(), s.as_f64().unwrap().abs()))
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert!(peak > 1.0, "{shoulder:?}");
        assert!(
            (from..=to).contains(&peak_time),
            "{peak_time} vs {from}..{to}"
        );
        robot.payload = None;
        let answer = timeline(Some(&sequence), &robot);
        assert!(answer["findings"]
            .as_array()
            .unwrap()
            .iter()
            .all(|f| f["kind"] != "torque"));
    }

    #[test]
    fn held_still_the_share_is_the_weight_over_the_stall_torque() {
        // The arm stretched out and held: the shoulder's share is its holding torque over the
        // 5 V STS3215's 1.35 N·m stall torque (docs/robots.md §14), at every instant.
        let robot = Robot::builtin("so101").unwrap();
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"time": 0, "joints": {"shoulder_lift": 90, "elbow_flex": -90}},
                          {"time": 1, "joints": {"shoulder_lift": 90, "elbow_flex": -90}}]}"#;
        let sequence = Sequence::from_json("hold.json", text).unwrap();
        let answer = timeline(Some(&sequence), &robot);
        let holding = Dynamics::for_robot(&robot)
            .unwrap()
            .holding_torques(&[0.0, 90.0, -90.0, 0.0, 0.0, 0.0])[1];
        for share in answer["torque"]["joints"][1].as_array().unwrap() {
            assert!(
                (share.as_f64().unwrap() - holding / 1.35).abs() < 1e-9,
                "{share}"
            );
        }
        assert!((holding / 1.35).abs() > 0.1, "{holding}");
    }
}
