//! The status ERR byte and the Status register (65): alarm bits, one layout for both (Feetech
//! protocol manual, "status packet"; STS3215 memory table).

use crate::bus::Alarms;

/// The bits are the Status register's (65), control-table data in the servo catalogue.
use crate::servo::sts3215::STATUS_BITS;

/// The alarms in a status ERR byte, or in the Status register (65), which uses the same bits.
/// Feetech's status byte reports conditions, not refusals: the instruction was carried out.
pub fn status_alarms(bits: u8) -> Alarms {
    STATUS_BITS.decode(bits)
}

/// The status byte an emulated servo reports for `alarms`.
pub fn status_bits(alarms: &Alarms) -> u8 {
    STATUS_BITS.encode(alarms)
}
