//! The time a real bus takes, for the virtual bus to take it too: bytes at the baud rate
//! (8N1, 10 bits a byte), each servo's return delay, and the USB adapter's latency.
//!
//! The bus is half duplex: one packet at a time. An instruction's last byte arrives
//! [`WireTiming::bytes_time`] after its first could start (when the line is free); each
//! answering servo waits its return delay after the line falls quiet, then sends its status
//! packet, which takes its own bytes' time; the host sees an answer once its last byte is in
//! and the adapter has passed it on (its latency timer: FTDI's default 16 ms, 1 ms tuned).
//! docs/protocols.md §3 describes the model and its sources.

use std::ops::Range;
use std::time::{Duration, Instant};

/// 8N1 framing: a start bit, 8 data bits, a stop bit.
pub const BITS_PER_BYTE: u64 = 10;

/// How the virtual bus times the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireTiming {
    /// Bits per second.
    pub baud: u32,
    /// Added to every answer before the host can read it: the USB adapter's latency.
    pub usb_latency: Duration,
}

impl WireTiming {
    /// The wire at `baud`, with no adapter latency.
    pub fn at(baud: u32) -> WireTiming {
        WireTiming {
            baud,
            usb_latency: Duration::ZERO,
        }
    }

    /// How long `bytes` take on the line.
    pub fn bytes_time(&self, bytes: usize) -> Duration {
        let bits = bytes as u128 * u128::from(BITS_PER_BYTE);
        let nanos = bits * 1_000_000_000 / u128::from(self.baud.max(1));
        Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
    }
}

/// One status packet as the virtual servos produced it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Answer {
    /// The servo's return delay (zero for a servo that has none).
    pub return_delay: Duration,
    /// An injected late-answer fault on top of it.
    pub extra_delay: Duration,
    pub bytes: Vec<u8>,
}

/// One instruction packet taken off the line and the answers it drew.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exchange {
    /// Bytes the instruction took on the line (with any garbage decoded before it).
    pub request_bytes: usize,
    pub answers: Vec<Answer>,
}

/// The line's state over time: when it falls quiet.
#[derive(Debug, Clone)]
pub struct Wire {
    timing: WireTiming,
    quiet_at: Option<Instant>,
}

impl Wire {
    pub fn new(timing: WireTiming) -> Wire {
        Wire {
            timing,
            quiet_at: None,
        }
    }

    /// Schedules `exchange`, whose instruction the host handed over at `written_at`: returns
    /// the instants at which each answer becomes readable to the host, in order.
    pub fn schedule(&mut self, written_at: Instant, exchange: &Exchange) -> Vec<Instant> {
        let start = self.quiet_at.map_or(written_at, |q| q.max(written_at));
        let mut line = start + self.timing.bytes_time(exchange.request_bytes);
        let mut readable = Vec::with_capacity(exchange.answers.len());
        for answer in &exchange.answers {
            line += answer.return_delay + answer.extra_delay;
            line += self.timing.bytes_time(answer.bytes.len());
            readable.push(line + self.timing.usb_latency);
        }
        self.quiet_at = Some(line);
        readable
    }
}

/// The longest an answer is held past the instant the wire delivers it, to reach the host
/// together with the answers after it: what a USB adapter whose latency timer is tuned to 1 ms
/// (the udev rule keypose recommends) may hold bytes for. See [`deliveries`].
pub const HOLD: Duration = Duration::from_millis(1);

/// Answers of one exchange handed to the host together, in one write.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Delivery {
    /// Which of the exchange's answers, in order.
    pub answers: Range<usize>,
    /// When they become readable: the wire's instant for the last of them.
    pub at: Instant,
}

