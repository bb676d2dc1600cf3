//! A model's motion-profile registers as data: which registers bound the servo's own motion
//! between goals, in what units and up to what value, and the Drive_Mode bits that change what
//! they mean. `robot::profile` turns a joint's limits into these units; the emulated servos'
//! firmware (`bus::protocol::*::firmware`) moves by them.

use super::register::Register;
use super::table::RegisterTable;

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
    /// [`DriveModeBits::time_based`]); never written.
    DriveMode,
    /// Feetech Overload_Torque: only read, for the push guard's threshold (see
    /// [`super::OverloadRule`]); never written.
    OverloadTorque,
    /// Feetech Protection_Time: only read, for how long the push guard lets an overload last;
    /// never written.
    ProtectionTime,
    /// The output cap a grasp's effort is written to ([`RegisterTable::effort_limit`]).
    EffortLimit,
}

impl Setting {
    /// The register in `table`, if the model has it.
    pub fn register(self, table: &RegisterTable) -> Option<Register> {
        match self {
            Setting::Acceleration => table.acceleration,
            Setting::ProfileAcceleration => table.profile_acceleration,
            Setting::ProfileVelocity => table.profile_velocity,
            Setting::DriveMode => table.drive_mode,
            Setting::OverloadTorque => table.overload.threshold_register(),
            Setting::ProtectionTime => table.overload.time_register(),
            Setting::EffortLimit => Some(table.effort_limit.0),
        }
    }

    /// The register's name in the vendor's control table.
    pub fn name(self) -> &'static str {
        match self {
            Setting::Acceleration => "Acceleration",
            Setting::ProfileAcceleration => "Profile_Acceleration",
            Setting::ProfileVelocity => "Profile_Velocity",
            Setting::DriveMode => "Drive_Mode",
            Setting::OverloadTorque => "Overload_Torque",
            Setting::ProtectionTime => "Protection_Time",
            Setting::EffortLimit => "Torque_Limit or Goal_PWM",
        }
    }
}

/// Which of a joint's limits a profile register bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limit {
    /// Ticks per second.
    Velocity,
    /// Ticks per second².
    Acceleration,
}

impl Limit {
    /// The limit's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Limit::Velocity => "velocity",
            Limit::Acceleration => "acceleration",
        }
    }

    /// The time part of its unit: "/s" or "/s²".
    pub fn per_time(self) -> &'static str {
        match self {
            Limit::Velocity => "/s",
            Limit::Acceleration => "/s²",
        }
    }
}

/// One motion-profile register `--servo-profile` writes: the limit it bounds, its unit and
/// its largest value. 0 means "no limit" on every supported model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileRegister {
    /// Which register.
    pub setting: Setting,
    /// Which of the joint's limits it bounds.
    pub limit: Limit,
    /// Ticks per second (velocity) or per second² (acceleration) per register unit.
    pub unit: f64,
    /// The largest value the register takes (in the velocity-based profile on Dynamixel).
    pub max: i64,
}

/// The Drive_Mode bits keypose reads (Dynamixel X, e-Manual `control_table_drivemode.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveModeBits {
    /// Set: goal and present positions run the other way within one turn (the firmware
    /// mirrors them).
    pub reverse: i64,
    /// Set: the time-based profile, where the profile registers hold milliseconds.
    pub time_based: i64,
}

impl DriveModeBits {
    /// Whether a Drive_Mode value has the reverse bit set.
    pub fn reversed(self, drive_mode: i64) -> bool {
        drive_mode & self.reverse != 0
    }

    /// Whether a Drive_Mode value selects the time-based profile, in which the profile
    /// registers are durations in milliseconds: joint limits written in the velocity-based
    /// units would then mean a move time, not a bound.
    pub fn time_based(self, drive_mode: i64) -> bool {
        drive_mode & self.time_based != 0
    }
}
