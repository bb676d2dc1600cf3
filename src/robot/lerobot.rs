//! Import of a LeRobot calibration file into the servo mapping.
//!
//! LeRobot stores, per motor, `id`, `drive_mode`, `homing_offset`, `range_min` and `range_max`
//! (raw Present Position ticks, read after the homing offset was written to the servo). Its
//! degree normalisation centres each joint on the midpoint of the recorded range, so that
//! midpoint becomes keypose's `zero_tick`. LeRobot divides by 4095 ticks per turn where the
//! encoder has 4096; keypose keeps the true 4096, which differs from LeRobot's degrees by at most
//! 1/4096 of the angle (0.04° at 160°).

use super::Robot;
use crate::json::{self, InputError, Node};

/// What an import changed, for the user to read.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationReport {
    pub calibrated: Vec<String>,
    /// Joints the file does not mention; they keep the robot file's mapping.
    pub untouched: Vec<String>,
    /// Joints whose position limits were narrowed to the recorded range: (joint, min, max).
    pub narrowed: Vec<(String, f64, f64)>,
}

/// Applies a LeRobot calibration (JSON text) to `robot`'s servo mapping and limits.
pub fn import_lerobot_calibration(
    robot: &mut Robot,
    file: &str,
    text: &str,
) -> Result<CalibrationReport, InputError> {
    let value = json::parse(file, text)?;
    let root = Node::root(file, &value);
    let mut report = CalibrationReport {
        calibrated: Vec::new(),
        untouched: Vec::new(),
        narrowed: Vec::new(),
    };
    let entries = root.entries()?;
    for (motor, node) in &entries {
        let Some(index) = robot.joint_index(motor) else {
            return Err(node.error(format!(
                "motor {motor:?} is not a joint of {}; expected one of: {}",
                robot.name,
                robot.joint_names().join(", ")
            )));
        };
        node.only_fields(&[
            "id",
            "drive_mode",
            "homing_offset",
            "range_min",
            "range_max",
        ])?;
        let id = node
            .require("id", "servo id")?
            .integer("servo id", 0, 252)? as u8;
        let drive_node = node.require("drive_mode", "0 or 1")?;
        let drive_mode = drive_node.integer("drive mode", 0, 1)?;
        let homing_offset = node
            .require("homing_offset", "the servo's homing offset")?
            .integer("ticks", -1_048_575, 1_048_575)?;
        let range_min = node
            .require("range_min", "lowest recorded tick")?
            .integer("ticks", -1_048_575, 1_048_575)?;
        let range_max_node = node.require("range_max", "highest recorded tick")?;
        let range_max = range_max_node.integer("ticks", -1_048_575, 1_048_575)?;
        if range_max <= range_min {
            return Err(range_max_node.expected(&format!("a tick above range_min ({range_min})")));
        }

        let joint = &mut robot.joints[index];
        joint.servo.id = id;
        joint.servo.zero_tick = (range_min + range_max) as f64 / 2.0;
        joint.servo.direction = if drive_mode == 1 { -1.0 } else { 1.0 };
        joint.servo.homing_offset = Some(homing_offset);
        let a = joint.servo.value(range_min);
        let b = joint.servo.value(range_max);
        let (low, high) = (a.min(b), a.max(b));
        let min = joint.limits.min.max(low);
        let max = joint.limits.max.min(high);
        if min >= max {
            return Err(node.error(format!(
                "the recorded range ({low:.2} … {high:.2}) does not overlap the joint's limits ({} … {})",
                joint.limits.min, joint.limits.max
            )));
        }
        if min != joint.limits.min || max != joint.limits.max {
            joint.limits.min = min;
            joint.limits.max = max;
            report.narrowed.push((joint.name.clone(), min, max));
        }
        report.calibrated.push(joint.name.clone());
    }
    let mut seen_ids = std::collections::HashSet::new();
    for joint in &robot.joints {
        if !seen_ids.insert(joint.servo.id) {
            return Err(json::InputError::new(
                file,
                json::Location::File,
                format!(
                    "servo id {} is used by two joints after import",
                    joint.servo.id
                ),
            ));
        }
        if !report.calibrated.contains(&joint.name) {
            report.untouched.push(joint.name.clone());
        }
    }
    for (joint, home) in robot.joints.iter().zip(robot.home.iter_mut()) {
        *home = home.clamp(joint.limits.min, joint.limits.max);
    }
    Ok(report)
}
