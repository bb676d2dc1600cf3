//! Emulated servos that answer the real protocols byte for byte.
//!
//! Each virtual servo keeps its control table in memory, laid out by the model's register table,
//! and moves as [`motion::Motion`] says. Instruction packets are decoded with the same codecs the
//! driver uses to encode them, but the answers are built from the register tables and the
//! protocol documents, and the conformance tests check both against the vendors' own SDKs.
//!
//! Faults can be injected per servo (no answer, a corrupted checksum, a late answer, an alarm)
//! and for the whole bus (the port disappearing). The instruction packets received are recorded
//! (the last [`RECEIVED_LOG_CAPACITY`] of them, so a server left running at 1 kHz does not grow
//! without bound), so tests can inspect exactly what reached the servos.

mod hand;
pub mod motion;
mod pty;
pub mod wire;

pub use hand::Hand;
pub use pty::PtyServer;
pub use wire::WireTiming;

use super::protocol::packet::{Decoded, Direction, Packet};
use super::protocol::{codec, Codec, FastSyncReadEntry, Refusal};
use super::registers::{self, RegisterTable};
use super::transport::Responder;
use super::Alarms;
use crate::robot::{Protocol, Robot, ServoModel};
use motion::Motion;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Size of each emulated control table; every register of the supported models lies below.
const MEMORY_SIZE: usize = 256;
/// Supply voltage reported by emulated servos, tenths of a volt.
const SUPPLY_DECIVOLTS: i64 = 120;
const ROOM_TEMPERATURE_C: i64 = 30;

/// A fault to inject into one servo's behaviour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ServoFault {
    /// The servo never answers.
    NoAnswer,
    /// Answers carry a wrong checksum.
    CorruptChecksum,
    /// Answers come this late.
    Late(Duration),
    /// The servo raises these alarms (Dynamixel: alert bit + Hardware Error Status, and torque
    /// shuts off; Feetech: the status error bits).
    Alarm(Alarms),
}

#[derive(Debug, Clone)]
pub struct VirtualServo {
    pub id: u8,
    pub model: ServoModel,
    pub motion: Motion,
    memory: Vec<u8>,
    pub fault: Option<ServoFault>,
    /// Writes of 0 to the torque-enable register so far: someone asked the servo to go limp.
    pub releases: u32,
}

impl VirtualServo {
    fn new(id: u8, model: ServoModel, position: f64) -> VirtualServo {
        let table = model.spec().table;
        let mut servo = VirtualServo {
            id,
            model,
            motion: Motion::new(model, position),
            memory: vec![0; MEMORY_SIZE],
            fault: None,
            releases: 0,
        };
        servo.store(
            table.model_number_register,
            i64::from(model.spec().model_number),
        );
        servo.store(table.id, i64::from(id));
        servo.store(table.status_return_level, table.factory_status_return_level);
        servo.store(table.present_voltage, SUPPLY_DECIVOLTS);
        servo.store(table.present_temperature, ROOM_TEMPERATURE_C);
        servo.store(table.goal_position, position.round() as i64);
        servo
    }

