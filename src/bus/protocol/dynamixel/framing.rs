//! Protocol 2.0 framing: `FF FF FD 00 ID LEN_L LEN_H INST params CRC_L CRC_H`, stuffed.

use super::crc::crc16;
use super::stuffing::{stuff_into, unstuff};
use super::{BROADCAST_ID, HEADER, MAX_DEVICE_ID, MAX_LENGTH_FIELD, MAX_PACKET, PREFIX, STATUS};
use crate::bus::protocol::packet::{
    seek_header, Decoded, Direction, Framing, Packet, PacketError, PacketKind,
};

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
    /// The packet whose region (unstuffed) is `head` (INST, or 0x55 ERR) then `params`, built
    /// in one buffer: the region is stuffed straight into it and the length field set after.
    fn encode_region(&self, id: u8, head: &[u8], params: &[u8]) -> Result<Vec<u8>, PacketError> {
        if !valid_id(id) {
            return Err(PacketError::Id { id });
        }
        let region = head.iter().chain(params).copied();
        let unstuffed = head.len() + params.len();
        // Stuffing adds at most one byte per three.
        let mut out = Vec::with_capacity(PREFIX + unstuffed + unstuffed / 3 + 2);
        out.extend_from_slice(&HEADER);
        out.push(id);
        out.extend_from_slice(&[0, 0]); // the length field, set once the region is in
        if is_unstuffed_status(id, head.first().copied()) {
            out.extend(region);
        } else {
            stuff_into(&mut out, region);
        }
        let region_len = out.len() - PREFIX;
        if PREFIX + region_len + 2 > MAX_PACKET {
            return Err(PacketError::TooLong {
                id,
                length: region_len,
                max: MAX_PACKET - PREFIX - 2,
            });
        }
        // Fits: the packet is at most 1024 bytes, so the length field fits a u16.
        let length = (region_len + 2) as u16;
        out[PREFIX - 2..PREFIX].copy_from_slice(&length.to_le_bytes());
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
        self.encode_region(id, &[instruction], params)
    }

    fn try_encode_status(&self, id: u8, error: u8, params: &[u8]) -> Result<Vec<u8>, PacketError> {
        self.encode_region(id, &[STATUS, error], params)
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
            let raw = &buf[PREFIX..total - 2];
            let region = if is_unstuffed_status(id, raw.first().copied()) {
                raw.to_vec()
            } else {
                unstuff(raw)
            };
            buf.drain(..total);
            return packet_from_region(id, length, region, direction);
        }
    }
}

/// The packet of an unstuffed `region` (INST params, or 0x55 ERR params); its buffer becomes
/// the packet's parameters.
fn packet_from_region(
    id: u8,
    length: u16,
    mut region: Vec<u8>,
    direction: Direction,
) -> Result<Decoded, PacketError> {
    let (found, kind, head) = match region[..] {
        [STATUS, error, ..] => (Direction::FromServo, PacketKind::Status { error }, 2),
        [STATUS] => return Err(PacketError::Length { id, length }),
        [instruction, ..] => (Direction::ToServo, PacketKind::Instruction(instruction), 1),
        [] => return Err(PacketError::Length { id, length }),
    };
    if found != direction {
        return Err(PacketError::Direction {
            id,
            expected: direction,
            found,
        });
    }
    region.drain(..head);
    Ok(Decoded::Packet(Packet {
        id,
        kind,
        params: region,
    }))
}
