//! Several arms as one robot: a cell. Its joints are every arm's, in arm order, named
//! `ARM/JOINT`; everything that works in joint space (tracks, the limit check, retiming, the
//! player's limiter and guard, the log) treats a cell as one robot with more joints, which is
//! what keeps the arms on one timeline. What needs one arm's geometry (inverse kinematics, the
//! simulation's models) goes through [`Arm`], which keeps each arm's own description.

use super::{Robot, RobotSource};
use crate::pose::RigidTransform;
use glam::DVec3;
use std::ops::Range;

/// One arm of a cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// The prefix of its joints in the cell.
    pub name: String,
    /// The arm alone, as its own bus sees it: its joint names, servo ids and calibration.
    pub robot: Robot,
    /// Its base frame in the cell frame.
    pub base: RigidTransform,
    /// Its joints' indices among the cell's.
    pub joints: Range<usize>,
}

/// Why arms cannot make a cell.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CellError {
    /// Two arms by one name (the name it is).
    #[error("arm {0:?} is named twice; expected each arm once")]
    DuplicateArm(String),
    /// The cell addresses its joints as servos 1 … N (see [`Robot::cell`]).
    #[error("the arms have {found} joints together; expected at most {max}")]
    TooManyJoints {
        /// The arms' joints together.
        found: usize,
        /// [`MAX_CELL_JOINTS`].
        max: usize,
    },
}

/// Most joints a cell may have: the cell numbers its joints as the ids of one bus.
pub const MAX_CELL_JOINTS: usize = 252;

/// The name of an arm's joint in the cell.
pub fn cell_joint_name(arm: &str, joint: &str) -> String {
    format!("{arm}/{joint}")
}

/// `("left", "elbow_flex")` for `"left/elbow_flex"`; None for a name without an arm.
pub fn split_joint_name(name: &str) -> Option<(&str, &str)> {
    name.split_once('/')
}

impl Robot {
    /// The cell of `arms` (name, robot, base), in the order given.
    ///
    /// Each joint keeps its arm's limits, servo model and calibration. Its servo id in the cell
    /// is its place in the cell's joint list plus one: the arms' own ids repeat from bus to bus,
    /// and the bus that drives a cell maps each cell id back to its arm's bus and servo. The
    /// first joint of each arm is placed at the arm's base, so the cell's forward kinematics
    /// gives every joint frame in the cell frame.
    pub fn cell(arms: Vec<(String, Robot, RigidTransform)>) -> Result<Robot, CellError> {
        let total: usize = arms.iter().map(|(_, r, _)| r.joints.len()).sum();
        if total > MAX_CELL_JOINTS {
            return Err(CellError::TooManyJoints {
                found: total,
                max: MAX_CELL_JOINTS,
            });
        }
        let mut cell = Robot {
            name: String::new(),
            source: RobotSource::Cell,
            description: String::new(),
            bus: arms.first().map_or(default_bus(), |(_, r, _)| r.bus),
            // The loop runs as fast as the fastest arm asks; checks follow the same rate.
            control_hz: arms
                .iter()
                .map(|(_, r, _)| r.control_hz)
                .fold(0.0, f64::max),
            joints: Vec::with_capacity(total),
            tcp: None,
            home: Vec::with_capacity(total),
            lerobot: None,
            arms: Vec::with_capacity(arms.len()),
            // The cell keeps the largest clearance any arm asks for.
            clearance: arms.iter().map(|(_, r, _)| r.clearance).fold(0.0, f64::max),
            // Each arm carries its own.
            payload: None,
        };
        for (name, robot, base) in arms {
            if cell.arms.iter().any(|a| a.name == name) {
                return Err(CellError::DuplicateArm(name));
            }
            let start = cell.joints.len();
            for (i, joint) in robot.joints.iter().enumerate() {
                let mut joint = joint.clone();
                joint.name = cell_joint_name(&name, &joint.name);
                joint.servo.id = (cell.joints.len() + 1) as u8;
                if i == 0 {
                    joint.origin = base.compose(&joint.origin);
                }
                cell.joints.push(joint);
            }
            cell.home.extend_from_slice(&robot.home);
            cell.arms.push(Arm {
                name,
                robot,
                base,
                joints: start..cell.joints.len(),
            });
        }
        cell.name = cell
            .arms
            .iter()
            .map(|a| format!("{}={}", a.name, a.robot.name))
            .collect::<Vec<_>>()
            .join(",");
        cell.description = format!("a cell of {} arms: {}", cell.arms.len(), cell.name);
        Ok(cell)
    }

