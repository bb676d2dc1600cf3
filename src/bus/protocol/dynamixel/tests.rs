//! Dynamixel codec tests: hand-computed packets from the e-Manual, and properties.

use super::crc::CRC_TABLE;
use super::*;
use crate::bus::protocol::packet::{Decoded, Direction, Framing};
use crate::bus::{Alarms, BusError};
use proptest::prelude::*;

/// Bit-by-bit CRC, written from the definition rather than the table, as a second oracle.
fn crc_bitwise(data: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &byte in data {
        crc ^= (byte as u16) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x8005
            } else {
                crc << 1
            };
        }
    }
    crc
}

fn decode_all(buf: &mut Vec<u8>, direction: Direction) -> Vec<Result<Packet, PacketError>> {
    crate::bus::protocol::packet::test_support::decode_all(&Dynamixel2, buf, direction)
}

use crate::bus::protocol::packet::test_support::packets;

#[test]
fn crc_check_value_of_crc16_umts() {
    assert_eq!(crc16(b"123456789"), 0xFEE8);
    assert_eq!(crc_bitwise(b"123456789"), 0xFEE8);
}

#[test]
fn crc_table_matches_the_sdk_table_start() {
    // First entries of `updateCRC`'s table in the ROBOTIS SDK.
    assert_eq!(
        CRC_TABLE[..8],
        [0x0000, 0x8005, 0x800F, 0x000A, 0x801B, 0x001E, 0x0014, 0x8011]
    );
    assert_eq!(CRC_TABLE[255], 0x0202);
}

#[test]
fn crc_update_continues() {
    let data = b"FF FF FD some packet";
    let (a, b) = data.split_at(7);
    assert_eq!(crc16_update(crc16(a), b), crc16(data));
}

#[test]
fn ping_instruction_matches_the_emanual_example() {
    let bytes = Dynamixel2.encode_instruction(1, PING, &[]);
    assert_eq!(
        bytes,
        [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E]
    );
}

#[test]
fn read_status_example_decodes() {
    let mut buf = vec![
        0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x55, 0x00, 0xA6, 0x00, 0x00, 0x00, 0x8C, 0xC0,
    ];
    let decoded = Dynamixel2.decode(&mut buf, Direction::FromServo).unwrap();
    assert_eq!(
        decoded,
        Decoded::Packet(Packet::status(1, 0, vec![0xA6, 0, 0, 0]))
    );
    assert!(buf.is_empty());
    // And it is what an emulated servo would send.
    assert_eq!(
        Dynamixel2.encode_status(1, 0, &[0xA6, 0, 0, 0]),
        [
            0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x55, 0x00, 0xA6, 0x00, 0x00, 0x00, 0x8C,
            0xC0
        ]
    );
}

/// Goal position −131073 = 0xFFFF_FFFF − 0x2_0000 = 0xFFFD_FFFF, little-endian `FF FF FD FF`.
/// Write to id 1 at 116 = 0x0074: INST 03, params `74 00 FF FF FD FF`. The `FF FF FD` gets
/// an extra FD: `03 74 00 FF FF FD FD FF` = 8 bytes, so LEN = 8 + 2 = 10 = `0A 00`. The CRC
/// 0xE523 was computed over the stuffed bytes by an independent bit-by-bit implementation.
const STUFFED_WRITE: [u8; 17] = [
    0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x0A, 0x00, 0x03, 0x74, 0x00, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF, 0x23,
    0xE5,
];

#[test]
fn negative_extended_position_is_stuffed() {
    let data = (-131073i32).to_le_bytes();
    assert_eq!(data, [0xFF, 0xFF, 0xFD, 0xFF]);
    let bytes = Dynamixel2.encode_instruction(1, WRITE, &FIELDS.write(116, &data).unwrap());
    assert_eq!(bytes, STUFFED_WRITE);
    assert_eq!(crc_bitwise(&STUFFED_WRITE[..15]), 0xE523);
}

#[test]
fn stuffed_packet_decodes_to_the_unstuffed_params() {
    let mut buf = STUFFED_WRITE.to_vec();
    let decoded = Dynamixel2.decode(&mut buf, Direction::ToServo).unwrap();
    assert_eq!(
        decoded,
        Decoded::Packet(Packet::instruction(
            1,
            WRITE,
            vec![0x74, 0x00, 0xFF, 0xFF, 0xFD, 0xFF]
        ))
    );
    assert!(buf.is_empty());
}

