//! The servos' own motion profile: the acceleration (and, on Dynamixel, velocity) limit a
//! servo applies between the goals it receives, so it smooths a streamed trajectory itself.
//!
//! Registers and units (docs/protocols.md):
//! - Feetech STS3215 **Acceleration** (41, 1 byte): 100 steps/s² per unit, 0–254; 0 = no limit.
//! - Dynamixel X **Profile_Acceleration** (108, 4 bytes): 214.577 rev/min² per unit in the
//!   velocity-based profile (Drive Mode bit 2 clear, the factory setting); 0 = no limit.
//! - Dynamixel X **Profile_Velocity** (112, 4 bytes): 0.229 rev/min per unit. The e-Manual's
//!   profile table: while it is 0 no profile is used at all (a step instruction, the
//!   acceleration ignored), so it is written too.
//!
//! A joint limit becomes register units **rounded down**: the servo then never accelerates (or
//! moves) faster than the joint's limit allows, at the price of lagging a goal stream that uses
//! the whole limit by under one unit's worth. Rounding up would let it exceed the limit that
//! the plan was checked against. A limit below one unit cannot be expressed (0 means "no
//! limit", the opposite of what is wanted) and is refused.

use super::registers::{Register, RegisterTable};
use crate::robot::{Joint, Vendor};

/// A profile register the player sets with `--servo-profile`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// Feetech STS Acceleration.
    Acceleration,
    /// Dynamixel Profile_Acceleration.
    ProfileAcceleration,
    /// Dynamixel Profile_Velocity.
    ProfileVelocity,
    /// Dynamixel Drive_Mode: only read, to tell which profile the servo runs (see
    /// [`time_based`]); never written.
    DriveMode,
}

impl Setting {
    /// The register in `table`, if the model has it.
    pub fn register(self, table: &RegisterTable) -> Option<Register> {
        match self {
            Setting::Acceleration => table.acceleration,
            Setting::ProfileAcceleration => table.profile_acceleration,
            Setting::ProfileVelocity => table.profile_velocity,
            Setting::DriveMode => table.drive_mode,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Setting::Acceleration => "Acceleration",
            Setting::ProfileAcceleration => "Profile_Acceleration",
            Setting::ProfileVelocity => "Profile_Velocity",
            Setting::DriveMode => "Drive_Mode",
        }
    }
}

/// Drive_Mode bit 2: the time-based profile (e-Manual, Drive Mode).
const DRIVE_MODE_TIME_BASED: i64 = 1 << 2;

/// Whether a Dynamixel Drive_Mode value selects the time-based profile, in which
/// Profile_Acceleration and Profile_Velocity are durations in milliseconds: the joint limits
/// written in the velocity-based units would then mean a move time, not a bound.
pub fn time_based(drive_mode: i64) -> bool {
    drive_mode & DRIVE_MODE_TIME_BASED != 0
}

/// Servo steps (ticks) per revolution of the supported models.
const TICKS_PER_REV: f64 = 4096.0;
/// STS Acceleration: steps/s² per unit.
pub const STS_ACCELERATION_UNIT: f64 = 100.0;
/// STS Acceleration's largest value.
const STS_ACCELERATION_MAX: i64 = 254;
/// Dynamixel Profile_Acceleration: rev/min² per unit.
const DXL_ACCELERATION_UNIT_REV_MIN2: f64 = 214.577;
/// Dynamixel Profile_Velocity: rev/min per unit.
const DXL_VELOCITY_UNIT_REV_MIN: f64 = 0.229;
/// Profile_Acceleration's and Profile_Velocity's largest value in the velocity-based profile.
const DXL_PROFILE_MAX: i64 = 32_767;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("--servo-profile: joint {joint}'s {what} limit {limit} {unit} is below one unit of the servo's {register} ({unit_value:.3} {unit}); nothing was written")]
pub struct ProfileError {
    pub joint: String,
    pub what: &'static str,
    pub register: &'static str,
    pub limit: f64,
    pub unit_value: f64,
    pub unit: String,
}

