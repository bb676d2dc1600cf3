//! One emulated servo: its control-table memory, laid out and filled with factory values from
//! the model's full table (`servo::item`), the checks a write must pass (access, EEPROM lock,
//! range), and what the registers do: homing offset and drive mode between the shaft and the
//! reported positions, position limits, operating modes, motion profiles, torque.
//!
//! Positions have two frames. The *actual* position is the shaft's (what [`Motion`] moves);
//! the *present* frame is what Present/Goal Position carry, after the homing offset and
//! direction. How the two combine, how the profile registers bound a move and what a mode
//! change resets are the vendor firmware's rules ([`Firmware`], beside each codec;
//! docs/protocols.md §1.8, §2.6); every number (ticks per revolution, position mode, units,
//! the recalibrate value) is the model's, from the servo catalogue. Nothing here asks which
//! vendor the servo is.

use super::motion::Motion;
use super::{ServoFault, MEMORY_SIZE, ROOM_TEMPERATURE_C, SUPPLY_DECIVOLTS};
use crate::bus::protocol::firmware::ControlTable;
use crate::bus::protocol::motor::{LoadSample, ProtectionWatch, Trip};
use crate::bus::protocol::{codec, Firmware, Refusal};
use crate::bus::Alarms;
use crate::servo::item::{Access, Default, Item};
use crate::servo::{ModelSpec, Register, RegisterTable, ServoModel};
use std::time::Duration;

/// One emulated servo: its control table in memory, its shaft, and any fault it acts out.
#[derive(Debug, Clone)]
pub struct VirtualServo {
    /// Its id on the bus.
    pub id: u8,
    /// Its model, whose table and firmware rules it follows.
    pub model: ServoModel,
    /// The shaft, in the actual frame.
    pub motion: Motion,
    memory: Vec<u8>,
    /// How it misbehaves, if it does (see [`VirtualServos::set_fault`](super::VirtualServos::set_fault)).
    pub fault: Option<ServoFault>,
    /// Writes of 0 to the torque-enable register so far: someone asked the servo to go limp.
    pub releases: u32,
    /// The protection's clocks (a servo that carries an arm's physics).
    pub(super) watch: ProtectionWatch,
    /// The alarms its own protection raised: until a reboot where the model shuts down on an
    /// alarm, until the torque is enabled again elsewhere.
    pub tripped: Alarms,
    /// Where a hand pulls the shaft (actual ticks), for servos that carry an arm's physics.
    pub(super) hand: Option<f64>,
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
            watch: ProtectionWatch::default(),
            tripped: Alarms::default(),
            hand: None,
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

