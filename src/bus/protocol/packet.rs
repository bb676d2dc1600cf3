//! Framing vocabulary shared by the Dynamixel 2.0 and Feetech codecs: what a packet is once the
//! header, length and checksum are gone, and the [`Framing`] trait that turns packets into bytes
//! and a byte stream back into packets.
//!
//! Decoding is incremental and resynchronising. A serial line delivers partial packets, echoes,
//! power-on glitches and bit errors; the decoder is fed whatever has arrived, takes what it can
//! from the front of the buffer and never waits on a header that cannot be real. Every call that
//! does not return [`Decoded::NeedMore`] removes at least one byte, so a caller that loops until
//! `NeedMore` always terminates.

use crate::bus::BusError;
use std::fmt;

/// Which way a packet travels. Feetech instruction and status packets share one layout and can
/// only be told apart by direction; Dynamixel marks status packets with instruction 0x55 but
/// the direction still says which of the two the reader expects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From the controller to the servos: instruction packets (what an emulated servo reads).
    ToServo,
    /// From a servo to the controller: status packets (what the driver reads).
    FromServo,
}

/// What a packet carries besides its id and parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PacketKind {
    /// An instruction code (PING, READ, WRITE, …).
    Instruction(u8),
    /// A status answer with the servo's error byte, whose meaning is vendor-specific.
    Status {
        /// The error byte.
        error: u8,
    },
}

/// One packet with the framing removed. `params` are unstuffed (Dynamixel) and exclude the
/// Dynamixel status instruction 0x55 and the error byte, which live in `kind`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packet {
    /// The servo addressed, or the one answering.
    pub id: u8,
    /// An instruction, or a status with its error byte.
    pub kind: PacketKind,
    /// The parameters (instruction) or data (status).
    pub params: Vec<u8>,
}

impl Packet {
    /// An instruction packet to servo `id`.
    pub fn instruction(id: u8, instruction: u8, params: Vec<u8>) -> Packet {
        Packet {
            id,
            kind: PacketKind::Instruction(instruction),
            params,
        }
    }

    /// A status packet from servo `id` with its error byte.
    pub fn status(id: u8, error: u8, params: Vec<u8>) -> Packet {
        Packet {
            id,
            kind: PacketKind::Status { error },
            params,
        }
    }

    /// The error byte of a status packet.
    pub fn error(&self) -> Option<u8> {
        match self.kind {
            PacketKind::Status { error } => Some(error),
            PacketKind::Instruction(_) => None,
        }
    }

    /// The instruction code of an instruction packet.
    pub fn instruction_code(&self) -> Option<u8> {
        match self.kind {
            PacketKind::Instruction(code) => Some(code),
            PacketKind::Status { .. } => None,
        }
    }

    /// The data of a status answer that must carry exactly `len` bytes, e.g. a READ answer.
    pub fn status_data(&self, len: usize) -> Result<&[u8], PacketError> {
        match self.kind {
            PacketKind::Status { .. } if self.params.len() == len => Ok(&self.params),
            PacketKind::Status { .. } => Err(PacketError::DataLength {
                id: self.id,
                expected: len,
                found: self.params.len(),
            }),
            PacketKind::Instruction(code) => Err(PacketError::Malformed {
                id: self.id,
                detail: format!("instruction {code:#04x} where a status answer was expected"),
            }),
        }
    }
}

/// The outcome of one successful decoding step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    /// A complete packet, removed from the front of the buffer.
    Packet(Packet),
    /// No complete packet at the front of the buffer yet; what is left is the start of one (or
    /// a possible start of a header) and must be kept for the next call.
    NeedMore,
}

