//! Import of a LeRobot calibration file into the servo mapping.
//!
//! LeRobot stores, per motor, `id`, `drive_mode`, `homing_offset`, `range_min` and `range_max`
//! (raw Present Position ticks, read after the homing offset was written to the servo). Its
//! degree normalisation centres each joint on the midpoint of the recorded range, so that
//! midpoint becomes keypose's `zero_tick`; its degrees never apply `drive_mode`
//! ([`LEROBOT_DEGREES_DIRECTION`]). LeRobot divides by 4095 ticks per turn where the
//! encoder has 4096; keypose keeps the true 4096, which differs from LeRobot's degrees by at most
//! 1/4096 of the angle (0.04° at 160°).
//!
//! The limits follow the zero into the calibrated frame. A joint whose range LeRobot recorded
//! gets that range as its limits, wider or narrower than the robot's: it is the range the arm
//! was moved through by hand, and LeRobot writes it into the servo's own Min/Max_Position_Limit
//! registers (`write_calibration` in `feetech.py` and `dynamixel.py`), which bound the servo in
//! position mode. A joint LeRobot gives the whole turn instead ([`WHOLE_TURN`]) keeps the robot's
//! limits, moved by ticks from the robot's zero to the calibrated one: the same servo positions,
//! within that turn. docs/robots.md §8.
//!
//! A calibration belongs to one arm: it must name every joint, with the servo id the robot
//! gives that joint. A partial file or other ids mean it was made for another arm or another
//! wiring, and applying it would move servos by another arm's offsets.

use super::{CalibratedRange, Joint, LimitsOrigin, Robot, Servo};
use crate::json::{self, InputError, Node};

/// The top-level arrays of LeRobot's old calibration format (one array per field, indexed by
/// `motor_names`), which current LeRobot replaced by one object per motor.
const OLD_FORMAT_FIELDS: [&str; 6] = [
    "homing_offset",
    "drive_mode",
    "start_pos",
    "end_pos",
    "calib_mode",
    "motor_names",
];

/// The range LeRobot writes for a motor it does not record a range for: the whole turn,
/// 0 … 4095 (the SO arms' wrist_roll and the Koch's shoulder_pan and wrist_roll in their
/// `calibrate()`, every motor of the OMX follower's).
const WHOLE_TURN: (i64, i64) = (0, 4095);

/// LeRobot's gripper motor, in 0 … 100 % of its calibrated range on every SO and Koch arm.
pub const LEROBOT_GRIPPER: &str = "gripper";

/// Whether `joint` is an arm's gripper as LeRobot names it (`gripper`, or `ARM/gripper` on a
/// cell).
pub fn is_lerobot_gripper(joint: &Joint) -> bool {
    super::split_joint_name(&joint.name).map_or(joint.name.as_str(), |(_, j)| j) == LEROBOT_GRIPPER
}

/// The sign of LeRobot's degrees against Present Position, whatever `drive_mode` says.
/// LeRobot's `MotorNormMode.DEGREES` is `(raw − mid) · 360 / 4095` and reads no `drive_mode`
/// on any vendor (S6 `motors_bus.py::_normalize` and `_unnormalize`, unchanged since the
/// 2025-06 hardware API); `drive_mode` mirrors only the −100…100 and 0…100 modes, and only on
/// Feetech (`apply_drive_mode = True` in `feetech.py`, `False` in `dynamixel.py`). On a
/// Dynamixel servo, drive_mode 1 is the servo's own Drive Mode register (LeRobot's leader
/// calibrations write it), so Present Position arrives already mirrored: reversing it here
/// too would undo it. docs/robots.md §8.
const LEROBOT_DEGREES_DIRECTION: f64 = 1.0;

/// The recorded range as LeRobot's 0…100 scale maps it, in keypose's values of `joint` (its
/// servo mapping already set from this calibration). LeRobot's `MotorNormMode.RANGE_0_100`
/// (S6 `motors_bus.py::_normalize`): `(raw − range_min) / (range_max − range_min) · 100`,
/// then `100 − x` when `apply_drive_mode and drive_mode`, which only Feetech applies: a
/// Dynamixel's drive_mode 1 has mirrored the ticks in the servo already. So the range is
/// mirrored here for a model whose firmware has no Drive_Mode reverse bit.
fn calibrated_range(
    joint: &Joint,
    range_min: i64,
    range_max: i64,
    drive_mode_one: bool,
) -> CalibratedRange {
    let (at_0, at_100) = (joint.servo.value(range_min), joint.servo.value(range_max));
    if drive_mode_one && joint.servo.model.spec().drive_mode.is_none() {
        CalibratedRange {
            at_0: at_100,
            at_100: at_0,
        }
    } else {
        CalibratedRange { at_0, at_100 }
    }
}

