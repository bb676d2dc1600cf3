//! Dynamixel Protocol 2.0: CRC-16, byte stuffing, packet framing, parameter layouts of the
//! instructions the drivers use, the status error byte and the Hardware Error Status register.
//!
//! Every layout here is from PROTOCOLS.md §1 (ROBOTIS e-Manual Protocol 2.0 and the ROBOTIS
//! Python SDK). Multi-byte fields are little-endian.

use super::packet::{
    append_sync_entries, seek_header, Decoded, Direction, Framing, Packet, PacketError, PacketKind,
};
use super::{AlarmBits, Alarms, BusError, PingInfo};

pub const PING: u8 = 0x01;
pub const READ: u8 = 0x02;
pub const WRITE: u8 = 0x03;
pub const REG_WRITE: u8 = 0x04;
pub const ACTION: u8 = 0x05;
pub const FACTORY_RESET: u8 = 0x06;
pub const REBOOT: u8 = 0x08;
pub const CLEAR: u8 = 0x10;
/// The instruction byte of every status packet.
pub const STATUS: u8 = 0x55;
pub const SYNC_READ: u8 = 0x82;
pub const SYNC_WRITE: u8 = 0x83;
pub const FAST_SYNC_READ: u8 = 0x8A;
pub const BULK_READ: u8 = 0x92;
pub const BULK_WRITE: u8 = 0x93;
pub const FAST_BULK_READ: u8 = 0x9A;

pub const BROADCAST_ID: u8 = 0xFE;
/// Highest device id; 0xFD and 0xFF are never used so that they cannot look like a header.
pub const MAX_DEVICE_ID: u8 = 0xFC;

/// Header and reserved byte.
pub const HEADER: [u8; 4] = [0xFF, 0xFF, 0xFD, 0x00];
/// Largest length field accepted on receive: the ROBOTIS SDK's receive buffer
/// (`RXPACKET_MAX_LEN`). A corrupted length beyond it must not make us wait for kilobytes.
pub const MAX_LENGTH_FIELD: u16 = 1024;
/// Largest whole packet we transmit: the ROBOTIS SDK's `TXPACKET_MAX_LEN`, so that nothing we
/// send is bigger than what the reference implementation would send.
pub const MAX_PACKET: usize = 1024;

/// Header, reserved, id and the two length bytes.
const PREFIX: usize = 7;

/// CRC-16 with polynomial 0x8005, MSB first, initial value 0, no final XOR (CRC-16/UMTS), one
/// table entry per value of the top byte.
const CRC_TABLE: [u16; 256] = {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x8005
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
};

/// Continues a CRC over more bytes.
pub fn crc16_update(mut crc: u16, data: &[u8]) -> u16 {
    for &byte in data {
        let index = ((crc >> 8) as u8 ^ byte) as usize;
        crc = (crc << 8) ^ CRC_TABLE[index];
    }
    crc
}

/// The packet CRC of `data` (everything from the header to the last parameter, as sent).
pub fn crc16(data: &[u8]) -> u16 {
    crc16_update(0, data)
}

/// Inserts 0xFD after every `FF FF FD` so that the header cannot appear inside a packet.
/// `region` is the instruction byte and the parameters (for a status: 0x55, ERR, parameters).
pub fn stuff(region: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(region.len() + region.len() / 3);
    for (i, &byte) in region.iter().enumerate() {
        out.push(byte);
        if byte == 0xFD && i >= 2 && region[i - 1] == 0xFF && region[i - 2] == 0xFF {
            out.push(0xFD);
        }
    }
    out
}

/// Reverses [`stuff`]: drops the 0xFD that follows each `FF FF FD` of the received bytes.
///
/// An `FF FF FD` not followed by 0xFD cannot come from a correct transmitter; the bytes are
/// kept as they are, as the ROBOTIS SDK does, because the CRC has already vouched for them.
pub fn unstuff(region: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(region.len());
    let mut i = 0;
    while i < region.len() {
        let byte = region[i];
        out.push(byte);
        let stuffed = byte == 0xFD
            && i >= 2
            && region[i - 1] == 0xFF
            && region[i - 2] == 0xFF
            && region.get(i + 1) == Some(&0xFD);
        i += if stuffed { 2 } else { 1 };
    }
    out
}

