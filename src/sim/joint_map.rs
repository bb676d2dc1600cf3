//! Which model joint plays which robot joint, for a model whose joints are named otherwise
//! (MuJoCo Menagerie's Koch, ROBOTIS's OpenMANIPULATOR-X): shipped maps by name, a
//! `keypose-joint-map/1` file, or `robot=model,…` pairs. Joints a map does not name keep their
//! robot name.

use crate::json::{self, InputError, Location, Node};
use crate::robot::Robot;
use std::path::{Path, PathBuf};

/// The maps keypose ships (sim/joint_maps/), by name.
const SHIPPED: [(&str, &str); 2] = [
    (
        "menagerie-koch",
        include_str!("../../sim/joint_maps/menagerie-koch.json"),
    ),
    (
        "robotis-omx",
        include_str!("../../sim/joint_maps/robotis-omx.json"),
    ),
];

/// The `format` a joint map file declares.
pub const FORMAT: &str = "keypose-joint-map/1";

/// Robot joint → model joint.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JointMap {
    pairs: Vec<(String, String)>,
}

/// A model file and the map of its joint names.
#[derive(Debug, Clone, PartialEq)]
pub struct MjcfModel {
    /// The MJCF file.
    pub path: PathBuf,
    /// Which of its joints plays which robot joint.
    pub joint_map: JointMap,
}

impl MjcfModel {
    /// A model whose joints carry the robot's names.
    pub fn new(path: &Path) -> MjcfModel {
        MjcfModel {
            path: path.to_path_buf(),
            joint_map: JointMap::default(),
        }
    }
}

impl JointMap {
    /// The names of the shipped maps.
    pub fn shipped_names() -> Vec<&'static str> {
        SHIPPED.iter().map(|(n, _)| *n).collect()
    }

    /// A shipped map's name, `robot=model,…` pairs, or a map file; checked against `robot`.
    pub fn parse(spec: &str, robot: &Robot) -> Result<JointMap, InputError> {
        let map = if let Some((_, text)) = SHIPPED.iter().find(|(name, _)| *name == spec) {
            JointMap::from_json(spec, text)?
        } else if spec.contains('=') {
            JointMap::from_pairs(spec)?
        } else {
            let path = Path::new(spec);
            JointMap::from_json(&path.display().to_string(), &json::read_text(path)?)?
        };
        map.check(spec, robot)?;
        Ok(map)
    }

    fn from_pairs(spec: &str) -> Result<JointMap, InputError> {
        let mut pairs = Vec::new();
        for item in spec.split(',').filter(|s| !s.trim().is_empty()) {
            let Some((robot, model)) = item.split_once('=') else {
                return Err(InputError::new(
                    "--joint-map",
                    Location::File,
                    format!("{item:?}: expected ROBOT_JOINT=MODEL_JOINT"),
                ));
            };
            pairs.push((robot.trim().to_string(), model.trim().to_string()));
        }
        Ok(JointMap { pairs })
    }

    fn from_json(file: &str, text: &str) -> Result<JointMap, InputError> {
        let value = json::parse(file, text)?;
        let root = Node::root(file, &value);
        root.only_fields(&["format", "robot", "model", "joints"])?;
        root.check_format(FORMAT)?;
        let joints = root.require("joints", "robot joint → model joint names")?;
        let mut pairs = Vec::new();
        for (robot, node) in joints.named_entries("robot joint names")? {
            pairs.push((
                robot.to_string(),
                node.name("a model joint name")?.to_string(),
            ));
        }
        Ok(JointMap { pairs })
    }

    /// Every robot joint named must be the robot's, and no model joint may play two.
    fn check(&self, spec: &str, robot: &Robot) -> Result<(), InputError> {
        let error = |m: String| InputError::new(spec, Location::File, m);
        for (i, (joint, model)) in self.pairs.iter().enumerate() {
            if robot.joint_index(joint).is_none() {
                return Err(error(format!(
                    "{joint:?} is not a joint of {}; expected names from: {}",
                    robot.name,
                    robot.joint_names().join(", ")
                )));
            }
            if self.pairs[..i]
                .iter()
                .any(|(j, m)| m == model || j == joint)
            {
                return Err(error(format!(
                    "{joint:?} → {model:?}: each joint once, each model joint once"
                )));
            }
        }
        Ok(())
    }

    /// The model's name of robot joint `joint`.
    pub fn model_name<'a>(&'a self, joint: &'a str) -> &'a str {
        self.pairs
            .iter()
            .find(|(j, _)| j == joint)
            .map_or(joint, |(_, m)| m.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_maps_name_their_robots_joints() {
        for (name, robot) in [("menagerie-koch", "koch"), ("robotis-omx", "omx")] {
            let robot = Robot::builtin(robot).unwrap();
            let map = JointMap::parse(name, &robot).unwrap();
            assert_ne!(
                map.model_name(&robot.joints[0].name),
                robot.joints[0].name,
                "{name}"
            );
        }
        let koch = Robot::builtin("koch").unwrap();
        let map = JointMap::parse("menagerie-koch", &koch).unwrap();
        // docs/robots.md §2.2: the Menagerie's names of the Koch's joints.
        assert_eq!(map.model_name("shoulder_lift"), "pitch");
        assert_eq!(map.model_name("wrist_flex"), "wrist_pitch");
        assert_eq!(map.model_name("wrist_roll"), "wrist_roll");
        let twice = JointMap::parse("elbow_flex=a,wrist_flex=a", &koch).unwrap_err();
        assert!(
            twice.to_string().contains("each model joint once"),
            "{twice}"
        );
    }
}
