//! `GET /api/timeline`: what the page's timeline draws — every joint's position and velocity
//! curves with its keys and limits, as `keypose plot` computes them ([`report::plot_data`]),
//! and where `keypose check` finds the limits broken, a contact or a servo over its
//! torque-speed line ([`plan::check`], at the control rate `teach` checks at).

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
        assert!(torque["text"]
            .as_str()
            .unwrap()
            .contains("where the line gives"));
        robot.payload = None;
        let answer = timeline(Some(&sequence), &robot);
        assert!(answer["findings"]
            .as_array()
            .unwrap()
            .iter()
            .all(|f| f["kind"] != "torque"));
    }
}