/// A joint whose calibration gives another servo id than the robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdMismatch {
    /// The joint's name.
    pub joint: String,
    /// The id the calibration gives its motor.
    pub calibration_id: u8,
    /// The id the robot gives its servo.
    pub robot_id: u8,
}

/// A calibration that does not fit the robot as a whole.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CalibrationMismatch {
    /// LeRobot's old format, top-level arrays instead of an object per motor.
    #[error(
        "LeRobot's old calibration format (top-level arrays {}); keypose reads the current one, \
         an object per motor with id, drive_mode, homing_offset, range_min and range_max: \
         recalibrate the arm with current LeRobot (lerobot-calibrate)",
        fields.join(", ")
    )]
    OldFormat {
        /// The old format's top-level arrays found.
        fields: Vec<String>,
    },
    /// Joints of the robot the calibration has no entry for.
    #[error(
        "the calibration does not name joint(s) {} of {robot}: expected an entry for every joint ({})",
        missing.join(", "),
        expected.join(", ")
    )]
    MissingJoints {
        /// The robot's name.
        robot: String,
        /// The joints without an entry.
        missing: Vec<String>,
        /// Every joint of the robot.
        expected: Vec<String>,
    },
    /// Servo ids that differ between the calibration and the robot.
    #[error(
        "servo ids differ from {robot}'s: {}; a calibration is for the arm it was made on",
        mismatches
            .iter()
            .map(|m| format!("{} has id {} in the calibration, {} in the robot", m.joint, m.calibration_id, m.robot_id))
            .collect::<Vec<_>>()
            .join("; ")
    )]
    Ids {
        /// The robot's name.
        robot: String,
        /// Every joint whose ids differ.
        mismatches: Vec<IdMismatch>,
    },
}

/// A motor's entry that cannot have been made on this arm's joint: the calibration belongs to
/// another servo model or another arm (an SO-101's file names the same motors with the same ids
/// as a Koch's).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotThisJoint {
    /// The homing offset is beyond what the servo's Homing_Offset register holds.
    #[error(
        "homing_offset {offset} of {joint} is outside what the {model}'s Homing_Offset holds \
         ({low} … {high}): a calibration made on another servo model"
    )]
    HomingOffset {
        /// The joint's name.
        joint: String,
        /// The servo model's name.
        model: &'static str,
        /// The offset the calibration gives.
        offset: i64,
        /// The register's lowest value.
        low: i64,
        /// The register's highest value.
        high: i64,
    },
    /// The recorded range spans more than the servo's one turn.
    #[error(
        "{joint}'s range_min … range_max ({min} … {max}) spans {span} ticks, more than the \
         {model}'s turn of {turn} ticks: no joint of this arm turns that far by hand"
    )]
    MoreThanATurn {
        /// The joint's name.
        joint: String,
        /// The servo model's name.
        model: &'static str,
        /// range_min.
        min: i64,
        /// range_max.
        max: i64,
        /// range_max − range_min.
        span: i64,
        /// Ticks per revolution.
        turn: i64,
    },
    /// The recorded range is far wider than the joint can move.
    #[error(
        "{joint}'s recorded range ({min} … {max}) is {recorded:.1} {unit} of travel, but \
         {robot}'s {joint} moves through {travel:.1} {unit} (its limits): a range recorded by \
         hand on this arm is at most {factor}× that; this calibration was made on another arm \
         (an SO arm and a Koch name the same motors with the same ids): use this arm's own"
    )]
    WiderThanTheJoint {
        /// The joint's name.
        joint: String,
        /// The robot's name.
        robot: String,
        /// range_min.
        min: i64,
        /// range_max.
        max: i64,
        /// The recorded travel, in the joint's unit.
        recorded: f64,
        /// The robot's travel (max − min of its limits).
        travel: f64,
        /// The joint's unit.
        unit: &'static str,
        /// [`WIDEST_RECORDED_RANGE`].
        factor: f64,
    },
    /// A whole-turn joint whose limits leave no room within the turn.
    #[error(transparent)]
    OutsideTheTurn(#[from] OutsideTheTurn),
}

/// How much wider than the robot's own limits a range recorded by hand may be. LeRobot
/// records the range the arm was moved through to its mechanical stops, which the robot's
/// limits approximate: 1.05× at the SO-101's shoulder_lift in a real follower's file
/// (tests/data/lerobot_so101_follower.json), where that SO-101 file read as a Koch's is 1.67×
/// at shoulder_lift.
pub const WIDEST_RECORDED_RANGE: f64 = 1.5;

