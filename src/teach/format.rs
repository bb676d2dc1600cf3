//! The words and numbers of the teaching screen and its messages: joint values in their
//! units, key labels, counts, the prompts' questions. Pure text, shared by the terminal UI,
//! the key script's echo and the state's status line.

use super::prompt::{Field, Prompt};
use super::state::TeachState;
use crate::curve::Interp;
use crate::plan::CheckReport;
use crate::robot::{Joint, JointKind, Robot};
use crate::sequence::{KeyValue, Sequence};

/// A joint value for the screen and messages: degrees, or millimetres for prismatic joints.
pub(crate) fn value(joint: &Joint, value: f64) -> String {
    match joint.kind {
        JointKind::Revolute => format!("{value:.1}°"),
        JointKind::Prismatic => format!("{:.1} mm", value * 1000.0),
    }
}

/// A joint value with, on a joint whose calibration recorded a range, where it is on that range
/// as LeRobot's 0…100 scale counts it: LeRobot users know their gripper in percent.
pub fn value_and_percent(joint: &Joint, v: f64) -> String {
    match joint.calibrated_range {
        Some(range) => format!("{} {:.0}%", value(joint, v), range.percent(v)),
        None => value(joint, v),
    }
}

/// The joint value a key gives, when it gives a number or a percent it can be resolved from.
pub fn key_number(joint: &Joint, key: &KeyValue) -> Option<f64> {
    match *key {
        KeyValue::Joint(v) => Some(v),
        KeyValue::Percent(p) => joint.calibrated_range.map(|range| range.value(p)),
        KeyValue::Transform(_) => None,
    }
}

/// A key's value as the joint table shows it: a percent as written, with its degrees when the
/// calibration says where they are.
pub fn key_text(joint: &Joint, key: &KeyValue) -> String {
    match (key, key_number(joint, key)) {
        (KeyValue::Transform(_), _) => "transform".into(),
        (KeyValue::Percent(p), Some(v)) => format!("{p}% {}", value(joint, v)),
        (KeyValue::Percent(p), None) => format!("{p}% uncal."),
        (KeyValue::Joint(_), Some(v)) => value_and_percent(joint, v),
        (KeyValue::Joint(v), None) => value(joint, *v),
    }
}

/// The unit the screen gives a joint's values in.
pub(crate) fn unit(joint: &Joint) -> &'static str {
    match joint.kind {
        JointKind::Revolute => "°",
        JointKind::Prismatic => " mm",
    }
}

/// A joint value as a number in the screen's unit: degrees, or millimetres (to the
/// nanometre, so that 0.032 m reads 32 and not 32.000000000000004).
fn screen_number(joint: &Joint, value: f64) -> f64 {
    match joint.kind {
        JointKind::Revolute => value,
        JointKind::Prismatic => (value * 1e6).round() / 1e3,
    }
}

/// A number typed in the screen's unit as the key holds it (degrees, metres). Dividing the
/// typed millimetres gives the nearest double to the decimal, as the file should show it.
pub(crate) fn from_screen(joint: &Joint, shown: f64) -> f64 {
    match joint.kind {
        JointKind::Revolute => shown,
        JointKind::Prismatic => shown / 1000.0,
    }
}

/// "-96.83° … 96.83°": the exact limits, so a refusal never names a rounded limit that the
/// refused value seems to be inside.
pub(crate) fn limits(joint: &Joint) -> String {
    let unit = unit(joint);
    format!(
        "{}{unit} … {}{unit}",
        screen_number(joint, joint.limits.min),
        screen_number(joint, joint.limits.max)
    )
}

/// "1 key", "3 keys".
pub(crate) fn count(keys: usize) -> String {
    if keys == 1 {
        "1 key".into()
    } else {
        format!("{keys} keys")
    }
}

/// "key 2", or "key 2 (wave)" when the key has a name.
pub(crate) fn key_label(sequence: &Sequence, index: usize) -> String {
    match sequence
        .keyframes
        .get(index)
        .and_then(|key| key.name.as_ref())
    {
        Some(name) => format!("key {index} ({name})"),
        None => format!("key {index}"),
    }
}

/// "keys 2, 3 and 5" (or `key_label` of one), for the status line.
pub(crate) fn keys_label(sequence: &Sequence, indices: &[usize]) -> String {
    match indices {
        [one] => key_label(sequence, *one),
        [rest @ .., last] => {
            let rest: Vec<String> = rest.iter().map(usize::to_string).collect();
            format!("keys {} and {last}", rest.join(", "))
        }
        [] => "no key".into(),
    }
}

/// The mode of the segment from key `index`: its own, else the sequence's.
pub fn segment_interp(sequence: &Sequence, index: usize) -> Interp {
    sequence
        .keyframes
        .get(index)
        .and_then(|key| key.interp)
        .unwrap_or(sequence.interpolation)
}