/// Fast Sync Read answers are one packet assembled by several servos; each servo appends its
/// block with a fixed, precomputed length, so the combined packet is not stuffed. The ROBOTIS
/// SDK accordingly skips `removeStuffing` for them (`rxPacket(port, fast_option=True)`); such
/// packets are the only status packets that carry the broadcast id.
fn is_unstuffed_status(id: u8, region_first: Option<u8>) -> bool {
    id == BROADCAST_ID && region_first == Some(STATUS)
}

fn valid_id(id: u8) -> bool {
    id <= MAX_DEVICE_ID || id == BROADCAST_ID
}

/// Dynamixel Protocol 2.0 framing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Dynamixel2;

impl Dynamixel2 {
    /// `region` is INST [ERR] params, unstuffed.
    fn encode_region(&self, id: u8, region: &[u8]) -> Result<Vec<u8>, PacketError> {
        if !valid_id(id) {
            return Err(PacketError::Id { id });
        }
        let region = if is_unstuffed_status(id, region.first().copied()) {
            region.to_vec()
        } else {
            stuff(region)
        };
        let total = PREFIX + region.len() + 2;
        if total > MAX_PACKET {
            return Err(PacketError::TooLong {
                id,
                length: region.len(),
                max: MAX_PACKET - PREFIX - 2,
            });
        }
        // Fits: total ≤ 1024, so the length field fits a u16.
        let length = (region.len() + 2) as u16;
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(&HEADER);
        out.push(id);
        out.extend_from_slice(&length.to_le_bytes());
        out.extend_from_slice(&region);
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        Ok(out)
    }
}

impl Framing for Dynamixel2 {
    fn broadcast_id(&self) -> u8 {
        BROADCAST_ID
    }

    fn try_encode_instruction(
        &self,
        id: u8,
        instruction: u8,
        params: &[u8],
    ) -> Result<Vec<u8>, PacketError> {
        if instruction == STATUS {
            return Err(PacketError::Malformed {
                id,
                detail: "0x55 is the status instruction, not one a controller sends".into(),
            });
        }
        let mut region = Vec::with_capacity(1 + params.len());
        region.push(instruction);
        region.extend_from_slice(params);
        self.encode_region(id, &region)
    }

    fn try_encode_status(&self, id: u8, error: u8, params: &[u8]) -> Result<Vec<u8>, PacketError> {
        let mut region = Vec::with_capacity(2 + params.len());
        region.push(STATUS);
        region.push(error);
        region.extend_from_slice(params);
        self.encode_region(id, &region)
    }

    fn decode(&self, buf: &mut Vec<u8>, direction: Direction) -> Result<Decoded, PacketError> {
        loop {
            if !seek_header(buf, &HEADER[..3]) || buf.len() < 4 {
                return Ok(Decoded::NeedMore);
            }
            match buf[3] {
                0x00 => {}
                // `FF FF FD FD` is stuffed data inside some packet we did not see the start of.
                0xFD => {
                    buf.drain(..1);
                    continue;
                }
                value => {
                    buf.drain(..1);
                    return Err(PacketError::Reserved { value });
                }
            }
            if buf.len() < PREFIX {
                return Ok(Decoded::NeedMore);
            }
            let id = buf[4];
            if !valid_id(id) {
                buf.drain(..1);
                return Err(PacketError::Id { id });
            }
            let length = u16::from_le_bytes([buf[5], buf[6]]);
            // At least INST and the CRC.
            if !(3..=MAX_LENGTH_FIELD).contains(&length) {
                buf.drain(..1);
                return Err(PacketError::Length { id, length });
            }
            let total = PREFIX + length as usize;
            if buf.len() < total {
                return Ok(Decoded::NeedMore);
            }
            let expected = crc16(&buf[..total - 2]);
            let found = u16::from_le_bytes([buf[total - 2], buf[total - 1]]);
            if expected != found {
                // Only the first byte goes: the length may be what was damaged, and the next
                // good packet may start inside the span it claims.
                buf.drain(..1);
                return Err(PacketError::Checksum {
                    id,
                    expected,
                    found,
                });
            }
            let bytes: Vec<u8> = buf.drain(..total).collect();
            let raw = &bytes[PREFIX..total - 2];
            let region = if is_unstuffed_status(id, raw.first().copied()) {
                raw.to_vec()
            } else {
                unstuff(raw)
            };
            return packet_from_region(id, length, &region, direction);
        }
    }
}

