//! Where a model's firmware draws the line of its overload protection: the output share it
//! counts as an overload and how long it lets one last before it trips. The emulated
//! firmware trips by it; the player's push guard stops pushing well before it.

use super::register::Register;

/// How a model's firmware decides that its motor is overloaded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OverloadRule {
    /// Set in registers (Feetech Overload_Torque, percent of full output, and Protection_Time),
    /// which the user may have changed (LeRobot lowers the gripper's to 25 %).
    Registers {
        /// The threshold register, percent of full output.
        threshold: Register,
        /// Its factory value, percent.
        factory_percent: f64,
        /// The time register.
        time: Register,
        /// Seconds per unit of the time register.
        time_unit_s: f64,
        /// Its factory value, seconds.
        factory_seconds: f64,
    },
    /// Fixed in the firmware.
    Fixed {
        /// The threshold, percent of full output.
        percent: f64,
        /// How long an overload lasts before it trips, seconds.
        seconds: f64,
    },
}

impl OverloadRule {
    /// The threshold register, where the user can set the threshold.
    pub fn threshold_register(&self) -> Option<Register> {
        match self {
            OverloadRule::Registers { threshold, .. } => Some(*threshold),
            OverloadRule::Fixed { .. } => None,
        }
    }

    /// The time register, where the user can set how long an overload may last.
    pub fn time_register(&self) -> Option<Register> {
        match self {
            OverloadRule::Registers { time, .. } => Some(*time),
            OverloadRule::Fixed { .. } => None,
        }
    }

    /// How long an overload lasts before the firmware trips, seconds, from the time register's
    /// value where the model has one (`None`: its factory value).
    pub fn seconds(&self, register_value: Option<i64>) -> f64 {
        match self {
            OverloadRule::Registers {
                factory_seconds,
                time_unit_s,
                ..
            } => register_value.map_or(*factory_seconds, |v| v as f64 * time_unit_s),
            OverloadRule::Fixed { seconds, .. } => *seconds,
        }
    }

    /// The threshold, percent of full output, from the threshold register's value where the
    /// model has one (`None`: its factory value).
    pub fn threshold_percent(&self, register_value: Option<i64>) -> f64 {
        match self {
            OverloadRule::Registers {
                factory_percent, ..
            } => register_value.map_or(*factory_percent, |v| v as f64),
            OverloadRule::Fixed { percent, .. } => *percent,
        }
    }
}