    fn table(&self) -> &'static RegisterTable {
        self.model.spec().table
    }

    /// Sets the Homing_Offset register, as a calibration tool writes it (the emulated servo
    /// reports it; its positions are emulated after the offset, as a real servo's are).
    pub fn set_homing_offset(&mut self, ticks: i64) {
        self.store(self.table().homing_offset, ticks);
    }

    /// Sets the Present Load (or Present Current) register, as a servo under load reports it;
    /// the emulated motion does not model load, so the value stays until set again.
    pub fn set_present_load(&mut self, value: i64) {
        self.store(self.table().present_load, value);
    }

    fn store(&mut self, register: registers::Register, value: i64) {
        if let Ok(bytes) = self.table().encode(&register, value) {
            let start = usize::from(register.address);
            self.memory[start..start + bytes.len()].copy_from_slice(&bytes);
        }
    }

    fn load(&self, register: registers::Register) -> i64 {
        let start = usize::from(register.address);
        self.table()
            .decode(
                &register,
                &self.memory[start..start + usize::from(register.size)],
            )
            .unwrap_or(0)
    }

    fn alarms(&self) -> Alarms {
        match self.fault {
            Some(ServoFault::Alarm(alarms)) => alarms,
            _ => Alarms::default(),
        }
    }

    /// Brings the present-value registers up to date with the motion.
    fn refresh(&mut self) {
        self.motion.update();
        let table = self.table();
        let position = self.motion.position.round() as i64;
        let moving = (self.motion.goal - self.motion.position).abs() > 0.5 && self.motion.torque;
        self.store(table.present_position, position);
        self.store(table.moving, i64::from(moving));
        self.store(table.torque_enable, i64::from(self.motion.torque));
        let alarm_bits = table.alarm_bits.encode(&self.alarms());
        self.store(table.hardware_error, i64::from(alarm_bits));
    }

    /// Applies a write to the control table, then acts on the registers that move the servo.
    /// Returns why the write is refused, if it is.
    fn write(&mut self, address: usize, data: &[u8]) -> Result<(), Refusal> {
        let end = address + data.len();
        if end > MEMORY_SIZE {
            return Err(Refusal::DataLimit);
        }
        let table = self.table();
        if address < usize::from(table.torque_locked_below) && self.motion.torque {
            return Err(Refusal::Access);
        }
        self.memory[address..end].copy_from_slice(data);
        let touches =
            |r: registers::Register| usize::from(r.address) < end && usize::from(r.end()) > address;
        if touches(table.torque_enable) {
            let on = self.load(table.torque_enable) != 0;
            if !on {
                self.releases += 1;
            }
            // A servo in shutdown keeps torque off until rebooted.
            let shut_down = table.shuts_down_on_alarm && self.alarms().any();
            self.motion.set_torque(on && !shut_down);
        }
        if touches(table.goal_position) {
            self.motion.set_goal(self.load(table.goal_position) as f64);
        }
        Ok(())
    }

    fn read(&mut self, address: usize, length: usize) -> Option<Vec<u8>> {
        self.refresh();
        self.memory
            .get(address..address + length)
            .map(<[u8]>::to_vec)
    }
}

/// Instruction packets kept in [`VirtualServos::received`]: minutes of a 6-servo arm at 1 kHz,
/// far more than any test reads.
pub const RECEIVED_LOG_CAPACITY: usize = 1_000_000;

/// The emulated bus: servos, fault switches, and the record of received instructions.
pub struct VirtualServos {
    codec: &'static dyn Codec,
    pub servos: Vec<VirtualServo>,
    /// The instruction packets decoded, in order: at least the last `received_capacity` (the
    /// oldest are dropped in batches, so a push stays cheap).
    pub received: Vec<Packet>,
    /// How many packets `received` keeps ([`RECEIVED_LOG_CAPACITY`]).
    pub received_capacity: usize,
    /// Packets dropped from the front of `received`.
    pub received_dropped: usize,
    /// Bytes that did not decode into packets (for diagnosing a broken encoder).
    pub corrupt_packets: usize,
    /// False once the port "disappears".
    pub connected: bool,
    rx: Vec<u8>,
}

impl VirtualServos {
    /// The servos of `robot`, resting at its home pose with torque off, holding the homing
    /// offsets the robot (or its calibration) gives: the arm it describes.
    pub fn for_robot(robot: &Robot) -> VirtualServos {
        let servos = robot
            .joints
            .iter()
            .zip(&robot.home)
            .map(|(joint, &home)| {
                let tick = joint.servo.tick_exact(home);
                let mut servo = VirtualServo::new(joint.servo.id, joint.servo.model, tick);
                if let Some(offset) = joint.servo.homing_offset {
                    servo.set_homing_offset(offset);
                }
                servo
            })
            .collect();
        VirtualServos::new(robot.bus.protocol, servos)
    }

    pub fn new(protocol: Protocol, servos: Vec<VirtualServo>) -> VirtualServos {
        VirtualServos {
            codec: codec(protocol),
            servos,
            received: Vec::new(),
            received_capacity: RECEIVED_LOG_CAPACITY,
            received_dropped: 0,
            corrupt_packets: 0,
            connected: true,
            rx: Vec::new(),
        }
    }

    pub fn servo_mut(&mut self, id: u8) -> Option<&mut VirtualServo> {
        self.servos.iter_mut().find(|s| s.id == id)
    }

    pub fn set_fault(&mut self, id: u8, fault: Option<ServoFault>) {
        if let Some(servo) = self.servo_mut(id) {
            servo.fault = fault;
            if let Some(ServoFault::Alarm(alarms)) = fault {
                // X series shut the torque off on a hardware error (Shutdown register default).
                if alarms.any() && servo.model.spec().table.shuts_down_on_alarm {
                    servo.motion.set_torque(false);
                }
            }
        }
    }

