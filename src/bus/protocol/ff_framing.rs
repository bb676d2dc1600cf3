//! The `FF FF ID LEN INST/ERR params CHK` framing, with its one-byte inverted-sum checksum:
//! Robotis Protocol 1.0's packet format, which Feetech SCS/STS took over ("FT-SCS"). Here, not
//! in a vendor's folder, so that every protocol of this format shares it: Feetech today,
//! Protocol 1.0 (AX-12) if it comes. Packet fields are single bytes, so the framing has no
//! byte order.

use super::packet::{seek_header, Decoded, Direction, Framing, Packet, PacketError, PacketKind};

/// The two bytes every packet starts with.
pub const HEADER: [u8; 2] = [0xFF, 0xFF];
/// The broadcast id: every servo takes the packet.
pub const BROADCAST_ID: u8 = 0xFE;
/// Highest id a servo answers with; the SDKs reject status packets from higher ids.
pub const MAX_DEVICE_ID: u8 = 0xFD;
/// The length byte counts the parameters plus INST/ERR and the checksum, and is one byte.
pub const MAX_PARAMS: usize = u8::MAX as usize - 2;
/// Status error bytes with bit 7 set do not exist; the SDKs treat them as noise.
pub const MAX_ERROR_BYTE: u8 = 0x7F;

/// Header, id and length.
pub(super) const PREFIX: usize = 4;

/// The inverted sum over id, length, instruction or error, and parameters.
pub fn checksum(bytes: &[u8]) -> u8 {
    !bytes.iter().fold(0u8, |sum, &b| sum.wrapping_add(b))
}

/// The framing `FF FF ID LEN INST/ERR params CHK`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FfFraming;

impl FfFraming {
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

impl Framing for FfFraming {
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
            let code = buf[PREFIX];
            let params = buf[PREFIX + 1..total - 1].to_vec();
            buf.drain(..total);
            let kind = match direction {
                Direction::ToServo => PacketKind::Instruction(code),
                Direction::FromServo => PacketKind::Status { error: code },
            };
            return Ok(Decoded::Packet(Packet { id, kind, params }));
        }
    }
}