/// A corrupt packet, an impossible header, or a packet that cannot be built.
///
/// On decoding, every error has already removed bytes from the buffer: keep calling
/// [`Framing::decode`] to continue the search behind it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PacketError {
    /// The checksum (Feetech, one byte) or CRC-16 (Dynamixel) does not match the bytes.
    #[error("packet for id {id}: bad checksum (computed {expected:#06x}, received {found:#06x})")]
    Checksum {
        /// The id in the packet.
        id: u8,
        /// The checksum computed over its bytes.
        expected: u16,
        /// The checksum it carries.
        found: u16,
    },
    /// The length field cannot belong to a real packet (too short for the mandatory fields, or
    /// longer than any receiver buffers).
    #[error("packet for id {id}: impossible length field {length}")]
    Length {
        /// The id in the packet.
        id: u8,
        /// The length field's value.
        length: u16,
    },
    /// The id byte is one the protocol never uses in this direction.
    #[error("packet with impossible id {id:#04x}")]
    Id {
        /// The id byte.
        id: u8,
    },
    /// Dynamixel: the reserved byte after the header is not 0x00.
    #[error("packet header with reserved byte {value:#04x} instead of 0x00")]
    Reserved {
        /// The reserved byte's value.
        value: u8,
    },
    /// Feetech: a status error byte with bit 7 set, which no servo sends.
    #[error("status packet from id {id}: impossible error byte {error:#04x}")]
    ErrorByte {
        /// The id in the packet.
        id: u8,
        /// The error byte.
        error: u8,
    },
    /// A well-formed packet travelling the other way (an instruction where a status was
    /// expected, e.g. the echo of our own transmission on a half-duplex line, or vice versa).
    #[error("packet for id {id}: {found} where {expected} was expected")]
    Direction {
        /// The id in the packet.
        id: u8,
        /// The direction the reader expected.
        expected: Direction,
        /// The packet's.
        found: Direction,
    },
    /// The parameters do not have the layout the instruction or answer calls for.
    #[error("packet for id {id}: {detail}")]
    Malformed {
        /// The id in the packet.
        id: u8,
        /// What is wrong with the layout.
        detail: String,
    },
    /// A per-servo data block of a sync write (or a fast-sync-read answer) has the wrong size.
    #[error("data for id {id}: {found} bytes where the register block has {expected}")]
    DataLength {
        /// The servo the block belongs to.
        id: u8,
        /// The register block's size, bytes.
        expected: usize,
        /// The block's size, bytes.
        found: usize,
    },
    /// Encoding: an address or length does not fit the protocol's one-byte field (Feetech).
    #[error("{value} does not fit a one-byte address or length field")]
    FieldWidth {
        /// The address or length.
        value: u16,
    },
    /// Encoding: the packet would not fit the length field or the receivers' buffers.
    #[error("packet for id {id}: {length} bytes of instruction and parameters exceed the limit of {max}")]
    TooLong {
        /// The servo addressed.
        id: u8,
        /// Bytes of instruction and parameters.
        length: usize,
        /// The most the protocol allows.
        max: usize,
    },
}

impl PacketError {
    /// The servo id the error is about, as far as the damaged bytes tell.
    pub fn id(&self) -> Option<u8> {
        match self {
            PacketError::Checksum { id, .. }
            | PacketError::Length { id, .. }
            | PacketError::Id { id }
            | PacketError::ErrorByte { id, .. }
            | PacketError::Direction { id, .. }
            | PacketError::Malformed { id, .. }
            | PacketError::DataLength { id, .. }
            | PacketError::TooLong { id, .. } => Some(*id),
            PacketError::Reserved { .. } | PacketError::FieldWidth { .. } => None,
        }
    }

    /// The bus error for a transaction whose answer from servo `awaited` was damaged. The id
    /// in the damaged bytes is not trusted: it may be the damaged byte.
    pub fn corrupt_answer(&self, awaited: u8) -> BusError {
        BusError::corrupt(awaited, self.clone())
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Direction::ToServo => "an instruction packet",
            Direction::FromServo => "a status packet",
        })
    }
}

/// A vendor's packet format.
///
/// The trait is object safe, so a driver can hold a `Box<dyn Framing>` chosen from the robot
/// file's protocol.
pub trait Framing {
    /// The id every servo listens to.
    fn broadcast_id(&self) -> u8;

    /// The bytes of an instruction packet, or why it cannot be sent.
    fn try_encode_instruction(
        &self,
        id: u8,
        instruction: u8,
        params: &[u8],
    ) -> Result<Vec<u8>, PacketError>;

    /// The bytes of a status packet (what an emulated servo answers), or why it cannot be sent.
    fn try_encode_status(&self, id: u8, error: u8, params: &[u8]) -> Result<Vec<u8>, PacketError>;

    /// Takes bytes from the front of `buf`, removing what it consumed including skipped
    /// garbage, and returns the first packet travelling in `direction`.
    ///
    /// `Err` reports a corrupt packet or an impossible header; only its first byte has been
    /// removed (a damaged length field must not swallow the good packet behind it), so call
    /// again to resume the search.
    fn decode(&self, buf: &mut Vec<u8>, direction: Direction) -> Result<Decoded, PacketError>;

    /// Like [`Framing::try_encode_instruction`], for packets known to fit.
    ///
    /// # Panics
    /// When the parameters exceed the protocol's length limit (253 bytes on Feetech, about
    /// 1000 on Dynamixel). Use the `try_` form when the size depends on input, e.g. a sync
    /// write over a user-given number of servos.
    fn encode_instruction(&self, id: u8, instruction: u8, params: &[u8]) -> Vec<u8> {
        match self.try_encode_instruction(id, instruction, params) {
            Ok(bytes) => bytes,
            Err(e) => panic!("{e}"),
        }
    }

    /// Like [`Framing::try_encode_status`], for packets known to fit.
    ///
    /// # Panics
    /// When the parameters exceed the protocol's length limit.
    fn encode_status(&self, id: u8, error: u8, params: &[u8]) -> Vec<u8> {
        match self.try_encode_status(id, error, params) {
            Ok(bytes) => bytes,
            Err(e) => panic!("{e}"),
        }
    }

