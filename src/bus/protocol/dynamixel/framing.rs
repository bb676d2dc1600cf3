//! Protocol 2.0 framing: `FF FF FD 00 ID LEN_L LEN_H INST params CRC_L CRC_H`, stuffed.

use super::crc::crc16;
use super::stuffing::{stuff, unstuff};
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
