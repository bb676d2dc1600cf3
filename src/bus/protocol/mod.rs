//! The vendors' protocols, one folder each: `dynamixel` (Protocol 2.0) and `feetech` (SCS and
//! STS), over the framing vocabulary every protocol shares (`packet`), the `FF FF` framing of
//! Protocol 1.0's format that Feetech uses (`ff_framing`, where another protocol of that
//! format finds it) and the parameter layouts that differ only in field width (`fields`).
//!
//! A [`Codec`] is everything the driver and the emulated servos need to know about a protocol:
//! instruction codes, parameter layout, framing, the meaning of a status byte, the ping answer,
//! and the rules its servos' firmware follows ([`Firmware`], `firmware`; each vendor's in its
//! folder). Neither the driver nor the emulated servos ask which vendor they talk to; [`codec`]
//! is the one place a protocol picks one. Adding a protocol means a folder here (codec,
//! firmware, status byte), an arm in [`codec`], and its variant and models in the servo
//! catalogue ([`crate::servo`]).

pub mod dynamixel;
pub mod feetech;
pub mod ff_framing;
mod fields;
pub mod firmware;
pub mod motor;
pub mod packet;

pub use fields::Fields;
pub use firmware::Firmware;

use super::{AlarmBits, Alarms, PingInfo};
use crate::robot::Protocol;
use crate::servo::{ByteOrder, Register};
use packet::{Framing, Packet, PacketError};

/// The instruction codes of a protocol; `None` where it has no such instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Instructions {
    /// PING.
    pub ping: u8,
    /// READ.
    pub read: u8,
    /// WRITE.
    pub write: u8,
    /// Feetech SCS servos do not answer Sync Read.
    pub sync_read: Option<u8>,
    /// SYNC WRITE.
    pub sync_write: u8,
    /// Dynamixel only: the one way to clear a hardware-error shutdown.
    pub reboot: Option<u8>,
    /// Dynamixel only: one instruction reading or writing a different span of each servo.
    pub bulk_read: Option<u8>,
    /// Dynamixel only: BULK WRITE.
    pub bulk_write: Option<u8>,
}

use crate::servo::Vendor;

impl Vendor {
    /// The vendor's Python SDK module, which `--driver sdk` drives through the bridge.
    pub fn sdk_module(self) -> &'static str {
        match self {
            Vendor::Dynamixel => "dynamixel_sdk",
            Vendor::Feetech => "scservo_sdk",
        }
    }
}

/// What a status packet's error byte says about the instruction it answers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Status {
    /// Carried out, nothing to report.
    Done,
    /// Not carried out, for this reason.
    Refused(String),
    /// Carried out; the servo has these alarms (never empty).
    Alarms(Alarms),
    /// Carried out; the servo has an alarm that only its alarm register names.
    Alert,
}

/// Why an emulated servo refuses an instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// An instruction it does not know.
    Instruction,
    /// Parameters too short for the instruction.
    DataLength,
    /// An access beyond its control table.
    DataLimit,
    /// A value outside the register's range (or a mode the model does not have).
    DataRange,
    /// A write to a register it does not allow now (EEPROM with torque on).
    Access,
}

/// One servo's part of a combined read answer (Dynamixel Fast Sync Read).
pub use dynamixel::FastSyncReadEntry;

/// A read answered by all servos in one packet.
pub trait FastSyncRead: Sync {
    /// Its instruction code.
    fn instruction(&self) -> u8;
    /// The servos' blocks of `length` bytes in a combined answer.
    fn parse(&self, packet: &Packet, length: u16) -> Result<Vec<FastSyncReadEntry>, PacketError>;
    /// The combined answer's bytes (what an emulated bus sends).
    fn encode(&self, entries: &[FastSyncReadEntry]) -> Result<Vec<u8>, PacketError>;
}

/// One vendor protocol, as the driver and the emulated servos use it.
pub trait Codec: Sync + std::fmt::Debug {
    /// The protocol this codec speaks.
    fn protocol(&self) -> Protocol;
    /// Whose servos it addresses.
    fn vendor(&self) -> Vendor;
    /// How its packets are framed on the wire.
    fn framing(&self) -> &dyn Framing;
    /// Its instruction codes.
    fn instructions(&self) -> &'static Instructions;
    /// The widths of its address and length fields.
    fn fields(&self) -> Fields;
    /// The byte order of register values.
    fn byte_order(&self) -> ByteOrder;
    /// The highest id a servo can have.
    fn max_device_id(&self) -> u8;
    /// The model number register, at the same place on every model of the vendor, so that a
    /// servo of unknown model can be asked what it is.
    fn model_number_register(&self) -> Register;
    /// The register that names a servo's alarms, at the same place on every model of the
    /// vendor, and its bits.
    fn alarm_register(&self) -> (Register, AlarmBits);
    /// What a status error byte says.
    fn status(&self, error: u8) -> Status;
    /// The status error byte an emulated servo with `alarms` sends, refusing for `refusal`;
    /// `None` when the protocol has the servo stay silent instead.
    fn status_byte(&self, alarms: &Alarms, refusal: Option<Refusal>) -> Option<u8>;
    /// The servo's identity in a ping answer; `Ok(None)` when the answer carries none and the
    /// model number register must be read.
    fn ping_answer(&self, packet: &Packet) -> Result<Option<PingInfo>, PacketError>;
    /// The parameters of an emulated servo's ping answer.
    fn ping_answer_params(&self, model_number: u16, firmware: u8) -> Vec<u8>;
    /// Whether a status packet can be byte for byte an instruction (Feetech: one layout for
    /// both), so that a copy of what was sent may be the answer rather than its echo.
    fn status_may_equal_instruction(&self) -> bool;
    /// The rules the firmware of the protocol's servos follows, which the emulated servos act
    /// out.
    fn firmware(&self) -> &'static dyn Firmware;
    /// The combined read, where the protocol has one.
    fn fast_sync_read(&self) -> Option<&dyn FastSyncRead> {
        None
    }
}

/// The codec of a robot file's protocol.
pub fn codec(protocol: Protocol) -> &'static dyn Codec {
    match protocol {
        Protocol::Dynamixel2 => &dynamixel::Dynamixel2,
        Protocol::FeetechSts => &feetech::STS,
        Protocol::FeetechScs => &feetech::SCS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_protocol_has_its_codec() {
        for protocol in Protocol::ALL {
            assert_eq!(codec(protocol).protocol(), protocol);
        }
        assert_eq!(codec(Protocol::FeetechScs).byte_order(), ByteOrder::Big);
        assert_eq!(codec(Protocol::FeetechSts).byte_order(), ByteOrder::Little);
        assert_eq!(codec(Protocol::Dynamixel2).fields(), Fields::WIDE);
        assert!(codec(Protocol::FeetechScs)
            .instructions()
            .sync_read
            .is_none());
        assert!(codec(Protocol::Dynamixel2).fast_sync_read().is_some());
        assert!(codec(Protocol::FeetechSts).fast_sync_read().is_none());
    }
}
