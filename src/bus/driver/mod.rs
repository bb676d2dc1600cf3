//! Our own [`ServoBus`] over a [`Transport`]: Dynamixel 2.0 or Feetech STS/SCS.
//!
//! One transaction at a time, half duplex: discard stale input, send, then collect answers until
//! a deadline. Reads are retried a bounded number of times; writes never are. Echoes of our own
//! packets (some half-duplex adapters loop the line back, see [`super::echo`]) and answers from
//! other ids are skipped, corrupt packets are counted and the search goes on behind them. A
//! servo's late answer to an earlier request is never taken for the present one
//! ([`in_flight`]), and a wait that keypose itself overslept is told apart from a silent servo.
//! A cell can cut a read short from another thread when it would hold the other arms
//! ([`super::cutoff`]); a read cut short is not waited for again nor retried.

mod in_flight;

use self::in_flight::{Answer, InFlight};
use super::cutoff::ReadCutoff;
use super::echo::{Echoes, Front};
use super::models::Servos;
use super::protocol::packet::{Decoded, Direction, Packet, PacketError};
use super::protocol::{codec, Codec, Instructions, Status};
use super::transport::Transport;
use super::DecodeAnswer;
use super::{homing, Alarms, BusError, CorruptAnswer, Health, PingInfo, PositionLoad, ServoBus};
use crate::robot::{Protocol, ServoModel};
use crate::servo::{span, Register, RegisterTable, Setting};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long to wait for one answer inside a control loop ([`ServoBus::pace`]). Generous against
/// the wire time of any packet here (under 1 ms at 1 Mbps) because a USB adapter adds its
/// latency timer (up to 16 ms on FTDI).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(40);
/// How long a one-off exchange outside a control loop (a session's start, torque, settings,
/// health between motions) waits for its answer. Nothing is late for waiting there, and on a
/// loaded machine the kernel hands a serial port's input to its reader from a worker thread of
/// ordinary priority (a USB adapter's as a pseudo-terminal's): measured beside busy processes,
/// a pseudo-terminal's round trip took over 40 ms a few times a minute, once 350 ms. A control
/// loop keeps the short timeout: its reads come every period, and a lost one is skipped.
pub const DEFAULT_SETUP_TIMEOUT: Duration = Duration::from_millis(200);
/// Extra attempts for a read that got no valid answer.
pub const DEFAULT_READ_RETRIES: u32 = 2;
/// A wait for an answer that ends this long after its deadline was not the servo's silence
/// alone: keypose's thread was not running (CPU starvation). Far beyond a loaded machine's
/// ordinary wake-up delay, well within the timeout.
pub const STARVED_AFTER: Duration = Duration::from_millis(10);

/// keypose's own driver: a [`ServoBus`] speaking a vendor protocol (its [`Codec`]) over a
/// transport (a serial port, or emulated servos in memory).
pub struct NativeBus {
    transport: Box<dyn Transport>,
    codec: &'static dyn Codec,
    servos: Servos,
    /// How long to wait for one answer inside a control loop.
    pub timeout: Duration,
    /// How long to wait for one answer outside a control loop.
    pub setup_timeout: Duration,
    /// Whether a control loop drives the bus ([`ServoBus::pace`]): which timeout applies.
    paced: bool,
    /// Extra attempts for a read that got no valid answer.
    pub read_retries: u32,
    /// Dynamixel: read with Fast Sync Read (0x8A, one combined answer) instead of Sync Read.
    /// Off by default: which models and firmware support it is unverified (docs/protocols.md).
    pub fast_sync_read: bool,
    rx: Vec<u8>,
    /// When the bytes in `rx` were read from the port: when the answers decoded from them came.
    received: Instant,
    /// Packets sent whose echo may still come back.
    echoes: Echoes,
    /// Requests whose answers have not come yet.
    in_flight: InFlight,
    /// Set from another thread to stop waiting for answers ([`ServoBus::set_read_cutoff`]).
    read_cutoff: Option<Arc<ReadCutoff>>,
}

impl NativeBus {
    /// A bus over `transport` for the given servos (id, model); ids not listed can only be
    /// pinged.
    pub fn new(
        transport: Box<dyn Transport>,
        protocol: Protocol,
        servos: &[(u8, ServoModel)],
    ) -> NativeBus {
        NativeBus {
            transport,
            codec: codec(protocol),
            servos: Servos::new(servos),
            timeout: DEFAULT_TIMEOUT,
            setup_timeout: DEFAULT_SETUP_TIMEOUT,
            paced: false,
            read_retries: DEFAULT_READ_RETRIES,
            fast_sync_read: false,
            rx: Vec::new(),
            received: Instant::now(),
            echoes: Echoes::default(),
            in_flight: InFlight::default(),
            read_cutoff: None,
        }
    }

