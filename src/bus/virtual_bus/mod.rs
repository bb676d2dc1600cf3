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
mod physics;
mod pty;
mod servo;
#[cfg(test)]
mod servo_tests;
pub mod wire;

pub use hand::Hand;
pub use physics::{ratings, MotorCommand, PhysicalArmError, Physics, PhysicsError, Shaft};
pub use pty::PtyServer;
pub use servo::VirtualServo;
pub use wire::WireTiming;

use super::protocol::dynamixel;
use super::protocol::packet::{Decoded, Direction, Packet};
use super::protocol::{codec, Codec, FastSyncReadEntry, Refusal};
use super::transport::Responder;
use super::Alarms;
use crate::robot::{Protocol, Robot};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Size of each emulated control table; every register of the supported models lies below.
pub(crate) const MEMORY_SIZE: usize = 256;
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

/// Instruction packets kept in [`VirtualServos::received`]: minutes of a 6-servo arm at 1 kHz,
/// far more than any test reads.
pub const RECEIVED_LOG_CAPACITY: usize = 1_000_000;

/// The emulated bus: servos, fault switches, and the record of received instructions.
pub struct VirtualServos {
    codec: &'static dyn Codec,
    /// The servos on the bus, each with its own id.
    pub servos: Vec<VirtualServo>,
    /// The instruction packets decoded, in order: at least the last `received_capacity` (the
    /// oldest are dropped in batches, so a push stays cheap).
    pub received: Vec<Packet>,
    /// When each packet of `received` was decoded (the same index).
    pub received_at: Vec<Instant>,
    /// How many packets `received` keeps (`RECEIVED_LOG_CAPACITY`).
    pub received_capacity: usize,
    /// Packets dropped from the front of `received`.
    pub received_dropped: usize,
    /// Bytes that did not decode into packets (for diagnosing a broken encoder).
    pub corrupt_packets: usize,
    /// False once the port "disappears".
    pub connected: bool,
    rx: Vec<u8>,
    /// The arm's physics, for servos that carry it (`with_physics`).
    physics: Option<physics::PhysicsLink>,
}

impl VirtualServos {
    /// The servos of `robot`, resting at its home pose with torque off, holding the homing
    /// offsets the robot (or its calibration) gives: the arm it describes. Each shaft is placed
    /// so that Present Position, through the offset, reads the home tick.
    pub fn for_robot(robot: &Robot) -> VirtualServos {
        let servos = robot
            .joints
            .iter()
            .zip(&robot.home)
            .map(|(joint, &home)| servo_for_joint(joint, home))
            .collect();
        VirtualServos::new(robot.bus.protocol, servos)
    }

    /// The servos of `robot` as [`VirtualServos::for_robot`] makes them, their shafts the
    /// arm's in `physics` from now on: its joints at the robot's home pose, at rest.
    pub fn with_physics(
        robot: &Robot,
        physics: Box<dyn Physics>,
    ) -> Result<VirtualServos, PhysicalArmError> {
        let mut servos = VirtualServos::for_robot(robot);
        let link = physics::PhysicsLink::new(robot, &servos.servos, physics)?;
        for servo in &mut servos.servos {
            servo.motion.external = true;
        }
        servos.physics = Some(link);
        // The shafts as the physics has them (an arm that settled first lies elsewhere than
        // at home), before any instruction can act on them.
        servos.advance_physics_to(0.0);
        Ok(servos)
    }

    /// Brings the arm's physics up to now (nothing for servos without). Physics that fails
    /// takes the bus with it: the port "disappears", as a real one whose arm lost power.
    pub fn advance_physics(&mut self) {
        self.advance_physics_to(f64::INFINITY);
    }

    /// Brings the arm's physics up to `until` seconds after it started (at most to now): what
    /// a test that samples the arm at chosen moments calls, so that when its thread runs late
    /// the sample is still of that moment.
    pub fn advance_physics_to(&mut self, until: f64) {
        let Some(link) = &mut self.physics else {
            return;
        };
        if let Err(e) = link.advance_to(&mut self.servos, until) {
            eprintln!("virtual bus: {e}; the bus is gone");
            self.physics = None;
            self.connected = false;
        }
    }

