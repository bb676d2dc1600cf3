//! The Feetech STS3215 (SO-100/SO-101 arms): control table from the STS3215 memory table
//! rev. 220328, model number 777 as `scservo_sdk` and LeRobot read it.

use super::{sign_magnitude, unsigned, ModelSpec, Modes};
use crate::bus::protocol::feetech;
use crate::bus::registers::{ByteOrder, LoadUnit, RegisterTable};
use crate::robot::ServoModel;

/// STS3215 (Feetech STS3215 memory table rev. 220328); negative values are sign-magnitude with
/// the sign at the bit given per register (`scservo_sdk` `SCS_TOSCS`).
static STS3215_TABLE: RegisterTable = RegisterTable {
    byte_order: ByteOrder::Little,
    homing_offset_sign: -1,
    model_number_register: unsigned("Model_Number", 3, 2),
    id: unsigned("ID", 5, 1),
    baud_rate: unsigned("Baud_Rate", 6, 1),
    return_delay: unsigned("Return_Delay_Time", 7, 1),
    status_return_level: unsigned("Response_Status_Level", 8, 1),
    drive_mode: None,
    operating_mode: unsigned("Operating_Mode", 33, 1),
    homing_offset: sign_magnitude("Homing_Offset", 31, 11),
    torque_enable: unsigned("Torque_Enable", 40, 1),
    hardware_error: unsigned("Status", 65, 1),
    goal_position: sign_magnitude("Goal_Position", 42, 15),
    present_position: sign_magnitude("Present_Position", 56, 15),
    present_velocity: sign_magnitude("Present_Velocity", 58, 15),
    present_load: sign_magnitude("Present_Load", 60, 10),
    load_unit: LoadUnit::TenthPercent,
    present_voltage: unsigned("Present_Voltage", 62, 1),
    present_temperature: unsigned("Present_Temperature", 63, 1),
    moving: unsigned("Moving", 66, 1),
    profile_velocity: None,
    profile_acceleration: None,
    acceleration: Some(unsigned("Acceleration", 41, 1)),
    goal_speed: Some(sign_magnitude("Goal_Speed", 46, 15)),
    lock: Some(unsigned("Lock", 55, 1)),
    alarm_bits: feetech::STATUS_BITS,
    torque_locked_below: 0,
    shuts_down_on_alarm: false,
    factory_status_return_level: 1,
};

/// No-load speed about 34 rpm on the SO-101's 5 V supply: Feetech rates the STS3215 at 7.4 V,
/// and the speed scales with the supply.
pub(super) static STS3215: ModelSpec = ModelSpec {
    model: ServoModel::Sts3215,
    model_number: 777,
    table: &STS3215_TABLE,
    no_load_speed_deg_s: 200.0,
    // Operating mode 0 (position) spans one turn; keypose uses no other mode.
    modes: Modes {
        position: (0, 4095),
        extended_position: None,
    },
};
