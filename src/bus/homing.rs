//! The homing offsets a robot description (or the LeRobot calibration applied to it) expects,
//! checked against what the servos hold.
//!
//! LeRobot writes each servo's Homing_Offset register when it calibrates an arm, and its
//! recorded ranges are Present Position ticks after that offset. A servo holding another
//! offset has been recalibrated since, or belongs to another arm: every tick the description
//! computes would land elsewhere, so nothing may move.

use super::{BusError, ServoBus};
use crate::robot::Robot;

/// One joint whose servo holds another homing offset than the description says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OffsetMismatch {
    pub joint: String,
    pub servo: u8,
    /// What the robot description or the calibration says, in ticks.
    pub expected: i64,
    /// What the servo's Homing_Offset register holds, in ticks.
    pub found: i64,
}

/// Servos whose homing offsets differ from the description's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "homing offset differs from the servo's: {}. The arm was recalibrated since, or is another arm: \
     calibrate it again (or use the calibration made on it); nothing was moved",
    .mismatches
        .iter()
        .map(|m| format!(
            "joint {} (servo {}): the file says {}, the servo holds {}",
            m.joint, m.servo, m.expected, m.found
        ))
        .collect::<Vec<_>>()
        .join("; ")
)]
pub struct HomingMismatch {
    pub mismatches: Vec<OffsetMismatch>,
}

/// Reads the Homing_Offset register of every servo whose joint gives `homing_offset` and
/// compares. Only reads: nothing is written to any servo.
pub fn check_homing_offsets(bus: &mut dyn ServoBus, robot: &Robot) -> Result<(), BusError> {
    let joints: Vec<_> = robot
        .joints
        .iter()
        .filter_map(|j| j.servo.homing_offset.map(|offset| (j, offset)))
        .collect();
    if joints.is_empty() {
        return Ok(());
    }
    let servos: Vec<_> = joints
        .iter()
        .map(|(j, _)| (j.servo.id, j.servo.model))
        .collect();
    let found = bus.read_homing_offsets(&servos)?;
    let mismatches: Vec<OffsetMismatch> = joints
        .iter()
        .zip(found)
        .filter(|((_, expected), found)| expected != found)
        .map(|((joint, expected), found)| OffsetMismatch {
            joint: joint.name.clone(),
            servo: joint.servo.id,
            expected: *expected,
            found,
        })
        .collect();
    if mismatches.is_empty() {
        Ok(())
    } else {
        Err(BusError::HomingOffset(HomingMismatch { mismatches }))
    }
}
