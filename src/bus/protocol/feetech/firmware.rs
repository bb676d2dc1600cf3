//! The STS firmware's rules (STS3215 memory table; docs/protocols.md §2.6): Present Position =
//! actual − Homing_Offset, wrapped into one turn in (single-turn) position mode; Goal_Speed
//! and Acceleration bound a move, 0 meaning "as fast as it can"; a mode change resets nothing.

use crate::bus::protocol::firmware::{ControlTable, Firmware, Profile};
use crate::servo::Setting;

/// The Feetech STS/SMS firmware.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StsFirmware;

/// One turn in position mode, unless both position limits are 0 (multi-turn).
fn wrap(servo: &dyn ControlTable, ticks: f64) -> f64 {
    if servo.in_position_mode() && !servo.multi_turn() {
        ticks.rem_euclid(servo.spec().ticks_per_revolution)
    } else {
        ticks
    }
}

impl Firmware for StsFirmware {
    fn present_of(&self, servo: &dyn ControlTable, actual: f64) -> f64 {
        wrap(servo, actual - servo.homing_offset())
    }

    fn actual_of(&self, servo: &dyn ControlTable, present: f64) -> f64 {
        wrap(servo, present + servo.homing_offset())
    }

    fn offset_for(&self, _servo: &dyn ControlTable, actual: f64, present: f64) -> f64 {
        actual - present
    }

    /// Goal_Speed in Present_Velocity's unit (steps/s), whatever its sign; Acceleration in its
    /// unit.
    fn profile(&self, servo: &dyn ControlTable, _distance: f64) -> Profile {
        let spec = servo.spec();
        let speed = servo.value("Goal_Speed").unsigned_abs() as f64 * spec.velocity_unit;
        let acceleration_unit = spec
            .profile_register(Setting::Acceleration)
            .map_or(0.0, |register| register.unit);
        let acceleration = servo.value(Setting::Acceleration.name()) as f64 * acceleration_unit;
        Profile::bounded(speed, acceleration)
    }

    fn mode_changed(&self, _servo: &mut dyn ControlTable) {}
}
