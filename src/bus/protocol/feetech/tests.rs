//! Feetech codec tests: hand-computed packets and properties.

use super::*;
use crate::bus::protocol::ff_framing::PREFIX;
use crate::bus::protocol::packet::PacketError;
use crate::bus::protocol::packet::{Decoded, Direction, Framing, Packet};
use crate::bus::protocol::{codec, Codec};
use crate::bus::Alarms;
use crate::robot::PositionEncoding;
use crate::robot::Protocol;
use crate::servo::sts3215::{ERR_ANGLE_SENSOR, ERR_OVER_CURRENT};
use crate::servo::ByteOrder;
use crate::servo::Vendor;
use proptest::prelude::*;

fn decode_all(buf: &mut Vec<u8>, direction: Direction) -> Vec<Result<Packet, PacketError>> {
    crate::bus::protocol::packet::test_support::decode_all(&Feetech, buf, direction)
}

use crate::bus::protocol::packet::test_support::packets;

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
        Feetech.encode_instruction(1, WRITE, &FIELDS.write(42, &data).unwrap()),
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
    assert_eq!(FIELDS.read(56, 2).unwrap(), [56, 2]);
    assert_eq!(
        FIELDS.sync_read(56, 2, &[1, 2, 3]).unwrap(),
        [56, 2, 1, 2, 3]
    );
    assert_eq!(
        FIELDS
            .sync_write(42, 2, &[(1, vec![0x00, 0x08]), (2, vec![0x64, 0x80])])
            .unwrap(),
        [42, 2, 1, 0x00, 0x08, 2, 0x64, 0x80]
    );
    assert!(FIELDS.sync_write(42, 2, &[(1, vec![0])]).is_err());
    assert!(Feetech.try_encode_instruction(1, WRITE, &[0; 253]).is_ok());
    assert!(matches!(
        Feetech.try_encode_instruction(1, WRITE, &[0; 254]),
        Err(PacketError::TooLong { .. })
    ));
    assert!(Feetech.try_encode_instruction(0xFF, PING, &[]).is_err());
}

#[test]
fn sync_packet_sizes_match_the_wire_budget() {
    // docs/protocols.md: STS sync write of 6 goal positions = 26 bytes, sync read of 6 ids =
    // 14 bytes, status with 2 data bytes = 8 bytes.
    let entries: Vec<(u8, Vec<u8>)> = (1..=6).map(|id| (id, vec![0, 8])).collect();
    let write = Feetech.encode_instruction(
        BROADCAST_ID,
        SYNC_WRITE,
        &FIELDS.sync_write(42, 2, &entries).unwrap(),
    );
    assert_eq!(write.len(), 26);
    let read = Feetech.encode_instruction(
        BROADCAST_ID,
        SYNC_READ,
        &FIELDS.sync_read(56, 2, &[1, 2, 3, 4, 5, 6]).unwrap(),
    );
    assert_eq!(read.len(), 14);
    assert_eq!(Feetech.encode_status(1, 0, &[0, 8]).len(), 8);
}

#[test]
fn series_byte_order() {
    assert_eq!(codec(Protocol::FeetechSts).byte_order(), ByteOrder::Little);
    assert_eq!(codec(Protocol::FeetechScs).byte_order(), ByteOrder::Big);
    assert_eq!(codec(Protocol::Dynamixel2).vendor(), Vendor::Dynamixel);
    assert_eq!(codec(Protocol::FeetechSts).vendor(), Vendor::Feetech);
    assert!(SCS.instructions().sync_read.is_none());
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
        let (found, expected) = crate::bus::protocol::packet::test_support::between_garbage(
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