#[test]
fn stuffing_edge_cases() {
    assert_eq!(stuff(&[0xFF, 0xFF, 0xFD]), [0xFF, 0xFF, 0xFD, 0xFD]);
    assert_eq!(
        stuff(&[0xFF, 0xFF, 0xFD, 0xFD]),
        [0xFF, 0xFF, 0xFD, 0xFD, 0xFD]
    );
    assert_eq!(
        stuff(&[0xFF, 0xFF, 0xFF, 0xFD]),
        [0xFF, 0xFF, 0xFF, 0xFD, 0xFD]
    );
    assert_eq!(stuff(&[0xFF, 0xFD, 0xFF]), [0xFF, 0xFD, 0xFF]);
    assert_eq!(
        unstuff(&[0xFF, 0xFF, 0xFD, 0xFD, 0xFD]),
        [0xFF, 0xFF, 0xFD, 0xFD]
    );
    // Not produced by a correct sender; kept as is.
    assert_eq!(unstuff(&[0xFF, 0xFF, 0xFD, 0x01]), [0xFF, 0xFF, 0xFD, 0x01]);
}

#[test]
fn a_header_spanning_the_instruction_or_error_byte_and_the_params_is_stuffed() {
    // The region is INST params (or 0x55 ERR params): an `FF FF FD` across the instruction or
    // error byte and the first parameters is stuffed like any other (e-Manual, Protocol 2.0,
    // "Byte Stuffing"), though the packet is built from the two parts.
    let instruction = Dynamixel2
        .try_encode_instruction(1, 0xFF, &[0xFF, 0xFD, 0x07])
        .unwrap();
    // Header, id 1, length 7 (4 + 1 stuffed region bytes + CRC 2), FF · FF FD FD 07.
    assert_eq!(
        instruction[..instruction.len() - 2],
        [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x07, 0x00, 0xFF, 0xFF, 0xFD, 0xFD, 0x07]
    );
    let status = Dynamixel2
        .try_encode_status(2, 0xFF, &[0xFF, 0xFD])
        .unwrap();
    // Header, id 2, length 7 (4 + 1 stuffed region bytes + CRC 2), 55 FF · FF FD FD.
    assert_eq!(
        status[..status.len() - 2],
        [0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x07, 0x00, 0x55, 0xFF, 0xFF, 0xFD, 0xFD]
    );
    let mut buf = instruction;
    assert_eq!(
        Dynamixel2.decode(&mut buf, Direction::ToServo),
        Ok(Decoded::Packet(Packet::instruction(
            1,
            0xFF,
            vec![0xFF, 0xFD, 0x07]
        )))
    );
    let mut buf = status;
    assert_eq!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Ok(Decoded::Packet(Packet::status(2, 0xFF, vec![0xFF, 0xFD])))
    );
}

#[test]
fn leading_garbage_is_skipped() {
    let mut buf = vec![0x00, 0x13, 0xFF, 0x42, 0xFF, 0xFF, 0x00];
    buf.extend_from_slice(&Dynamixel2.encode_status(7, 0, &[1, 2]));
    let found = decode_all(&mut buf, Direction::FromServo);
    assert_eq!(found, vec![Ok(Packet::status(7, 0, vec![1, 2]))]);
    assert!(buf.is_empty());
}

#[test]
fn a_corrupted_crc_is_reported_and_the_next_packet_found() {
    let mut bad = Dynamixel2.encode_status(2, 0, &[9, 9, 9, 9]);
    let last = bad.len() - 1;
    bad[last] ^= 0x01;
    let mut buf = bad;
    buf.extend_from_slice(&Dynamixel2.encode_status(3, 0, &[4, 3, 2, 1]));
    let first = Dynamixel2.decode(&mut buf, Direction::FromServo);
    assert!(matches!(first, Err(PacketError::Checksum { id: 2, .. })));
    let rest = decode_all(&mut buf, Direction::FromServo);
    assert_eq!(packets(rest), vec![Packet::status(3, 0, vec![4, 3, 2, 1])]);
}

#[test]
fn a_corrupted_length_does_not_swallow_the_next_packet() {
    let mut bad = Dynamixel2.encode_status(2, 0, &[9, 9]);
    bad[5] = 0x30; // claims 48 bytes
    let good = Dynamixel2.encode_status(3, 0, &[1]);
    let mut buf = bad;
    buf.extend_from_slice(&good);
    // Not enough bytes for the claimed length yet: wait.
    assert_eq!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Ok(Decoded::NeedMore)
    );
    // More traffic arrives; the bogus span fails its CRC and the good packet is found.
    buf.extend_from_slice(&[0u8; 60]);
    let found = packets(decode_all(&mut buf, Direction::FromServo));
    assert_eq!(found, vec![Packet::status(3, 0, vec![1])]);
}