/// The settings to write for `joint` (register, value), from its limits.
pub fn settings_for(joint: &Joint) -> Result<Vec<(Setting, i64)>, ProfileError> {
    let (acceleration, velocity) = (joint.limits.acceleration, joint.limits.velocity);
    match joint.servo.model.vendor() {
        Vendor::Feetech => {
            let value = units(
                joint,
                "acceleration",
                Setting::Acceleration,
                acceleration,
                STS_ACCELERATION_UNIT,
                "/s²",
            )?;
            Ok(vec![(
                Setting::Acceleration,
                value.min(STS_ACCELERATION_MAX),
            )])
        }
        Vendor::Dynamixel => {
            let (accel_unit, vel_unit) = (dxl_acceleration_unit(), dxl_velocity_unit());
            let acceleration = units(
                joint,
                "acceleration",
                Setting::ProfileAcceleration,
                acceleration,
                accel_unit,
                "/s²",
            )?;
            let velocity = units(
                joint,
                "velocity",
                Setting::ProfileVelocity,
                velocity,
                vel_unit,
                "/s",
            )?;
            Ok(vec![
                (Setting::ProfileVelocity, velocity.min(DXL_PROFILE_MAX)),
                (
                    Setting::ProfileAcceleration,
                    acceleration.min(DXL_PROFILE_MAX),
                ),
            ])
        }
    }
}

/// What the servo will really apply for `joint` once [`settings_for`] is written, in joint
/// units: (acceleration limit per s², velocity limit per s if the servo has one), from the
/// rounded register values. The simulation models these, so its verdict reflects the rounding.
pub fn applied_limits(joint: &Joint) -> Result<(f64, Option<f64>), ProfileError> {
    let per_tick = joint.servo.units_per_tick.abs();
    let mut acceleration = 0.0;
    let mut velocity = None;
    for (setting, value) in settings_for(joint)? {
        match setting {
            Setting::Acceleration => acceleration = value as f64 * STS_ACCELERATION_UNIT * per_tick,
            Setting::ProfileAcceleration => {
                acceleration = value as f64 * dxl_acceleration_unit() * per_tick
            }
            Setting::ProfileVelocity => {
                velocity = Some(value as f64 * dxl_velocity_unit() * per_tick)
            }
            Setting::DriveMode => {}
        }
    }
    Ok((acceleration, velocity))
}

/// Dynamixel Profile_Acceleration's unit in ticks/s² (velocity-based profile).
pub fn dxl_acceleration_unit() -> f64 {
    DXL_ACCELERATION_UNIT_REV_MIN2 * TICKS_PER_REV / 3600.0
}

/// Dynamixel Profile_Velocity's (and Present_Velocity's) unit in ticks/s.
pub fn dxl_velocity_unit() -> f64 {
    DXL_VELOCITY_UNIT_REV_MIN * TICKS_PER_REV / 60.0
}

/// `limit` (joint units per second, or per second squared) in register units of `unit_ticks`
/// ticks each, rounded down; refused below one unit.
fn units(
    joint: &Joint,
    what: &'static str,
    setting: Setting,
    limit: f64,
    unit_ticks: f64,
    per: &str,
) -> Result<i64, ProfileError> {
    let limit_ticks = limit / joint.servo.units_per_tick;
    let value = (limit_ticks.abs() / unit_ticks).floor();
    if value >= 1.0 {
        return Ok(value.min(i64::MAX as f64) as i64);
    }
    let unit = format!("{}{per}", joint.kind.unit());
    Err(ProfileError {
        joint: joint.name.clone(),
        what,
        register: setting.name(),
        limit,
        unit_value: unit_ticks * joint.servo.units_per_tick.abs(),
        unit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    #[test]
    fn a_limit_below_one_register_unit_is_refused_rather_than_written_as_no_limit() {
        // STS: one unit = 100 steps/s² = 100 · 360/4096 = 8.789 °/s²; 5 °/s² is below it.
        let mut robot = Robot::builtin("so101").unwrap();
        robot.joints[0].limits.acceleration = 5.0;
        let error = settings_for(&robot.joints[0]).unwrap_err();
        assert_eq!(error.register, "Acceleration");
        assert!((error.unit_value - 8.789).abs() < 1e-3, "{error}");
    }

    #[test]
    fn the_simulated_profile_is_the_rounded_register_value_in_joint_units() {
        // so101: 344 °/s² → 39 units → 39 · 100 · 360/4096 = 342.77 °/s², no velocity register.
        let robot = Robot::builtin("so101").unwrap();
        let (a, v) = applied_limits(&robot.joints[0]).unwrap();
        assert!((a - 342.773).abs() < 1e-3, "{a}");
        assert_eq!(v, None);
        // koch shoulder_pan (XL430): 32 · 21.4577 = 686.65 °/s²; 160 · 1.374 = 219.84 °/s.
        let koch = Robot::builtin("koch").unwrap();
        let (a, v) = applied_limits(&koch.joints[0]).unwrap();
        assert!((a - 686.65).abs() < 1e-2, "{a}");
        assert!((v.unwrap() - 219.84).abs() < 1e-2, "{v:?}");
    }
}
