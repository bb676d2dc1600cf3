//! The native driver against the emulated servos of a built-in robot through a proxy that the
//! fuzzer controls: it drops, corrupts, truncates, pads, duplicates and echoes answers, splits
//! them into arbitrary reads, keeps stale bytes past a discard, or loses the port. The fuzzer
//! also picks the driver calls.
//! Property: the driver never panics or hangs (the proxy never blocks: an empty read is the
//! deadline passing), errors are typed, and every position or homing offset it reports decodes
//! from the data of a well-formed status packet of that servo among the bytes it was given.
#![no_main]

use keypose::bus::protocol::packet::{Decoded, Direction, Framing};
use keypose::bus::protocol::{codec, Codec};
use keypose::bus::transport::Transport;
use keypose::bus::DecodeAnswer;
use keypose::bus::NativeBus;
use keypose::bus::ServoBus;
use keypose::robot::Robot;
use keypose::servo::{Register, RegisterTable};
use keypose::testing::VirtualServos;
use keypose_fuzz::builtin_robot;
use libfuzzer_sys::fuzz_target;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The fuzzer's bytes, shared by the scenario and the proxy (0 once they run out).
struct Script {
    data: Vec<u8>,
    at: usize,
}

impl Script {
    fn byte(&mut self) -> u8 {
        let b = self.data.get(self.at).copied().unwrap_or(0);
        self.at += 1;
        b
    }

    fn done(&self) -> bool {
        self.at >= self.data.len()
    }
}

struct Shared {
    script: Script,
    servos: VirtualServos,
    /// Answer bytes not yet read.
    pending: Vec<u8>,
    /// Every byte the driver has read during the current call.
    delivered: Vec<u8>,
}

struct Proxy(Arc<Mutex<Shared>>);

impl Proxy {
    fn shared(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.0.lock().unwrap()
    }
}

/// One answer chunk as the fuzzer has it reach the driver.
fn mangle(script: &mut Script, mut answer: Vec<u8>) -> Vec<u8> {
    match script.byte() % 8 {
        0..=2 => answer,
        3 => Vec::new(),
        4 => {
            let at = usize::from(script.byte()) % answer.len().max(1);
            if let Some(b) = answer.get_mut(at) {
                *b ^= script.byte() | 1;
            }
            answer
        }
        5 => {
            answer.truncate(usize::from(script.byte()) % answer.len().max(1));
            answer
        }
        6 => {
            let n = script.byte() % 16;
            let mut out: Vec<u8> = (0..n).map(|_| script.byte()).collect();
            out.extend(answer);
            out
        }
        _ => [answer.clone(), answer].concat(),
    }
}

impl Transport for Proxy {
    fn describe(&self) -> String {
        "fuzzing proxy".into()
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut shared = self.shared();
        let shared = &mut *shared;
        match shared.script.byte() {
            0xFF => return Err(io::Error::new(io::ErrorKind::BrokenPipe, "port lost")),
            // A half-duplex adapter that loops the line back.
            b if b & 0x80 != 0 => shared.pending.extend_from_slice(bytes),
            _ => {}
        }
        for (_, answer) in shared.servos.handle(bytes) {
            let mangled = mangle(&mut shared.script, answer);
            shared.pending.extend(mangled);
        }
        Ok(())
    }

    fn read_until(&mut self, buf: &mut [u8], _deadline: Instant) -> io::Result<usize> {
        let mut shared = self.shared();
        if shared.pending.is_empty() {
            return Ok(0);
        }
        let wanted = 1 + usize::from(shared.script.byte()) * 4;
        let n = wanted.min(buf.len()).min(shared.pending.len());
        let chunk: Vec<u8> = shared.pending.drain(..n).collect();
        buf[..n].copy_from_slice(&chunk);
        shared.delivered.extend(chunk);
        Ok(n)
    }

    fn discard_input(&mut self) -> io::Result<()> {
        let mut shared = self.shared();
        // One time in four, bytes still in flight survive the discard.
        if !shared.script.byte().is_multiple_of(4) {
            shared.pending.clear();
        }
        Ok(())
    }
}

/// The most bytes beyond its register a read may ask for: the driver asks for a few more while
/// an earlier read of the same servo is unanswered, so that the answers tell their requests
/// apart (`bus::driver::in_flight`); this bound is generous on purpose.
const MOST_EXTRA_BYTES: u16 = 8;