#[test]
fn impossible_length_and_id_are_rejected_without_waiting() {
    let mut buf = vec![0xFF, 0xFF, 0xFD, 0x00, 0x01, 0xFF, 0xFF];
    assert!(matches!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Err(PacketError::Length {
            id: 1,
            length: 0xFFFF
        })
    ));
    let mut buf = vec![0xFF, 0xFF, 0xFD, 0x00, 0xFD, 0x03, 0x00];
    assert!(matches!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Err(PacketError::Id { id: 0xFD })
    ));
    let mut buf = vec![0xFF, 0xFF, 0xFD, 0x07, 0x01, 0x03, 0x00];
    assert!(matches!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Err(PacketError::Reserved { value: 7 })
    ));
}

#[test]
fn truncated_input_needs_more_and_completes() {
    let full = Dynamixel2.encode_status(5, 0x80, &[1, 2, 3]);
    for cut in 0..full.len() {
        let mut buf = full[..cut].to_vec();
        assert_eq!(
            Dynamixel2.decode(&mut buf, Direction::FromServo),
            Ok(Decoded::NeedMore),
            "cut at {cut}"
        );
        buf.extend_from_slice(&full[cut..]);
        assert_eq!(
            Dynamixel2.decode(&mut buf, Direction::FromServo),
            Ok(Decoded::Packet(Packet::status(5, 0x80, vec![1, 2, 3]))),
            "cut at {cut}"
        );
    }
}

#[test]
fn the_echo_of_an_instruction_is_not_a_status() {
    let mut buf = Dynamixel2.encode_instruction(1, PING, &[]);
    buf.extend_from_slice(&Dynamixel2.encode_status(1, 0, &ping_answer_params(1200, 52)));
    assert_eq!(
        Dynamixel2.decode(&mut buf, Direction::FromServo),
        Err(PacketError::Direction {
            id: 1,
            expected: Direction::FromServo,
            found: Direction::ToServo
        })
    );
    let Ok(Decoded::Packet(answer)) = Dynamixel2.decode(&mut buf, Direction::FromServo) else {
        panic!("ping answer not found");
    };
    assert_eq!(
        parse_ping_answer(&answer),
        Ok(PingInfo {
            id: 1,
            model_number: 1200,
            firmware: Some(52),
            alarms: crate::bus::Alarms::default(),
        })
    );
}

#[test]
fn ping_answer_layout() {
    // XL430-W250 = 1060 = 0x0424.
    assert_eq!(ping_answer_params(1060, 46), [0x24, 0x04, 46]);
    let short = Packet::status(1, 0, vec![0x24, 0x04]);
    assert!(matches!(
        parse_ping_answer(&short),
        Err(PacketError::Malformed { id: 1, .. })
    ));
}

#[test]
fn param_builders() {
    assert_eq!(FIELDS.read(132, 4).unwrap(), [0x84, 0x00, 0x04, 0x00]);
    assert_eq!(FIELDS.write(64, &[1]).unwrap(), [0x40, 0x00, 0x01]);
    assert_eq!(
        FIELDS.sync_read(132, 4, &[1, 2]).unwrap(),
        [0x84, 0x00, 0x04, 0x00, 1, 2]
    );
    assert_eq!(
        FIELDS
            .sync_write(116, 4, &[(1, vec![0, 8, 0, 0]), (2, vec![0xFF; 4])])
            .unwrap(),
        [0x74, 0x00, 0x04, 0x00, 1, 0, 8, 0, 0, 2, 0xFF, 0xFF, 0xFF, 0xFF]
    );
    assert_eq!(
        FIELDS.sync_write(116, 4, &[(3, vec![0; 2])]),
        Err(PacketError::DataLength {
            id: 3,
            expected: 4,
            found: 2
        })
    );
}

#[test]
fn sync_write_packet_size_matches_the_wire_budget() {
    // docs/protocols.md: goal positions of 6 servos in one sync write are 44 bytes.
    let entries: Vec<(u8, Vec<u8>)> = (1..=6).map(|id| (id, vec![0, 8, 0, 0])).collect();
    let params = FIELDS.sync_write(116, 4, &entries).unwrap();
    let bytes = Dynamixel2.encode_instruction(BROADCAST_ID, SYNC_WRITE, &params);
    assert_eq!(bytes.len(), 44);
}

