//! Robots compiled into the binary, so keypose works from any directory.

use super::{Robot, RobotSource};

/// (name, file text) of every built-in robot.
const BUILTIN: [(&str, &str); 4] = [
    ("so101", include_str!("../../robots/so101.json")),
    ("so100", include_str!("../../robots/so100.json")),
    ("koch", include_str!("../../robots/koch.json")),
    ("omx", include_str!("../../robots/omx.json")),
];

pub const BUILTIN_NAMES: [&str; 4] = ["so101", "so100", "koch", "omx"];

pub fn get(name: &str) -> Option<Robot> {
    let (_, text) = BUILTIN.iter().find(|(n, _)| *n == name)?;
    // A built-in that does not parse is a build defect that the tests catch; refuse it rather
    // than panic in a user's hands.
    let mut robot = Robot::from_json(&format!("robots/{name}.json (built in)"), text).ok()?;
    robot.source = RobotSource::Builtin(name.to_string());
    robot.lerobot = super::lerobot_names::follower_type_of(name);
    Some(robot)
}