/// Groups the answers of an exchange, readable at `readable` (what [`Wire::schedule`] gave),
/// into as few deliveries as holding none more than `hold` past its instant allows. Each
/// delivery comes at its last answer's instant, so no answer is readable before the wire
/// delivers it, the last of a run exactly then, and the order is the wire's. An answer an
/// injected fault makes late starts a delivery of its own: the answers before it are not
/// held for it.
///
/// Every delivery costs the emulator a wake-up (a sleep, a context switch, a write), which
/// is what a server answering each status packet at its own instant spends most of its time
/// on; a sync read's answers follow each other on the line within a few hundred
/// microseconds, so they mostly go in one.
pub fn deliveries(answers: &[Answer], readable: &[Instant], hold: Duration) -> Vec<Delivery> {
    let mut out: Vec<Delivery> = Vec::new();
    for (k, (answer, &at)) in answers.iter().zip(readable).enumerate() {
        let joins = out.last().is_some_and(|last| {
            let first_at = readable[last.answers.start];
            answer.extra_delay.is_zero() && at.saturating_duration_since(first_at) <= hold
        });
        match out.last_mut() {
            Some(last) if joins => {
                last.answers.end = k + 1;
                last.at = at;
            }
            _ => out.push(Delivery {
                answers: k..k + 1,
                at,
            }),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn answers(n: usize, bytes: usize, return_delay: Duration) -> Vec<Answer> {
        (0..n)
            .map(|_| Answer {
                return_delay,
                extra_delay: Duration::ZERO,
                bytes: vec![0; bytes],
            })
            .collect()
    }

    #[test]
    fn a_six_servo_sts_cycle_takes_880_microseconds_at_1_mbps() {
        // Feetech STS packets (docs/protocols.md §3): header FF FF, id, length, instruction.
        // Sync write of 2-byte goal positions to 6 servos: 2+1+1+1 + address + data length
        // + 6·(id + 2 bytes) + checksum = 7 + 18 + 1 = 26 bytes.
        // Sync read of 2 bytes from 6 servos: 7 + 6 ids + checksum = 14 bytes.
        // Each status packet: FF FF id length error + 2 data bytes + checksum = 8 bytes.
        // 26 + 14 + 6·8 = 88 bytes · 10 bits = 880 bits at 1 Mbit/s = 880 µs; STS3215 has no
        // return delay (the register has no function on STS).
        let mut wire = Wire::new(WireTiming::at(1_000_000));
        let t0 = Instant::now();
        let write = Exchange {
            request_bytes: 26,
            answers: Vec::new(),
        };
        assert!(wire.schedule(t0, &write).is_empty());
        let read = Exchange {
            request_bytes: 14,
            answers: answers(6, 8, Duration::ZERO),
        };
        let readable = wire.schedule(t0, &read);
        // The first answer: 26 + 14 + 8 = 48 bytes in; the last, all 88.
        assert_eq!(readable[0] - t0, Duration::from_micros(480));
        assert_eq!(readable[5] - t0, Duration::from_micros(880));
    }

    #[test]
    fn each_dynamixel_answer_waits_its_return_delay_and_the_adapter_adds_its_latency() {
        // Dynamixel X factory Return_Delay_Time 250 × 2 µs = 500 µs. A read of 4 bytes from one
        // servo: instruction 14 bytes (FF FF FD 00 id len len 02 addr addr len len crc crc),
        // status 15 (FF FF FD 00 id len len 55 err 4 data crc crc): 140 µs + 500 µs + 150 µs =
        // 790 µs on the wire at 1 Mbps, + 1 ms adapter latency = 1.79 ms.
        let timing = WireTiming {
            baud: 1_000_000,
            usb_latency: Duration::from_millis(1),
        };
        let mut wire = Wire::new(timing);
        let t0 = Instant::now();
        let exchange = Exchange {
            request_bytes: 14,
            answers: answers(1, 15, Duration::from_micros(500)),
        };
        assert_eq!(
            wire.schedule(t0, &exchange)[0] - t0,
            Duration::from_micros(1790)
        );
        // The line was busy until 790 µs: an instruction handed over at 100 µs waits for it.
        let next = wire.schedule(t0 + Duration::from_micros(100), &exchange);
        assert_eq!(next[0] - t0, Duration::from_micros(790 + 1790));
    }

    #[test]
    fn a_sync_reads_answers_reach_the_host_together_when_the_last_is_in() {
        // The six STS answers of the 880 µs cycle above come 80 µs apart, 480…880 µs: one
        // delivery at 880 µs, the last answer's own instant.
        let us = Duration::from_micros;
        let t0 = Instant::now();
        let readable: Vec<Instant> = (0..6).map(|k| t0 + us(480 + 80 * k)).collect();
        let answers = answers(6, 8, Duration::ZERO);
        let one = deliveries(&answers, &readable, HOLD);
        assert_eq!(
            one,
            vec![Delivery {
                answers: 0..6,
                at: t0 + us(880)
            }]
        );
        // Holding none: each answer on its own, at its instant.
        let each = deliveries(&answers, &readable, Duration::ZERO);
        assert_eq!(each.len(), 6);
        for (k, delivery) in each.iter().enumerate() {
            assert_eq!(
                (delivery.answers.clone(), delivery.at),
                (k..k + 1, readable[k])
            );
        }
    }

    #[test]
    fn no_answer_is_held_longer_than_the_hold_nor_for_a_late_one() {
        let us = Duration::from_micros;
        let t0 = Instant::now();
        // Dynamixel answers 650 µs apart (500 µs return delay + 15 bytes): 0, 650, 1300, 1950
        // µs. Within 1 ms of a delivery's first answer: {0, 650}, {1300, 1950}.
        let readable: Vec<Instant> = (0..4).map(|k| t0 + us(650 * k)).collect();
        let mut answers = answers(4, 15, us(500));
        let groups = |d: Vec<Delivery>| -> Vec<(Range<usize>, Duration)> {
            d.into_iter().map(|d| (d.answers, d.at - t0)).collect()
        };
        assert_eq!(
            groups(deliveries(&answers, &readable, HOLD)),
            vec![(0..2, us(650)), (2..4, us(1950))]
        );
        // The third answer injected late (its instant moved on by 40 ms): the first two are not
        // held for it; it and the one after it (which follows it on the line) come together.
        answers[2].extra_delay = Duration::from_millis(40);
        let late: Vec<Instant> = [0, 650, 41_300, 41_950].map(|t| t0 + us(t)).to_vec();
        assert_eq!(
            groups(deliveries(&answers, &late, HOLD)),
            vec![(0..2, us(650)), (2..4, us(41_950))]
        );
        // Late by only 200 µs, within the hold of the one before it: still a delivery of its
        // own, the answer before it not held for it (by the hold alone, 0 and 850 µs would go
        // together).
        answers[2].extra_delay = Duration::ZERO;
        answers[1].extra_delay = us(200);
        let slightly: Vec<Instant> = [0, 850, 1500, 2150].map(|t| t0 + us(t)).to_vec();
        assert_eq!(
            groups(deliveries(&answers, &slightly, HOLD)),
            vec![(0..1, us(0)), (1..3, us(1500)), (3..4, us(2150))]
        );
        assert!(deliveries(&[], &[], HOLD).is_empty());
    }

    #[test]
    fn a_byte_takes_ten_bit_times() {
        // 57600 baud: 10 bits = 173.611 µs, truncated to the nanosecond.
        assert_eq!(
            WireTiming::at(57_600).bytes_time(1),
            Duration::from_nanos(173_611)
        );
        assert_eq!(
            WireTiming::at(1_000_000).bytes_time(100),
            Duration::from_millis(1)
        );
    }
}

#[cfg(test)]
mod exchange_tests {
    use super::super::VirtualServos;
    use crate::bus::protocol::codec;
    use crate::robot::{Protocol, Robot};
    use std::time::Duration;

    /// A Feetech packet: FF FF, id, length (parameters + 2), instruction, parameters, checksum
    /// = the inverted low byte of the sum from id to the last parameter (docs/protocols.md §2.1).
    fn feetech(id: u8, instruction: u8, params: &[u8]) -> Vec<u8> {
        let mut body = vec![id, params.len() as u8 + 2, instruction];
        body.extend_from_slice(params);
        let sum: u32 = body.iter().map(|&b| u32::from(b)).sum();
        let mut packet = vec![0xFF, 0xFF];
        packet.extend_from_slice(&body);
        packet.push(!(sum as u8));
        packet
    }

    #[test]
    fn a_sync_write_and_sync_read_arriving_together_are_timed_packet_by_packet() {
        let robot = Robot::builtin("so101").unwrap();
        let mut servos = VirtualServos::for_robot(&robot);
        // Sync write (0x83) of Goal_Position (42, 2 bytes) = 2048 to ids 1…6: 26 bytes; sync
        // read (0x82) of Present_Position (56, 2 bytes) from ids 1…6: 14 bytes.
        let mut write_params = vec![42, 2];
        for id in 1..=6u8 {
            write_params.extend_from_slice(&[id, 0x00, 0x08]);
        }
        let mut bytes = feetech(0xFE, 0x83, &write_params);
        bytes.extend(feetech(0xFE, 0x82, &[56, 2, 1, 2, 3, 4, 5, 6]));
        assert_eq!(bytes.len(), 26 + 14);
        let exchanges = servos.exchanges(&bytes);
        assert_eq!(exchanges.len(), 2);
        assert_eq!(exchanges[0].request_bytes, 26);
        assert!(exchanges[0].answers.is_empty());
        assert_eq!(exchanges[1].request_bytes, 14);
        let answers = &exchanges[1].answers;
        // Six 8-byte status packets, none delayed: the STS3215 has no return delay.
        assert_eq!(answers.len(), 6);
        assert!(answers
            .iter()
            .all(|a| a.bytes.len() == 8 && a.return_delay.is_zero()));
    }

    #[test]
    fn a_dynamixel_servo_answers_after_its_return_delay_register() {
        let robot = Robot::builtin("koch").unwrap();
        let mut servos = VirtualServos::for_robot(&robot);
        let framing = codec(Protocol::Dynamixel2).framing();
        // The servos keep the factory Return_Delay_Time, 250 × 2 µs; WRITE (0x03)
        // Return_Delay_Time (address 9, 1 byte) = 10 on servo 1 (torque is off): 10 × 2 µs.
        servos.exchanges(&framing.encode_instruction(1, 0x03, &[9, 0, 10]));
        // SYNC READ (0x82) of Present_Position (132, 4 bytes) from ids 1…6: 10 + 4 + 6 = 20
        // bytes; each answer 11 + 4 = 15 bytes.
        let read = framing.encode_instruction(0xFE, 0x82, &[132, 0, 4, 0, 1, 2, 3, 4, 5, 6]);
        let exchanges = servos.exchanges(&read);
        assert_eq!(exchanges[0].request_bytes, 20);
        let delays: Vec<Duration> = exchanges[0]
            .answers
            .iter()
            .map(|a| a.return_delay)
            .collect();
        let mut expected = vec![Duration::from_micros(500); 6];
        expected[0] = Duration::from_micros(20);
        assert_eq!(delays, expected);
        assert!(exchanges[0].answers.iter().all(|a| a.bytes.len() == 15));
    }
}