#[test]
fn fast_sync_read_answer_layout() {
    let entries = vec![
        FastSyncReadEntry {
            id: 1,
            error: 0,
            data: vec![0x00, 0x08, 0, 0],
        },
        FastSyncReadEntry {
            id: 2,
            error: 0x80,
            data: vec![0xFF, 0xFF, 0xFD, 0xFF],
        },
        FastSyncReadEntry {
            id: 3,
            error: 0,
            data: vec![1, 2, 3, 4],
        },
    ];
    let bytes = encode_fast_sync_read(&entries).unwrap();
    // 3 servos × (4 + 4) + INST = 25, the length of the e-Manual's "(data_length + 4) ×
    // devices" plus the instruction byte; 7 + 25 bytes in all.
    assert_eq!(bytes[5..7], [25, 0]);
    assert_eq!(bytes.len(), 32);
    // Each block ends with the running CRC; the last is the packet CRC.
    assert_eq!(bytes[7], STATUS);
    let first_block_end = 8 + 1 + 1 + 4;
    assert_eq!(
        u16::from_le_bytes([bytes[first_block_end], bytes[first_block_end + 1]]),
        crc_bitwise(&bytes[..first_block_end])
    );
    // Not stuffed: the `FF FF FD` in servo 2's data is sent as is.
    assert!(bytes.windows(4).any(|w| w == [0xFF, 0xFF, 0xFD, 0xFF]));

    let mut buf = bytes;
    let Ok(Decoded::Packet(packet)) = Dynamixel2.decode(&mut buf, Direction::FromServo) else {
        panic!("fast sync read answer not decoded");
    };
    assert_eq!(packet.id, BROADCAST_ID);
    assert_eq!(packet.error(), Some(0));
    assert_eq!(parse_fast_sync_read(&packet, 4).unwrap(), entries);
    assert!(matches!(
        parse_fast_sync_read(&packet, 3),
        Err(PacketError::Malformed { .. })
    ));
}

#[test]
fn fast_sync_read_encoder_checks_its_input() {
    assert!(encode_fast_sync_read(&[]).is_err());
    let uneven = [
        FastSyncReadEntry {
            id: 1,
            error: 0,
            data: vec![0; 4],
        },
        FastSyncReadEntry {
            id: 2,
            error: 0,
            data: vec![0; 2],
        },
    ];
    assert_eq!(
        encode_fast_sync_read(&uneven),
        Err(PacketError::DataLength {
            id: 2,
            expected: 4,
            found: 2
        })
    );
}

#[test]
fn status_byte() {
    assert_eq!(StatusByte::parse(0), StatusByte::default());
    let s = StatusByte::parse(0x87);
    assert!(s.alert);
    assert_eq!(s.error, Some(ErrorNumber::Access));
    assert_eq!(s.to_byte(), 0x87);
    assert!(matches!(
        s.refusal(4),
        Some(BusError::Refused { id: 4, .. })
    ));
    let alert_only = StatusByte::parse(0x80);
    assert!(alert_only.alert && alert_only.refusal(4).is_none());
    assert_eq!(StatusByte::parse(0x09).error, Some(ErrorNumber::Unknown(9)));
    for n in 0..=0x7F {
        assert_eq!(StatusByte::parse(n).to_byte(), n);
        assert_eq!(StatusByte::parse(n | 0x80).to_byte(), n | 0x80);
    }
}

#[test]
fn hardware_error_bits_map_to_alarms() {
    assert_eq!(hardware_error_alarms(0), Alarms::default());
    assert_eq!(
        hardware_error_alarms(0b0010_0101),
        Alarms {
            input_voltage: true,
            overheating: true,
            overload: true,
            ..Alarms::default()
        }
    );
    // Unused bits 1, 6, 7 raise nothing.
    assert!(!hardware_error_alarms(0b1100_0010).any());
    for bits in 0..=u8::MAX {
        let used = bits & 0b0011_1101;
        assert_eq!(hardware_error_bits(&hardware_error_alarms(bits)), used);
    }
}

