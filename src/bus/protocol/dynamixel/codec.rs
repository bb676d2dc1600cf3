//! Protocol 2.0 as a [`Codec`].

use super::{
    encode_fast_sync_read, parse_fast_sync_read, parse_ping_answer, ping_answer_params, Dynamixel2,
    ErrorNumber, FastSyncReadEntry, StatusByte, XSeriesFirmware, ALERT_BIT, BULK_READ, BULK_WRITE,
    FAST_SYNC_READ, FIELDS, MAX_DEVICE_ID, PING, READ, REBOOT, SYNC_READ, SYNC_WRITE, WRITE,
};
use crate::bus::protocol::packet::{Framing, Packet, PacketError};
use crate::bus::protocol::{Codec, FastSyncRead, Fields, Firmware, Instructions, Refusal, Status};
use crate::bus::{AlarmBits, Alarms, PingInfo};
use crate::robot::Protocol;
use crate::servo::dynamixel_x::{HARDWARE_ERROR_BITS, HARDWARE_ERROR_STATUS};
use crate::servo::Vendor;
use crate::servo::{ByteOrder, Encoding, Register};

static INSTRUCTIONS: Instructions = Instructions {
    ping: PING,
    read: READ,
    write: WRITE,
    sync_read: Some(SYNC_READ),
    sync_write: SYNC_WRITE,
    reboot: Some(REBOOT),
    bulk_read: Some(BULK_READ),
    bulk_write: Some(BULK_WRITE),
};

impl Codec for Dynamixel2 {
    fn protocol(&self) -> Protocol {
        Protocol::Dynamixel2
    }

    fn vendor(&self) -> Vendor {
        Vendor::Dynamixel
    }

    fn framing(&self) -> &dyn Framing {
        self
    }

    fn instructions(&self) -> &'static Instructions {
        &INSTRUCTIONS
    }

    fn fields(&self) -> Fields {
        FIELDS
    }

    fn byte_order(&self) -> ByteOrder {
        ByteOrder::Little
    }

    fn max_device_id(&self) -> u8 {
        MAX_DEVICE_ID
    }

    /// Model Number, address 0, on every X series model (ROBOTIS e-Manual control tables).
    fn model_number_register(&self) -> Register {
        Register::new("Model_Number", 0, 2, Encoding::Unsigned)
    }

    /// Hardware Error Status, one byte at 70 on every X series model, so it can be read from a
    /// servo of unknown model (a scan).
    fn alarm_register(&self) -> (Register, AlarmBits) {
        let register = Register::new(
            "Hardware_Error_Status",
            HARDWARE_ERROR_STATUS,
            1,
            Encoding::Unsigned,
        );
        (register, HARDWARE_ERROR_BITS)
    }

    /// An error number is a refusal; the alert bit alone means the instruction was carried
    /// out and the cause is in the Hardware Error Status register.
    fn status(&self, error: u8) -> Status {
        let status = StatusByte::parse(error);
        match (status.error, status.alert) {
            (Some(number), _) => Status::Refused(number.to_string()),
            (None, true) => Status::Alert,
            (None, false) => Status::Done,
        }
    }

    fn status_byte(&self, alarms: &Alarms, refusal: Option<Refusal>) -> Option<u8> {
        let alert = if alarms.any() { ALERT_BIT } else { 0 };
        let number = refusal.map_or(0, |refusal| error_number(refusal).number());
        Some(alert | number)
    }

    fn ping_answer(&self, packet: &Packet) -> Result<Option<PingInfo>, PacketError> {
        parse_ping_answer(packet).map(Some)
    }

    fn ping_answer_params(&self, model_number: u16, firmware: u8) -> Vec<u8> {
        ping_answer_params(model_number, firmware)
    }

    /// A status carries instruction 0x55, which no instruction packet does.
    fn status_may_equal_instruction(&self) -> bool {
        false
    }

    fn firmware(&self) -> &'static dyn Firmware {
        &XSeriesFirmware
    }

    fn fast_sync_read(&self) -> Option<&dyn FastSyncRead> {
        Some(self)
    }
}

fn error_number(refusal: Refusal) -> ErrorNumber {
    match refusal {
        Refusal::Instruction => ErrorNumber::Instruction,
        Refusal::DataLength => ErrorNumber::DataLength,
        Refusal::DataLimit => ErrorNumber::DataLimit,
        Refusal::DataRange => ErrorNumber::DataRange,
        Refusal::Access => ErrorNumber::Access,
    }
}

impl FastSyncRead for Dynamixel2 {
    fn instruction(&self) -> u8 {
        FAST_SYNC_READ
    }

    fn parse(&self, packet: &Packet, length: u16) -> Result<Vec<FastSyncReadEntry>, PacketError> {
        parse_fast_sync_read(packet, length)
    }

    fn encode(&self, entries: &[FastSyncReadEntry]) -> Result<Vec<u8>, PacketError> {
        encode_fast_sync_read(entries)
    }
}
