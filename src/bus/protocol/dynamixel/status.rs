//! The status packet's ERR byte (alert bit and error number) and the X series Hardware Error
//! Status register (ROBOTIS e-Manual, Protocol 2.0 "Status Packet" and the X series control
//! tables, address 70).

use crate::bus::{Alarms, BusError};

/// The error number in bits 6..0 of a status error byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ErrorNumber {
    /// 1: the servo could not process the instruction.
    #[error("result fail: the servo could not process the instruction")]
    ResultFail,
    /// 2: an undefined instruction, or ACTION without REG WRITE.
    #[error("instruction error: undefined instruction, or Action without Reg Write")]
    Instruction,
    /// 3: the servo received a corrupted packet.
    #[error("CRC error: the servo received a corrupted packet")]
    Crc,
    /// 4: a value outside the register's range.
    #[error("data range error: the data is out of the register's range")]
    DataRange,
    /// 5: data shorter than the register.
    #[error("data length error: the data is shorter than the register")]
    DataLength,
    /// 6: data beyond a limit register.
    #[error("data limit error: the data exceeds a limit register")]
    DataLimit,
    /// 7: a read-only register, or EEPROM while the torque is on.
    #[error("access error: the register is read-only, or EEPROM while torque is on")]
    Access,
    /// A number the e-Manual does not list.
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

    /// The number in bits 6..0.
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
    /// The servo has a hardware error; read Hardware Error Status for which
    /// ([`HARDWARE_ERROR_STATUS`](crate::servo::dynamixel_x::HARDWARE_ERROR_STATUS)).
    pub alert: bool,
    /// Why the instruction was refused, if it was.
    pub error: Option<ErrorNumber>,
}

/// Bit 7 of the ERR byte: the servo has a hardware error.
pub const ALERT_BIT: u8 = 0x80;

impl StatusByte {
    /// The meaning of an ERR byte.
    pub fn parse(byte: u8) -> StatusByte {
        StatusByte {
            alert: byte & ALERT_BIT != 0,
            error: ErrorNumber::from_number(byte & !ALERT_BIT),
        }
    }

    /// The ERR byte that says this (what an emulated servo sends).
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

/// The X series Hardware Error Status register (70) and its bits are control-table data, in
/// the servo catalogue.
use crate::servo::dynamixel_x::HARDWARE_ERROR_BITS;

/// The alarms in a Hardware Error Status value.
pub fn hardware_error_alarms(bits: u8) -> Alarms {
    HARDWARE_ERROR_BITS.decode(bits)
}

/// The Hardware Error Status value an emulated servo reports for `alarms`.
pub fn hardware_error_bits(alarms: &Alarms) -> u8 {
    HARDWARE_ERROR_BITS.encode(alarms)
}
