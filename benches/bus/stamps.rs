//! Timing at the write: keypose's own serial transport, wrapped so that the instant each goal
//! write returned from `write()` is recorded, and the player's clock, wrapped so that its cycle
//! starts can be found beside those instants.
//!
//! The player measures its lateness when a cycle starts, and a cell measures how far apart its
//! buses' goal writes were at the start gate, before the packets are encoded and written. What
//! the servos feel is the write itself, some microseconds later, and later still when the thread
//! is preempted in between; so the benchmark stamps the write. The stamp is taken right after
//! keypose's `SerialTransport::write_all` returns: `write()` of the packet and the `tcdrain()`
//! that follows it (which on a pseudo-terminal returns at once); the call's own duration is kept
//! too, to show how far the stamp is from the call's start.

use keypose::bus::transport::{SerialTransport, Transport};
use keypose::pacing::{Clock, WallClock};
use keypose::robot::{Protocol, Robot};
use keypose::stop::StopSignal;
use std::io;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Sync Write's instruction code, the same in Dynamixel Protocol 2.0 and Feetech's
/// (docs/protocols.md §1.4, §2.3).
const SYNC_WRITE: u8 = 0x83;

/// What happened, in order, on one bus's thread.
#[derive(Debug, Clone, Copy)]
pub enum Event {
    /// The player's clock was read; the value it returned.
    Now(Duration),
    /// A goal write: when the transport's write call began and when it returned.
    GoalWrite { called: Instant, returned: Instant },
}

/// A shared record of [`Event`]s.
pub type Log = Arc<Mutex<Vec<Event>>>;

/// Whether `packet` is a sync write to the goal position register at `goal` (the packet's
/// instruction and first parameter: docs/protocols.md §1.3 and §2.1 give the layouts).
fn is_goal_write(protocol: Protocol, goal: u16, packet: &[u8]) -> bool {
    match protocol {
        // FF FF FD 00 ID LEN_L LEN_H INST ADDR_L ADDR_H …
        Protocol::Dynamixel2 => {
            packet.len() > 9
                && packet[7] == SYNC_WRITE
                && u16::from_le_bytes([packet[8], packet[9]]) == goal
        }
        // FF FF ID LEN INST ADDR …
        _ => packet.len() > 5 && packet[4] == SYNC_WRITE && u16::from(packet[5]) == goal,
    }
}

/// keypose's serial transport, recording its goal writes in a [`Log`].
pub struct Stamped {
    inner: SerialTransport,
    protocol: Protocol,
    goal: u16,
    log: Log,
}

impl Stamped {
    /// Opens `path` for `robot`'s bus.
    pub fn open(robot: &Robot, path: &str, log: Log) -> Result<Stamped, String> {
        let inner = SerialTransport::open(path, robot.bus.baud).map_err(|e| e.to_string())?;
        Ok(Stamped {
            inner,
            protocol: robot.bus.protocol,
            goal: robot.joints[0]
                .servo
                .model
                .spec()
                .table
                .goal_position
                .address,
            log,
        })
    }
}

impl Transport for Stamped {
    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        let called = Instant::now();
        let result = self.inner.write_all(bytes);
        let returned = Instant::now();
        if result.is_ok() && is_goal_write(self.protocol, self.goal, bytes) {
            let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
            log.push(Event::GoalWrite { called, returned });
        }
        result
    }

    fn read_until(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize> {
        self.inner.read_until(buf, deadline)
    }

    fn discard_input(&mut self) -> io::Result<()> {
        self.inner.discard_input()
    }
}

/// The wall clock the player uses, recording every reading in a [`Log`].
pub struct RecordingClock {
    wall: WallClock,
    /// The instant the wall clock's time 0 stands for (to within the few tens of nanoseconds
    /// between two readings).
    epoch: Instant,
    log: Log,
}

impl RecordingClock {
    pub fn new(log: Log) -> RecordingClock {
        let wall = WallClock::new();
        let before = Instant::now();
        let reading = wall.now();
        let after = Instant::now();
        let epoch = before + (after - before) / 2 - reading;
        RecordingClock { wall, epoch, log }
    }

    /// Clock time (seconds) of `instant`.
    pub fn seconds_at(&self, instant: Instant) -> f64 {
        instant.duration_since(self.epoch).as_secs_f64()
    }
}

impl Clock for RecordingClock {
    fn now(&self) -> Duration {
        let now = self.wall.now();
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        log.push(Event::Now(now));
        now
    }

    fn sleep_until(&self, deadline: Duration, stop: &StopSignal, seen: u32) {
        self.wall.sleep_until(deadline, stop, seen);
    }
}

/// The goal writes of `log`, in order: (call began, call returned).
pub fn goal_writes(log: &Log) -> Vec<(Instant, Instant)> {
    let log = log.lock().unwrap_or_else(|p| p.into_inner());
    log.iter()
        .filter_map(|e| match *e {
            Event::GoalWrite { called, returned } => Some((called, returned)),
            Event::Now(_) => None,
        })
        .collect()
}
