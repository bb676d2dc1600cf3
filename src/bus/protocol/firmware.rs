//! What a vendor's firmware does with a servo's registers, as the emulated servos act it out:
//! how the homing offset and the direction make the position the servo reports, how the
//! profile registers bound a move, what a change of operating mode resets. Each vendor's rules
//! are its [`Firmware`], beside its codec (`dynamixel/firmware.rs`, `feetech/firmware.rs`),
//! reached through [`super::Codec::firmware`]; the numbers they work with (ticks per
//! revolution, units, the position mode's value, the drive-mode bits) are the model's, in the
//! servo catalogue. The emulated servo (`virtual_bus::servo`) asks only this trait, never
//! which vendor it is.

use super::motor::{LoadSample, MotorLimits, ProtectionWatch, Trip};
use crate::servo::{Drive, ModelSpec, Register};
use std::fmt;

/// One servo's control table as its firmware sees it: the model's description and the values
/// its registers hold. The provided methods read the catalogue's numbers against the
/// registers, the same way for every vendor.
pub trait ControlTable {
    /// The model's description.
    fn spec(&self) -> &'static ModelSpec;
    /// The value `register` holds.
    fn load(&self, register: Register) -> i64;
    /// Puts `value` in `register`, as the firmware does (no checks of a write).
    fn store(&mut self, register: Register, value: i64);

    /// The value of the control-table item `name`; 0 for an item the model does not have.
    fn value(&self, name: &str) -> i64 {
        self.spec()
            .item(name)
            .map_or(0, |item| self.load(item.register))
    }

    /// Whether the servo is in (single-turn) position mode, its factory mode. A model without
    /// Operating_Mode always is.
    fn in_position_mode(&self) -> bool {
        let spec = self.spec();
        spec.table
            .operating_mode
            .is_none_or(|register| self.load(register) == spec.modes.position_mode)
    }

    /// Whether both position limits are 0: Feetech multi-turn, where positions leave one turn
    /// (and on Dynamixel no range to clamp goals to).
    fn multi_turn(&self) -> bool {
        let table = self.spec().table;
        self.load(table.min_position_limit) == 0 && self.load(table.max_position_limit) == 0
    }

    /// Whether Drive_Mode has the reverse bit set (models without Drive_Mode never do).
    fn reversed(&self) -> bool {
        let spec = self.spec();
        match (spec.drive_mode, spec.table.drive_mode) {
            (Some(bits), Some(register)) => bits.reversed(self.load(register)),
            _ => false,
        }
    }

    /// Whether Drive_Mode selects the time-based profile.
    fn time_based(&self) -> bool {
        let spec = self.spec();
        match (spec.drive_mode, spec.table.drive_mode) {
            (Some(bits), Some(register)) => bits.time_based(self.load(register)),
            _ => false,
        }
    }

    /// The homing offset the servo applies now: the register's, unless the model ignores an
    /// offset that large in position mode; none (0) on a model without Homing_Offset.
    fn homing_offset(&self) -> f64 {
        let spec = self.spec();
        let Some(register) = spec.table.homing_offset else {
            return 0.0;
        };
        let offset = self.load(register);
        let ignored = spec
            .modes
            .position_mode_offset_limit
            .is_some_and(|limit| self.in_position_mode() && offset.abs() > limit);
        if ignored {
            0.0
        } else {
            offset as f64
        }
    }
}

/// A vendor's firmware rules, as far as the emulated servos need them. Positions are ticks:
/// *actual* is the shaft's, *present* what Goal and Present Position carry.
pub trait Firmware: Sync + fmt::Debug {
    /// The present position of the shaft at `actual`.
    fn present_of(&self, servo: &dyn ControlTable, actual: f64) -> f64;
    /// The shaft position whose present position is `present`.
    fn actual_of(&self, servo: &dyn ControlTable, present: f64) -> f64;
    /// The homing offset with which the shaft at `actual` reads `present` (what a
    /// recalibration writes).
    fn offset_for(&self, servo: &dyn ControlTable, actual: f64, present: f64) -> f64;
    /// The bounds the profile registers put on a move of `distance` ticks.
    fn profile(&self, servo: &dyn ControlTable, distance: f64) -> Profile;
    /// What a write of the operating mode does besides setting it.
    fn mode_changed(&self, servo: &mut dyn ControlTable);
    /// What the registers let the motor do now; `drive` is the servo's rating at its supply,
    /// `watch` the protection's state.
    fn motor(
        &self,
        servo: &dyn ControlTable,
        drive: &Drive,
        watch: &ProtectionWatch,
    ) -> MotorLimits;
    /// The protection's verdict after `dt` seconds of carrying `load`, its clocks in `watch`.
    fn protect(
        &self,
        servo: &dyn ControlTable,
        watch: &mut ProtectionWatch,
        load: &LoadSample,
        dt: f64,
    ) -> Trip;
}

