//! Feetech SCS and STS as a [`Codec`]: one framing, two byte orders.

use super::{
    status_alarms, status_bits, Series, StsFirmware, FIELDS, MAX_DEVICE_ID, PING, READ, SYNC_READ,
    SYNC_WRITE, WRITE,
};
use crate::bus::protocol::ff_framing::FfFraming;
use crate::bus::protocol::packet::{Framing, Packet, PacketError};
use crate::bus::protocol::{Codec, Fields, Firmware, Instructions, Refusal, Status};
use crate::bus::{AlarmBits, Alarms, PingInfo};
use crate::robot::Protocol;
use crate::servo::sts3215::STATUS_BITS;
use crate::servo::Vendor;
use crate::servo::{ByteOrder, Encoding, Register};

static STS_INSTRUCTIONS: Instructions = Instructions {
    ping: PING,
    read: READ,
    write: WRITE,
    sync_read: Some(SYNC_READ),
    sync_write: SYNC_WRITE,
    reboot: None,
    bulk_read: None,
    bulk_write: None,
};

/// SCS servos do not answer Sync Read (Feetech protocol manual; `scservo_sdk` offers it only
/// for protocol 0).
static SCS_INSTRUCTIONS: Instructions = Instructions {
    sync_read: None,
    ..STS_INSTRUCTIONS
};

impl Codec for Series {
    fn protocol(&self) -> Protocol {
        match self {
            Series::StsSms => Protocol::FeetechSts,
            Series::Scs => Protocol::FeetechScs,
        }
    }

    fn vendor(&self) -> Vendor {
        Vendor::Feetech
    }

    fn framing(&self) -> &dyn Framing {
        &FfFraming
    }

    fn instructions(&self) -> &'static Instructions {
        match self {
            Series::StsSms => &STS_INSTRUCTIONS,
            Series::Scs => &SCS_INSTRUCTIONS,
        }
    }

    fn fields(&self) -> Fields {
        FIELDS
    }

    fn byte_order(&self) -> ByteOrder {
        match self {
            Series::StsSms => ByteOrder::Little,
            Series::Scs => ByteOrder::Big,
        }
    }

    fn max_device_id(&self) -> u8 {
        MAX_DEVICE_ID
    }

    /// Model number, address 3, on STS and SCS (Feetech memory tables).
    fn model_number_register(&self) -> Register {
        Register::new("Model_Number", 3, 2, Encoding::Unsigned)
    }

    /// The Status register (65) holds the bits of the status byte.
    fn alarm_register(&self) -> (Register, AlarmBits) {
        (
            Register::new("Status", 65, 1, Encoding::Unsigned),
            STATUS_BITS,
        )
    }

    /// Feetech's status byte reports conditions, not refusals: the instruction was carried out.
    fn status(&self, error: u8) -> Status {
        let alarms = status_alarms(error);
        if alarms.any() {
            Status::Alarms(alarms)
        } else {
            Status::Done
        }
    }

    /// A servo does not answer an instruction it does not know; any other answer carries only
    /// its alarm bits.
    fn status_byte(&self, alarms: &Alarms, refusal: Option<Refusal>) -> Option<u8> {
        match refusal {
            Some(Refusal::Instruction) => None,
            _ => Some(status_bits(alarms)),
        }
    }

    /// The ping answer is an empty status packet: the model number takes a register read.
    fn ping_answer(&self, _packet: &Packet) -> Result<Option<PingInfo>, PacketError> {
        Ok(None)
    }

    fn ping_answer_params(&self, _model_number: u16, _firmware: u8) -> Vec<u8> {
        Vec::new()
    }

    /// SCS servos are taken to follow the STS rules; keypose's catalogue has no SCS model.
    fn firmware(&self) -> &'static dyn Firmware {
        &StsFirmware
    }

    /// Instruction and status packets share one layout: a PING to id 1 and the answer of id 1
    /// with error byte 0x01 are the same six bytes.
    fn status_may_equal_instruction(&self) -> bool {
        true
    }
}