    /// Present positions (ticks), as the servos would report them now.
    pub fn positions(&mut self) -> HashMap<u8, f64> {
        self.servos
            .iter_mut()
            .map(|s| {
                s.motion.update();
                (s.id, s.motion.position)
            })
            .collect()
    }

    /// Every goal position written, in order: (servo id, ticks).
    pub fn goals_received(&self) -> Vec<(u8, i64)> {
        let mut goals = Vec::new();
        for packet in &self.received {
            for (id, address, data) in self.writes_in(packet) {
                if let Some(servo) = self.servos.iter().find(|s| s.id == id) {
                    let table = servo.table();
                    let register = table.goal_position;
                    if address == usize::from(register.address)
                        && data.len() >= usize::from(register.size)
                    {
                        if let Ok(value) =
                            table.decode(&register, &data[..usize::from(register.size)])
                        {
                            goals.push((id, value));
                        }
                    }
                }
            }
        }
        goals
    }

    /// The (id, address, data) writes an instruction packet makes.
    fn writes_in(&self, packet: &Packet) -> Vec<(u8, usize, Vec<u8>)> {
        let Some(code) = packet.instruction_code() else {
            return Vec::new();
        };
        let instructions = self.codec.instructions();
        let fields = self.codec.fields();
        if code == instructions.write {
            return match fields.split(&packet.params) {
                Some((address, data)) if !data.is_empty() => {
                    vec![(packet.id, usize::from(address), data.to_vec())]
                }
                _ => Vec::new(),
            };
        }
        if code != instructions.sync_write {
            return Vec::new();
        }
        let Some((address, length, entries)) = fields.split_read(&packet.params) else {
            return Vec::new();
        };
        let length = usize::from(length);
        if length == 0 {
            return Vec::new();
        }
        entries
            .chunks(1 + length)
            .filter(|chunk| chunk.len() == 1 + length)
            .map(|chunk| (chunk[0], usize::from(address), chunk[1..].to_vec()))
            .collect()
    }

    /// Keeps `packet` in the log, dropping the oldest quarter of the capacity once it is
    /// exceeded by that much: a `Vec` stays what callers index and slice, and the cost of a
    /// drop is spread over as many pushes.
    fn record(&mut self, packet: Packet) {
        self.received.push(packet);
        let slack = (self.received_capacity / 4).max(1);
        if self.received.len() > self.received_capacity + slack {
            let excess = self.received.len() - self.received_capacity;
            self.received.drain(..excess);
            self.received_dropped += excess;
        }
    }

    /// Decodes what arrived and answers each instruction.
    pub fn handle(&mut self, bytes: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.exchanges(bytes)
            .into_iter()
            .flat_map(|exchange| exchange.answers)
            .map(|answer| (answer.extra_delay, answer.bytes))
            .collect()
    }

    /// Like [`VirtualServos::handle`], instruction by instruction, with the bytes each took on
    /// the line and each answering servo's return delay: what [`wire::Wire`] times.
    pub fn exchanges(&mut self, bytes: &[u8]) -> Vec<wire::Exchange> {
        self.rx.extend_from_slice(bytes);
        let mut exchanges = Vec::new();
        // Bytes still buffered from before belong to the packet they complete.
        let mut pending = self.rx.len() - bytes.len();
        loop {
            let before = self.rx.len();
            match self
                .codec
                .framing()
                .decode(&mut self.rx, Direction::ToServo)
            {
                Ok(Decoded::Packet(packet)) => {
                    let answers = self.answer(&packet);
                    exchanges.push(wire::Exchange {
                        request_bytes: before - self.rx.len() + std::mem::take(&mut pending),
                        answers: answers
                            .into_iter()
                            .map(|(extra_delay, bytes)| wire::Answer {
                                return_delay: self.answer_return_delay(&bytes),
                                extra_delay,
                                bytes,
                            })
                            .collect(),
                    });
                    self.record(packet);
                }
                Ok(Decoded::NeedMore) => break,
                Err(_) => self.corrupt_packets += 1,
            }
        }
        exchanges
    }

    /// The return delay of the servo that sent `answer` (its id read back from the bytes,
    /// damaged or not); zero for an answer no single servo sent (Fast Sync Read's).
    fn answer_return_delay(&self, answer: &[u8]) -> Duration {
        let id = match self
            .codec
            .framing()
            .decode(&mut answer.to_vec(), Direction::FromServo)
        {
            Ok(Decoded::Packet(packet)) => Some(packet.id),
            Ok(Decoded::NeedMore) => None,
            Err(e) => e.id(),
        };
        id.and_then(|id| self.return_delay(id))
            .unwrap_or(Duration::ZERO)
    }