/// Whether any of `alarms` has its bit set in the register `name` (Feetech's
/// Unloading_Condition, Dynamixel's Shutdown: the same layout as the alarm byte).
pub fn masked_by(servo: &dyn ControlTable, alarms: &crate::bus::Alarms, name: &str) -> bool {
    let bits = servo.spec().table.alarm_bits.encode(alarms);
    i64::from(bits) & servo.value(name) != 0
}

/// The position loop's stiffness as a share of the rating's: the gain register's value over
/// the gain the rating is for, or over the register's factory value where the rating names no
/// gain (ROBOTIS publishes no stiffness: keypose's is for the factory gain).
pub fn gain_share(servo: &dyn ControlTable, drive: &Drive) -> f64 {
    let (name, rated) = drive.gain;
    let Some(item) = servo.spec().item(name) else {
        return 1.0;
    };
    let reference = if rated > 0.0 {
        rated
    } else {
        match item.default {
            crate::servo::item::Default::Value(v) if v > 0 => v as f64,
            _ => return 1.0,
        }
    };
    servo.load(item.register) as f64 / reference
}

/// Bounds on a move, ticks per second and per second²; `None` is no bound beyond the motor's.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Profile {
    /// Top speed, ticks/s.
    pub max_speed: Option<f64>,
    /// Acceleration (and deceleration), ticks/s².
    pub acceleration: Option<f64>,
}

impl Profile {
    /// A speed and an acceleration bound, 0 meaning none (as the registers say).
    pub fn bounded(speed: f64, acceleration: f64) -> Profile {
        let positive = |v: f64| (v > 0.0).then_some(v);
        Profile {
            max_speed: positive(speed),
            acceleration: positive(acceleration),
        }
    }

    /// A time-based profile (Dynamixel Drive Mode bit 2): the move of `distance` ticks takes
    /// `total` seconds, accelerating for `accelerating` seconds (at most half of it) and
    /// braking as long; 0 s total is no profile. The trapezoid's top speed is
    /// distance / (total − accelerating).
    pub fn timed(distance: f64, total: f64, accelerating: f64) -> Profile {
        if total <= 0.0 {
            return Profile::default();
        }
        let accelerating = accelerating.clamp(0.0, total / 2.0);
        let speed = distance / (total - accelerating);
        let acceleration = if accelerating > 0.0 {
            speed / accelerating
        } else {
            0.0
        };
        Profile::bounded(speed.max(f64::MIN_POSITIVE), acceleration)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::protocol::codec;
    use crate::servo::dynamixel_x::WITHOUT_OFFSET_OR_MODE;
    use crate::servo::{Protocol, ServoModel};
    use std::collections::HashMap;

    /// A control table whose memory holds values by address, whatever the model calls them.
    struct Memory {
        spec: &'static ModelSpec,
        values: HashMap<u16, i64>,
    }

    impl ControlTable for Memory {
        fn spec(&self) -> &'static ModelSpec {
            self.spec
        }
        fn load(&self, register: Register) -> i64 {
            self.values.get(&register.address).copied().unwrap_or(0)
        }
        fn store(&mut self, register: Register, value: i64) {
            self.values.insert(register.address, value);
        }
    }

    #[test]
    fn without_operating_mode_and_homing_offset_a_servo_is_in_position_mode_with_no_offset() {
        // X series addresses 11 (Operating_Mode) and 20 (Homing_Offset): extended position
        // mode (4) and an offset of 200, which an X series servo applies.
        let values = HashMap::from([(11, 4), (20, 200)]);
        let x = Memory {
            spec: ServoModel::Xl330M288.spec(),
            values: values.clone(),
        };
        assert!(!x.in_position_mode());
        assert_eq!(x.homing_offset(), 200.0);
        let firmware = codec(Protocol::Dynamixel2).firmware();
        assert_eq!(firmware.present_of(&x, 1000.0), 1200.0);
        // The same memory in a model without those registers means nothing to it.
        let without = Memory {
            spec: &WITHOUT_OFFSET_OR_MODE,
            values,
        };
        assert!(without.in_position_mode());
        assert_eq!(without.homing_offset(), 0.0);
        assert_eq!(firmware.present_of(&without, 1000.0), 1000.0);
        assert_eq!(firmware.actual_of(&without, 1000.0), 1000.0);
        assert!(!without.reversed());
    }
}
