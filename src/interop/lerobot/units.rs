//! LeRobot's normalised motor values as keypose joint values (docs/interop.md §1.4).
//!
//! LeRobot's `MotorNormMode` (S6 `motors_bus.py::_normalize`): `DEGREES` is
//! `(raw − mid) · 360 / 4095`, the same zero as keypose's with the arm's calibration applied
//! (src/robot/lerobot.rs); `RANGE_M100_100` maps the calibrated range_min … range_max onto
//! −100 … 100 and `RANGE_0_100` onto 0 … 100, both mirrored when Feetech's drive_mode is 1 —
//! exactly the ends [`CalibratedRange`] keeps. The SO and Koch arms' grippers are always
//! `RANGE_0_100`; their other joints `DEGREES` when the arm was configured with
//! `use_degrees=True`, else `RANGE_M100_100`.

use super::LeRobotError;
use crate::robot::{split_joint_name, CalibratedRange, Joint};

/// How the dataset's body joints (all but the gripper) are normalised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyUnits {
    /// `MotorNormMode.DEGREES`.
    Degrees,
    /// `MotorNormMode.RANGE_M100_100`: needs the arm's calibration.
    Range,
}

impl BodyUnits {
    /// The name `--units` takes: `degrees` or `range`.
    pub fn name(self) -> &'static str {
        match self {
            BodyUnits::Degrees => "degrees",
            BodyUnits::Range => "range",
        }
    }

    /// The units named `name` ([`BodyUnits::name`]).
    pub fn parse(name: &str) -> Option<BodyUnits> {
        [BodyUnits::Degrees, BodyUnits::Range]
            .into_iter()
            .find(|u| u.name() == name)
    }
}

/// The units of each arm's body joints, by arm name (empty for a robot of one arm): LeRobot
/// configures `use_degrees` per arm.
pub type UnitsPerArm = Vec<(String, BodyUnits)>;

/// Largest |value| of `RANGE_M100_100`: beyond it a body joint's values must be degrees.
const RANGE_BOUND: f64 = 100.0;

pub use crate::robot::is_lerobot_gripper as is_gripper;

/// The units of the body joints of one arm (`arm`, empty for a robot of one arm): those asked
/// for, or what the values show. Returns the units and, when they could not be told apart, a
/// notice saying so.
pub fn decide(
    asked: Option<BodyUnits>,
    values: &[Vec<f64>],
    body_columns: &[usize],
    arm: &str,
) -> (BodyUnits, Option<String>) {
    if let Some(units) = asked {
        return (units, None);
    }
    let largest = values
        .iter()
        .flat_map(|row| body_columns.iter().map(move |&c| row[c].abs()))
        .fold(0.0f64, f64::max);
    if largest > RANGE_BOUND {
        return (BodyUnits::Degrees, None);
    }
    let of_arm = match arm {
        "" => String::new(),
        arm => format!(" of arm {arm}"),
    };
    let notice = format!(
        "note: every body-joint value{of_arm} is within ±{RANGE_BOUND} (largest {largest:.2}), so they may \
         be degrees or LeRobot's −100…100 range normalisation (an arm configured with \
         use_degrees=False); read as degrees, what current LeRobot records: if the arm used the \
         range, give --units range with its --calibration or --robot-id"
    );
    (BodyUnits::Degrees, Some(notice))
}

/// How one dataset column becomes a joint value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Conversion {
    /// Already in the joint's unit.
    Identity,
    /// `at_0 + (v − low) / (high − low) · (at_100 − at_0)`.
    Range {
        low: f64,
        high: f64,
        ends: CalibratedRange,
    },
}

impl Conversion {
    pub fn apply(self, v: f64) -> f64 {
        match self {
            Conversion::Identity => v,
            Conversion::Range { low, high, ends } => {
                ends.at_0 + (v - low) / (high - low) * (ends.at_100 - ends.at_0)
            }
        }
    }

    /// The dataset's value of joint value `v`: the inverse of [`Conversion::apply`], for
    /// writing a dataset (super::export).
    pub fn invert(self, v: f64) -> f64 {
        match self {
            Conversion::Identity => v,
            Conversion::Range { low, high, ends } => {
                low + (v - ends.at_0) / (ends.at_100 - ends.at_0) * (high - low)
            }
        }
    }
}

/// The conversion of `joint`'s column, and a notice when it had to guess.
pub fn conversion(
    joint: &Joint,
    units: BodyUnits,
) -> Result<(Conversion, Option<String>), LeRobotError> {
    if is_gripper(joint) {
        return Ok(gripper_conversion(joint));
    }
    match (units, joint.calibrated_range) {
        (BodyUnits::Degrees, _) => Ok((Conversion::Identity, None)),
        (BodyUnits::Range, Some(ends)) => Ok((
            Conversion::Range {
                low: -RANGE_BOUND,
                high: RANGE_BOUND,
                ends,
            },
            None,
        )),
        (BodyUnits::Range, None) => Err(LeRobotError::NeedsCalibration {
            joint: joint.name.clone(),
            arm: option_arm(joint),
        }),
    }
}

/// How the calibration options name `joint`'s arm: `left=` on a cell, nothing on one arm.
fn option_arm(joint: &Joint) -> String {
    split_joint_name(&joint.name).map_or(String::new(), |(arm, _)| format!("{arm}="))
}

/// 0 … 100 % onto the calibrated range, or onto the joint's limits without a calibration.
fn gripper_conversion(joint: &Joint) -> (Conversion, Option<String>) {
    let percent = |ends| Conversion::Range {
        low: 0.0,
        high: 100.0,
        ends,
    };
    match joint.calibrated_range {
        Some(ends) => (percent(ends), None),
        None => {
            let ends = CalibratedRange {
                at_0: joint.limits.min,
                at_100: joint.limits.max,
            };
            let notice = format!(
                "note: {} is in 0…100 % of its calibrated range; without a calibration 0 % is \
                 read as its lower limit ({}) and 100 % as its upper ({}): give --calibration \
                 {arm}FILE or --robot-id {arm}NAME for the arm's own range",
                joint.name,
                joint.limits.min,
                joint.limits.max,
                arm = option_arm(joint)
            );
            (percent(ends), Some(notice))
        }
    }
}
