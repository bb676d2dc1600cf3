//! Dynamixel Protocol 2.0: instruction codes, ids and limits, the ping answer, and the codec
//! the driver and the emulated servos use (`codec`). The framing (`framing`) rests on the CRC
//! (`crc`) and byte stuffing (`stuffing`); `fast_sync_read` is the one combined answer, `bulk`
//! the Bulk Read and Bulk Write parameters, `status`
//! the status error byte and the Hardware Error Status register.
//!
//! Layouts are from the ROBOTIS e-Manual (Protocol 2.0) and the ROBOTIS Python SDK
//! (`dynamixel_sdk`); see also docs/protocols.md. Multi-byte fields are little-endian.

mod bulk;
mod codec;
mod crc;
mod fast_sync_read;
mod firmware;
mod framing;
mod status;
mod stuffing;
#[cfg(test)]
mod tests;

pub use bulk::{
    encode_bulk_read, encode_bulk_write, parse_bulk_read, parse_bulk_write, BulkRead, BulkWrite,
};
pub use crc::{crc16, crc16_update};
pub use fast_sync_read::{encode_fast_sync_read, parse_fast_sync_read, FastSyncReadEntry};
pub use firmware::XSeriesFirmware;
pub use framing::Dynamixel2;
pub use status::{hardware_error_alarms, hardware_error_bits, ErrorNumber, StatusByte, ALERT_BIT};
pub use stuffing::{stuff, unstuff};

use super::packet::{Packet, PacketError, PacketKind};
use super::Fields;
use crate::bus::PingInfo;

/// Instruction PING: is the servo there, and what model.
pub const PING: u8 = 0x01;
/// Instruction READ: bytes of the control table.
pub const READ: u8 = 0x02;
/// Instruction WRITE: bytes into the control table.
pub const WRITE: u8 = 0x03;
/// Instruction REG WRITE: a write held until ACTION.
pub const REG_WRITE: u8 = 0x04;
/// Instruction ACTION: carry out the held REG WRITEs.
pub const ACTION: u8 = 0x05;
/// Instruction FACTORY RESET.
pub const FACTORY_RESET: u8 = 0x06;
/// Instruction REBOOT: the only way out of a hardware-error shutdown.
pub const REBOOT: u8 = 0x08;
/// Instruction CLEAR: resets the multi-turn count or clears errors.
pub const CLEAR: u8 = 0x10;
/// The instruction byte of every status packet.
pub const STATUS: u8 = 0x55;
/// Instruction SYNC READ: one block of several servos, an answer each.
pub const SYNC_READ: u8 = 0x82;
/// Instruction SYNC WRITE: one block into several servos, no answer.
pub const SYNC_WRITE: u8 = 0x83;
/// Instruction FAST SYNC READ: one block of several servos in one combined answer.
pub const FAST_SYNC_READ: u8 = 0x8A;
/// Instruction BULK READ: a block of its own from each servo.
pub const BULK_READ: u8 = 0x92;
/// Instruction BULK WRITE: a block of its own into each servo.
pub const BULK_WRITE: u8 = 0x93;
/// Instruction FAST BULK READ: bulk read in one combined answer.
pub const FAST_BULK_READ: u8 = 0x9A;

/// The broadcast id: every servo takes the packet.
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

/// Addresses and lengths are two bytes, little-endian.
pub const FIELDS: Fields = Fields::WIDE;

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
            alarms: crate::bus::Alarms::default(),
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
