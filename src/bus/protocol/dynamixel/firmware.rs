//! The X series firmware's rules (ROBOTIS e-Manual; docs/protocols.md §1.8): Present Position
//! = direction(actual) + Homing_Offset, where Drive Mode's reverse bit mirrors the direction
//! within one turn; the profile registers bound a move by velocity and acceleration, or give
//! its duration in the time-based profile; a change of operating mode resets the profile.
//! PWM_Limit and Goal_PWM (and Goal_Current in current-based position mode) bound the motor's
//! output; a sustained overload or heat raises Hardware Error Status and, where Shutdown says
//! so, turns the torque off until a reboot (docs/protocols.md §3.3).

use crate::bus::protocol::firmware::{gain_share, masked_by, ControlTable, Firmware, Profile};
use crate::bus::protocol::motor::{LoadSample, MotorLimits, ProtectionWatch, Trip};
use crate::bus::Alarms;
use crate::servo::dynamixel_x::{CURRENT_BASED_POSITION_MODE, PWM_LIMIT};
use crate::servo::{Drive, LoadUnit, OverloadRule, Setting};

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

    fn motor(
        &self,
        servo: &dyn ControlTable,
        drive: &Drive,
        _watch: &ProtectionWatch,
    ) -> MotorLimits {
        // Goal_PWM caps the PWM in every position mode, within PWM_Limit.
        let pwm = servo.value("PWM_Limit").min(servo.value("Goal_PWM").abs());
        let mut force_share = pwm as f64 / PWM_LIMIT as f64;
        let current_based = servo.value("Operating_Mode") == CURRENT_BASED_POSITION_MODE;
        if let (
            true,
            LoadUnit::Current {
                milliamps_per_unit, ..
            },
        ) = (current_based, servo.spec().table.load_unit)
        {
            let goal_ma = servo.value("Goal_Current").unsigned_abs() as f64 * milliamps_per_unit;
            force_share = force_share.min(goal_ma / (drive.stall_current.value * 1000.0));
        }
        MotorLimits {
            force_share,
            stiffness_share: gain_share(servo, drive),
        }
    }

    fn protect(
        &self,
        servo: &dyn ControlTable,
        watch: &mut ProtectionWatch,
        load: &LoadSample,
        dt: f64,
    ) -> Trip {
        // The X series' rule is fixed in its firmware (`servo::dynamixel_x`).
        let (percent, seconds) = match servo.spec().table.overload {
            OverloadRule::Fixed { percent, seconds } => (percent, seconds),
            OverloadRule::Registers { .. } => (f64::INFINITY, f64::INFINITY),
        };
        let overloaded = load.output_share.abs() * 100.0 > percent;
        let overloaded_for = ProtectionWatch::count(&mut watch.overloaded_s, overloaded, dt);
        let alarms = Alarms {
            overload: overloaded && overloaded_for >= seconds,
            overheating: load.temperature_c >= servo.value("Temperature_Limit") as f64,
            ..Alarms::default()
        };
        if !alarms.any() {
            return Trip::default();
        }
        Trip {
            alarms,
            torque_off: masked_by(servo, &alarms, "Shutdown"),
        }
    }
}