    fn table(&self, id: u8) -> Result<&'static RegisterTable, BusError> {
        self.servos.table(id)
    }

    fn protocol_error(&self, error: PacketError) -> BusError {
        BusError::Unframable {
            protocol: self.codec.protocol().name(),
            error,
        }
    }

    fn no_instruction(&self, instruction: &'static str) -> BusError {
        BusError::NoInstruction {
            protocol: self.codec.protocol().name(),
            instruction,
        }
    }

    fn port_error(&self, source: std::io::Error) -> BusError {
        BusError::Port {
            port: self.transport.describe(),
            source,
        }
    }

    fn instructions(&self) -> &'static Instructions {
        self.codec.instructions()
    }

    fn send(&mut self, id: u8, instruction: u8, params: &[u8]) -> Result<(), BusError> {
        let bytes = self
            .codec
            .framing()
            .try_encode_instruction(id, instruction, params)
            .map_err(|e| self.protocol_error(e))?;
        // Anything still in the input is a late answer to an earlier, abandoned transaction (or
        // an echo, which `echoes` still expects if it comes later).
        self.rx.clear();
        self.transport
            .discard_input()
            .map_err(|e| self.port_error(e))?;
        self.transport
            .write_all(&bytes)
            .map_err(|e| self.port_error(e))?;
        self.echoes.sent(bytes);
        Ok(())
    }

    /// Reads what has arrived since the last transaction (which [`Self::send`] would drop),
    /// waiting until `until` for the first bytes when none are there yet, so that late answers
    /// settle their requests, and free their lengths, before a new read is given one.
    fn settle_input(&mut self, until: Instant) -> Result<(), BusError> {
        let mut chunk = [0u8; 512];
        let asked = Instant::now();
        // A bounded look: a line that keeps talking cannot hold the transaction up.
        for look in 0..16 {
            let wait = if look == 0 { until } else { Instant::now() };
            let n = self.wait_input(&mut chunk, asked, wait)?;
            if n == 0 {
                break;
            }
            self.rx.extend_from_slice(&chunk[..n]);
        }
        self.received = Instant::now();
        loop {
            match self.echoes.strip(&mut self.rx) {
                Front::Undecided => break,
                Front::Echo(_) => continue,
                Front::NotEcho => {}
            }
            match self
                .codec
                .framing()
                .decode(&mut self.rx, Direction::FromServo)
            {
                Ok(Decoded::Packet(packet)) => {
                    let length = packet.params.len();
                    self.in_flight.answered(packet.id, length, self.received);
                }
                Ok(Decoded::NeedMore) => break,
                Err(_) => continue,
            }
        }
        Ok(())
    }

    /// How long one answer is waited for now: in a control loop or outside one.
    fn answer_timeout(&self) -> Duration {
        match self.paced {
            true => self.timeout,
            false => self.setup_timeout,
        }
    }

    /// The next status packet from `id`, or a timeout.
    fn receive(&mut self, id: u8) -> Result<Packet, BusError> {
        self.receive_answer(id, None)
    }

    /// The next status packet from `id` carrying `data_bytes` bytes (when given), or a timeout.
    fn receive_answer(&mut self, id: u8, data_bytes: Option<usize>) -> Result<Packet, BusError> {
        self.collect_answer(id, data_bytes, false)
    }

    /// The next status packet from `id` carrying `data_bytes` bytes (when given), or an error
    /// once the timeout has passed (counted from when it began to wait: answers already read
    /// take none). Status packets carry no request number: an answer is matched
    /// to its request by [`InFlight`] (the late answer to an earlier request is skipped, and
    /// named only if nothing better comes), and a packet from the right servo that fits no
    /// request, with another length and no error, is skipped as well.
    ///
    /// A wait that ends long after its deadline ([`STARVED_AFTER`]) is keypose's own: the
    /// thread was not running. The answer may be in the input already (it is always read, even
    /// past the deadline) or, from an emulated bus starved with this process, still to come, so
    /// the wait is given once more; nothing then is [`BusError::Starved`], not a timeout.
    ///
    /// `copy_may_answer`: the answer can be byte for byte the request (a Feetech PING answered
    /// with error byte 0x01, input voltage, is the PING itself). A copy of the request is then
    /// an echo if anything else comes after it, and the answer if nothing does by the deadline:
    /// an adapter without echo delivers only the answer.
    fn collect_answer(
        &mut self,
        id: u8,
        data_bytes: Option<usize>,
        copy_may_answer: bool,
    ) -> Result<Packet, BusError> {
        // The wait for the answer starts when nothing complete is left to decode: the answers
        // of a sync read mostly come in one read of the port, and those decoded from it needed
        // no clock. The clock is read once per wait, not once per packet.
        let mut asked: Option<Instant> = None;
        let mut deadline: Option<Instant> = None;
        let mut starved: Option<Duration> = None;
        let mut seen = Seen::default();
        let mut chunk = [0u8; 512];
        loop {
            if let Some(packet) = self.decode_buffered(id, data_bytes, copy_may_answer, &mut seen) {
                return Ok(packet);
            }
            let asked = *asked.get_or_insert_with(Instant::now);
            let until = *deadline.get_or_insert(asked + self.answer_timeout());
            let n = self.wait_input(&mut chunk, asked, until)?;
            if n > 0 {
                self.received = Instant::now();
                self.rx.extend_from_slice(&chunk[..n]);
                continue;
            }
            // Cut short (a cell's other arms are not held for it): no second wait.
            let cut = self.cut_off();
            let overslept = Instant::now().saturating_duration_since(until);
            if overslept > STARVED_AFTER && starved.is_none() && !cut {
                starved = Some(overslept);
                deadline = Some(Instant::now() + self.answer_timeout());
                continue;
            }
            // Anything else after the copy, even corrupt, shows the copy was an echo.
            if let Some(packet) = seen.own_copy.take().filter(|_| seen.clean()) {
                self.echoes.answered();
                return Ok(packet);
            }
            // How long it waited: less than the timeout when cut short.
            let waited = match cut {
                true => asked.elapsed().min(self.answer_timeout()),
                false => self.answer_timeout(),
            };
            let silence = Silence {
                timeout_ms: waited.as_millis() as u64,
                starved,
                cut,
            };
            return Err(seen.into_error(id, data_bytes, silence));
        }
    }

    /// Decodes what the port has delivered until the answer of servo `id` is found (returned),
    /// or nothing complete is left; what is not the answer is noted in `seen` (echoes, other
    /// servos' late answers, stale or corrupt packets).
    fn decode_buffered(
        &mut self,
        id: u8,
        data_bytes: Option<usize>,
        copy_may_answer: bool,
        seen: &mut Seen,
    ) -> Option<Packet> {
        loop {
            match self.echoes.strip(&mut self.rx) {
                Front::Undecided => return None,
                Front::Echo(mut bytes) => {
                    if copy_may_answer {
                        if let Ok(Decoded::Packet(p)) = self
                            .codec
                            .framing()
                            .decode(&mut bytes, Direction::FromServo)
                        {
                            seen.own_copy = Some(p).filter(|p| p.id == id);
                        }
                    }
                    continue;
                }
                Front::NotEcho => {}
            }
            match self
                .codec
                .framing()
                .decode(&mut self.rx, Direction::FromServo)
            {
                Ok(Decoded::Packet(packet)) if packet.id == id => {
                    let length = packet.params.len();
                    let errorless = packet.error().unwrap_or(0) == 0;
                    match self.in_flight.answered(id, length, self.received) {
                        Answer::Earlier { late: by } => {
                            seen.late = seen.late.max(Some(by));
                        }
                        Answer::Unknown if errorless && data_bytes.is_some_and(|n| length != n) => {
                            seen.stale = Some(length);
                        }
                        Answer::Current | Answer::Unknown => {
                            self.echoes.answered();
                            return Some(packet);
                        }
                    }
                }
                // Another servo's late answer: not ours, but it settles that servo's
                // requests up to the one it answers.
                Ok(Decoded::Packet(packet)) => {
                    let length = packet.params.len();
                    self.in_flight.answered(packet.id, length, self.received);
                }
                Ok(Decoded::NeedMore) => return None,
                // The echo of our own instruction on a looped-back line.
                Err(PacketError::Direction { .. }) => {}
                Err(e) => seen.corrupt = Some(e),
            }
        }
    }

    /// What arrives before `deadline`, or, when the read cutoff passes first for a request sent
    /// at `asked`, before that (waited up to when the cutoff says, see [`super::cutoff`]); 0
    /// bytes when either has come. What has arrived by then is still read: a thread that was
    /// not running when its answer came does not call that silence.
    fn wait_input(
        &mut self,
        buf: &mut [u8],
        asked: Instant,
        deadline: Instant,
    ) -> Result<usize, BusError> {
        let cutoff = self.read_cutoff.clone();
        loop {
            let now = Instant::now();
            let cut = cutoff.as_ref().is_some_and(|c| c.passed(asked, now));
            // One wait up to the cut, or to when one may come (an answer ends it sooner).
            let look = cutoff
                .as_ref()
                .and_then(|c| c.next_look(asked, now))
                .map_or(deadline, |look| look.min(deadline));
            let until = if cut { now } else { look };
            let n = self
                .transport
                .read_until(buf, until)
                .map_err(|e| self.port_error(e))?;
            if n > 0 || cut || Instant::now() >= deadline {
                return Ok(n);
            }
        }
    }

    /// Whether the read cutoff has come: a read is then not waited for or tried again.
    fn cut_off(&self) -> bool {
        self.read_cutoff
            .as_ref()
            .is_some_and(|cutoff| cutoff.reached(Instant::now()))
    }

    /// Turns a status packet's error byte into an error, reading the alarm register when a
    /// Dynamixel servo raises its alert bit.
    fn check_status(&mut self, packet: &Packet) -> Result<(), BusError> {
        self.check_status_passive(packet)
            .map_err(|e| self.resolve_alarm(e))
    }

    /// Dynamixel Hardware Error Status: one byte at the same address on every X-series model,
    /// so it can be read from a servo of unknown model (a scan).
    fn read_alarm_register(&mut self, id: u8) -> Result<Alarms, BusError> {
        let (register, bits) = self.codec.alarm_register();
        let packet = self.read_register(id, register)?;
        let raw = packet.params.first().copied().unwrap_or(0);
        Ok(bits.decode(raw))
    }

    /// One READ of `register` from servo `id`, its answer unchecked: the status byte is the
    /// caller's to judge. Its data is the register's bytes.
    fn read_register(&mut self, id: u8, register: Register) -> Result<Packet, BusError> {
        let size = u16::from(register.size);
        let asked = size + self.extra_bytes(&[id], |extra| usize::from(size) + extra)?;
        let params = self.codec.fields().read(register.address, asked);
        let params = params.map_err(|e| self.protocol_error(e))?;
        self.send(id, self.instructions().read, &params)?;
        self.in_flight
            .sent(&[id], usize::from(asked), Instant::now());
        let mut packet = self.receive_answer(id, Some(usize::from(asked)))?;
        packet.params.truncate(usize::from(size));
        Ok(packet)
    }

    /// How many bytes more than its register a read answered by `ids` asks for, so that its
    /// answers fit none of their unanswered requests ([`InFlight`]); `answer_bytes` gives the
    /// data length of an answer for a number of extra bytes. When every length is taken, the
    /// late answers are waited for, as an answer would be, up to the timeout: a servo still
    /// holding them then answers too late to be read now.
    fn extra_bytes(
        &mut self,
        ids: &[u8],
        answer_bytes: impl Fn(usize) -> usize,
    ) -> Result<u16, BusError> {
        let mut now = Instant::now();
        let deadline = now + self.answer_timeout();
        let mut until = now;
        loop {
            if self.in_flight.waiting() {
                self.settle_input(until)?;
                now = Instant::now();
            }
            match self.in_flight.extra_bytes(ids, &answer_bytes, now) {
                Ok(extra) => return Ok(extra as u16),
                Err((id, oldest)) if now >= deadline || self.cut_off() => {
                    return Err(BusError::Stale {
                        id,
                        timeout_ms: self.answer_timeout().as_millis() as u64,
                        late_ms: oldest.as_millis() as u64,
                    })
                }
                Err(_) => until = deadline,
            }
        }
    }

    /// One instruction to one servo and its answer (with `data_bytes` of data, when given),
    /// checked.
    fn transaction(
        &mut self,
        id: u8,
        instruction: u8,
        params: &[u8],
        data_bytes: Option<usize>,
    ) -> Result<Packet, BusError> {
        self.send(id, instruction, params)?;
        let packet = self.receive_answer(id, data_bytes)?;
        self.check_status(&packet)?;
        Ok(packet)
    }

    /// Reads `length` bytes at `address` from each servo, in the order of `ids`: one sync read
    /// where the protocol has it, else one read per servo. Retried as a whole on failure.
    fn read_block(
        &mut self,
        ids: &[u8],
        address: u16,
        length: u16,
    ) -> Result<Vec<Vec<u8>>, BusError> {
        // The first failure names the culprit: a late answer from one servo can make a retry
        // time out on another, whose error would then mislead.
        let retried = |e: &BusError| e.is_no_answer() || matches!(e, BusError::Corrupt { .. });
        let first_failure = match self.read_block_once(ids, address, length) {
            Ok(blocks) => return Ok(blocks),
            Err(e) if retried(&e) => e,
            Err(e) => return Err(e),
        };
        for _ in 0..self.read_retries {
            if self.cut_off() {
                break;
            }
            match self.read_block_once(ids, address, length) {
                Ok(blocks) => return Ok(blocks),
                Err(e) if retried(&e) => {}
                Err(e) => return Err(e),
            }
        }
        Err(first_failure)
    }

    /// One attempt of [`Self::read_block`]. Each read asks for `length` bytes and as many more
    /// as [`Self::extra_bytes`] says, so that its answers are told from late ones; the blocks
    /// returned hold the `length` bytes asked for.
    fn read_block_once(
        &mut self,
        ids: &[u8],
        address: u16,
        length: u16,
    ) -> Result<Vec<Vec<u8>>, BusError> {
        let block = |packet: Packet, asked: u16| {
            if packet.params.len() == usize::from(asked) {
                let mut data = packet.params;
                data.truncate(usize::from(length));
                Ok(data)
            } else {
                Err(BusError::corrupt(
                    packet.id,
                    CorruptAnswer::DataLength {
                        expected: usize::from(asked),
                        found: packet.params.len(),
                    },
                ))
            }
        };
        let mut blocks = Vec::with_capacity(ids.len());
        let Some(sync_read) = self.instructions().sync_read else {
            let read = self.instructions().read;
            for &id in ids {
                let asked =
                    length + self.extra_bytes(&[id], |extra| usize::from(length) + extra)?;
                let params = self.codec.fields().read(address, asked);
                let params = params.map_err(|e| self.protocol_error(e))?;
                self.send(id, read, &params)?;
                self.in_flight
                    .sent(&[id], usize::from(asked), Instant::now());
                let packet = self.receive_answer(id, Some(usize::from(asked)))?;
                self.check_status(&packet)?;
                blocks.push(block(packet, asked)?);
            }
            return Ok(blocks);
        };
        if self.fast_sync_read && self.codec.fast_sync_read().is_some() {
            return self.fast_sync_read_once(ids, address, length);
        }
        let asked = length + self.extra_bytes(ids, |extra| usize::from(length) + extra)?;
        let params = self.codec.fields().sync_read(address, asked, ids);
        let params = params.map_err(|e| self.protocol_error(e))?;
        let broadcast = self.codec.framing().broadcast_id();
        self.send(broadcast, sync_read, &params)?;
        self.in_flight.sent(ids, usize::from(asked), Instant::now());
        // Each servo answers with its own status packet, in list order.
        let mut first_error = None;
        for &id in ids {
            let packet = self.receive_answer(id, Some(usize::from(asked)))?;
            if let Err(e) = self.check_status_passive(&packet) {
                first_error.get_or_insert(e);
            }
            blocks.push(block(packet, asked)?);
        }
        match first_error {
            Some(e) => Err(self.resolve_alarm(e)),
            None => Ok(blocks),
        }
    }

    /// Dynamixel Fast Sync Read: one answer from the broadcast id carrying every servo's block.
    fn fast_sync_read_once(
        &mut self,
        ids: &[u8],
        address: u16,
        length: u16,
    ) -> Result<Vec<Vec<u8>>, BusError> {
        let broadcast = self.codec.framing().broadcast_id();
        let Some(fast) = self.codec.fast_sync_read() else {
            return Err(self.no_instruction("the protocol has no fast sync read"));
        };
        // One combined answer: `ERR ID DATA CRC` per servo on the wire, less the first ERR and
        // the last CRC in the decoded packet (see `parse_fast_sync_read`).
        let answer_bytes = |data: usize| (ids.len() * (data + 4)).saturating_sub(3);
        let asked = length
            + self.extra_bytes(&[broadcast], |extra| {
                answer_bytes(usize::from(length) + extra)
            })?;
        let params = self.codec.fields().sync_read(address, asked, ids);
        let params = params.map_err(|e| self.protocol_error(e))?;
        self.send(broadcast, fast.instruction(), &params)?;
        let expected = answer_bytes(usize::from(asked));
        self.in_flight.sent(&[broadcast], expected, Instant::now());
        let packet = self.receive_answer(broadcast, Some(expected))?;
        let mut entries = fast
            .parse(&packet, asked)
            .map_err(|e| e.corrupt_answer(ids.first().copied().unwrap_or(broadcast)))?;
        for entry in &mut entries {
            entry.data.truncate(usize::from(length));
        }
        // The split into blocks depends only on the length asked for, so check that the ids
        // that came back are the ones asked for, in order.
        let got: Vec<u8> = entries.iter().map(|e| e.id).collect();
        if got != ids {
            let missing = ids.iter().find(|id| !got.contains(id)).copied();
            let source = CorruptAnswer::Ids {
                expected: ids.to_vec(),
                found: got,
            };
            return Err(BusError::corrupt(missing.unwrap_or(broadcast), source));
        }
        let mut first_error = None;
        let mut blocks = Vec::with_capacity(entries.len());
        for entry in entries {
            let status = Packet::status(entry.id, entry.error, Vec::new());
            if let Err(e) = self.check_status_passive(&status) {
                first_error.get_or_insert(e);
            }
            blocks.push(entry.data);
        }
        match first_error {
            Some(e) => Err(self.resolve_alarm(e)),
            None => Ok(blocks),
        }
    }

    /// A write whose status answer did not come is confirmed by reading the register back.
    /// The answer can be lost on the line, or reach keypose after the timeout although the
    /// servo answered at once: on a loaded machine the kernel hands a serial port's input
    /// (a USB adapter's as a pseudo-terminal's) to the reader from a worker thread of
    /// ordinary priority, measured up to 120 ms late beside busy processes. The read is
    /// retried and tells its answer from late ones by its length ([`InFlight`]); when it too
    /// fails, or the register does not hold `value`, the write's own error stands.
    fn confirm_by_reading(
        &mut self,
        id: u8,
        register: Register,
        table: &'static RegisterTable,
        value: i64,
        lost: BusError,
    ) -> Result<(), BusError> {
        match self.read_register_values(&[id], register, table) {
            Ok(read) if read == [value] => Ok(()),
            _ => Err(lost),
        }
    }

    /// Dynamixel REBOOT: the only way to clear a hardware-error shutdown (ROBOTIS e-Manual,
    /// X series Shutdown register).
    /// The servo comes back with torque off.
    pub fn reboot(&mut self, id: u8) -> Result<(), BusError> {
        let Some(reboot) = self.instructions().reboot else {
            return Err(self.no_instruction("REBOOT is a Dynamixel instruction"));
        };
        self.send(id, reboot, &[])?;
        let packet = self.receive(id)?;
        match self.codec.status(packet.error().unwrap_or(0)) {
            Status::Refused(reason) => Err(BusError::Refused { id, reason }),
            _ => Ok(()),
        }
    }

    /// Like [`Self::check_status`] without any bus traffic (inside a sync read, where other
    /// answers are still arriving); a Dynamixel alert is resolved afterwards.
    fn check_status_passive(&self, packet: &Packet) -> Result<(), BusError> {
        let id = packet.id;
        match self.codec.status(packet.error().unwrap_or(0)) {
            Status::Done => Ok(()),
            Status::Refused(reason) => Err(BusError::Refused { id, reason }),
            Status::Alarms(alarms) => Err(BusError::Alarm { id, alarms }),
            // Named by `resolve_alarm` once the bus is free for a register read.
            Status::Alert => Err(BusError::Alarm {
                id,
                alarms: Alarms::default(),
            }),
        }
    }

    /// Fills in which alarm an alert stands for, once the sync read is over.
    fn resolve_alarm(&mut self, error: BusError) -> BusError {
        match error {
            BusError::Alarm { id, alarms } if !alarms.any() => match self.read_alarm_register(id) {
                Ok(alarms) if alarms.any() => BusError::Alarm { id, alarms },
                _ => BusError::Alarm {
                    id,
                    alarms: Alarms {
                        overload: true,
                        ..Alarms::default()
                    },
                },
            },
            other => other,
        }
    }

    /// One register of every servo in `ids` (the same in all their tables), as values; `pick`
    /// as in [`Servos::common_register`].
    fn read_values(
        &mut self,
        ids: &[u8],
        pick: impl Fn(&RegisterTable) -> Result<Register, &'static str>,
    ) -> Result<Vec<i64>, BusError> {
        let (register, table) = self.servos.common_register(ids, pick)?;
        self.read_register_values(ids, register, table)
    }

    fn read_register_values(
        &mut self,
        ids: &[u8],
        register: Register,
        table: &'static RegisterTable,
    ) -> Result<Vec<i64>, BusError> {
        let blocks = self.read_block(ids, register.address, u16::from(register.size))?;
        ids.iter()
            .zip(blocks)
            .map(|(&id, bytes)| table.decode_answer(id, &register, &bytes))
            .collect()
    }

    /// Writes one value per servo into one register with a single sync write (no answer);
    /// `pick` as in [`Servos::common_register`].
    fn write_register(
        &mut self,
        values: &[(u8, i64)],
        pick: impl Fn(&RegisterTable) -> Result<Register, &'static str>,
    ) -> Result<(), BusError> {
        let ids: Vec<u8> = values.iter().map(|(id, _)| *id).collect();
        let (register, table) = self.servos.common_register(&ids, pick)?;
        self.write_register_values(values, register, table)
    }

    fn write_register_values(
        &mut self,
        values: &[(u8, i64)],
        register: Register,
        table: &'static RegisterTable,
    ) -> Result<(), BusError> {
        let data = values
            .iter()
            .map(|&(id, value)| {
                table
                    .encode(&register, value)
                    .map(|bytes| (id, bytes))
                    .map_err(|error| BusError::Unencodable { id, error })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let sync_write = self.instructions().sync_write;
        let params =
            self.codec
                .fields()
                .sync_write(register.address, u16::from(register.size), &data);
        let params = params.map_err(|e| self.protocol_error(e))?;
        let broadcast = self.codec.framing().broadcast_id();
        self.send(broadcast, sync_write, &params)
    }
}

impl ServoBus for NativeBus {
    fn describe(&self) -> String {
        format!(
            "{} on {}",
            self.codec.protocol().name(),
            self.transport.describe()
        )
    }

    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        let ping = self.instructions().ping;
        self.send(id, ping, &[])?;
        let copy_may_answer = self.codec.status_may_equal_instruction();
        let packet = self.collect_answer(id, None, copy_may_answer)?;
        // A servo in alarm still answers: the alarms go into the answer, not into an error.
        let alarms = match self.check_status(&packet) {
            Ok(()) => Alarms::default(),
            Err(BusError::Alarm { alarms, .. }) => alarms,
            Err(e) => return Err(e),
        };
        let answer = self.codec.ping_answer(&packet);
        if let Some(info) = answer.map_err(|e| e.corrupt_answer(id))? {
            return Ok(PingInfo { alarms, ..info });
        }
        // The ping answer carries no model: read the model number register (its answer
        // carries the same alarm bits, already taken from the ping's).
        let register = self.codec.model_number_register();
        let packet = self.read_register(id, register)?;
        let model_number = register
            .decode(&packet.params, self.codec.byte_order())
            .map_err(|e| BusError::corrupt(id, e))? as u16;
        Ok(PingInfo {
            id,
            model_number,
            firmware: None,
            alarms,
        })
    }

    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        self.read_values(ids, |t| Ok(t.present_position))
    }

    /// One block from the first of the two registers to the end of the other: 6 bytes a servo
    /// on the STS3215 (56…61), 10 on the X series (126…135).
    fn read_positions_loads(&mut self, ids: &[u8]) -> Result<Vec<PositionLoad>, BusError> {
        let (position, _) = self
            .servos
            .common_register(ids, |t| Ok(t.present_position))?;
        let (load, _) = self.servos.common_register(ids, |t| Ok(t.present_load))?;
        let Some((start, length)) = span(&[position, load]) else {
            return Err(BusError::NoServos);
        };
        let blocks = self.read_block(ids, start, length)?;
        ids.iter()
            .zip(&blocks)
            .map(|(&id, block)| {
                // Each model its own load unit: a Koch's XL430 reads load, its XL330s current.
                let table = self.table(id)?;
                let decode = |register: Register| {
                    register
                        .decode_in_block(block, start, table.byte_order)
                        .map_err(|e| BusError::corrupt(id, e))
                };
                Ok(PositionLoad {
                    position: decode(position)?,
                    load_percent: Some(table.load_percent(decode(load)?)),
                })
            })
            .collect()
    }

    fn set_read_cutoff(&mut self, cutoff: Arc<ReadCutoff>) {
        self.read_cutoff = Some(cutoff);
    }

    fn pace(&mut self, period: Option<Duration>) {
        self.paced = period.is_some();
    }

    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        self.write_register(goals, |t| Ok(t.goal_position))
    }

    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        let ids: Vec<u8> = servos.iter().map(|(id, _)| *id).collect();
        self.read_values(&ids, |t| t.homing_offset.ok_or(homing::REGISTER))
    }

    fn read_setting(&mut self, ids: &[u8], setting: Setting) -> Result<Vec<i64>, BusError> {
        self.read_values(ids, |t| setting.register(t).ok_or(setting.name()))
    }

    fn write_setting(&mut self, values: &[(u8, i64)], setting: Setting) -> Result<(), BusError> {
        let ids: Vec<u8> = values.iter().map(|(id, _)| *id).collect();
        let pick = |t: &RegisterTable| setting.register(t).ok_or(setting.name());
        self.write_register(values, pick)?;
        let read = self.read_values(&ids, pick)?;
        match values
            .iter()
            .zip(&read)
            .find(|((_, want), got)| want != *got)
        {
            Some((&(id, expected), &found)) => Err(BusError::RegisterMismatch {
                id,
                register: setting.name(),
                expected,
                found,
            }),
            None => Ok(()),
        }
    }

    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        // One confirmed write per servo: torque is the one setting whose loss drops the arm or
        // leaves it stiff, so each servo must say it took it.
        let write = self.instructions().write;
        for &id in ids {
            let table = self.table(id)?;
            let register = table.torque_enable;
            let data = table
                .encode(&register, i64::from(on))
                .map_err(|error| BusError::Unencodable { id, error })?;
            let params = self.codec.fields().write(register.address, &data);
            let params = params.map_err(|e| self.protocol_error(e))?;
            match self.transaction(id, write, &params, None) {
                Ok(_) => {}
                Err(lost) if lost.is_no_answer() => {
                    self.confirm_by_reading(id, register, table, i64::from(on), lost)?
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        let first = *ids.first().ok_or(BusError::NoServos)?;
        let table = self.table(first)?;
        let registers = table.health_registers();
        // Dynamixel keeps its alarm register (70) far from the others (126…146): two reads
        // are shorter on the wire than one spanning both.
        let groups: Vec<Vec<Register>> = match span(&registers) {
            Some((_, length)) if length > 32 => {
                let (alarm, rest): (Vec<Register>, Vec<Register>) = registers
                    .iter()
                    .partition(|r| r.address == table.hardware_error.address);
                vec![rest, alarm]
            }
            _ => vec![registers.clone()],
        };
        let mut values: Vec<HashMap<&'static str, i64>> = vec![HashMap::new(); ids.len()];
        for group in &groups {
            let Some((start, length)) = span(group) else {
                continue;
            };
            let blocks = self.read_block(ids, start, length)?;
            for ((slot, block), &id) in values.iter_mut().zip(&blocks).zip(ids) {
                for register in group {
                    let value = register
                        .decode_in_block(block, start, table.byte_order)
                        .map_err(|e| BusError::corrupt(id, e))?;
                    slot.insert(register.name, value);
                }
            }
        }
        ids.iter()
            .zip(values)
            .map(|(&id, v)| {
                // Same addresses, but each model its own units (a Koch's XL430 reads load,
                // its XL330s current).
                let table = self.table(id)?;
                let get = |r: Register| v.get(r.name).copied().unwrap_or(0);
                Ok(Health {
                    id,
                    temperature_c: table.temperature_c(get(table.present_temperature)),
                    voltage_v: table.voltage_v(get(table.present_voltage)),
                    load_percent: table.load_percent(get(table.present_load)),
                    current_a: table.current_a(
                        get(table.present_load),
                        table.present_current.map(|(register, _)| get(register)),
                    ),
                    alarms: table.alarms(get(table.hardware_error) as u8),
                })
            })
            .collect()
    }
}

/// What a wait for one servo's answer met that was not the answer.
#[derive(Default)]
struct Seen {
    /// A packet that did not decode.
    corrupt: Option<PacketError>,
    /// The data length of an errorless answer of the wrong length (an earlier request's).
    stale: Option<usize>,
    /// How late the latest answer to an earlier request came.
    late: Option<Duration>,
    /// The servo's answer as the echo of our own line (a looped-back adapter), taken as the
    /// answer only if nothing else came.
    own_copy: Option<Packet>,
}

/// How a wait ended without the answer.
struct Silence {
    /// How long it waited, ms.
    timeout_ms: u64,
    /// How long the thread overslept its first deadline, when it did.
    starved: Option<Duration>,
    /// Whether the read cutoff ended it.
    cut: bool,
}

impl Seen {
    /// Nothing corrupt or stale came.
    fn clean(&self) -> bool {
        self.corrupt.is_none() && self.stale.is_none()
    }

    /// The error of a wait for servo `id` that ended in `silence`: what came instead, else
    /// the silence itself.
    fn into_error(self, id: u8, data_bytes: Option<usize>, silence: Silence) -> BusError {
        let Silence {
            timeout_ms,
            starved,
            cut,
        } = silence;
        match (self.corrupt, self.late, self.stale, data_bytes) {
            (Some(e), _, _, _) => BusError::corrupt(id, e),
            (None, Some(late), _, _) => BusError::Stale {
                id,
                timeout_ms,
                late_ms: late.as_millis() as u64,
            },
            (None, None, Some(found), Some(expected)) => {
                BusError::corrupt(id, CorruptAnswer::DataLength { expected, found })
            }
            _ => match starved {
                Some(asleep) => BusError::Starved {
                    id,
                    timeout_ms,
                    starved_ms: asleep.as_millis() as u64,
                },
                None if cut => BusError::CutShort {
                    id,
                    waited_ms: timeout_ms,
                },
                None => BusError::Timeout { id, timeout_ms },
            },
        }
    }
}

#[cfg(test)]
mod tests;
