//! The STS firmware's rules (STS3215 memory table; docs/protocols.md §2.6): Present Position =
//! actual − Homing_Offset, wrapped into one turn in (single-turn) position mode; Goal_Speed
//! and Acceleration bound a move, 0 meaning "as fast as it can"; a mode change resets nothing.
//! Torque_Limit bounds the motor's output; the protections (overload, over-current, heat) trip
//! after their times and unload the servo where Unloading_Condition says so, or limit it to
//! Protective_Torque (docs/protocols.md §3.2).

use crate::bus::protocol::firmware::{gain_share, masked_by, ControlTable, Firmware, Profile};
use crate::bus::protocol::motor::{LoadSample, MotorLimits, ProtectionWatch, Trip};
use crate::bus::Alarms;
use crate::servo::{Drive, Setting};

/// Protection_Current's unit, mA (STS3215 memory table).
const PROTECTION_CURRENT_MA: f64 = 6.5;
/// Protection_Time's and Over_Current_Protection_Time's unit, seconds (10 ms).
const PROTECTION_TIME_S: f64 = 0.01;
/// Torque_Limit's full scale: 1000 is 100 %.
const TORQUE_LIMIT_FULL: f64 = 1000.0;

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

    fn motor(
        &self,
        servo: &dyn ControlTable,
        drive: &Drive,
        watch: &ProtectionWatch,
    ) -> MotorLimits {
        let limit = servo.value("Torque_Limit") as f64 / TORQUE_LIMIT_FULL;
        MotorLimits {
            force_share: watch.limited_to.map_or(limit, |l| l.min(limit)),
            stiffness_share: gain_share(servo, drive),
        }
    }

    /// Overload: the output above Overload_Torque (% of full) for Protection_Time; over-current:
    /// the current above Protection_Current for Over_Current_Protection_Time; heat: above
    /// Max_Temperature_Limit. A condition whose Unloading_Condition bit is set unloads the servo;
    /// otherwise its output is held to Protective_Torque.
    fn protect(
        &self,
        servo: &dyn ControlTable,
        watch: &mut ProtectionWatch,
        load: &LoadSample,
        dt: f64,
    ) -> Trip {
        let seconds = |name| servo.value(name) as f64 * PROTECTION_TIME_S;
        let overloaded = load.output_share.abs() * 100.0 > servo.value("Overload_Torque") as f64;
        let over_current = load.current_a * 1000.0
            > servo.value("Protection_Current") as f64 * PROTECTION_CURRENT_MA;
        let overloaded_for = ProtectionWatch::count(&mut watch.overloaded_s, overloaded, dt);
        let over_current_for = ProtectionWatch::count(&mut watch.over_current_s, over_current, dt);
        let alarms = Alarms {
            overload: overloaded && overloaded_for >= seconds("Protection_Time"),
            electrical: over_current && over_current_for >= seconds("Over_Current_Protection_Time"),
            overheating: load.temperature_c >= servo.value("Max_Temperature_Limit") as f64,
            ..Alarms::default()
        };
        if !alarms.any() {
            return Trip::default();
        }
        let unloads = masked_by(servo, &alarms, "Unloading_Condition");
        if !unloads {
            watch.limited_to = Some(servo.value("Protective_Torque") as f64 / 100.0);
        }
        Trip {
            alarms,
            torque_off: unloads,
        }
    }
}