    /// Whether the servos carry an arm's physics.
    pub fn has_physics(&self) -> bool {
        self.physics.is_some()
    }

    /// Seconds since the physics started that it has reached, for servos that carry it.
    pub fn physics_time(&self) -> Option<f64> {
        self.physics.as_ref().map(physics::PhysicsLink::time)
    }

    /// Seconds of processor time the physics took per simulated second, for servos that
    /// carry it.
    pub fn physics_cost(&self) -> Option<f64> {
        self.physics.as_ref().map(physics::PhysicsLink::cost)
    }

    /// How long servo `id` waits before it answers (its Return_Delay_Time register; nothing on
    /// the STS3215, where the register has no function).
    pub fn return_delay(&self, id: u8) -> Option<Duration> {
        self.servos
            .iter()
            .find(|s| s.id == id)
            .map(VirtualServo::return_delay)
    }

    /// `servos` answering `protocol`, connected, nothing received yet.
    pub fn new(protocol: Protocol, servos: Vec<VirtualServo>) -> VirtualServos {
        VirtualServos {
            codec: codec(protocol),
            servos,
            received: Vec::new(),
            received_at: Vec::new(),
            received_capacity: RECEIVED_LOG_CAPACITY,
            received_dropped: 0,
            corrupt_packets: 0,
            connected: true,
            rx: Vec::new(),
            physics: None,
        }
    }

    /// The servo with id `id`.
    pub fn servo_mut(&mut self, id: u8) -> Option<&mut VirtualServo> {
        self.servos.iter_mut().find(|s| s.id == id)
    }

    /// Makes servo `id` misbehave as `fault` says from now on (`None`: behave again).
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

    /// Present positions (ticks, after the homing offsets), as the servos would report them
    /// now.
    pub fn positions(&mut self) -> HashMap<u8, f64> {
        self.advance_physics();
        self.servos
            .iter_mut()
            .map(|s| (s.id, s.present_position()))
            .collect()
    }

    /// Every goal position written, in order: (servo id, ticks).
    pub fn goals_received(&self) -> Vec<(u8, i64)> {
        self.goals_in_first(self.received.len())
    }

    /// The goal positions written by the first `packets` packets of `received`, in order.
    ///
    /// What a test injecting a fault mid-run should use: it notes `received.len()` under the
    /// lock, which costs nothing, and decodes after the run. Decoding every packet while
    /// holding the lock keeps the server thread waiting; on a busy machine the holder can be
    /// preempted meanwhile, and a servo then misses its answer for the test's sake.
    pub fn goals_in_first(&self, packets: usize) -> Vec<(u8, i64)> {
        self.received[..packets.min(self.received.len())]
            .iter()
            .flat_map(|packet| self.goals_in(packet))
            .collect()
    }

    /// When each packet that wrote a goal position arrived, in order.
    pub fn goal_writes_at(&self) -> Vec<Instant> {
        self.received
            .iter()
            .zip(&self.received_at)
            .filter(|(packet, _)| !self.goals_in(packet).is_empty())
            .map(|(_, &at)| at)
            .collect()
    }

