//! Feetech SCS/STS protocol ("FT-SCS", the Dynamixel 1.0 packet format): framing with a
//! one-byte inverted-sum checksum, instruction codes, parameter layouts and the status byte.
//!
//! From PROTOCOLS.md §2 (Feetech protocol manual and memory table, the `scservo_sdk` Python
//! SDK). Packet fields are single bytes, so framing has no byte order; register values do, and
//! it depends on the series ([`Series`]).

use super::packet::{
    append_sync_entries, seek_header, Decoded, Direction, Framing, Packet, PacketError, PacketKind,
};
use super::registers::ByteOrder;
use super::{AlarmBits, Alarms};
use crate::robot::Protocol;

pub const PING: u8 = 0x01;
pub const READ: u8 = 0x02;
pub const WRITE: u8 = 0x03;
pub const REG_WRITE: u8 = 0x04;
pub const ACTION: u8 = 0x05;
/// STS/SMS only; SCS servos do not answer it.
pub const SYNC_READ: u8 = 0x82;
pub const SYNC_WRITE: u8 = 0x83;

pub const BROADCAST_ID: u8 = 0xFE;
/// Highest id a servo answers with; the SDK rejects status packets from higher ids.
pub const MAX_DEVICE_ID: u8 = 0xFD;
pub const HEADER: [u8; 2] = [0xFF, 0xFF];
/// The length byte counts the parameters plus INST/ERR and the checksum, and is one byte.
pub const MAX_PARAMS: usize = u8::MAX as usize - 2;
/// Status error bytes with bit 7 set do not exist; the SDK treats them as noise.
pub const MAX_ERROR_BYTE: u8 = 0x7F;

/// Header, id and length.
const PREFIX: usize = 4;

/// The inverted sum over id, length, instruction or error, and parameters.
pub fn checksum(bytes: &[u8]) -> u8 {
    !bytes.iter().fold(0u8, |sum, &b| sum.wrapping_add(b))
}

/// The two Feetech families, which differ in byte order and in which instructions they know.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Series {
    /// Magnetic-encoder STS/SMS servos ("protocol 0" in the SDK): little-endian, sign-magnitude
    /// negatives, Sync Read supported.
    StsSms,
    /// Potentiometer SCS servos ("protocol 1"): big-endian, no Sync Read.
    Scs,
}

impl Series {
    pub fn from_protocol(protocol: Protocol) -> Option<Series> {
        match protocol {
            Protocol::FeetechSts => Some(Series::StsSms),
            Protocol::FeetechScs => Some(Series::Scs),
            Protocol::Dynamixel2 => None,
        }
    }

    pub fn byte_order(self) -> ByteOrder {
        match self {
            Series::StsSms => ByteOrder::Little,
            Series::Scs => ByteOrder::Big,
        }
    }

    pub fn supports_sync_read(self) -> bool {
        matches!(self, Series::StsSms)
    }
}

/// Feetech framing: `FF FF ID LEN INST/ERR params CHK`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Feetech;

impl Feetech {
    fn encode_body(&self, id: u8, code: u8, params: &[u8]) -> Result<Vec<u8>, PacketError> {
        if params.len() > MAX_PARAMS {
            return Err(PacketError::TooLong {
                id,
                length: params.len() + 1,
                max: MAX_PARAMS + 1,
            });
        }
        let mut out = Vec::with_capacity(PREFIX + 2 + params.len());
        out.extend_from_slice(&HEADER);
        out.push(id);
        out.push((params.len() + 2) as u8);
        out.push(code);
        out.extend_from_slice(params);
        let chk = checksum(&out[2..]);
        out.push(chk);
        Ok(out)
    }
}

impl Framing for Feetech {
    fn broadcast_id(&self) -> u8 {
        BROADCAST_ID
    }

    fn try_encode_instruction(
        &self,
        id: u8,
        instruction: u8,
        params: &[u8],
    ) -> Result<Vec<u8>, PacketError> {
        if id > BROADCAST_ID {
            return Err(PacketError::Id { id });
        }
        self.encode_body(id, instruction, params)
    }

    fn try_encode_status(&self, id: u8, error: u8, params: &[u8]) -> Result<Vec<u8>, PacketError> {
        if id > MAX_DEVICE_ID {
            return Err(PacketError::Id { id });
        }
        if error > MAX_ERROR_BYTE {
            return Err(PacketError::ErrorByte { id, error });
        }
        self.encode_body(id, error, params)
    }

