//! One emulated servo: its control-table memory, laid out and filled with factory values from
//! the model's full table (`models::item`), the checks a write must pass (access, EEPROM lock,
//! range), and what the registers do: homing offset and drive mode between the shaft and the
//! reported positions, position limits, operating modes, motion profiles, torque.
//!
//! Positions have two frames. The *actual* position is the shaft's (what [`Motion`] moves);
//! the *present* frame is what Present/Goal Position carry, after the vendor's homing offset
//! and direction (docs/protocols.md §1.8, §2.6):
//! - Dynamixel: Present = direction(actual) + Homing_Offset, where Drive Mode bit 0 mirrors the
//!   direction; in position mode (3) an offset beyond ±1024 is ignored.
//! - Feetech: Present = actual − Homing_Offset, wrapped into one turn in position mode (0).

use super::motion::{Motion, Profile};
use super::{ServoFault, MEMORY_SIZE, ROOM_TEMPERATURE_C, SUPPLY_DECIVOLTS};
use crate::bus::models::item::{Access, Default, Item};
use crate::bus::models::{ModelSpec, TORQUE_RECALIBRATE};
use crate::bus::profile;
use crate::bus::protocol::Refusal;
use crate::bus::registers::{Register, RegisterTable};
use crate::bus::Alarms;
use crate::robot::{ServoModel, Vendor};
use std::time::Duration;

const TICKS_PER_TURN: f64 = 4096.0;
/// Drive Mode bit 0 (e-Manual `control_table_drivemode.md`); bit 2 is [`profile::time_based`].
const DRIVE_REVERSE: i64 = 1 << 0;
/// Dynamixel position control mode, the factory one; Feetech's is 0.
const DYNAMIXEL_POSITION_MODE: i64 = 3;
const FEETECH_POSITION_MODE: i64 = 0;
/// In Dynamixel position mode a Homing Offset beyond this is ignored (e-Manual
/// `control_table_homingoffset.md`).
const POSITION_MODE_OFFSET_LIMIT: i64 = 1024;

#[derive(Debug, Clone)]
pub struct VirtualServo {
    pub id: u8,
    pub model: ServoModel,
    /// The shaft, in the actual frame.
    pub motion: Motion,
    memory: Vec<u8>,
    pub fault: Option<ServoFault>,
    /// Writes of 0 to the torque-enable register so far: someone asked the servo to go limp.
    pub releases: u32,
}

impl VirtualServo {
    /// A servo fresh from the factory but for its id, whose Present Position reads `present`.
    pub fn new(id: u8, model: ServoModel, present: f64) -> VirtualServo {
        let mut servo = VirtualServo {
            id,
            model,
            motion: Motion::new(model, present),
            memory: vec![0; MEMORY_SIZE],
            fault: None,
            releases: 0,
        };
        for item in model.spec().all_items() {
            if let Default::Value(value) = item.default {
                servo.store(item.register, value);
            }
        }
        let table = servo.table();
        servo.store(
            table.model_number_register,
            i64::from(model.spec().model_number),
        );
        servo.store(table.id, i64::from(id));
        servo.store(table.present_voltage, SUPPLY_DECIVOLTS);
        servo.store(table.present_temperature, ROOM_TEMPERATURE_C);
        servo.place_at(present);
        servo
    }