    /// The goal positions an instruction packet writes: (servo id, ticks).
    fn goals_in(&self, packet: &Packet) -> Vec<(u8, i64)> {
        let mut goals = Vec::new();
        for (id, address, data) in self.writes_in(packet) {
            if let Some(servo) = self.servos.iter().find(|s| s.id == id) {
                let table = servo.table();
                let register = table.goal_position;
                if address == usize::from(register.address)
                    && data.len() >= usize::from(register.size)
                {
                    if let Ok(value) = table.decode(&register, &data[..usize::from(register.size)])
                    {
                        goals.push((id, value));
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
        if Some(code) == instructions.bulk_write {
            return dynamixel::parse_bulk_write(&packet.params)
                .unwrap_or_default()
                .into_iter()
                .map(|w| (w.id, usize::from(w.address), w.data))
                .collect();
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
        // `received` may have been emptied from outside (a test clearing it): the times of the
        // packets it no longer holds go too.
        let gone = (self.received_at.len() + 1).saturating_sub(self.received.len());
        self.received_at.drain(..gone);
        self.received_at.push(Instant::now());
        let slack = (self.received_capacity / 4).max(1);
        if self.received.len() > self.received_capacity + slack {
            let excess = self.received.len() - self.received_capacity;
            self.received.drain(..excess);
            self.received_at.drain(..excess);
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
    /// the line and each answering servo's return delay: what `wire::Wire` times.
    pub fn exchanges(&mut self, bytes: &[u8]) -> Vec<wire::Exchange> {
        self.advance_physics();
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
                    exchanges.push(wire::Exchange {
                        request_bytes: before - self.rx.len() + std::mem::take(&mut pending),
                        answers: self.answer(&packet),
                    });
                    self.record(packet);
                }
                Ok(Decoded::NeedMore) => break,
                Err(_) => self.corrupt_packets += 1,
            }
        }
        exchanges
    }

    fn answer(&mut self, packet: &Packet) -> Vec<wire::Answer> {
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
            c if Some(c) == instructions.bulk_write => self.apply_writes(packet, false),
            c if Some(c) == instructions.bulk_read => self.answer_bulk_read(&packet.params),
            c if Some(c) == instructions.sync_read => self.answer_sync_read(&packet.params),
            c if Some(c) == fast_sync_read => self.fast_sync_read(&packet.params),
            c if Some(c) == instructions.reboot => {
                if let Some(servo) = self.servo_mut(packet.id) {
                    servo.reboot();
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
    fn answer_ping(&self, id: u8) -> Vec<wire::Answer> {
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

    fn answer_read(&mut self, packet: &Packet) -> Vec<wire::Answer> {
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
    fn apply_writes(&mut self, packet: &Packet, answered: bool) -> Vec<wire::Answer> {
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
    fn answer_sync_read(&mut self, params: &[u8]) -> Vec<wire::Answer> {
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

    /// Each listed servo answers with its own span, in list order (Protocol 2.0 Bulk Read).
    fn answer_bulk_read(&mut self, params: &[u8]) -> Vec<wire::Answer> {
        let Some(entries) = dynamixel::parse_bulk_read(params) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for entry in entries {
            let read = self
                .servo_mut(entry.id)
                .map(|s| s.read(usize::from(entry.address), usize::from(entry.length)));
            match read {
                Some(Some(bytes)) => out.extend(self.status(entry.id, None, &bytes)),
                Some(None) => out.extend(self.status(entry.id, Some(Refusal::DataLimit), &[])),
                None => {}
            }
        }
        out
    }

    fn fast_sync_read(&mut self, params: &[u8]) -> Vec<wire::Answer> {
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
        // The combined answer is one whole packet from the broadcast id, which no single servo
        // sends: no return delay of its own.
        match fast.encode(&entries) {
            Ok(bytes) => vec![wire::Answer {
                return_delay: Duration::ZERO,
                extra_delay: Duration::ZERO,
                bytes,
            }],
            Err(_) => Vec::new(),
        }
    }

    /// A status packet from servo `id`, shaped by its injected fault.
    fn status(&self, id: u8, refusal: Option<Refusal>, params: &[u8]) -> Vec<wire::Answer> {
        let Some(servo) = self.servos.iter().find(|s| s.id == id) else {
            return Vec::new();
        };
        let Some(error) = self.codec.status_byte(&servo.alarms(), refusal) else {
            return Vec::new();
        };
        let Ok(mut bytes) = self.codec.framing().try_encode_status(id, error, params) else {
            return Vec::new();
        };
        let mut extra_delay = Duration::ZERO;
        match servo.fault {
            Some(ServoFault::NoAnswer) => return Vec::new(),
            Some(ServoFault::CorruptChecksum) => {
                if let Some(last) = bytes.last_mut() {
                    *last ^= 0x5A;
                }
            }
            Some(ServoFault::Late(d)) => extra_delay = d,
            _ => {}
        }
        vec![wire::Answer {
            return_delay: servo.return_delay(),
            extra_delay,
            bytes,
        }]
    }
}

/// Firmware version reported in Dynamixel ping answers, as register 6 holds it.
const FIRMWARE_VERSION: u8 = crate::servo::dynamixel_x::FIRMWARE_VERSION as u8;

/// The servo of `joint` at joint value `home`. A servo that has an extended (multi-turn)
/// position mode is put in it when the joint's ticks leave the position mode's range or its
/// offset exceeds what position mode accepts (Dynamixel: ±1024): the way LeRobot configures the
/// Koch arm, and the only way such a joint works on a real servo.
fn servo_for_joint(joint: &crate::robot::Joint, home: f64) -> VirtualServo {
    let servo_spec = &joint.servo;
    let modes = servo_spec.model.spec().modes;
    let tick = servo_spec.tick_exact(home);
    let mut servo = VirtualServo::new(servo_spec.id, servo_spec.model, tick);
    let offset = servo_spec.homing_offset.unwrap_or(0);
    if let Some(offset) = servo_spec.homing_offset {
        // A model without Homing_Offset refuses it and applies none, as the real one would;
        // connecting refuses a robot that gives such a servo another offset than 0
        // (`bus::homing`).
        servo.set_homing_offset(offset).ok();
    }
    let ticks = [joint.limits.min, joint.limits.max, home].map(|v| servo_spec.tick_exact(v));
    let (first, last) = modes.position;
    let one_turn = ticks
        .iter()
        .all(|t| (first as f64..=last as f64).contains(t));
    let offset_ignored = modes
        .position_mode_offset_limit
        .is_some_and(|limit| offset.abs() > limit);
    if let Some(extended) = modes.extended_position {
        if !one_turn || offset_ignored {
            // Only a model with Operating_Mode has an extended mode (catalogue tests).
            servo.set_operating_mode(extended.mode).ok();
        }
    }
    servo.place_at(tick);
    servo
}

impl Responder for VirtualServos {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.handle(written)
    }

    fn connected(&self) -> bool {
        self.connected
    }
}

/// How often the physics of servos nobody talks to is brought up to now.
pub const PHYSICS_CLOCK: Duration = Duration::from_millis(10);

/// Shared access to a running virtual bus (from a test, or the server thread).
#[derive(Clone)]
pub struct VirtualBus(Arc<Mutex<VirtualServos>>);

impl VirtualBus {
    /// Shares `servos`.
    pub fn new(servos: VirtualServos) -> VirtualBus {
        VirtualBus(Arc::new(Mutex::new(servos)))
    }

    /// The servos, for as long as the guard lives (the server waits meanwhile).
    pub fn lock(&self) -> MutexGuard<'_, VirtualServos> {
        // A panic while holding the lock leaves consistent data here (plain values), so a
        // poisoned lock is still usable.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Keeps the servos' physics up to now between instructions, every 10 ms, for
    /// as long as anyone else holds the bus: a limp arm falls while nobody reads it, and an
    /// instruction after a quiet minute does not wait for a minute of physics.
    pub fn keep_physics_running(&self) {
        let weak = Arc::downgrade(&self.0);
        std::thread::spawn(move || {
            while let Some(shared) = weak.upgrade() {
                {
                    let mut servos = shared.lock().unwrap_or_else(|e| e.into_inner());
                    if !servos.has_physics() {
                        return;
                    }
                    servos.advance_physics();
                }
                drop(shared);
                std::thread::sleep(PHYSICS_CLOCK);
            }
        });
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