    fn decode(&self, buf: &mut Vec<u8>, direction: Direction) -> Result<Decoded, PacketError> {
        loop {
            if !seek_header(buf, &HEADER) || buf.len() < PREFIX {
                return Ok(Decoded::NeedMore);
            }
            let id = buf[2];
            // `FF FF FF`: a longer run of FF, the header proper starts further on.
            if id == 0xFF {
                buf.drain(..1);
                continue;
            }
            let max_id = match direction {
                Direction::ToServo => BROADCAST_ID,
                Direction::FromServo => MAX_DEVICE_ID,
            };
            if id > max_id {
                buf.drain(..1);
                return Err(PacketError::Id { id });
            }
            let length = buf[3];
            // At least INST/ERR and the checksum.
            if length < 2 {
                buf.drain(..1);
                return Err(PacketError::Length {
                    id,
                    length: length as u16,
                });
            }
            if direction == Direction::FromServo {
                let Some(&error) = buf.get(PREFIX) else {
                    return Ok(Decoded::NeedMore);
                };
                if error > MAX_ERROR_BYTE {
                    buf.drain(..1);
                    return Err(PacketError::ErrorByte { id, error });
                }
            }
            let total = PREFIX + length as usize;
            if buf.len() < total {
                return Ok(Decoded::NeedMore);
            }
            let expected = checksum(&buf[2..total - 1]);
            let found = buf[total - 1];
            if expected != found {
                // Only the first byte goes: the length may be what was damaged.
                buf.drain(..1);
                return Err(PacketError::Checksum {
                    id,
                    expected: expected as u16,
                    found: found as u16,
                });
            }
            let bytes: Vec<u8> = buf.drain(..total).collect();
            let code = bytes[PREFIX];
            let kind = match direction {
                Direction::ToServo => PacketKind::Instruction(code),
                Direction::FromServo => PacketKind::Status { error: code },
            };
            return Ok(Decoded::Packet(Packet {
                id,
                kind,
                params: bytes[PREFIX + 1..total - 1].to_vec(),
            }));
        }
    }
}

/// READ parameters: address and length.
pub fn read_params(address: u8, length: u8) -> Vec<u8> {
    vec![address, length]
}

/// WRITE parameters: address, then the data (already in the series' byte order).
pub fn write_params(address: u8, data: &[u8]) -> Vec<u8> {
    let mut params = Vec::with_capacity(1 + data.len());
    params.push(address);
    params.extend_from_slice(data);
    params
}

/// SYNC READ parameters: address, length, ids. Send to [`BROADCAST_ID`]; each servo answers
/// with its own status packet.
pub fn sync_read_params(address: u8, length: u8, ids: &[u8]) -> Vec<u8> {
    let mut params = read_params(address, length);
    params.extend_from_slice(ids);
    params
}

/// SYNC WRITE parameters: address, length, then each id with exactly `length` bytes of data.
/// Send to [`BROADCAST_ID`].
pub fn sync_write_params(
    address: u8,
    length: u8,
    entries: &[(u8, Vec<u8>)],
) -> Result<Vec<u8>, PacketError> {
    let mut params = read_params(address, length);
    append_sync_entries(&mut params, usize::from(length), entries)?;
    Ok(params)
}

pub const ERR_VOLTAGE: u8 = 1 << 0;
pub const ERR_ANGLE_SENSOR: u8 = 1 << 1;
pub const ERR_OVERHEAT: u8 = 1 << 2;
pub const ERR_OVER_CURRENT: u8 = 1 << 3;
pub const ERR_OVERLOAD: u8 = 1 << 5;

/// Status ERR byte and Status register (65) bits.
pub const STATUS_BITS: AlarmBits = AlarmBits {
    input_voltage: ERR_VOLTAGE,
    overheating: ERR_OVERHEAT,
    encoder: ERR_ANGLE_SENSOR,
    electrical: ERR_OVER_CURRENT,
    overload: ERR_OVERLOAD,
};

/// The alarms in a status ERR byte, or in the Status register (65), which uses the same bits.
/// Feetech's status byte reports conditions, not refusals: the instruction was carried out.
pub fn status_alarms(bits: u8) -> Alarms {
    STATUS_BITS.decode(bits)
}

