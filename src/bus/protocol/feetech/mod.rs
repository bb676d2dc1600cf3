//! Feetech SCS/STS protocol ("FT-SCS", the Dynamixel 1.0 packet format): instruction codes,
//! parameter layouts, the two series, the status byte (`status`), the codec (`codec`) and the
//! firmware's rules (`firmware`). The framing, with its one-byte inverted-sum checksum, is the
//! shared FF FF one (`protocol::ff_framing`).
//!
//! From the Feetech protocol manual and STS3215 memory table and the `scservo_sdk` Python SDK;
//! see also docs/protocols.md. Packet fields are single bytes, so framing has no byte order;
//! register values do, and it depends on the series ([`Series`]).

mod codec;
mod firmware;
mod status;
#[cfg(test)]
mod tests;

/// Feetech's packets are the FF FF framing, its limits and its checksum.
pub use super::ff_framing::{
    checksum, FfFraming as Feetech, BROADCAST_ID, HEADER, MAX_DEVICE_ID, MAX_ERROR_BYTE, MAX_PARAMS,
};
pub use firmware::StsFirmware;
pub use status::{status_alarms, status_bits};

use super::Fields;

/// Instruction PING: is the servo there.
pub const PING: u8 = 0x01;
/// Instruction READ: bytes of the memory table.
pub const READ: u8 = 0x02;
/// Instruction WRITE: bytes into the memory table.
pub const WRITE: u8 = 0x03;
/// Instruction REG WRITE: a write held until ACTION.
pub const REG_WRITE: u8 = 0x04;
/// Instruction ACTION: carry out the held REG WRITEs.
pub const ACTION: u8 = 0x05;
/// Instruction SYNC READ: one block of several servos, an answer each. STS/SMS only; SCS
/// servos do not answer it.
pub const SYNC_READ: u8 = 0x82;
/// Instruction SYNC WRITE: one block into several servos, no answer.
pub const SYNC_WRITE: u8 = 0x83;

/// The two Feetech families, which differ in byte order and in which instructions they know.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Series {
    /// Magnetic-encoder STS/SMS servos ("protocol 0" in the SDK): little-endian, sign-magnitude
    /// negatives, Sync Read supported.
    StsSms,
    /// Potentiometer SCS servos ("protocol 1"): big-endian, no Sync Read.
    Scs,
}

/// The STS/SMS codec.
pub static STS: Series = Series::StsSms;
/// The SCS codec.
pub static SCS: Series = Series::Scs;

/// Addresses and lengths are one byte.
pub const FIELDS: Fields = Fields::NARROW;