    // MERGE NOTE (branch `wire`): a stand-in for `VirtualServos::return_delay` from branch
    // `vregs`, which replaces it; the wire timing only needs this signature.
    /// How long servo `id` waits before answering, from its Return_Delay_Time register:
    /// Dynamixel counts 2 µs a unit; Feetech STS servos ignore the register (Feetech's
    /// memory table gives the address no function on STS).
    pub fn return_delay(&self, id: u8) -> Option<Duration> {
        let servo = self.servos.iter().find(|s| s.id == id)?;
        match servo.model.vendor() {
            crate::robot::Vendor::Dynamixel => {
                let units = servo.load(servo.table().return_delay).max(0) as u64;
                Some(Duration::from_micros(2 * units))
            }
            crate::robot::Vendor::Feetech => Some(Duration::ZERO),
        }
    }

    fn answer(&mut self, packet: &Packet) -> Vec<(Duration, Vec<u8>)> {
        let Some(code) = packet.instruction_code() else {
            return Vec::new();
        };
        let instructions = self.codec.instructions();
        let fast_sync_read = self.codec.fast_sync_read().map(|f| f.instruction());
        match code {
            c if c == instructions.ping => self.answer_ping(packet.id),
            c if c == instructions.read && packet.id != self.broadcast() => {
                self.answer_read(packet)
            }
            c if c == instructions.write => self.apply_writes(packet, true),
            c if c == instructions.sync_write => self.apply_writes(packet, false),
            c if Some(c) == instructions.sync_read => self.answer_sync_read(&packet.params),
            c if Some(c) == fast_sync_read => self.fast_sync_read(&packet.params),
            c if Some(c) == instructions.reboot => {
                if let Some(servo) = self.servo_mut(packet.id) {
                    servo.fault = None;
                    servo.motion.set_torque(false);
                }
                self.status(packet.id, None, &[])
            }
            _ if packet.id != self.broadcast() => {
                self.status(packet.id, Some(Refusal::Instruction), &[])
            }
            _ => Vec::new(),
        }
    }

    fn broadcast(&self) -> u8 {
        self.codec.framing().broadcast_id()
    }

    /// Every servo answers a broadcast ping.
    fn answer_ping(&self, id: u8) -> Vec<(Duration, Vec<u8>)> {
        let ids: Vec<u8> = if id == self.broadcast() {
            self.servos.iter().map(|s| s.id).collect()
        } else {
            vec![id]
        };
        let mut out = Vec::new();
        for id in ids {
            let Some(servo) = self.servos.iter().find(|s| s.id == id) else {
                continue;
            };
            let params = self
                .codec
                .ping_answer_params(servo.model.spec().model_number, FIRMWARE_VERSION);
            out.extend(self.status(id, None, &params));
        }
        out
    }

    fn answer_read(&mut self, packet: &Packet) -> Vec<(Duration, Vec<u8>)> {
        let Some((address, length, _)) = self.codec.fields().split_read(&packet.params) else {
            return self.status(packet.id, Some(Refusal::DataLength), &[]);
        };
        let data = self
            .servo_mut(packet.id)
            .map(|s| s.read(usize::from(address), usize::from(length)));
        match data {
            Some(Some(bytes)) => self.status(packet.id, None, &bytes),
            Some(None) => self.status(packet.id, Some(Refusal::DataLimit), &[]),
            None => Vec::new(),
        }
    }

    /// A WRITE (`answered`: each addressed servo answers) or a SYNC WRITE (no answers).
    fn apply_writes(&mut self, packet: &Packet, answered: bool) -> Vec<(Duration, Vec<u8>)> {
        let broadcast = self.broadcast();
        let mut out = Vec::new();
        for (id, address, data) in self.writes_in(packet) {
            if id == broadcast {
                // A broadcast write reaches every servo and none answers.
                for servo in &mut self.servos {
                    let _ = servo.write(address, &data);
                }
                continue;
            }
            let result = match self.servo_mut(id) {
                Some(servo) => servo.write(address, &data),
                None => continue,
            };
            if answered {
                out.extend(self.status(id, result.err(), &[]));
            }
        }
        out
    }

    /// Each listed servo answers with its own status packet, in list order.
    fn answer_sync_read(&mut self, params: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let Some((address, length, ids)) = self.codec.fields().split_read(params) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for &id in ids {
            let read = self
                .servo_mut(id)
                .and_then(|s| s.read(usize::from(address), usize::from(length)));
            if let Some(bytes) = read {
                out.extend(self.status(id, None, &bytes));
            }
        }
        out
    }