/// The status byte an emulated servo reports for `alarms`.
pub fn status_bits(alarms: &Alarms) -> u8 {
    STATUS_BITS.encode(alarms)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::PositionEncoding;
    use proptest::prelude::*;

    fn decode_all(buf: &mut Vec<u8>, direction: Direction) -> Vec<Result<Packet, PacketError>> {
        crate::bus::packet::test_support::decode_all(&Feetech, buf, direction)
    }

    use crate::bus::packet::test_support::packets;

    #[test]
    fn ping_matches_the_rustypot_example() {
        assert_eq!(
            Feetech.encode_instruction(1, PING, &[]),
            [0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB]
        );
    }

    /// Goal position −100 on an STS: sign-magnitude with bit 15, 0x8000 | 100 = 0x8064,
    /// little-endian `64 80`. Write to id 1 at 42 = 0x2A: params `2A 64 80`, LEN = 3 + 2 = 5.
    /// Checksum: 0x01 + 0x05 + 0x03 + 0x2A + 0x64 + 0x80 = 1 + 5 + 3 + 42 + 100 + 128 = 279
    /// = 0x117; low byte 0x17; inverted 0xFF − 0x17 = 0xE8.
    #[test]
    fn goal_position_minus_100_hand_computed() {
        let raw = PositionEncoding::SignMagnitude16 { sign_bit: 15 }
            .encode(-100)
            .unwrap();
        assert_eq!(raw, 0x8064);
        let data = (raw as u16).to_le_bytes();
        assert_eq!(data, [0x64, 0x80]);
        assert_eq!(
            Feetech.encode_instruction(1, WRITE, &write_params(42, &data)),
            [0xFF, 0xFF, 0x01, 0x05, 0x03, 0x2A, 0x64, 0x80, 0xE8]
        );
    }

    #[test]
    fn status_decodes_by_direction() {
        let bytes = [0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC];
        let mut buf = bytes.to_vec();
        assert_eq!(
            Feetech.decode(&mut buf, Direction::FromServo),
            Ok(Decoded::Packet(Packet::status(1, 0, vec![])))
        );
        let mut buf = bytes.to_vec();
        assert_eq!(
            Feetech.decode(&mut buf, Direction::ToServo),
            Ok(Decoded::Packet(Packet::instruction(1, 0, vec![])))
        );
        assert_eq!(Feetech.encode_status(1, 0, &[]), bytes);
    }

    #[test]
    fn broadcast_is_valid_only_towards_the_servos() {
        let ping = Feetech.encode_instruction(BROADCAST_ID, PING, &[]);
        let mut buf = ping.clone();
        assert_eq!(
            Feetech.decode(&mut buf, Direction::ToServo),
            Ok(Decoded::Packet(Packet::instruction(
                BROADCAST_ID,
                PING,
                vec![]
            )))
        );
        let mut buf = ping;
        assert_eq!(
            Feetech.decode(&mut buf, Direction::FromServo),
            Err(PacketError::Id { id: BROADCAST_ID })
        );
        assert!(Feetech.try_encode_status(BROADCAST_ID, 0, &[]).is_err());
    }

    #[test]
    fn error_byte_with_bit_7_is_noise() {
        let mut buf = vec![0xFF, 0xFF, 0x01, 0x02, 0x80];
        assert!(matches!(
            Feetech.decode(&mut buf, Direction::FromServo),
            Err(PacketError::ErrorByte { id: 1, error: 0x80 })
        ));
        assert!(Feetech.try_encode_status(1, 0x80, &[]).is_err());
    }

    #[test]
    fn resync_after_garbage_and_a_bad_checksum() {
        let mut buf = vec![0x12, 0xFF, 0x00, 0xFF, 0xFF, 0xFF];
        let mut bad = Feetech.encode_status(2, 0, &[1, 2]);
        let last = bad.len() - 1;
        bad[last] ^= 0x40;
        // The run `FF FF FF` before the bad packet's header is absorbed.
        buf.extend_from_slice(&bad[2..]);
        buf.extend_from_slice(&Feetech.encode_status(3, 0x20, &[0xFF, 0xFF, 0x07]));
        let results = decode_all(&mut buf, Direction::FromServo);
        assert!(matches!(
            results.first(),
            Some(Err(PacketError::Checksum { id: 2, .. }))
        ));
        assert_eq!(
            packets(results),
            vec![Packet::status(3, 0x20, vec![0xFF, 0xFF, 0x07])]
        );
        assert!(buf.is_empty());
    }

    #[test]
    fn truncated_input_needs_more() {
        let full = Feetech.encode_status(4, 0, &[0x64, 0x80]);
        for cut in 0..full.len() {
            let mut buf = full[..cut].to_vec();
            assert_eq!(
                Feetech.decode(&mut buf, Direction::FromServo),
                Ok(Decoded::NeedMore),
                "cut at {cut}"
            );
        }
    }

    #[test]
    fn param_builders_and_limits() {
        assert_eq!(read_params(56, 2), [56, 2]);
        assert_eq!(sync_read_params(56, 2, &[1, 2, 3]), [56, 2, 1, 2, 3]);
        assert_eq!(
            sync_write_params(42, 2, &[(1, vec![0x00, 0x08]), (2, vec![0x64, 0x80])]).unwrap(),
            [42, 2, 1, 0x00, 0x08, 2, 0x64, 0x80]
        );
        assert!(sync_write_params(42, 2, &[(1, vec![0])]).is_err());
        assert!(Feetech.try_encode_instruction(1, WRITE, &[0; 253]).is_ok());
        assert!(matches!(
            Feetech.try_encode_instruction(1, WRITE, &[0; 254]),
            Err(PacketError::TooLong { .. })
        ));
        assert!(Feetech.try_encode_instruction(0xFF, PING, &[]).is_err());
    }

    #[test]
    fn sync_packet_sizes_match_the_wire_budget() {
        // PROTOCOLS.md §3: STS sync write of 6 goal positions = 26 bytes, sync read of 6 ids =
        // 14 bytes, status with 2 data bytes = 8 bytes.
        let entries: Vec<(u8, Vec<u8>)> = (1..=6).map(|id| (id, vec![0, 8])).collect();
        let write = Feetech.encode_instruction(
            BROADCAST_ID,
            SYNC_WRITE,
            &sync_write_params(42, 2, &entries).unwrap(),
        );
        assert_eq!(write.len(), 26);
        let read = Feetech.encode_instruction(
            BROADCAST_ID,
            SYNC_READ,
            &sync_read_params(56, 2, &[1, 2, 3, 4, 5, 6]),
        );
        assert_eq!(read.len(), 14);
        assert_eq!(Feetech.encode_status(1, 0, &[0, 8]).len(), 8);
    }

    #[test]
    fn series_byte_order() {
        assert_eq!(
            Series::from_protocol(Protocol::FeetechSts).map(Series::byte_order),
            Some(ByteOrder::Little)
        );
        assert_eq!(
            Series::from_protocol(Protocol::FeetechScs).map(Series::byte_order),
            Some(ByteOrder::Big)
        );
        assert_eq!(Series::from_protocol(Protocol::Dynamixel2), None);
        assert!(!Series::Scs.supports_sync_read());
    }

    #[test]
    fn status_bits_map_to_alarms() {
        assert_eq!(
            status_alarms(ERR_ANGLE_SENSOR | ERR_OVER_CURRENT),
            Alarms {
                encoder: true,
                electrical: true,
                ..Alarms::default()
            }
        );
        assert!(!status_alarms(1 << 4 | 1 << 6).any());
        for bits in 0..=MAX_ERROR_BYTE {
            assert_eq!(status_bits(&status_alarms(bits)), bits & 0b0010_1111);
        }
    }

    fn instruction_id() -> impl Strategy<Value = u8> {
        0..=BROADCAST_ID
    }

    proptest! {
        #[test]
        fn instruction_round_trips(
            id in instruction_id(),
            instruction in any::<u8>(),
            params in prop::collection::vec(prop_oneof![any::<u8>(), Just(0xFF)], 0..=MAX_PARAMS),
        ) {
            let mut buf = Feetech.encode_instruction(id, instruction, &params);
            prop_assert_eq!(
                Feetech.decode(&mut buf, Direction::ToServo),
                Ok(Decoded::Packet(Packet::instruction(id, instruction, params)))
            );
            prop_assert!(buf.is_empty());
        }

        #[test]
        fn status_round_trips(
            id in 0..=MAX_DEVICE_ID,
            error in 0..=MAX_ERROR_BYTE,
            params in prop::collection::vec(prop_oneof![any::<u8>(), Just(0xFF)], 0..=MAX_PARAMS),
        ) {
            let mut buf = Feetech.encode_status(id, error, &params);
            prop_assert_eq!(
                Feetech.decode(&mut buf, Direction::FromServo),
                Ok(Decoded::Packet(Packet::status(id, error, params)))
            );
            prop_assert!(buf.is_empty());
        }

        #[test]
        fn packets_are_found_between_garbage(
            garbage in prop::collection::vec(
                prop::collection::vec(any::<u8>().prop_filter("no 0xFF", |&b| b != 0xFF), 0..20),
                3,
            ),
            params in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..40), 2),
            tail_ff in 0usize..4,
        ) {
            let (found, expected) = crate::bus::packet::test_support::between_garbage(
                &Feetech, &garbage, &params, tail_ff,
            );
            prop_assert_eq!(found, expected);
        }

        #[test]
        fn random_bytes_never_panic_or_stall(
            bytes in prop::collection::vec(prop_oneof![any::<u8>(), Just(0xFF)], 0..600),
            to_servo in any::<bool>(),
        ) {
            let direction = if to_servo { Direction::ToServo } else { Direction::FromServo };
            let mut buf = bytes;
            let _ = decode_all(&mut buf, direction);
            // Whatever is left is shorter than the longest possible packet.
            prop_assert!(buf.len() < PREFIX + u8::MAX as usize);
        }
    }
}