fn packet_from_region(
    id: u8,
    length: u16,
    region: &[u8],
    direction: Direction,
) -> Result<Decoded, PacketError> {
    let (found, kind, params) = match region {
        [STATUS, error, params @ ..] => (
            Direction::FromServo,
            PacketKind::Status { error: *error },
            params,
        ),
        [STATUS] => return Err(PacketError::Length { id, length }),
        [instruction, params @ ..] => (
            Direction::ToServo,
            PacketKind::Instruction(*instruction),
            params,
        ),
        [] => return Err(PacketError::Length { id, length }),
    };
    if found != direction {
        return Err(PacketError::Direction {
            id,
            expected: direction,
            found,
        });
    }
    Ok(Decoded::Packet(Packet {
        id,
        kind,
        params: params.to_vec(),
    }))
}

/// READ parameters: address and length.
pub fn read_params(address: u16, length: u16) -> Vec<u8> {
    let mut params = Vec::with_capacity(4);
    params.extend_from_slice(&address.to_le_bytes());
    params.extend_from_slice(&length.to_le_bytes());
    params
}

/// WRITE parameters: address, then the data.
pub fn write_params(address: u16, data: &[u8]) -> Vec<u8> {
    let mut params = Vec::with_capacity(2 + data.len());
    params.extend_from_slice(&address.to_le_bytes());
    params.extend_from_slice(data);
    params
}

/// SYNC READ and FAST SYNC READ parameters (both share this layout): address, length, ids.
/// Send to [`BROADCAST_ID`].
pub fn sync_read_params(address: u16, length: u16, ids: &[u8]) -> Vec<u8> {
    let mut params = read_params(address, length);
    params.extend_from_slice(ids);
    params
}

/// SYNC WRITE parameters: address, length, then each id with exactly `length` bytes of data.
/// Send to [`BROADCAST_ID`].
pub fn sync_write_params(
    address: u16,
    length: u16,
    entries: &[(u8, Vec<u8>)],
) -> Result<Vec<u8>, PacketError> {
    let mut params = read_params(address, length);
    append_sync_entries(&mut params, usize::from(length), entries)?;
    Ok(params)
}

/// Status parameters of a ping answer: model number and firmware version.
pub fn ping_answer_params(model_number: u16, firmware: u8) -> Vec<u8> {
    let [lo, hi] = model_number.to_le_bytes();
    vec![lo, hi, firmware]
}

/// The model number and firmware version in a ping answer.
pub fn parse_ping_answer(packet: &Packet) -> Result<PingInfo, PacketError> {
    match (packet.kind, packet.params.as_slice()) {
        (PacketKind::Status { .. }, &[lo, hi, firmware]) => Ok(PingInfo {
            id: packet.id,
            model_number: u16::from_le_bytes([lo, hi]),
            firmware: Some(firmware),
            // Which alarms an Alert bit stands for takes a register read: the driver's part.
            alarms: super::Alarms::default(),
        }),
        (PacketKind::Status { .. }, params) => Err(PacketError::Malformed {
            id: packet.id,
            detail: format!(
                "a ping answer carries 3 bytes (model number, firmware), not {}",
                params.len()
            ),
        }),
        (PacketKind::Instruction(code), _) => Err(PacketError::Malformed {
            id: packet.id,
            detail: format!("instruction {code:#04x} where a ping answer was expected"),
        }),
    }
}

/// One servo's part of a Fast Sync Read answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FastSyncReadEntry {
    pub id: u8,
    /// The servo's status error byte.
    pub error: u8,
    pub data: Vec<u8>,
}

/// Splits a Fast Sync Read answer (one status packet from [`BROADCAST_ID`]) into its servos'
/// blocks. On the wire each block is `ERR ID DATA(length) CRC(2)`; in the decoded packet the
/// first ERR is the status error byte and the last CRC is the packet CRC, so the parameters are
/// `ID DATA CRC | ERR ID DATA CRC | … | ERR ID DATA`.
///
/// The per-block CRCs are skipped unchecked, as the ROBOTIS SDK does: the packet CRC already
/// covers every byte.
pub fn parse_fast_sync_read(
    packet: &Packet,
    length: u16,
) -> Result<Vec<FastSyncReadEntry>, PacketError> {
    let id = packet.id;
    let Some(first_error) = packet.error() else {
        return Err(PacketError::Malformed {
            id,
            detail: "an instruction packet where a fast sync read answer was expected".into(),
        });
    };
    let data_len = length as usize;
    let block = data_len + 4;
    // The decoded packet lacks the first ERR and the last CRC of the wire blocks.
    let wire_len = packet.params.len() + 3;
    if wire_len % block != 0 {
        return Err(PacketError::Malformed {
            id,
            detail: format!(
                "{} parameter bytes do not split into blocks of {} data bytes",
                packet.params.len(),
                data_len
            ),
        });
    }
    let count = wire_len / block;
    let mut entries = Vec::with_capacity(count);
    for k in 0..count {
        let truncated = || PacketError::Malformed {
            id,
            detail: format!("fast sync read block {k} is truncated"),
        };
        // Block k ≥ 1 starts (ERR) at k·block on the wire, one less in the parameters.
        let (error, id_at) = if k == 0 {
            (first_error, 0)
        } else {
            let error_at = k * block - 1;
            let error = *packet.params.get(error_at).ok_or_else(truncated)?;
            (error, error_at + 1)
        };
        let servo = *packet.params.get(id_at).ok_or_else(truncated)?;
        let data = packet
            .params
            .get(id_at + 1..id_at + 1 + data_len)
            .ok_or_else(truncated)?;
        entries.push(FastSyncReadEntry {
            id: servo,
            error,
            data: data.to_vec(),
        });
    }
    Ok(entries)
}

