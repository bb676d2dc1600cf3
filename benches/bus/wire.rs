//! The wire-time budget of one bus cycle (docs/protocols.md §3, "Wire-time budget (6 servos,
//! 8N1 = 10 bits per byte)"): what the fastest possible driver would take, against which each
//! driver's cycles are measured. No byte stuffing, no firmware time, no USB latency; the return
//! delay time (RDT) is paid once per answering servo.

use keypose::robot::{Protocol, Robot};
use keypose::testing::WireTiming;

pub const SERVOS: usize = 6;

/// Packet sizes in bytes for a 6-servo sync write + sync read of positions (§3 table).
pub struct Traffic {
    pub name: &'static str,
    pub sync_write: usize,
    pub sync_read_instruction: usize,
    pub status_each: usize,
    /// The robot's baud rate.
    pub wire: WireTiming,
}

impl Traffic {
    pub fn of(robot: &Robot) -> Traffic {
        let wire = WireTiming::at(robot.bus.baud);
        match robot.bus.protocol {
            Protocol::Dynamixel2 => Traffic {
                name: "DXL",
                // Sync Write, Goal Position (4 B) ×6: 8 + 4 + 6·5 + 2 = 44.
                sync_write: 8 + 4 + SERVOS * 5 + 2,
                // Sync Read instruction, 6 IDs: 8 + 4 + 6 + 2 = 20.
                sync_read_instruction: 8 + 4 + SERVOS + 2,
                // Status packet with 4 data bytes: 15 (×6 = 90).
                status_each: 15,
                wire,
            },
            _ => Traffic {
                name: "STS",
                // Sync Write, Goal Position (2 B) ×6: 2+1+1+1+2 + 6·3 + 1 = 26.
                sync_write: 2 + 1 + 1 + 1 + 2 + SERVOS * 3 + 1,
                // Sync Read instruction, 6 IDs: 2+1+1+1+2 + 6 + 1 = 14.
                sync_read_instruction: 2 + 1 + 1 + 1 + 2 + SERVOS + 1,
                // Status packet with 2 data bytes: 8 (×6 = 48).
                status_each: 8,
                wire,
            },
        }
    }

    pub fn bytes(&self) -> usize {
        self.sync_write + self.sync_read_instruction + SERVOS * self.status_each
    }

    /// Wire time of one cycle, seconds, with the return delay `rdt` per servo.
    pub fn cycle_seconds(&self, rdt: f64) -> f64 {
        self.wire.bytes_time(self.bytes()).as_secs_f64() + SERVOS as f64 * rdt
    }

    /// The most cycles per second the wire allows (§3: DXL ≤ 650 Hz at RDT 0, ≤ 220 Hz at
    /// RDT 500 µs; STS ≤ 1140 Hz at RDT 0 — §3 rounds to 2–3 digits).
    pub fn limit_hz(&self, rdt: f64) -> f64 {
        1.0 / self.cycle_seconds(rdt)
    }
}

/// The return delay the emulated servos of `robot` apply (the same for all, seconds).
pub fn virtual_return_delay(robot: &Robot) -> f64 {
    let servos = keypose::testing::VirtualServos::for_robot(robot);
    let first = robot.joints[0].servo.id;
    servos.return_delay(first).map_or(0.0, |d| d.as_secs_f64())
}
