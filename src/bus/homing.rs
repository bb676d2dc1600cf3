//! The homing offsets a robot description (or the LeRobot calibration applied to it) expects,
//! checked against what the servos hold.
//!
//! LeRobot writes each servo's Homing_Offset register when it calibrates an arm, and its
//! recorded ranges are Present Position ticks after that offset. A servo holding another
//! offset has been recalibrated since, or belongs to another arm: every tick the description
//! computes would land elsewhere, so nothing may move.

use super::{BusError, ServoBus};
use crate::robot::Robot;
use crate::servo::ModelSpec;

/// One joint whose servo holds another homing offset than the description says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OffsetMismatch {
    /// The joint's name.
    pub joint: String,
    /// Its servo's id.
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
    /// Each joint whose servo differs, in the robot's joint order.
    pub mismatches: Vec<OffsetMismatch>,
}

/// A homing offset other than 0 for a servo whose model has no Homing_Offset register: such
/// a servo reports its shaft's own position, so 0 is the only offset that describes it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "joint {joint} (servo {servo}): the file gives homing offset {expected}, but the {model} has \
     no Homing_Offset register (it applies no offset), so only 0 fits; nothing was moved"
)]
pub struct NoHomingRegister {
    /// The joint's name.
    pub joint: String,
    /// Its servo's id.
    pub servo: u8,
    /// The servo's model, as robot files name it.
    pub model: &'static str,
    /// What the robot description or the calibration says, in ticks.
    pub expected: i64,
}

/// The register this check reads, as errors about a model without it name it.
pub(crate) const REGISTER: &str = "Homing_Offset";

/// Reads the Homing_Offset register of every servo whose joint gives `homing_offset` and
/// compares. Only reads: nothing is written to any servo. A servo whose model has no such
/// register is not read: an offset of 0 agrees with it, any other is refused
/// ([`NoHomingRegister`]).
pub fn check_homing_offsets(bus: &mut dyn ServoBus, robot: &Robot) -> Result<(), BusError> {
    let mut joints = Vec::new();
    for joint in &robot.joints {
        let Some(expected) = joint.servo.homing_offset else {
            continue;
        };
        let spec = joint.servo.model.spec();
        if needs_reading(&joint.name, joint.servo.id, spec, expected)? {
            joints.push((joint, expected));
        }
    }
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

/// Whether checking the offset `expected` of servo `servo` (joint `joint`, a `spec`) takes
/// reading its register. A model without Homing_Offset applies no offset: 0 agrees with it
/// unread, any other offset is refused.
fn needs_reading(
    joint: &str,
    servo: u8,
    spec: &ModelSpec,
    expected: i64,
) -> Result<bool, NoHomingRegister> {
    match (spec.table.homing_offset, expected) {
        (Some(_), _) => Ok(true),
        (None, 0) => Ok(false),
        (None, expected) => Err(NoHomingRegister {
            joint: joint.to_string(),
            servo,
            model: spec.name,
            expected,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::servo::dynamixel_x::WITHOUT_OFFSET_OR_MODE;
    use crate::servo::ServoModel;

    #[test]
    fn a_model_without_the_register_agrees_only_with_offset_0_and_is_not_read() {
        let spec = &WITHOUT_OFFSET_OR_MODE;
        assert_eq!(needs_reading("elbow", 3, spec, 0), Ok(false));
        let refused = needs_reading("elbow", 3, spec, -300).unwrap_err();
        assert_eq!(
            refused,
            NoHomingRegister {
                joint: "elbow".into(),
                servo: 3,
                model: spec.name,
                expected: -300,
            }
        );
        let error = BusError::from(refused);
        assert_eq!(error.servo(), Some(3));
        assert_eq!(error.kind(), crate::error::ErrorKind::BadInput);
    }

    #[test]
    fn a_model_with_the_register_is_read_whatever_the_offset() {
        for model in ServoModel::ALL {
            for expected in [0, -300] {
                assert_eq!(needs_reading("elbow", 3, model.spec(), expected), Ok(true));
            }
        }
    }
}