/// The whole Fast Sync Read answer packet for `entries` (what an emulated bus sends). Each
/// block's CRC is the running CRC of every byte before it, so the last one is the packet CRC,
/// as the layout requires. Not stuffed, like the real answer (see [`parse_fast_sync_read`]).
pub fn encode_fast_sync_read(entries: &[FastSyncReadEntry]) -> Result<Vec<u8>, PacketError> {
    let Some(first) = entries.first() else {
        return Err(PacketError::Malformed {
            id: BROADCAST_ID,
            detail: "a fast sync read answer needs at least one servo".into(),
        });
    };
    let data_len = first.data.len();
    for entry in entries {
        if entry.id > MAX_DEVICE_ID {
            return Err(PacketError::Id { id: entry.id });
        }
        if entry.data.len() != data_len {
            return Err(PacketError::DataLength {
                id: entry.id,
                expected: data_len,
                found: entry.data.len(),
            });
        }
    }
    let region_len = 1 + entries.len() * (data_len + 4);
    if PREFIX + region_len > MAX_PACKET {
        return Err(PacketError::TooLong {
            id: BROADCAST_ID,
            length: region_len - 2,
            max: MAX_PACKET - PREFIX - 2,
        });
    }
    let mut out = Vec::with_capacity(PREFIX + region_len);
    out.extend_from_slice(&HEADER);
    out.push(BROADCAST_ID);
    out.extend_from_slice(&(region_len as u16).to_le_bytes());
    out.push(STATUS);
    for entry in entries {
        out.push(entry.error);
        out.push(entry.id);
        out.extend_from_slice(&entry.data);
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_le_bytes());
    }
    Ok(out)
}

/// The error number in bits 6..0 of a status error byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ErrorNumber {
    #[error("result fail: the servo could not process the instruction")]
    ResultFail,
    #[error("instruction error: undefined instruction, or Action without Reg Write")]
    Instruction,
    #[error("CRC error: the servo received a corrupted packet")]
    Crc,
    #[error("data range error: the data is out of the register's range")]
    DataRange,
    #[error("data length error: the data is shorter than the register")]
    DataLength,
    #[error("data limit error: the data exceeds a limit register")]
    DataLimit,
    #[error("access error: the register is read-only, or EEPROM while torque is on")]
    Access,
    #[error("unknown error number {0:#04x}")]
    Unknown(u8),
}

impl ErrorNumber {
    /// `None` for 0 (no error).
    pub fn from_number(number: u8) -> Option<ErrorNumber> {
        Some(match number {
            0 => return None,
            1 => ErrorNumber::ResultFail,
            2 => ErrorNumber::Instruction,
            3 => ErrorNumber::Crc,
            4 => ErrorNumber::DataRange,
            5 => ErrorNumber::DataLength,
            6 => ErrorNumber::DataLimit,
            7 => ErrorNumber::Access,
            other => ErrorNumber::Unknown(other),
        })
    }

    pub fn number(self) -> u8 {
        match self {
            ErrorNumber::ResultFail => 1,
            ErrorNumber::Instruction => 2,
            ErrorNumber::Crc => 3,
            ErrorNumber::DataRange => 4,
            ErrorNumber::DataLength => 5,
            ErrorNumber::DataLimit => 6,
            ErrorNumber::Access => 7,
            ErrorNumber::Unknown(n) => n,
        }
    }
}

/// A status packet's ERR byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StatusByte {
    /// The servo has a hardware error; read [`HARDWARE_ERROR_STATUS`] for which.
    pub alert: bool,
    /// Why the instruction was refused, if it was.
    pub error: Option<ErrorNumber>,
}