/// (id, data) of every well-formed status packet that starts anywhere in `bytes`, and of every
/// servo's block in a Fast Sync Read answer among them (split for each length the read may
/// have asked for): all the driver could have taken values from.
fn well_formed(codec: &dyn Codec, bytes: &[u8], length: u16) -> Vec<(u8, Vec<u8>)> {
    let framing: &dyn Framing = codec.framing();
    let mut found = Vec::new();
    for start in 0..bytes.len() {
        let mut rest = bytes[start..].to_vec();
        let Ok(Decoded::Packet(packet)) = framing.decode(&mut rest, Direction::FromServo) else {
            continue;
        };
        if let Some(fast) = codec.fast_sync_read() {
            for asked in length..=length + MOST_EXTRA_BYTES {
                if let Ok(entries) = fast.parse(&packet, asked) {
                    found.extend(entries.into_iter().map(|e| (e.id, e.data)));
                }
            }
        }
        found.push((packet.id, packet.params));
    }
    found
}

fn check_values(
    shared: &Arc<Mutex<Shared>>,
    robot: &Robot,
    codec: &dyn Codec,
    ids: &[u8],
    values: &[i64],
    pick: fn(&RegisterTable) -> Register,
) {
    assert_eq!(values.len(), ids.len());
    let delivered = std::mem::take(&mut shared.lock().unwrap().delivered);
    for (&id, &value) in ids.iter().zip(values) {
        let joint = robot.joints.iter().find(|j| j.servo.id == id).unwrap();
        let table = joint.servo.model.spec().table;
        let register = pick(table);
        let candidates = well_formed(codec, &delivered, u16::from(register.size));
        let size = usize::from(register.size);
        let decodes_to_value = |data: &[u8]| {
            (size..=size + usize::from(MOST_EXTRA_BYTES)).contains(&data.len())
                && table.decode_answer(id, &register, &data[..size]).ok() == Some(value)
        };
        assert!(
            candidates
                .iter()
                .any(|(from, data)| *from == id && decodes_to_value(data)),
            "servo {id}: {value} is in no well-formed answer among {delivered:02x?}"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    let robot = builtin_robot(selector);
    let shared = Arc::new(Mutex::new(Shared {
        script: Script {
            data: rest.to_vec(),
            at: 0,
        },
        servos: VirtualServos::for_robot(robot),
        pending: Vec::new(),
        delivered: Vec::new(),
    }));
    let codec = codec(robot.bus.protocol);
    let servos = robot.servos();
    let mut bus = NativeBus::new(Box::new(Proxy(shared.clone())), robot.bus.protocol, &servos);
    // The proxy never blocks, so a wait for late answers is spent polling it until the timeout
    // passes: short timeouts keep a run fast, and nothing here depends on their length.
    bus.timeout = std::time::Duration::from_millis(2);
    bus.setup_timeout = std::time::Duration::from_millis(2);
    let all: Vec<u8> = servos.iter().map(|(id, _)| *id).collect();
    for _ in 0..16 {
        let (op, arg) = {
            let mut s = shared.lock().unwrap();
            if s.script.done() {
                break;
            }
            s.delivered.clear();
            (s.script.byte(), s.script.byte())
        };
        let some: Vec<u8> = all
            .iter()
            .enumerate()
            .filter(|(i, _)| arg & (1 << i) != 0)
            .map(|(_, &id)| id)
            .collect();
        let ids = if some.is_empty() { all.clone() } else { some };
        match op % 8 {
            0 => {
                let _ = bus.ping(arg);
            }
            1 => {
                if let Ok(values) = bus.read_positions(&ids) {
                    check_values(&shared, robot, codec, &ids, &values, |t| t.present_position);
                }
            }
            2 => {
                let goals: Vec<(u8, i64)> =
                    ids.iter().map(|&id| (id, i64::from(arg) * 16)).collect();
                let _ = bus.write_goals(&goals);
            }
            3 => {
                let _ = bus.set_torque(&ids, arg & 1 == 1);
            }
            4 => {
                let _ = bus.read_health(&ids);
            }
            5 => {
                let models: Vec<_> = servos
                    .iter()
                    .filter(|(id, _)| ids.contains(id))
                    .copied()
                    .collect();
                if let Ok(values) = bus.read_homing_offsets(&models) {
                    check_values(&shared, robot, codec, &ids, &values, |t| {
                        t.homing_offset
                            .expect("the built-in robots' servos have Homing_Offset")
                    });
                }
            }
            6 => {
                let _ = bus.reboot(ids[0]);
            }
            _ => bus.fast_sync_read = !bus.fast_sync_read,
        }
    }
});
