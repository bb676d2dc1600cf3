//! The ROBOTIS X series models keypose drives: XL330-M288, XL330-M077, XL430-W250, XM430-W350.
//!
//! Control tables, model numbers and no-load speeds from the ROBOTIS e-Manual (each model's
//! page and `_data/dxl_x_info.yml`). The four share one control table; only what address 126
//! measures differs (current on XL330 and XM430, load on XL430).

use super::{signed, unsigned, ModelSpec, Modes};
use crate::bus::protocol::dynamixel;
use crate::bus::registers::{ByteOrder, LoadUnit, RegisterTable};
use crate::robot::ServoModel;

/// Operating Mode 3 spans one turn; Extended Position Control Mode (4) ±256 turns.
const X_SERIES_MODES: Modes = Modes {
    position: (0, 4095),
    extended_position: Some((-1_048_575, 1_048_575)),
};

/// The X series control table (ROBOTIS e-Manual, XL330-M288, XL430-W250 and XM430-W350
/// control tables, Protocol 2.0); the models differ only in the model number and in what
/// address 126 measures.
const DXL_X: RegisterTable = RegisterTable {
    byte_order: ByteOrder::Little,
    homing_offset_sign: 1,
    model_number_register: unsigned("Model_Number", 0, 2),
    id: unsigned("ID", 7, 1),
    baud_rate: unsigned("Baud_Rate", 8, 1),
    return_delay: unsigned("Return_Delay_Time", 9, 1),
    status_return_level: unsigned("Status_Return_Level", 68, 1),
    drive_mode: Some(unsigned("Drive_Mode", 10, 1)),
    operating_mode: unsigned("Operating_Mode", 11, 1),
    homing_offset: signed("Homing_Offset", 20, 4),
    torque_enable: unsigned("Torque_Enable", 64, 1),
    hardware_error: unsigned("Hardware_Error_Status", dynamixel::HARDWARE_ERROR_STATUS, 1),
    goal_position: signed("Goal_Position", 116, 4),
    present_position: signed("Present_Position", 132, 4),
    present_velocity: signed("Present_Velocity", 128, 4),
    present_load: signed("Present_Current", 126, 2),
    load_unit: XL330_CURRENT,
    present_voltage: unsigned("Present_Input_Voltage", 144, 2),
    present_temperature: unsigned("Present_Temperature", 146, 1),
    moving: unsigned("Moving", 122, 1),
    profile_velocity: Some(unsigned("Profile_Velocity", 112, 4)),
    profile_acceleration: Some(unsigned("Profile_Acceleration", 108, 4)),
    acceleration: None,
    goal_speed: None,
    lock: None,
    alarm_bits: dynamixel::HARDWARE_ERROR_BITS,
    torque_locked_below: 64,
    shuts_down_on_alarm: true,
    factory_status_return_level: 2,
};

/// XL330: "about 1 mA" per unit (e-Manual XL330-M077 control table, Current Limit and Goal
/// Current units; the e-Manual pages disagree, so this is not certain).
/// Stall current 1.47 A at the recommended 5.0 V for both XL330-M288 and XL330-M077
/// (ROBOTIS e-Manual `_data/dxl_x_info.yml`). XL330 measures input current, not motor
/// phase current.
const XL330_CURRENT: LoadUnit = LoadUnit::Current {
    milliamps_per_unit: 1.0,
    stall_milliamps: 1470.0,
};

static XL430_W250: RegisterTable = RegisterTable {
    present_load: signed("Present_Load", 126, 2),
    load_unit: LoadUnit::TenthPercent,
    ..DXL_X
};

/// XM430-W350: 2.69 mA per unit, stall current 2.3 A at 12 V (ROBOTIS e-Manual, XM430-W350).
static XM430_W350: RegisterTable = RegisterTable {
    load_unit: LoadUnit::Current {
        milliamps_per_unit: 2.69,
        stall_milliamps: 2300.0,
    },
    ..DXL_X
};

/// No-load speeds: XL330 at 5 V (103 and 383 rpm), XL430 and XM430 at 12 V (61 and 46 rpm),
/// the supplies these arms use.
pub(super) static XL330_M288: ModelSpec = ModelSpec {
    model: ServoModel::Xl330M288,
    model_number: 1200,
    table: &DXL_X,
    no_load_speed_deg_s: 618.0,
    modes: X_SERIES_MODES,
};

pub(super) static XL330_M077: ModelSpec = ModelSpec {
    model: ServoModel::Xl330M077,
    model_number: 1190,
    no_load_speed_deg_s: 2298.0,
    ..XL330_M288
};

pub(super) static XL430_W250_SPEC: ModelSpec = ModelSpec {
    model: ServoModel::Xl430W250,
    model_number: 1060,
    table: &XL430_W250,
    no_load_speed_deg_s: 366.0,
    ..XL330_M288
};

pub(super) static XM430_W350_SPEC: ModelSpec = ModelSpec {
    model: ServoModel::Xm430W350,
    model_number: 1020,
    table: &XM430_W350,
    no_load_speed_deg_s: 276.0,
    ..XL330_M288
};