    pub(super) fn table(&self) -> &'static RegisterTable {
        self.spec().table
    }

    /// The rules of the firmware the model runs: its protocol's.
    pub(super) fn firmware(&self) -> &'static dyn Firmware {
        codec(self.spec().protocol).firmware()
    }

    /// Sets the Homing_Offset register, as a calibration tool writes it: from now on Present
    /// Position reports the shaft through the new offset. A model without the register has
    /// no offset to set: refused as a write to an item it does not have.
    pub fn set_homing_offset(&mut self, ticks: i64) -> Result<(), Refusal> {
        let register = self.table().homing_offset.ok_or(Refusal::DataLimit)?;
        self.store(register, ticks);
        Ok(())
    }

    /// Sets the Operating_Mode register (without the checks of a write). A model without the
    /// register is always in position mode: refused as a write to an item it does not have.
    pub(super) fn set_operating_mode(&mut self, mode: i64) -> Result<(), Refusal> {
        let register = self.table().operating_mode.ok_or(Refusal::DataLimit)?;
        self.store(register, mode);
        Ok(())
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
        if self.motion.external {
            // The arm's physics: the hand pulls the shaft there instead of setting it.
            self.hand = Some(actual);
        } else {
            self.motion.push_to(actual);
        }
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
        ControlTable::value(self, name)
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

    /// How long the servo waits before answering: Return_Delay_Time in the model's unit (2 µs
    /// on Dynamixel; none on the STS3215, whose memory table says the register has no function
    /// there).
    pub fn return_delay(&self) -> Duration {
        let units = self
            .load(self.table().return_delay)
            .clamp(0, i64::from(u32::MAX));
        self.spec().return_delay_unit * units as u32
    }

    pub(super) fn store(&mut self, register: Register, value: i64) {
        // A value the register cannot hold leaves it as it was.
        let _ = self.table().encode_into(&register, value, &mut self.memory);
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

    /// The alarms raised: injected, and its own protection's.
    pub(super) fn alarms(&self) -> Alarms {
        let injected = match self.fault {
            Some(ServoFault::Alarm(alarms)) => alarms,
            _ => Alarms::default(),
        };
        injected.or(&self.tripped)
    }

    /// Runs the firmware's protection on what the motor carried over `dt` seconds.
    pub(super) fn protect(&mut self, load: &LoadSample, dt: f64) {
        let mut watch = self.watch;
        let trip: Trip = self.firmware().protect(self, &mut watch, load, dt);
        self.watch = watch;
        if trip.any() {
            self.tripped = self.tripped.or(&trip.alarms);
            if trip.torque_off {
                self.motion.set_torque(false);
            }
        }
    }

    /// A reboot: the protection's alarms cleared, the torque off.
    pub(super) fn reboot(&mut self) {
        self.fault = None;
        self.tripped = Alarms::default();
        self.watch = ProtectionWatch::default();
        self.motion.set_torque(false);
        self.refresh();
    }

    /// Sets the present-current register of a model that has one beside its load register
    /// (the STS3215's), from `amps`.
    pub(super) fn report_current(&mut self, amps: f64) {
        if let Some((register, milliamps_per_unit)) = self.table().present_current {
            self.store(
                register,
                (amps * 1000.0 / milliamps_per_unit).round() as i64,
            );
        }
    }

    fn present_of(&self, actual: f64) -> f64 {
        self.firmware().present_of(self, actual)
    }

    fn actual_of(&self, present: f64) -> f64 {
        self.firmware().actual_of(self, present)
    }

    /// Brings the present-value registers up to date with the motion.
    pub(super) fn refresh(&mut self) {
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

    /// Present Velocity in the model's unit (0.229 rpm Dynamixel, steps/s Feetech), in the
    /// present frame's direction.
    fn present_velocity(&self) -> i64 {
        let mut velocity = self.motion.velocity;
        if self.reversed() {
            velocity = -velocity;
        }
        (velocity / self.spec().velocity_unit).round() as i64
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
        let mut before = [0u8; MEMORY_SIZE];
        let before = &mut before[..data.len()];
        before.copy_from_slice(&self.memory[address..end]);
        self.memory[address..end].copy_from_slice(data);
        if let Err(refusal) = self.check_values(address, end) {
            self.memory[address..end].copy_from_slice(before);
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
            let unknown_mode = Some(item.register) == mode_register && !modes.contains(&value);
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
        if table.operating_mode.is_some_and(touches) {
            self.firmware().mode_changed(self);
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
        if self.spec().recalibrate == Some(value) {
            self.recalibrate();
            return;
        }
        let on = value != 0;
        if !on {
            self.releases += 1;
        }
        // A servo in shutdown keeps torque off until rebooted; elsewhere torque back on
        // re-arms the protection.
        let shut_down = table.shuts_down_on_alarm && self.alarms().any();
        if on && !shut_down {
            self.tripped = Alarms::default();
            self.watch = ProtectionWatch::default();
        }
        self.motion.set_torque(on && !shut_down);
        // The register reads back what the servo did: 0 in shutdown.
        self.store(table.torque_enable, i64::from(self.motion.torque));
    }

    /// The model's recalibrate value (Feetech Torque_Enable 128): the present position becomes
    /// half a turn (2048), by the offset that makes it so, within the offset's range; the
    /// torque stays as it was. (Only a model with Homing_Offset has a recalibrate value; one
    /// without would keep its position.)
    fn recalibrate(&mut self) {
        self.motion.update();
        if let Some(register) = self.table().homing_offset {
            let half_turn = (self.spec().ticks_per_revolution / 2.0).round();
            let offset = self
                .firmware()
                .offset_for(self, self.motion.position.round(), half_turn);
            let (min, max) = self
                .spec()
                .item(register.name)
                .map_or(register.range(), |item| item.range);
            self.store(register, (offset as i64).clamp(min, max));
        }
        self.store(self.table().torque_enable, i64::from(self.motion.torque));
    }

    /// The goal in the present frame, clamped to the position limits in position mode, moved
    /// to as the profile registers say.
    fn apply_goal(&mut self) {
        let goal = self.load(self.table().goal_position) as f64;
        let target = self.actual_of(self.within_limits(goal));
        self.motion.update();
        let profile = self
            .firmware()
            .profile(self, (target - self.motion.position).abs());
        self.motion.set_goal_with(target, profile);
    }

    /// Position limits bound goals in (single-turn) position mode only; both limits 0 select
    /// multi-turn mode on the STS3215 (and leave no range on Dynamixel: not clamped either).
    fn within_limits(&self, goal: f64) -> f64 {
        let min = self.load(self.table().min_position_limit) as f64;
        let max = self.load(self.table().max_position_limit) as f64;
        if !self.in_position_mode() || self.multi_turn() || min > max {
            return goal;
        }
        goal.clamp(min, max)
    }
}

impl ControlTable for VirtualServo {
    fn spec(&self) -> &'static ModelSpec {
        self.model.spec()
    }

    fn load(&self, register: Register) -> i64 {
        VirtualServo::load(self, register)
    }

    fn store(&mut self, register: Register, value: i64) {
        VirtualServo::store(self, register, value)
    }
}