    /// Either kind of packet.
    fn encode(&self, packet: &Packet) -> Result<Vec<u8>, PacketError> {
        match packet.kind {
            PacketKind::Instruction(code) => {
                self.try_encode_instruction(packet.id, code, &packet.params)
            }
            PacketKind::Status { error } => {
                self.try_encode_status(packet.id, error, &packet.params)
            }
        }
    }
}

/// Drops everything before the first occurrence of `header` in `buf`, or, when there is none,
/// everything except a tail that could still grow into one. Returns whether a header now starts
/// the buffer.
pub(crate) fn seek_header(buf: &mut Vec<u8>, header: &[u8]) -> bool {
    if let Some(start) = buf.windows(header.len()).position(|w| w == header) {
        buf.drain(..start);
        return true;
    }
    // Keep the longest suffix that is a proper prefix of the header: the rest of it may be in
    // the next read.
    let keep = (1..header.len())
        .rev()
        .find(|&n| buf.len() >= n && buf[buf.len() - n..] == header[..n])
        .unwrap_or(0);
    let drop = buf.len() - keep;
    buf.drain(..drop);
    false
}

/// Decoding helpers the codecs' tests share.
#[cfg(test)]
pub(crate) mod test_support {
    use super::{Decoded, Direction, Framing, Packet, PacketError};

    /// Every result `framing` decodes from `buf` until it needs more bytes. Panics if a step
    /// consumes nothing: the driver's receive loop would spin on such input.
    pub fn decode_all(
        framing: &dyn Framing,
        buf: &mut Vec<u8>,
        direction: Direction,
    ) -> Vec<Result<Packet, PacketError>> {
        let mut out = Vec::new();
        loop {
            let before = buf.len();
            match framing.decode(buf, direction) {
                Ok(Decoded::NeedMore) => return out,
                Ok(Decoded::Packet(p)) => out.push(Ok(p)),
                Err(e) => out.push(Err(e)),
            }
            assert!(buf.len() < before, "a decoding step consumed nothing");
        }
    }

    /// Decodes garbage, `tail_ff` bytes of 0xFF (a header's start), a status packet from servo
    /// 1, garbage, one from servo 2, garbage: returns what was found and the two packets that
    /// should have been.
    pub fn between_garbage(
        framing: &dyn Framing,
        garbage: &[Vec<u8>],
        params: &[Vec<u8>],
        tail_ff: usize,
    ) -> (Vec<Packet>, Vec<Packet>) {
        let mut buf = garbage[0].clone();
        buf.extend(std::iter::repeat_n(0xFF, tail_ff));
        buf.extend(framing.encode_status(1, 0, &params[0]));
        buf.extend(&garbage[1]);
        buf.extend(framing.encode_status(2, 0, &params[1]));
        buf.extend(&garbage[2]);
        let found = packets(decode_all(framing, &mut buf, Direction::FromServo));
        let expected = vec![
            Packet::status(1, 0, params[0].clone()),
            Packet::status(2, 0, params[1].clone()),
        ];
        (found, expected)
    }

    /// The packets among decoding results.
    pub fn packets(results: Vec<Result<Packet, PacketError>>) -> Vec<Packet> {
        results.into_iter().filter_map(Result::ok).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seek_header_drops_garbage_before_the_header() {
        let mut buf = vec![1, 2, 0xFF, 3, 0xFF, 0xFF, 0xFD, 9];
        assert!(seek_header(&mut buf, &[0xFF, 0xFF, 0xFD]));
        assert_eq!(buf, [0xFF, 0xFF, 0xFD, 9]);
    }

    #[test]
    fn seek_header_keeps_a_possible_header_start() {
        let mut buf = vec![1, 2, 0xFF, 0xFF];
        assert!(!seek_header(&mut buf, &[0xFF, 0xFF, 0xFD]));
        assert_eq!(buf, [0xFF, 0xFF]);

        let mut buf = vec![1, 0xFF, 0xFF, 0x00];
        assert!(!seek_header(&mut buf, &[0xFF, 0xFF, 0xFD]));
        assert!(buf.is_empty());

        let mut buf = vec![];
        assert!(!seek_header(&mut buf, &[0xFF, 0xFF]));
        assert!(buf.is_empty());
    }

    #[test]
    fn corrupt_answer_names_the_awaited_servo() {
        let e = PacketError::Checksum {
            id: 0x13,
            expected: 1,
            found: 2,
        };
        assert!(matches!(
            e.corrupt_answer(3),
            BusError::Corrupt {
                id: 3,
                source: crate::bus::CorruptAnswer::Packet(PacketError::Checksum { .. })
            }
        ));
    }

    #[test]
    fn packet_accessors() {
        let p = Packet::status(3, 0x80, vec![1]);
        assert_eq!(p.error(), Some(0x80));
        assert_eq!(p.instruction_code(), None);
        let p = Packet::instruction(3, 0x02, vec![]);
        assert_eq!(p.instruction_code(), Some(0x02));
        assert_eq!(p.error(), None);
    }
}