    fn spec(&self) -> &'static ModelSpec {
        self.model.spec()
    }

    pub(super) fn table(&self) -> &'static RegisterTable {
        self.spec().table
    }

    fn is_dynamixel(&self) -> bool {
        self.model.vendor() == Vendor::Dynamixel
    }

    /// Sets the Homing_Offset register, as a calibration tool writes it: from now on Present
    /// Position reports the shaft through the new offset.
    pub fn set_homing_offset(&mut self, ticks: i64) {
        self.store(self.table().homing_offset, ticks);
    }

    /// Sets the Operating_Mode register (without the checks of a write).
    pub fn set_operating_mode(&mut self, mode: i64) {
        self.store(self.table().operating_mode, mode);
    }

    /// Puts the shaft where Present Position reads `present`, holding it there.
    pub fn place_at(&mut self, present: f64) {
        let actual = self.actual_of(present);
        self.motion.position = actual;
        self.motion.goal = actual;
        self.store(self.table().goal_position, present.round() as i64);
    }

    /// Moves the shaft by hand to where Present Position reads `present` (it stays there
    /// while torque is off).
    pub fn push_to(&mut self, present: f64) {
        let actual = self.actual_of(present);
        self.motion.push_to(actual);
    }

    /// Present Position now, continuous.
    pub fn present_position(&mut self) -> f64 {
        self.motion.update();
        self.present_of(self.motion.position)
    }

    /// Sets the Present Load (or Present Current) register, as a servo under load reports it;
    /// the emulated motion does not model load, so the value stays until set again.
    pub fn set_present_load(&mut self, value: i64) {
        self.store(self.table().present_load, value);
    }

    /// The value of the control-table item `name`; 0 for an item the model does not have.
    pub fn value(&self, name: &str) -> i64 {
        self.spec()
            .item(name)
            .map_or(0, |item| self.load(item.register))
    }

    /// Writes `value` to the item `name` as a Write instruction would: with the servo's checks
    /// and effects. `Err` names what the servo would answer; an unknown item is a data-limit
    /// refusal.
    pub fn set(&mut self, name: &str, value: i64) -> Result<(), Refusal> {
        let item = self.spec().item(name).ok_or(Refusal::DataLimit)?;
        let bytes = self
            .table()
            .encode(&item.register, value)
            .map_err(|_| Refusal::DataRange)?;
        self.write(usize::from(item.register.address), &bytes)
    }

    /// How long the servo waits before answering: Return_Delay_Time × 2 µs on Dynamixel;
    /// none on the STS3215, whose memory table says the register has no function there.
    pub fn return_delay(&self) -> Duration {
        if !self.is_dynamixel() {
            return Duration::ZERO;
        }
        let units = self.load(self.table().return_delay).max(0) as u64;
        Duration::from_micros(2 * units)
    }

    pub(super) fn store(&mut self, register: Register, value: i64) {
        if let Ok(bytes) = self.table().encode(&register, value) {
            let start = usize::from(register.address);
            self.memory[start..start + bytes.len()].copy_from_slice(&bytes);
        }
    }

    fn load(&self, register: Register) -> i64 {
        let start = usize::from(register.address);
        self.table()
            .decode(
                &register,
                &self.memory[start..start + usize::from(register.size)],
            )
            .unwrap_or(0)
    }

    pub(super) fn alarms(&self) -> Alarms {
        match self.fault {
            Some(ServoFault::Alarm(alarms)) => alarms,
            _ => Alarms::default(),
        }
    }

    fn operating_mode(&self) -> i64 {
        self.load(self.table().operating_mode)
    }

    fn in_position_mode(&self) -> bool {
        let position = if self.is_dynamixel() {
            DYNAMIXEL_POSITION_MODE
        } else {
            FEETECH_POSITION_MODE
        };
        self.operating_mode() == position
    }

    fn drive_mode(&self) -> i64 {
        self.table().drive_mode.map_or(0, |r| self.load(r))
    }

    /// The homing offset the servo applies now.
    fn effective_offset(&self) -> f64 {
        let offset = self.load(self.table().homing_offset);
        let ignored = self.is_dynamixel()
            && self.in_position_mode()
            && offset.abs() > POSITION_MODE_OFFSET_LIMIT;
        if ignored {
            0.0
        } else {
            offset as f64
        }
    }

    /// Drive Mode reverse mirrors the direction within one turn (Dynamixel only). Its own
    /// inverse.
    fn direction(&self, ticks: f64) -> f64 {
        if self.drive_mode() & DRIVE_REVERSE != 0 {
            TICKS_PER_TURN - 1.0 - ticks
        } else {
            ticks
        }
    }

    /// Whether both position limits are 0: Feetech multi-turn, where positions leave one turn.
    fn multi_turn(&self) -> bool {
        self.value("Min_Position_Limit") == 0 && self.value("Max_Position_Limit") == 0
    }

    /// Feetech reports one turn in (single-turn) position mode.
    fn wrap(&self, ticks: f64) -> f64 {
        if !self.is_dynamixel() && self.in_position_mode() && !self.multi_turn() {
            ticks.rem_euclid(TICKS_PER_TURN)
        } else {
            ticks
        }
    }

    fn present_of(&self, actual: f64) -> f64 {
        if self.is_dynamixel() {
            self.direction(actual) + self.effective_offset()
        } else {
            self.wrap(actual - self.effective_offset())
        }
    }

    fn actual_of(&self, present: f64) -> f64 {
        if self.is_dynamixel() {
            self.direction(present - self.effective_offset())
        } else {
            self.wrap(present + self.effective_offset())
        }
    }

    /// Brings the present-value registers up to date with the motion.
    fn refresh(&mut self) {
        self.motion.update();
        let table = self.table();
        let present = self.present_of(self.motion.position).round() as i64;
        let moving = (self.motion.goal - self.motion.position).abs() > 0.5 && self.motion.torque;
        self.store(table.present_position, present);
        self.store(table.present_velocity, self.present_velocity());
        self.store(table.moving, i64::from(moving));
        self.store(table.torque_enable, i64::from(self.motion.torque));
        let alarm_bits = table.alarm_bits.encode(&self.alarms());
        self.store(table.hardware_error, i64::from(alarm_bits));
    }

    /// Present Velocity in the register's unit (0.229 rpm Dynamixel, steps/s Feetech), in the
    /// present frame's direction.
    fn present_velocity(&self) -> i64 {
        let mut velocity = self.motion.velocity;
        if self.drive_mode() & DRIVE_REVERSE != 0 {
            velocity = -velocity;
        }
        if self.is_dynamixel() {
            velocity /= profile::dxl_velocity_unit();
        }
        velocity.round() as i64
    }

    pub(super) fn read(&mut self, address: usize, length: usize) -> Option<Vec<u8>> {
        self.refresh();
        self.memory
            .get(address..address + length)
            .map(<[u8]>::to_vec)
    }

    /// Applies a write to the control table, then acts on the registers it touched. A refused
    /// write changes nothing and says why, as the servo's status does.
    pub(super) fn write(&mut self, address: usize, data: &[u8]) -> Result<(), Refusal> {
        let end = address + data.len();
        if end > MEMORY_SIZE {
            return Err(Refusal::DataLimit);
        }
        self.check_access(address, end)?;
        let before = self.memory[address..end].to_vec();
        self.memory[address..end].copy_from_slice(data);
        if let Err(refusal) = self.check_values(address, end) {
            self.memory[address..end].copy_from_slice(&before);
            return Err(refusal);
        }
        self.apply(address, end);
        Ok(())
    }

    fn touched(&self, start: usize, end: usize) -> impl Iterator<Item = &'static Item> {
        self.spec()
            .all_items()
            .filter(move |item| item.overlaps(start, end))
    }

    /// Read-only items refuse writes; Dynamixel EEPROM refuses them while the torque is on.
    fn check_access(&self, start: usize, end: usize) -> Result<(), Refusal> {
        if self
            .touched(start, end)
            .any(|i| i.access == Access::ReadOnly)
        {
            return Err(Refusal::Access);
        }
        let locked_below = usize::from(self.table().torque_locked_below);
        if start < locked_below && self.motion.torque {
            return Err(Refusal::Access);
        }
        Ok(())
    }

    /// Every item the write fills must hold a value of its range; the operating mode one the
    /// model has.
    fn check_values(&self, start: usize, end: usize) -> Result<(), Refusal> {
        let modes = self.spec().operating_modes;
        let mode_register = self.table().operating_mode;
        for item in self.touched(start, end).filter(|i| i.inside(start, end)) {
            let value = self.load(item.register);
            let unknown_mode = item.register == mode_register && !modes.contains(&value);
            if !item.accepts(value) || unknown_mode {
                return Err(Refusal::DataRange);
            }
        }
        Ok(())
    }

    /// The effects of a write to `start..end`.
    fn apply(&mut self, start: usize, end: usize) {
        let table = self.table();
        let touches = |r: Register| usize::from(r.address) < end && usize::from(r.end()) > start;
        if touches(table.operating_mode) && self.is_dynamixel() {
            // A mode change resets the profile (e-Manual `control_table_opmode_six_2.md`).
            for register in [table.profile_velocity, table.profile_acceleration]
                .into_iter()
                .flatten()
            {
                self.store(register, 0);
            }
        }
        if touches(table.torque_enable) {
            self.apply_torque_enable();
        }
        if touches(table.goal_position) {
            self.apply_goal();
        }
    }

    fn apply_torque_enable(&mut self) {
        let table = self.table();
        let value = self.load(table.torque_enable);
        if !self.is_dynamixel() && value == TORQUE_RECALIBRATE {
            self.recalibrate();
            return;
        }
        let on = value != 0;
        if !on {
            self.releases += 1;
        }
        // A servo in shutdown keeps torque off until rebooted.
        let shut_down = table.shuts_down_on_alarm && self.alarms().any();
        self.motion.set_torque(on && !shut_down);
    }

    /// Feetech Torque_Enable 128: the present position becomes 2048, by the offset that makes
    /// it so (Present = actual − offset); the torque stays as it was.
    fn recalibrate(&mut self) {
        self.motion.update();
        let offset = (self.motion.position.round() as i64 - 2048).clamp(-2047, 2047);
        self.set_homing_offset(offset);
        self.store(self.table().torque_enable, i64::from(self.motion.torque));
    }

    /// The goal in the present frame, clamped to the position limits in position mode, moved
    /// to as the profile registers say.
    fn apply_goal(&mut self) {
        let goal = self.load(self.table().goal_position) as f64;
        let target = self.actual_of(self.within_limits(goal));
        self.motion.update();
        let profile = self.profile((target - self.motion.position).abs());
        self.motion.set_goal_with(target, profile);
    }

    /// Position limits bound goals in (single-turn) position mode only; both limits 0 select
    /// multi-turn mode on the STS3215 (and leave no range on Dynamixel: not clamped either).
    fn within_limits(&self, goal: f64) -> f64 {
        let min = self.value("Min_Position_Limit") as f64;
        let max = self.value("Max_Position_Limit") as f64;
        if !self.in_position_mode() || self.multi_turn() || min > max {
            return goal;
        }
        goal.clamp(min, max)
    }

    /// The speed and acceleration bounds of a move of `distance` ticks.
    fn profile(&self, distance: f64) -> Profile {
        if !self.is_dynamixel() {
            // Goal_Speed and Acceleration 0 mean "as fast as it can".
            let speed = self.value("Goal_Speed").unsigned_abs() as f64;
            let acceleration = self.value("Acceleration") as f64 * profile::STS_ACCELERATION_UNIT;
            return Profile::bounded(speed, acceleration);
        }
        let velocity = self.value("Profile_Velocity") as f64;
        let acceleration = self.value("Profile_Acceleration") as f64;
        if profile::time_based(self.drive_mode()) {
            return Profile::timed(distance, velocity / 1000.0, acceleration / 1000.0);
        }
        Profile::bounded(
            velocity * profile::dxl_velocity_unit(),
            acceleration * profile::dxl_acceleration_unit(),
        )
    }
}