/// A whole-turn joint whose robot limits, moved to the calibrated zero, leave no room within
/// the turn: the robot file's zero is not where the calibrated servo's ticks are.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the robot's limits of {joint} ({min} … {max}) lie at ticks {low_tick:.1} … {high_tick:.1}, \
     outside the whole turn 0 … 4095 the calibration gives it: expected the robot's zero_tick \
     within that turn"
)]
pub struct OutsideTheTurn {
    /// The joint's name.
    pub joint: String,
    /// The robot's lower limit, in the joint's unit.
    pub min: f64,
    /// The robot's upper limit.
    pub max: f64,
    /// The tick the lower limit lands on with the calibrated zero.
    pub low_tick: f64,
    /// The tick the upper limit lands on.
    pub high_tick: f64,
}

/// What an import changed, for the user to read; each joint's `limits_origin` says where its
/// limits came from.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationReport {
    /// The joints the calibration was applied to, in joint order.
    pub calibrated: Vec<String>,
}

/// Applies a LeRobot calibration (JSON text) to `robot`'s servo mapping and limits.
pub fn import_lerobot_calibration(
    robot: &mut Robot,
    file: &str,
    text: &str,
) -> Result<CalibrationReport, InputError> {
    let value = json::parse(file, text)?;
    let root = Node::root(file, &value);
    let whole_file = |mismatch: CalibrationMismatch| {
        InputError::new(file, json::Location::File, mismatch.to_string())
    };
    let mut report = CalibrationReport {
        calibrated: Vec::new(),
    };
    let entries = root.named_entries("motor names")?;
    if let Some(old) = old_format(&entries) {
        return Err(whole_file(old));
    }
    let mut mismatches = Vec::new();
    for (motor, node) in &entries {
        let Some(index) = robot.joint_index(motor) else {
            return Err(node.error(format!(
                "motor {motor:?} is not a joint of {}; expected one of: {}",
                robot.name,
                robot.joint_names().join(", ")
            )));
        };
        let motor = read_motor(node)?;
        let joint = &mut robot.joints[index];
        if motor.id != joint.servo.id {
            mismatches.push(IdMismatch {
                joint: joint.name.clone(),
                calibration_id: motor.id,
                robot_id: joint.servo.id,
            });
        }
        apply_motor(joint, &robot.name, &motor, file)
            .map_err(|mismatch| node.error(mismatch.to_string()))?;
        report.calibrated.push(joint.name.clone());
    }
    if !mismatches.is_empty() {
        return Err(whole_file(CalibrationMismatch::Ids {
            robot: robot.name.clone(),
            mismatches,
        }));
    }
    if let Some(missing) = missing_joints(robot, &report.calibrated) {
        return Err(whole_file(missing));
    }
    for (joint, home) in robot.joints.iter().zip(robot.home.iter_mut()) {
        *home = home.clamp(joint.limits.min, joint.limits.max);
    }
    Ok(report)
}

/// One motor's entry of a calibration file, as LeRobot writes it.
struct MotorCalibration {
    id: u8,
    drive_mode: i64,
    homing_offset: i64,
    range_min: i64,
    range_max: i64,
}

/// LeRobot's old format kept each field as a top-level array: recognised, to say so.
fn old_format(entries: &[(&str, Node)]) -> Option<CalibrationMismatch> {
    let fields: Vec<String> = entries
        .iter()
        .filter(|(name, node)| OLD_FORMAT_FIELDS.contains(name) && node.value.is_array())
        .map(|(name, _)| name.to_string())
        .collect();
    (!fields.is_empty()).then_some(CalibrationMismatch::OldFormat { fields })
}

fn read_motor(node: &Node) -> Result<MotorCalibration, InputError> {
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
    // Not applied to the degrees (see `LEROBOT_DEGREES_DIRECTION`), only to the 0…100 scale.
    let drive_mode = node
        .require("drive_mode", "0 or 1")?
        .integer("drive mode", 0, 1)?;
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
    Ok(MotorCalibration {
        id,
        drive_mode,
        homing_offset,
        range_min,
        range_max,
    })
}

/// Centres the joint's zero on the recorded range (where LeRobot's degrees are 0), keeps the
/// range for percentages, and sets the limits in that frame ([`calibrated_limits`]).
fn apply_motor(
    joint: &mut Joint,
    robot: &str,
    motor: &MotorCalibration,
    file: &str,
) -> Result<(), NotThisJoint> {
    fits_the_servo(joint, motor)?;
    let uncalibrated = joint.servo.clone();
    joint.servo.zero_tick = (motor.range_min + motor.range_max) as f64 / 2.0;
    joint.servo.direction = LEROBOT_DEGREES_DIRECTION;
    joint.servo.homing_offset = Some(motor.homing_offset);
    let range = calibrated_range(
        joint,
        motor.range_min,
        motor.range_max,
        motor.drive_mode == 1,
    );
    joint.calibrated_range = Some(range);
    fits_the_joint(joint, robot, motor)?;
    let (min, max, origin) = calibrated_limits(joint, &uncalibrated, motor, file)?;
    joint.limits.min = min;
    joint.limits.max = max;
    joint.limits_origin = origin;
    Ok(())
}

