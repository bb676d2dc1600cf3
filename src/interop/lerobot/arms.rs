//! Which arm each of a dataset's values belongs to (docs/interop.md §1.2).
//!
//! LeRobot's bimanual robots wrap two single arms and prefix every feature of one with `left_`,
//! of the other with `right_` (`bi_so_follower.py::_motors_ft`, and `bi_so100_follower` before
//! the SO classes were merged): `left_shoulder_pan.pos`, `right_gripper.pos`. Such a dataset
//! becomes a cell of two arms named `left` and `right`, whose joints are `left/shoulder_pan` and
//! so on. A dataset says nothing about where the arms stand; [`Placement::default_for`](crate::sequence::Placement::default_for) places them.

use super::DatasetInfo;
use super::LeRobotError;
use crate::robot::{cell_joint_name, split_joint_name};

/// LeRobot's arm prefixes and the arms they become, in LeRobot's order.
const ARMS: [(&str, &str); 2] = [("left", "left_"), ("right", "right_")];

/// The arms a feature's names denote: none for a dataset of one arm, else those whose prefix
/// appears (`left`, `right`). Names with a prefix next to names without one are refused: each
/// value must belong to one arm.
pub fn dataset_arms(
    info: &DatasetInfo,
    field: &str,
    names: &[String],
) -> Result<Vec<&'static str>, LeRobotError> {
    let arms: Vec<&'static str> = ARMS
        .iter()
        .filter(|(_, prefix)| names.iter().any(|n| n.starts_with(prefix)))
        .map(|&(arm, _)| arm)
        .collect();
    if arms.is_empty() {
        return Ok(arms);
    }
    let unprefixed: Vec<&str> = names
        .iter()
        .filter(|n| arm_of(n).is_none())
        .map(String::as_str)
        .collect();
    if !unprefixed.is_empty() {
        return Err(LeRobotError::MixedArms {
            file: info.file.clone(),
            field: field.to_string(),
            unprefixed: unprefixed.join(", "),
        });
    }
    Ok(arms)
}

/// The arm a LeRobot name belongs to and the name within it: `("left", "gripper.pos")`.
fn arm_of(name: &str) -> Option<(&'static str, &str)> {
    ARMS.iter()
        .find_map(|&(arm, prefix)| name.strip_prefix(prefix).map(|rest| (arm, rest)))
}

/// The robot's name for a dataset value: on a cell `left_gripper.pos` is `left/gripper.pos`;
/// on one arm the name as it is.
pub fn robot_name(name: &str, cell: bool) -> String {
    match arm_of(name) {
        Some((arm, rest)) if cell => cell_joint_name(arm, rest),
        _ => name.to_string(),
    }
}

/// LeRobot's name of a robot joint, for messages: `left/gripper` is `left_gripper`.
pub fn lerobot_name(joint: &str) -> String {
    match split_joint_name(joint) {
        Some((arm, rest)) => format!("{arm}_{rest}"),
        None => joint.to_string(),
    }
}

/// The robot type of each arm of a bimanual `robot_type`: LeRobot names a bimanual robot
/// `bi_` and its arms' type (`bi_so100_follower` → `so100_follower`; the merged
/// `bi_so_follower` → `so_follower`, which names no arm model and is refused as such).
pub fn arm_robot_type(robot_type: &str) -> &str {
    robot_type.strip_prefix("bi_").unwrap_or(robot_type)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> DatasetInfo {
        DatasetInfo::for_tests("meta/info.json")
    }

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn lerobot_prefixes_become_arms_and_cell_joint_names() {
        let both = names(&["left_shoulder_pan.pos", "right_gripper.pos"]);
        assert_eq!(
            dataset_arms(&info(), "action", &both).unwrap(),
            ["left", "right"]
        );
        assert!(dataset_arms(&info(), "action", &names(&["gripper.pos"]))
            .unwrap()
            .is_empty());
        assert_eq!(
            robot_name("left_shoulder_pan.pos", true),
            "left/shoulder_pan.pos"
        );
        assert_eq!(
            robot_name("left_shoulder_pan.pos", false),
            "left_shoulder_pan.pos"
        );
        assert_eq!(lerobot_name("right/gripper"), "right_gripper");
        assert_eq!(arm_robot_type("bi_so100_follower"), "so100_follower");
    }

    #[test]
    fn a_value_of_no_arm_next_to_arms_is_refused_by_name() {
        let mixed = names(&["left_shoulder_pan.pos", "gripper.pos"]);
        let error = dataset_arms(&info(), "action", &mixed).unwrap_err();
        let text = error.to_string();
        assert!(text.contains("action"), "{text}");
        assert!(text.contains("gripper.pos"), "{text}");
    }
}
