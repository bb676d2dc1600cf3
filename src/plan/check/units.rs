//! Joint values typed in radians: keypose's are degrees, so a sequence whose every revolute
//! value lies within ±π on an arm whose joints range over tens of degrees passes the limit check
//! while moving the arm a degree or two. Not an error (a small nod is within ±π too): a warning
//! that names the values.

use crate::robot::{JointKind, Robot};
use crate::sequence::{KeyValue, Sequence};
use std::f64::consts::PI;

/// A range this wide (degrees) is one whose values in radians would fall far inside it.
const WIDE_RANGE_DEG: f64 = 60.0;
/// Below this largest value (degrees) a sequence is still at the arm's zero pose, not in radians.
const SOMETHING_MOVES: f64 = 0.2;

/// The warning for `sequence` on `robot` when its joint values look like radians, if they do.
pub fn radians_warning(sequence: &Sequence, robot: &Robot) -> Option<String> {
    let mut largest: f64 = 0.0;
    let mut values = 0;
    for key in &sequence.keyframes {
        for (name, value) in &key.values {
            let KeyValue::Joint(v) = value else { continue };
            let Some(joint) = robot.joints.iter().find(|j| &j.name == name) else {
                continue;
            };
            if joint.kind != JointKind::Revolute {
                continue;
            }
            if joint.limits.max - joint.limits.min < WIDE_RANGE_DEG || v.abs() > PI + 1e-9 {
                return None;
            }
            largest = largest.max(v.abs());
            values += 1;
        }
    }
    (values >= 2 && largest >= SOMETHING_MOVES).then(|| {
        format!(
            "units: every joint value is within ±π (the largest {largest:.3}) on joints that \
             range over tens of degrees: these look like radians, and keypose's joint values are \
             degrees (multiply by 180/π, 57.3)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn so101(values: &str) -> (Sequence, Robot) {
        let text = format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [{values}]}}"#
        );
        (
            Sequence::from_json("s.json", &text).unwrap(),
            Robot::builtin("so101").unwrap(),
        )
    }

    #[test]
    fn radians_are_named_and_degrees_are_not() {
        let (s, r) = so101(
            r#"{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 2, "joints": {"elbow_flex": 1.57, "shoulder_lift": -0.8}}"#,
        );
        let warning = radians_warning(&s, &r).unwrap();
        assert!(
            warning.contains("look like radians") && warning.contains("1.570"),
            "{warning}"
        );
        let (s, r) = so101(
            r#"{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 2, "joints": {"elbow_flex": 90}}"#,
        );
        assert_eq!(radians_warning(&s, &r), None);
        // All at zero: nothing to tell apart.
        let (s, r) = so101(
            r#"{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 2, "joints": {"elbow_flex": 0}}"#,
        );
        assert_eq!(radians_warning(&s, &r), None);
    }
}