/// The joints' names, or "all joints" when that is what they are.
pub(crate) fn joint_list(robot: &Robot, joints: &[usize]) -> String {
    if joints.len() == robot.joints.len() && joints.len() > 1 {
        return "all joints".into();
    }
    joints
        .iter()
        .filter_map(|&j| robot.joints.get(j).map(|joint| joint.name.as_str()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// "3 limit violation(s), first elbow_flex velocity in key 1 → key 2", or `None` when the
/// check passes.
pub(crate) fn first_violation(report: &CheckReport) -> Option<String> {
    let Some(v) = report.violations.first() else {
        let contacts: Vec<_> = report.undeclared_contacts().collect();
        let Some(c) = contacts.first() else {
            let overloads: Vec<_> = report.overloads().collect();
            let o = overloads.first()?;
            return Some(format!(
                "{} servo overload(s), first {}: {}",
                overloads.len(),
                o.describe(),
                o.advice
            ));
        };
        let other = c.bodies.1.as_deref().unwrap_or("the floor");
        return Some(format!(
            "{} contact(s), first {} with {other} at {:.2} s in {}: {}",
            contacts.len(),
            c.bodies.0,
            c.deepest_time,
            c.segment_label,
            c.advice
        ));
    };
    Some(format!(
        "{} limit violation(s), first {} {} in {}",
        report.violations.len(),
        v.joint,
        v.kind.name(),
        v.segment_label
    ))
}

/// The question of the pending prompt, for the screen and the script's echo.
pub fn question(state: &TeachState) -> Option<String> {
    Some(match state.prompt()? {
        Prompt::Recover { keys } => format!(
            "a journal of unsaved work ({keys} keys) is newer than {}: recover it? (y/n)",
            state.output().display()
        ),
        Prompt::Quit => format!(
            "unsaved changes: w writes them to {} and quits, y quits without them, n stays (w/y/n)",
            state.output().display()
        ),
        Prompt::Release { heavy, .. } => format!(
            "{} carr{} the arm's weight: support the arm, then release torque? (y/n)",
            joint_list(state.robot(), heavy),
            if heavy.len() == 1 { "ies" } else { "y" }
        ),
        Prompt::Replace { path } => format!(
            "unsaved changes: replace the list with {}? (y/n)",
            path.display()
        ),
        Prompt::Text { field, text } => {
            let (what, enter) = field_question(state, *field);
            format!("{what}: {text}▏ (Enter: {enter}, Esc: cancel)")
        }
        Prompt::MoveThere => format!(
            "move the arm to {} now, by the safe ramp? (y/n)",
            key_label(state.list().sequence(), state.list().current_index())
        ),
        Prompt::Direction { joint } => format!(
            "direction check: did the real {} move the way the drawn one did? \
             m matches, r reversed, Esc ends the check (m/r)",
            state.robot().joints[*joint].name
        ),
    })
}

/// What a text prompt asks for, and what Enter does with it.
fn field_question(state: &TeachState, field: Field) -> (String, &'static str) {
    let sequence = state.list().sequence();
    let index = state.list().current_index();
    let label = key_label(sequence, index);
    let key = sequence.keyframes.get(index);
    match field {
        Field::ImportPath => ("import file".into(), "import"),
        Field::Name => (format!("name of {label} (empty: no name)"), "name it"),
        Field::Hold => {
            let now = key.map_or(0.0, |k| k.hold);
            (format!("hold of {label} in s, now {now} (0: none)"), "set")
        }
        Field::Effort(j) => {
            let joint = &state.robot().joints[j];
            let now = key
                .and_then(|k| k.effort.iter().find(|(n, _)| *n == joint.name))
                .map_or("not set".to_string(), |(_, p)| format!("{p} %"));
            (
                format!(
                    "{} effort of {label} in % of its torque, now {now} (empty: none)",
                    joint.name
                ),
                "set",
            )
        }
        Field::Value(j) => {
            let joint = &state.robot().joints[j];
            let now = match key.and_then(|k| k.value(&joint.name)) {
                Some(KeyValue::Joint(v)) => screen_number(joint, *v).to_string(),
                Some(KeyValue::Percent(p)) => format!("{p}%"),
                _ => "not set".into(),
            };
            (
                format!(
                    "{} of {label} in {}, now {now} (limits {})",
                    joint.name,
                    match joint.kind {
                        JointKind::Revolute => "degrees",
                        JointKind::Prismatic => "mm",
                    },
                    limits(joint)
                ),
                "set",
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::Keyframe;

    #[test]
    fn values_keys_and_joints_read_as_the_screen_shows_them() {
        let robot = Robot::builtin("so101").unwrap();
        assert_eq!(value(&robot.joints[0], 12.34), "12.3°");
        assert_eq!((count(1), count(3)), ("1 key".into(), "3 keys".into()));
        let mut sequence = Sequence::new("so101");
        let mut key = Keyframe::new(vec![("gripper".into(), KeyValue::Joint(0.0))]);
        key.name = Some("wave".into());
        sequence.keyframes.push(key);
        assert_eq!(key_label(&sequence, 0), "key 0 (wave)");
        assert_eq!(key_label(&sequence, 1), "key 1");
        assert_eq!(joint_list(&robot, &[1, 2]), "shoulder_lift, elbow_flex");
        assert_eq!(joint_list(&robot, &[0, 1, 2, 3, 4, 5]), "all joints");
    }

    #[test]
    fn a_calibrated_joint_shows_its_percent_beside_the_degrees() {
        let robot = Robot::builtin("so101").unwrap();
        let mut gripper = robot.joints[5].clone();
        assert_eq!(value_and_percent(&gripper, -8.79), "-8.8°");
        assert_eq!(key_text(&gripper, &KeyValue::Percent(40.0)), "40% uncal.");
        // A recorded range of ±43.9453125° (ticks 2000 … 3000 about 2500): -8.7890625° is
        // 35.15625° above the low end, 40 % of 87.890625°.
        gripper.calibrated_range = Some(crate::robot::CalibratedRange {
            at_0: -43.9453125,
            at_100: 43.9453125,
        });
        assert_eq!(value_and_percent(&gripper, -8.7890625), "-8.8° 40%");
        assert_eq!(key_text(&gripper, &KeyValue::Percent(40.0)), "40% -8.8°");
        assert_eq!(
            key_text(&gripper, &KeyValue::Joint(-8.7890625)),
            "-8.8° 40%"
        );
    }
}
