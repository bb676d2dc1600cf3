//! What a servo's firmware lets its motor do, and how it protects the motor: the words the
//! vendors' rules ([`super::Firmware::motor`], [`super::Firmware::protect`]) speak when an
//! emulated servo carries an arm's weight (`virtual_bus --physics`). The rules themselves are
//! each vendor's, beside its codec; docs/protocols.md §3 gives them with their sources.

use crate::bus::Alarms;

/// The motor as the registers allow it now, as shares of the servo's rating at its supply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorLimits {
    /// The most the motor may push, as a share of its stall torque (Feetech Torque_Limit,
    /// Dynamixel PWM_Limit or, in current-based position mode, Goal_Current).
    pub force_share: f64,
    /// The position loop's stiffness as a share of the rating's, which is for the gain the
    /// rating names (`servo::Drive::gain`): the loop's output is proportional to its gain.
    pub stiffness_share: f64,
}

/// What the motor carried over the last interval, as the firmware measures it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadSample {
    /// The position loop's output as a share of the full supply (the PWM duty), signed:
    /// what Feetech's Present_Load and the XL430's report.
    pub output_share: f64,
    /// The motor's current, amperes, unsigned.
    pub current_a: f64,
    /// The winding's temperature, °C.
    pub temperature_c: f64,
}

/// The protection's clocks: how long each condition has lasted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProtectionWatch {
    /// Seconds the load has been above the overload threshold without a break.
    pub overloaded_s: f64,
    /// Seconds the current has been above the protection current without a break.
    pub over_current_s: f64,
    /// A protection tripped that limits the output instead of cutting it (Feetech's
    /// Protective_Torque): the share of stall torque left, until the torque is enabled again.
    pub limited_to: Option<f64>,
}

impl ProtectionWatch {
    /// Adds `dt` to a clock while `condition` holds, and starts it again when it breaks.
    pub fn count(clock: &mut f64, condition: bool, dt: f64) -> f64 {
        *clock = if condition { *clock + dt } else { 0.0 };
        *clock
    }
}

/// What a tripped protection does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Trip {
    /// The alarms it raises (status byte, Status or Hardware Error Status register).
    pub alarms: Alarms,
    /// Whether the torque goes off (Feetech's Unloading_Condition, Dynamixel's Shutdown).
    pub torque_off: bool,
}

impl Trip {
    /// Whether it does anything.
    pub fn any(&self) -> bool {
        self.alarms.any() || self.torque_off
    }
}
