//! Feetech SCS/STS protocol ("FT-SCS", the Dynamixel 1.0 packet format): instruction codes,
//! parameter layouts, the two series, the status byte (`status`), the framing with its
//! one-byte inverted-sum checksum (`framing`) and the codec (`codec`).
//!
//! From the Feetech protocol manual and STS3215 memory table and the `scservo_sdk` Python SDK;
//! see also docs/protocols.md. Packet fields are single bytes, so framing has no byte order;
//! register values do, and it depends on the series ([`Series`]).

mod codec;
mod framing;
mod status;
#[cfg(test)]
mod tests;

pub use framing::{checksum, Feetech};
pub use status::{
    status_alarms, status_bits, ERR_ANGLE_SENSOR, ERR_OVERHEAT, ERR_OVERLOAD, ERR_OVER_CURRENT,
    ERR_VOLTAGE, STATUS_BITS,
};

use super::Fields;

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
