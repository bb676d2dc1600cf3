//! The words and numbers of the teaching screen and its messages: joint values in their
//! units, key labels, counts, the prompts' questions. Pure text, shared by the terminal UI,
//! the key script's echo and the state's status line.

use super::prompt::Prompt;
use super::state::TeachState;
use crate::plan::CheckReport;
use crate::robot::{Joint, JointKind, Robot};
use crate::sequence::Sequence;

/// A joint value for the screen and messages: degrees, or millimetres for prismatic joints.
pub fn value(joint: &Joint, value: f64) -> String {
    match joint.kind {
        JointKind::Revolute => format!("{value:.1}°"),
        JointKind::Prismatic => format!("{:.1} mm", value * 1000.0),
    }
}

/// "1 key", "3 keys".
pub fn count(keys: usize) -> String {
    if keys == 1 {
        "1 key".into()
    } else {
        format!("{keys} keys")
    }
}

/// "key 2", or "key 2 (wave)" when the key has a name.
pub fn key_label(sequence: &Sequence, index: usize) -> String {
    match sequence
        .keyframes
        .get(index)
        .and_then(|key| key.name.as_ref())
    {
        Some(name) => format!("key {index} ({name})"),
        None => format!("key {index}"),
    }
}

/// The joints' names, or "all joints" when that is what they are.
pub fn joint_list(robot: &Robot, joints: &[usize]) -> String {
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
pub fn first_violation(report: &CheckReport) -> Option<String> {
    let v = report.violations.first()?;
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
        Prompt::Quit => "unsaved changes: quit without writing them? (y/n)".into(),
        Prompt::Release { heavy, .. } => format!(
            "{} carr{} the arm's weight: support the arm, then release torque? (y/n)",
            joint_list(state.robot(), heavy),
            if heavy.len() == 1 { "ies" } else { "y" }
        ),
        Prompt::Replace { path } => format!(
            "unsaved changes: replace the list with {}? (y/n)",
            path.display()
        ),
        Prompt::ImportPath { text } => {
            format!("import file: {text}▏ (Enter: import, Esc: cancel)")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::{KeyValue, Keyframe};

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
}