    /// Whether this robot is a cell of arms.
    pub fn is_cell(&self) -> bool {
        !self.arms.is_empty()
    }

    /// The arm called `name`.
    pub fn arm(&self, name: &str) -> Option<&Arm> {
        self.arms.iter().find(|a| a.name == name)
    }

    /// The arm joint `index` belongs to (None on a robot of one arm).
    pub fn arm_of_joint(&self, index: usize) -> Option<&Arm> {
        self.arms.iter().find(|a| a.joints.contains(&index))
    }

    /// The prefix of each tool's names, in the order of [`Robot::tool_positions`]: `""` for a
    /// robot of one arm, `"ARM/"` per arm of a cell.
    pub fn tool_prefixes(&self) -> Vec<String> {
        if self.is_cell() {
            self.arms.iter().map(|a| format!("{}/", a.name)).collect()
        } else {
            vec![String::new()]
        }
    }

    /// Where each tool is for joint values `values`: the robot's tcp in its base frame, or on a
    /// cell each arm's tcp in that arm's base frame (the frame its tool keys are in).
    pub fn tool_positions(&self, values: &[f64]) -> Vec<DVec3> {
        if self.is_cell() {
            self.arms
                .iter()
                .map(|a| a.robot.tcp_position(a.values(values)))
                .collect()
        } else {
            vec![self.tcp_position(values)]
        }
    }

    /// Whether joint `index` starts a chain of its own: the first joint of a cell's arm, whose
    /// origin is in the cell frame rather than on the previous joint.
    pub(super) fn starts_chain(&self, index: usize) -> bool {
        index == 0 || self.arms.iter().any(|a| a.joints.start == index)
    }
}

fn default_bus() -> super::BusSettings {
    super::BusSettings {
        protocol: super::Protocol::Dynamixel2,
        baud: 1_000_000,
    }
}

impl Arm {
    /// This arm's values out of the cell's (joint order).
    pub fn values<'a>(&self, cell_values: &'a [f64]) -> &'a [f64] {
        &cell_values[self.joints.clone()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_so101(offset: f64) -> Robot {
        let so101 = Robot::builtin("so101").unwrap();
        let base = RigidTransform::new(DVec3::new(0.0, offset, 0.0), glam::DQuat::IDENTITY);
        Robot::cell(vec![
            ("left".into(), so101.clone(), RigidTransform::IDENTITY),
            ("right".into(), so101, base),
        ])
        .unwrap()
    }

    #[test]
    fn a_cell_names_its_joints_by_arm_and_numbers_its_servos() {
        let cell = two_so101(0.4);
        assert_eq!(cell.joints.len(), 12);
        assert_eq!(cell.joints[0].name, "left/shoulder_pan");
        assert_eq!(cell.joints[6].name, "right/shoulder_pan");
        let ids: Vec<u8> = cell.joints.iter().map(|j| j.servo.id).collect();
        assert_eq!(ids, (1..=12).collect::<Vec<u8>>());
        assert_eq!(cell.arm_of_joint(7).unwrap().name, "right");
        assert_eq!(cell.arm("right").unwrap().joints, 6..12);
        assert_eq!(cell.home.len(), 12);
    }

    #[test]
    fn each_arm_of_a_cell_is_placed_at_its_base() {
        let cell = two_so101(0.4);
        let so101 = Robot::builtin("so101").unwrap();
        let pose: Vec<f64> = vec![10.0, -20.0, 30.0, 15.0, -40.0, 5.0];
        let both: Vec<f64> = pose.iter().chain(&pose).copied().collect();
        let alone = so101.joint_frames(&pose);
        let frames = cell.joint_frames(&both);
        for (k, frame) in alone.iter().enumerate() {
            assert!((frames[k].t - frame.t).length() < 1e-12);
            // The right arm is the same motion 0.4 m along y.
            let shifted = frames[6 + k].t - DVec3::new(0.0, 0.4, 0.0);
            assert!((shifted - frame.t).length() < 1e-12, "joint {k}");
        }
    }

    #[test]
    fn an_arm_named_twice_is_refused() {
        let so101 = Robot::builtin("so101").unwrap();
        let arms = vec![
            ("a".into(), so101.clone(), RigidTransform::IDENTITY),
            ("a".into(), so101, RigidTransform::IDENTITY),
        ];
        assert_eq!(
            Robot::cell(arms).unwrap_err(),
            CellError::DuplicateArm("a".into())
        );
    }
}
