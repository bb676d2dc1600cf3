//! The status ERR byte and the Status register (65): alarm bits, one layout for both (Feetech
//! protocol manual, "status packet"; STS3215 memory table).

use crate::bus::{AlarmBits, Alarms};

pub const ERR_VOLTAGE: u8 = 1 << 0;
pub const ERR_ANGLE_SENSOR: u8 = 1 << 1;
pub const ERR_OVERHEAT: u8 = 1 << 2;
pub const ERR_OVER_CURRENT: u8 = 1 << 3;
pub const ERR_OVERLOAD: u8 = 1 << 5;

/// Status ERR byte and Status register (65) bits.
pub const STATUS_BITS: AlarmBits = AlarmBits {
    input_voltage: ERR_VOLTAGE,
    overheating: ERR_OVERHEAT,
    encoder: ERR_ANGLE_SENSOR,
    electrical: ERR_OVER_CURRENT,
    overload: ERR_OVERLOAD,
};

/// The alarms in a status ERR byte, or in the Status register (65), which uses the same bits.
/// Feetech's status byte reports conditions, not refusals: the instruction was carried out.
pub fn status_alarms(bits: u8) -> Alarms {
    STATUS_BITS.decode(bits)
}

/// The status byte an emulated servo reports for `alarms`.
pub fn status_bits(alarms: &Alarms) -> u8 {
    STATUS_BITS.encode(alarms)
}
