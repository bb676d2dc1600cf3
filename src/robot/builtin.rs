//! The robots compiled into the binary, so keypose works from any directory: one registry,
//! keyed by the robot's name, holding everything keypose knows of each — its robot file, its
//! MuJoCo model and its LeRobot types. A new built-in arm is one entry here (and its two files).

use super::lerobot_names::{LeRobotRole, LeRobotType};
use super::{Robot, RobotSource};

/// One built-in robot.
#[derive(Debug, PartialEq, Eq)]
pub struct BuiltinRobot {
    /// The name `--robot` takes and robot files' `name` holds.
    pub name: &'static str,
    /// Its robot file (`robots/NAME.json`, keypose-robot/1).
    pub description: &'static str,
    /// Its MuJoCo model (`sim/models/NAME.xml`): `sim` loads it and the studio draws it.
    pub mjcf: &'static str,
    /// The LeRobot types that are this arm, follower first; empty when LeRobot has no driver
    /// for it.
    pub lerobot: &'static [LeRobotType],
}

/// Every built-in robot.
pub const BUILTINS: [BuiltinRobot; 4] = [
    BuiltinRobot {
        name: "so101",
        description: include_str!("../../robots/so101.json"),
        mjcf: include_str!("../../sim/models/so101.xml"),
        // LeRobot merged the SO arms' classes on 2026-01-12: since then SO-100 and SO-101 keep
        // calibrations under the class names `so_follower`/`so_leader`, before that under the
        // type names; the current place is looked in first.
        lerobot: &[
            LeRobotType {
                name: "so101_follower",
                role: LeRobotRole::Follower,
                calibration_dirs: &["robots/so_follower", "robots/so101_follower"],
            },
            LeRobotType {
                name: "so101_leader",
                role: LeRobotRole::Leader,
                calibration_dirs: &["teleoperators/so_leader", "teleoperators/so101_leader"],
            },
        ],
    },
    BuiltinRobot {
        name: "so100",
        description: include_str!("../../robots/so100.json"),
        mjcf: include_str!("../../sim/models/so100.xml"),
        lerobot: &[
            LeRobotType {
                name: "so100_follower",
                role: LeRobotRole::Follower,
                calibration_dirs: &["robots/so_follower", "robots/so100_follower"],
            },
            LeRobotType {
                name: "so100_leader",
                role: LeRobotRole::Leader,
                calibration_dirs: &["teleoperators/so_leader", "teleoperators/so100_leader"],
            },
        ],
    },
    BuiltinRobot {
        name: "koch",
        description: include_str!("../../robots/koch.json"),
        mjcf: include_str!("../../sim/models/koch.xml"),
        lerobot: &[
            LeRobotType {
                name: "koch_follower",
                role: LeRobotRole::Follower,
                calibration_dirs: &["robots/koch_follower"],
            },
            LeRobotType {
                name: "koch_leader",
                role: LeRobotRole::Leader,
                calibration_dirs: &["teleoperators/koch_leader"],
            },
        ],
    },
    BuiltinRobot {
        name: "omx",
        description: include_str!("../../robots/omx.json"),
        mjcf: include_str!("../../sim/models/omx.xml"),
        // LeRobot's `omx_follower` is another arm (lerobot_names::NotBuiltIn::Omx).
        lerobot: &[],
    },
];

/// The built-in robots' names, in [`BUILTINS`] order.
pub const BUILTIN_NAMES: [&str; BUILTINS.len()] = {
    let mut names = [""; BUILTINS.len()];
    let mut i = 0;
    while i < BUILTINS.len() {
        names[i] = BUILTINS[i].name;
        i += 1;
    }
    names
};

/// The built-in robot called `name`.
pub fn find(name: &str) -> Option<&'static BuiltinRobot> {
    BUILTINS.iter().find(|b| b.name == name)
}

/// The MuJoCo model (MJCF text) of the built-in robot called `name`: what `sim` loads, the
/// studio draws and the contact check reads its shapes from.
pub fn builtin_mjcf(name: &str) -> Option<&'static str> {
    find(name).map(|b| b.mjcf)
}

/// The built-in robot `robot` is built like, when its own name is none of theirs: the one
/// whose joints have the same names, kinds and servo models, in order (a copy of a built-in's
/// robot file, renamed). What keypose can offer its model and masses for.
pub fn builtin_like(robot: &Robot) -> Option<&'static str> {
    BUILTIN_NAMES.into_iter().find(|name| {
        get(name).is_some_and(|b| {
            b.joints.len() == robot.joints.len()
                && b.joints.iter().zip(&robot.joints).all(|(a, j)| {
                    a.name == j.name && a.kind == j.kind && a.servo.model == j.servo.model
                })
        })
    })
}

/// How a robot without a built-in model could have one: a word about the built-in it is built
/// like (name it so in its file), or nothing.
pub fn named_like_hint(robot: &Robot) -> String {
    match builtin_like(robot) {
        Some(like) => format!(
            "; its joints and servos are the built-in {like}'s: give it \"name\": \"{like}\" in its \
             file to use that model and its masses"
        ),
        None => String::new(),
    }
}

/// The built-in robot called `name`, loaded.
pub fn get(name: &str) -> Option<Robot> {
    let builtin = find(name)?;
    // A built-in that does not parse is a build defect that the tests catch; refuse it rather
    // than panic in a user's hands.
    let mut robot = Robot::from_json(
        &format!("robots/{name}.json (built in)"),
        builtin.description,
    )
    .ok()?;
    robot.source = RobotSource::Builtin(name.to_string());
    robot.lerobot = builtin.follower();
    Some(robot)
}

impl BuiltinRobot {
    /// LeRobot's follower type of this arm, if LeRobot drives it.
    pub fn follower(&self) -> Option<&'static LeRobotType> {
        self.lerobot
            .iter()
            .find(|t| t.role == LeRobotRole::Follower)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_entry_is_the_robot_its_files_describe() {
        for builtin in &BUILTINS {
            let robot = get(builtin.name).unwrap_or_else(|| panic!("{} loads", builtin.name));
            assert_eq!(
                robot.name, builtin.name,
                "robots/{}.json's name",
                builtin.name
            );
            let model = format!("<mujoco model=\"{}\"", builtin.name);
            assert!(
                builtin.mjcf.contains(&model),
                "sim/models/{}.xml names another model",
                builtin.name
            );
            for t in builtin.lerobot {
                assert!(
                    t.name.starts_with(builtin.name),
                    "{} under {}",
                    t.name,
                    builtin.name
                );
            }
        }
    }
}
