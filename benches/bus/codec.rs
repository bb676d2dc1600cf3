//! Section 3: the software cost of one bus cycle without I/O — encoding a sync write of 6
//! goals and a sync read, decoding the 6 status packets — by keypose's native driver and by
//! `rustypot`, each over an in-memory port that hands it the same canned answers (encoded once,
//! up front, handed over as one chunk): no system call, no emulator, nearly nothing but the
//! drivers' own code. CPU time of the thread, interleaved runs.

use super::cycles::{rustypot_handler, rustypot_registers};
use crate::common::Spread;
use keypose::bus::ServoBus;
use keypose::robot::Robot;
use std::io;
use std::time::Duration;

/// Cycles per timed run.
const CYCLES: usize = 50_000;
/// Interleaved timed runs of each side: many short ones, as a shared (virtual) machine takes
/// the processor away now and then and a run it hit is an outlier the median passes over.
const REPS: usize = 21;

/// CPU time of this thread, seconds.
fn thread_cpu_seconds() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// The six status packets of a sync read of the present positions, every servo at 2048 ticks,
/// encoded by keypose's framing (the bytes the emulated servos send).
fn canned_answers(robot: &Robot) -> Result<Vec<u8>, String> {
    use keypose::bus::protocol::codec;
    let framing = codec(robot.bus.protocol).framing();
    let table = robot.joints[0].servo.model.spec().table;
    let mut answers = Vec::new();
    for j in &robot.joints {
        let data = table
            .encode(&table.present_position, 2048)
            .map_err(|e| e.to_string())?;
        let packet = framing
            .try_encode_status(j.servo.id, 0, &data)
            .map_err(|e| e.to_string())?;
        answers.extend(packet);
    }
    Ok(answers)
}

/// keypose's side: answers every second write (the sync read; the sync write before it gets
/// no answer) with the canned packets at once.
struct Canned {
    answers: Vec<u8>,
    writes: u64,
}

impl keypose::testing::Responder for Canned {
    fn respond(&mut self, _written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.writes += 1;
        if self.writes % 2 == 1 {
            return Vec::new();
        }
        vec![(Duration::ZERO, self.answers.clone())]
    }
}

/// rustypot's side: a serial port that answers every second write with the canned packets.
/// `bytes_to_read` says 0, so rustypot's flush before each instruction finds nothing to drop.
struct CannedPort {
    answers: Vec<u8>,
    writes: u64,
    to_read: io::Cursor<Vec<u8>>,
}

impl io::Read for CannedPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.to_read.read(buf)
    }
}