pub const ALERT_BIT: u8 = 0x80;

impl StatusByte {
    pub fn parse(byte: u8) -> StatusByte {
        StatusByte {
            alert: byte & ALERT_BIT != 0,
            error: ErrorNumber::from_number(byte & !ALERT_BIT),
        }
    }

    pub fn to_byte(self) -> u8 {
        let number = self.error.map_or(0, |e| e.number() & !ALERT_BIT);
        if self.alert {
            number | ALERT_BIT
        } else {
            number
        }
    }

    /// The refusal as a bus error. The alert bit alone is not a refusal: the instruction was
    /// carried out, and the cause is in the Hardware Error Status register.
    pub fn refusal(self, id: u8) -> Option<BusError> {
        self.error.map(|e| BusError::Refused {
            id,
            reason: e.to_string(),
        })
    }
}

/// Address of the X series Hardware Error Status register.
pub const HARDWARE_ERROR_STATUS: u16 = 70;
pub const HW_INPUT_VOLTAGE: u8 = 1 << 0;
pub const HW_OVERHEATING: u8 = 1 << 2;
pub const HW_MOTOR_ENCODER: u8 = 1 << 3;
pub const HW_ELECTRICAL_SHOCK: u8 = 1 << 4;
pub const HW_OVERLOAD: u8 = 1 << 5;

/// Hardware Error Status bits (bits 1, 6 and 7 are unused).
pub const HARDWARE_ERROR_BITS: AlarmBits = AlarmBits {
    input_voltage: HW_INPUT_VOLTAGE,
    overheating: HW_OVERHEATING,
    encoder: HW_MOTOR_ENCODER,
    electrical: HW_ELECTRICAL_SHOCK,
    overload: HW_OVERLOAD,
};

/// The alarms in a Hardware Error Status value.
pub fn hardware_error_alarms(bits: u8) -> Alarms {
    HARDWARE_ERROR_BITS.decode(bits)
}

/// The Hardware Error Status value an emulated servo reports for `alarms`.
pub fn hardware_error_bits(alarms: &Alarms) -> u8 {
    HARDWARE_ERROR_BITS.encode(alarms)
}

#[cfg(test)]
mod tests {
    use super::*;
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
        crate::bus::packet::test_support::decode_all(&Dynamixel2, buf, direction)
    }

    use crate::bus::packet::test_support::packets;

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
            0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x08, 0x00, 0x55, 0x00, 0xA6, 0x00, 0x00, 0x00, 0x8C,
            0xC0,
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
        0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x0A, 0x00, 0x03, 0x74, 0x00, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF,
        0x23, 0xE5,
    ];

    #[test]
    fn negative_extended_position_is_stuffed() {
        let data = (-131073i32).to_le_bytes();
        assert_eq!(data, [0xFF, 0xFF, 0xFD, 0xFF]);
        let bytes = Dynamixel2.encode_instruction(1, WRITE, &write_params(116, &data));
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
        assert_eq!(read_params(132, 4), [0x84, 0x00, 0x04, 0x00]);
        assert_eq!(write_params(64, &[1]), [0x40, 0x00, 0x01]);
        assert_eq!(
            sync_read_params(132, 4, &[1, 2]),
            [0x84, 0x00, 0x04, 0x00, 1, 2]
        );
        assert_eq!(
            sync_write_params(116, 4, &[(1, vec![0, 8, 0, 0]), (2, vec![0xFF; 4])]).unwrap(),
            [0x74, 0x00, 0x04, 0x00, 1, 0, 8, 0, 0, 2, 0xFF, 0xFF, 0xFF, 0xFF]
        );
        assert_eq!(
            sync_write_params(116, 4, &[(3, vec![0; 2])]),
            Err(PacketError::DataLength {
                id: 3,
                expected: 4,
                found: 2
            })
        );
    }

    #[test]
    fn sync_write_packet_size_matches_the_wire_budget() {
        // PROTOCOLS.md §3: goal positions of 6 servos in one sync write are 44 bytes.
        let entries: Vec<(u8, Vec<u8>)> = (1..=6).map(|id| (id, vec![0, 8, 0, 0])).collect();
        let params = sync_write_params(116, 4, &entries).unwrap();
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
        // 3 servos × (4 + 4) + INST = 25, the length of PROTOCOLS.md's "(data_length + 4) ×
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
            let (found, expected) = crate::bus::packet::test_support::between_garbage(
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
}
