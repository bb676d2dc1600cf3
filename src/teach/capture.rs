//! Joint values as a key holds them: rounded for readability and inside the limits.

use crate::robot::{Joint, JointKind, Robot};
use crate::sequence::KeyValue;

/// A captured value is rounded to this for readability: 0.1° for revolute joints, 0.1 mm for
/// prismatic ones (well below what a hobby servo holds: one tick is 0.088°).
pub(crate) fn tidy(joint: &Joint, value: f64) -> f64 {
    let scale = match joint.kind {
        JointKind::Revolute => 10.0,
        JointKind::Prismatic => 10_000.0,
    };
    // +0.0 turns -0.0 into 0.0, which the file would otherwise show as "-0.0".
    ((value * scale).round() / scale).clamp(joint.limits.min, joint.limits.max) + 0.0
}

/// The pose `present` as key values, and the joints that were outside their limits
/// (calibration or backlash) and were clamped into them.
pub(crate) fn capture<'r>(
    robot: &'r Robot,
    present: &[f64],
) -> (Vec<(String, KeyValue)>, Vec<&'r str>) {
    let mut clamped = Vec::new();
    let values = robot
        .joints
        .iter()
        .zip(present)
        .map(|(joint, &v)| {
            // Within a tick of a limit is quantisation, not worth a word.
            let outside = (joint.limits.min - v).max(v - joint.limits.max);
            if outside > joint.servo.units_per_tick.abs() {
                clamped.push(joint.name.as_str());
            }
            (joint.name.clone(), KeyValue::Joint(tidy(joint, v)))
        })
        .collect();
    (values, clamped)
}