#[test]
fn encoding_refuses_what_cannot_be_sent() {
    assert!(matches!(
        Dynamixel2.try_encode_instruction(0xFD, PING, &[]),
        Err(PacketError::Id { id: 0xFD })
    ));
    assert!(Dynamixel2.try_encode_instruction(1, STATUS, &[]).is_err());
    assert!(matches!(
        Dynamixel2.try_encode_instruction(1, WRITE, &[0; 1100]),
        Err(PacketError::TooLong { id: 1, .. })
    ));
    let at_limit = vec![0u8; MAX_PACKET - PREFIX - 3];
    assert_eq!(
        Dynamixel2
            .try_encode_instruction(1, WRITE, &at_limit)
            .map(|b| b.len()),
        Ok(MAX_PACKET)
    );
}

fn params_with_header_runs() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(
        prop_oneof![
            4 => any::<u8>().prop_map(|b| vec![b]),
            1 => Just(vec![0xFF, 0xFF, 0xFD]),
            1 => Just(vec![0xFF, 0xFF, 0xFD, 0xFD]),
            1 => Just(vec![0xFF, 0xFF, 0xFD, 0x00]),
            1 => Just(vec![0xFF]),
        ],
        0..120,
    )
    .prop_map(|chunks| chunks.concat())
}

fn device_id() -> impl Strategy<Value = u8> {
    prop_oneof![0..=MAX_DEVICE_ID, Just(BROADCAST_ID)]
}

proptest! {
    #[test]
    fn stuffing_round_trips(region in params_with_header_runs()) {
        let stuffed = stuff(&region);
        prop_assert!(!stuffed.windows(4).any(|w| w == HEADER));
        prop_assert_eq!(unstuff(&stuffed), region);
    }

    #[test]
    fn instruction_round_trips(
        id in device_id(),
        instruction in any::<u8>().prop_filter("not the status code", |&i| i != STATUS),
        params in params_with_header_runs(),
    ) {
        let mut buf = Dynamixel2.encode_instruction(id, instruction, &params);
        let decoded = Dynamixel2.decode(&mut buf, Direction::ToServo);
        prop_assert_eq!(decoded, Ok(Decoded::Packet(Packet::instruction(id, instruction, params))));
        prop_assert!(buf.is_empty());
    }

    #[test]
    fn status_round_trips(id in device_id(), error in any::<u8>(), params in params_with_header_runs()) {
        let mut buf = Dynamixel2.encode_status(id, error, &params);
        let decoded = Dynamixel2.decode(&mut buf, Direction::FromServo);
        prop_assert_eq!(decoded, Ok(Decoded::Packet(Packet::status(id, error, params))));
        prop_assert!(buf.is_empty());
    }

    #[test]
    fn packets_are_found_between_garbage(
        garbage in prop::collection::vec(
            prop::collection::vec(any::<u8>().prop_filter("no 0xFF", |&b| b != 0xFF), 0..20),
            3,
        ),
        params in prop::collection::vec(params_with_header_runs(), 2),
        tail_ff in 0usize..3,
    ) {
        let (found, expected) = crate::bus::protocol::packet::test_support::between_garbage(
            &Dynamixel2, &garbage, &params, tail_ff,
        );
        prop_assert_eq!(found, expected);
    }

    #[test]
    fn random_bytes_never_panic_or_stall(
        bytes in prop::collection::vec(
            prop_oneof![any::<u8>(), Just(0xFF), Just(0xFD), Just(0x00)],
            0..600,
        ),
        to_servo in any::<bool>(),
    ) {
        let direction = if to_servo { Direction::ToServo } else { Direction::FromServo };
        let mut buf = bytes;
        // decode_all asserts progress on every non-NeedMore step.
        let _ = decode_all(&mut buf, direction);
        prop_assert!(buf.len() < PREFIX + MAX_LENGTH_FIELD as usize);
    }

    #[test]
    fn fast_sync_read_round_trips(
        datas in prop::collection::vec(prop::collection::vec(any::<u8>(), 4), 1..8),
        errors in prop::collection::vec(any::<u8>(), 8),
    ) {
        let entries: Vec<FastSyncReadEntry> = datas
            .into_iter()
            .enumerate()
            .map(|(k, data)| FastSyncReadEntry { id: k as u8 + 1, error: errors[k], data })
            .collect();
        let mut buf = encode_fast_sync_read(&entries).unwrap();
        let Ok(Decoded::Packet(packet)) = Dynamixel2.decode(&mut buf, Direction::FromServo) else {
            return Err(TestCaseError::fail("not decoded"));
        };
        prop_assert_eq!(parse_fast_sync_read(&packet, 4).unwrap(), entries);
    }
}