/// Whether `motor`'s entry is one the joint's servo model can hold: its homing offset within
/// the Homing_Offset register (the STS3215's is ±2047), its range within one turn.
fn fits_the_servo(joint: &Joint, motor: &MotorCalibration) -> Result<(), NotThisJoint> {
    let spec = joint.servo.model.spec();
    if let Some(register) = spec.table.homing_offset {
        let (low, high) = register.range();
        if !(low..=high).contains(&motor.homing_offset) {
            return Err(NotThisJoint::HomingOffset {
                joint: joint.name.clone(),
                model: spec.name,
                offset: motor.homing_offset,
                low,
                high,
            });
        }
    }
    let turn = spec.ticks_per_revolution as i64;
    let span = motor.range_max - motor.range_min;
    if span >= turn {
        return Err(NotThisJoint::MoreThanATurn {
            joint: joint.name.clone(),
            model: spec.name,
            min: motor.range_min,
            max: motor.range_max,
            span,
            turn,
        });
    }
    Ok(())
}

/// Whether a range recorded by hand (not LeRobot's whole turn) fits the joint's travel: at
/// most [`WIDEST_RECORDED_RANGE`] times the robot's limits (`joint`'s, not yet calibrated).
/// The gripper is left out: its jaws are squeezed past their model's limits by hand, and its
/// range is only its 0 … 100 %.
fn fits_the_joint(
    joint: &Joint,
    robot: &str,
    motor: &MotorCalibration,
) -> Result<(), NotThisJoint> {
    if (motor.range_min, motor.range_max) == WHOLE_TURN || is_lerobot_gripper(joint) {
        return Ok(());
    }
    let recorded = (joint.servo.value(motor.range_max) - joint.servo.value(motor.range_min)).abs();
    let travel = joint.limits.max - joint.limits.min;
    if recorded <= WIDEST_RECORDED_RANGE * travel {
        return Ok(());
    }
    Err(NotThisJoint::WiderThanTheJoint {
        joint: joint.name.clone(),
        robot: robot.to_string(),
        min: motor.range_min,
        max: motor.range_max,
        recorded,
        travel,
        unit: joint.kind.unit(),
        factor: WIDEST_RECORDED_RANGE,
    })
}

/// The position limits of `joint` (its servo mapping already calibrated) in the calibrated
/// frame: the recorded range where LeRobot recorded one; for a whole-turn joint, the robot's
/// limits at the same ticks as through `uncalibrated`, the robot's own mapping, within the turn.
fn calibrated_limits(
    joint: &Joint,
    uncalibrated: &Servo,
    motor: &MotorCalibration,
    file: &str,
) -> Result<(f64, f64, LimitsOrigin), OutsideTheTurn> {
    let file = file.to_string();
    let ends = [motor.range_min, motor.range_max].map(|tick| joint.servo.value(tick));
    let (low, high) = (ends[0].min(ends[1]), ends[0].max(ends[1]));
    if (motor.range_min, motor.range_max) != WHOLE_TURN {
        return Ok((low, high, LimitsOrigin::RecordedRange { file }));
    }
    let ticks = [joint.limits.min, joint.limits.max].map(|value| uncalibrated.tick_exact(value));
    let moved = ticks.map(|tick| joint.servo.value_exact(tick));
    let (min, max) = (
        moved[0].min(moved[1]).max(low),
        moved[0].max(moved[1]).min(high),
    );
    if min >= max {
        return Err(OutsideTheTurn {
            joint: joint.name.clone(),
            min: joint.limits.min,
            max: joint.limits.max,
            low_tick: ticks[0].min(ticks[1]),
            high_tick: ticks[0].max(ticks[1]),
        });
    }
    Ok((min, max, LimitsOrigin::Rebased { file }))
}

/// The joints a calibration must cover but does not: every joint of the robot.
fn missing_joints(robot: &Robot, calibrated: &[String]) -> Option<CalibrationMismatch> {
    let missing: Vec<String> = robot
        .joints
        .iter()
        .filter(|j| !calibrated.contains(&j.name))
        .map(|j| j.name.clone())
        .collect();
    (!missing.is_empty()).then(|| CalibrationMismatch::MissingJoints {
        robot: robot.name.clone(),
        missing,
        expected: robot.joint_names().iter().map(|n| n.to_string()).collect(),
    })
}