    fn fast_sync_read(&mut self, params: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let codec = self.codec;
        let (Some(fast), Some((address, length, ids))) =
            (codec.fast_sync_read(), codec.fields().split_read(params))
        else {
            return Vec::new();
        };
        let mut entries = Vec::new();
        for &id in ids {
            let Some(servo) = self.servo_mut(id) else {
                continue;
            };
            let Some(data) = servo.read(usize::from(address), usize::from(length)) else {
                continue;
            };
            let Some(error) = codec.status_byte(&servo.alarms(), None) else {
                continue;
            };
            entries.push(FastSyncReadEntry { id, error, data });
        }
        // The combined answer is one whole packet from the broadcast id.
        match fast.encode(&entries) {
            Ok(packet) => vec![(Duration::ZERO, packet)],
            Err(_) => Vec::new(),
        }
    }

    /// A status packet from servo `id`, shaped by its injected fault.
    fn status(&self, id: u8, refusal: Option<Refusal>, params: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let Some(servo) = self.servos.iter().find(|s| s.id == id) else {
            return Vec::new();
        };
        let Some(error) = self.codec.status_byte(&servo.alarms(), refusal) else {
            return Vec::new();
        };
        let Ok(mut bytes) = self.codec.framing().try_encode_status(id, error, params) else {
            return Vec::new();
        };
        let mut delay = Duration::ZERO;
        match servo.fault {
            Some(ServoFault::NoAnswer) => return Vec::new(),
            Some(ServoFault::CorruptChecksum) => {
                if let Some(last) = bytes.last_mut() {
                    *last ^= 0x5A;
                }
            }
            Some(ServoFault::Late(d)) => delay = d,
            _ => {}
        }
        vec![(delay, bytes)]
    }
}

/// Firmware version reported in Dynamixel ping answers.
const FIRMWARE_VERSION: u8 = 52;

impl Responder for VirtualServos {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.handle(written)
    }

    fn connected(&self) -> bool {
        self.connected
    }
}

/// Shared access to a running virtual bus (from a test, or the server thread).
#[derive(Clone)]
pub struct VirtualBus(Arc<Mutex<VirtualServos>>);

impl VirtualBus {
    pub fn new(servos: VirtualServos) -> VirtualBus {
        VirtualBus(Arc::new(Mutex::new(servos)))
    }

    pub fn lock(&self) -> MutexGuard<'_, VirtualServos> {
        // A panic while holding the lock leaves consistent data here (plain values), so a
        // poisoned lock is still usable.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Emulated servos for `robot` and the native driver talking to them through an in-memory
    /// transport: the real packet code on both sides, without a pseudo-terminal.
    pub fn in_process(robot: &Robot) -> (super::driver::NativeBus, VirtualBus) {
        let virtual_bus = VirtualBus::new(VirtualServos::for_robot(robot));
        let servos: Vec<_> = robot.servos();
        let transport = super::transport::MemoryTransport::new(virtual_bus.clone());
        let bus = super::driver::NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
        (bus, virtual_bus)
    }
}

/// A [`Responder`] over a shared virtual bus, for an in-process [`super::transport::MemoryTransport`].
impl Responder for VirtualBus {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.lock().handle(written)
    }

    fn connected(&self) -> bool {
        self.lock().connected
    }
}

#[cfg(test)]
mod log_tests {
    use super::*;
    use crate::bus::protocol::dynamixel;
    use crate::bus::protocol::packet::Framing;

    #[test]
    fn the_received_log_keeps_the_latest_packets_within_its_capacity() {
        let mut servos = VirtualServos::new(Protocol::Dynamixel2, Vec::new());
        servos.received_capacity = 8;
        // 100 pings to ids 0…99 (none answers: no servos), one packet each.
        for id in 0..100u8 {
            let bytes = dynamixel::Dynamixel2.encode_instruction(id, dynamixel::PING, &[]);
            servos.handle(&bytes);
        }
        let kept: Vec<u8> = servos.received.iter().map(|p| p.id).collect();
        // At most capacity + a quarter of it, at least the capacity, and the newest ones.
        assert!((8..=10).contains(&kept.len()), "{kept:?}");
        let first = 100 - kept.len() as u8;
        assert_eq!(kept, (first..100).collect::<Vec<u8>>());
        assert_eq!(servos.received_dropped + kept.len(), 100);
    }
}