impl io::Write for CannedPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writes += 1;
        if self.writes % 2 == 0 {
            self.to_read = io::Cursor::new(self.answers.clone());
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// What rustypot's protocol code calls is answered; the rest is never called here.
impl serialport::SerialPort for CannedPort {
    fn name(&self) -> Option<String> {
        None
    }
    fn baud_rate(&self) -> serialport::Result<u32> {
        Ok(1_000_000)
    }
    fn data_bits(&self) -> serialport::Result<serialport::DataBits> {
        Ok(serialport::DataBits::Eight)
    }
    fn flow_control(&self) -> serialport::Result<serialport::FlowControl> {
        Ok(serialport::FlowControl::None)
    }
    fn parity(&self) -> serialport::Result<serialport::Parity> {
        Ok(serialport::Parity::None)
    }
    fn stop_bits(&self) -> serialport::Result<serialport::StopBits> {
        Ok(serialport::StopBits::One)
    }
    fn timeout(&self) -> Duration {
        Duration::from_millis(10)
    }
    fn set_baud_rate(&mut self, _: u32) -> serialport::Result<()> {
        Ok(())
    }
    fn set_data_bits(&mut self, _: serialport::DataBits) -> serialport::Result<()> {
        Ok(())
    }
    fn set_flow_control(&mut self, _: serialport::FlowControl) -> serialport::Result<()> {
        Ok(())
    }
    fn set_parity(&mut self, _: serialport::Parity) -> serialport::Result<()> {
        Ok(())
    }
    fn set_stop_bits(&mut self, _: serialport::StopBits) -> serialport::Result<()> {
        Ok(())
    }
    fn set_timeout(&mut self, _: Duration) -> serialport::Result<()> {
        Ok(())
    }
    fn write_request_to_send(&mut self, _: bool) -> serialport::Result<()> {
        Ok(())
    }
    fn write_data_terminal_ready(&mut self, _: bool) -> serialport::Result<()> {
        Ok(())
    }
    fn read_clear_to_send(&mut self) -> serialport::Result<bool> {
        Ok(true)
    }
    fn read_data_set_ready(&mut self) -> serialport::Result<bool> {
        Ok(true)
    }
    fn read_ring_indicator(&mut self) -> serialport::Result<bool> {
        Ok(false)
    }
    fn read_carrier_detect(&mut self) -> serialport::Result<bool> {
        Ok(true)
    }
    fn bytes_to_read(&self) -> serialport::Result<u32> {
        Ok(0)
    }
    fn bytes_to_write(&self) -> serialport::Result<u32> {
        Ok(0)
    }
    fn clear(&self, _: serialport::ClearBuffer) -> serialport::Result<()> {
        Ok(())
    }
    fn try_clone(&self) -> serialport::Result<Box<dyn serialport::SerialPort>> {
        Err(serialport::Error::new(
            serialport::ErrorKind::Unknown,
            "a canned port is not cloned",
        ))
    }
    fn set_break(&self) -> serialport::Result<()> {
        Ok(())
    }
    fn clear_break(&self) -> serialport::Result<()> {
        Ok(())
    }
}

/// keypose's and rustypot's CPU microseconds per cycle on `name`, each a [`Spread`] over the
/// interleaved runs, and their ratio run by run (keypose / rustypot).
pub struct CodecCost {
    pub keypose: Vec<f64>,
    pub rustypot: Vec<f64>,
}

impl CodecCost {
    pub fn ratio(&self) -> Spread {
        Spread::ratio(&self.keypose, &self.rustypot)
    }
}

/// CPU microseconds per call of `cycle`, over [`CYCLES`] calls.
fn per_cycle(cycle: &mut dyn FnMut() -> Result<(), String>) -> Result<f64, String> {
    let before = thread_cpu_seconds();
    for _ in 0..CYCLES {
        cycle()?;
    }
    Ok((thread_cpu_seconds() - before) / CYCLES as f64 * 1e6)
}

pub fn codec_cost(name: &str) -> Result<CodecCost, String> {
    let robot = Robot::builtin(name).ok_or_else(|| format!("no built-in robot {name}"))?;
    let answers = canned_answers(&robot)?;
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();

    let transport = keypose::testing::MemoryTransport::new(Canned {
        answers: answers.clone(),
        writes: 0,
    });
    let mut bus =
        keypose::bus::NativeBus::new(Box::new(transport), robot.bus.protocol, &robot.servos());
    let goals: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 2048)).collect();
    // Both decode the same answers to the same positions before anything is timed.
    bus.write_goals(&goals).map_err(|e| e.to_string())?;
    let ticks = bus.read_positions(&ids).map_err(|e| e.to_string())?;
    if ticks.iter().any(|&t| t != 2048) {
        return Err(format!("keypose decoded {ticks:?}, not 2048 each"));
    }
    let mut ours = || -> Result<(), String> {
        bus.write_goals(&goals).map_err(|e| e.to_string())?;
        let read = bus.read_positions(&ids).map_err(|e| e.to_string())?;
        std::hint::black_box(read);
        Ok(())
    };

    let (goal_address, present_address, size) = rustypot_registers(&robot)?;
    let io = rustypot_handler(&robot);
    let mut port = CannedPort {
        answers,
        writes: 0,
        to_read: io::Cursor::new(Vec::new()),
    };
    let table = robot.joints[0].servo.model.spec().table;
    let encoded = |register| table.encode(register, 2048).map_err(|e| e.to_string());
    let goal_bytes: Vec<Vec<u8>> = vec![encoded(&table.goal_position)?; ids.len()];
    io.sync_write(&mut port, &ids, goal_address, &goal_bytes)
        .map_err(|e| e.to_string())?;
    let raw = io
        .sync_read(&mut port, &ids, present_address, size)
        .map_err(|e| e.to_string())?;
    let present = encoded(&table.present_position)?;
    if raw.iter().any(|r| *r != present) {
        return Err(format!("rustypot read {raw:?}, not 2048 each"));
    }
    let mut theirs = || -> Result<(), String> {
        io.sync_write(&mut port, &ids, goal_address, &goal_bytes)
            .map_err(|e| e.to_string())?;
        let read = io
            .sync_read(&mut port, &ids, present_address, size)
            .map_err(|e| e.to_string())?;
        std::hint::black_box(read);
        Ok(())
    };

    for _ in 0..2000 {
        ours()?;
        theirs()?;
    }
    let (mut keypose, mut rustypot) = (Vec::new(), Vec::new());
    for _ in 0..REPS {
        keypose.push(per_cycle(&mut ours)?);
        rustypot.push(per_cycle(&mut theirs)?);
    }
    Ok(CodecCost { keypose, rustypot })
}
