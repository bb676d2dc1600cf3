//! The X series firmware's rules (ROBOTIS e-Manual; docs/protocols.md §1.8): Present Position
//! = direction(actual) + Homing_Offset, where Drive Mode's reverse bit mirrors the direction
//! within one turn; the profile registers bound a move by velocity and acceleration, or give
//! its duration in the time-based profile; a change of operating mode resets the profile.

use crate::bus::protocol::firmware::{ControlTable, Firmware, Profile};
use crate::servo::Setting;

/// The ROBOTIS X series firmware.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct XSeriesFirmware;

/// Drive Mode's reverse bit mirrors ticks within one turn; its own inverse.
fn direction(servo: &dyn ControlTable, ticks: f64) -> f64 {
    if servo.reversed() {
        servo.spec().ticks_per_revolution - 1.0 - ticks
    } else {
        ticks
    }
}

impl Firmware for XSeriesFirmware {
    fn present_of(&self, servo: &dyn ControlTable, actual: f64) -> f64 {
        direction(servo, actual) + servo.homing_offset()
    }

    fn actual_of(&self, servo: &dyn ControlTable, present: f64) -> f64 {
        direction(servo, present - servo.homing_offset())
    }

    fn offset_for(&self, servo: &dyn ControlTable, actual: f64, present: f64) -> f64 {
        present - direction(servo, actual)
    }

    /// Profile_Velocity and Profile_Acceleration in their units; in the time-based profile
    /// (Drive Mode bit 2) the move's duration and its acceleration time, in ms.
    fn profile(&self, servo: &dyn ControlTable, distance: f64) -> Profile {
        let velocity = servo.value(Setting::ProfileVelocity.name()) as f64;
        let acceleration = servo.value(Setting::ProfileAcceleration.name()) as f64;
        if servo.time_based() {
            return Profile::timed(distance, velocity / 1000.0, acceleration / 1000.0);
        }
        let unit = |setting| {
            servo
                .spec()
                .profile_register(setting)
                .map_or(0.0, |register| register.unit)
        };
        Profile::bounded(
            velocity * unit(Setting::ProfileVelocity),
            acceleration * unit(Setting::ProfileAcceleration),
        )
    }

    /// A mode change resets the profile (e-Manual `control_table_opmode_six_2.md`).
    fn mode_changed(&self, servo: &mut dyn ControlTable) {
        let table = servo.spec().table;
        for register in [table.profile_velocity, table.profile_acceleration]
            .into_iter()
            .flatten()
        {
            servo.store(register, 0);
        }
    }
}
