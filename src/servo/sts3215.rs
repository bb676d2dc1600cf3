//! The Feetech STS3215 (SO-100/SO-101 arms): control table from the STS3215 memory table
//! rev. 220328, model number 777 as `scservo_sdk` and LeRobot read it.

use super::alarms::AlarmBits;
use super::item::{eeprom, live, ram, read_only, writable, Area, Default, Item};
use super::model::{ModelSpec, Modes, ServoModel};
use super::overload::OverloadRule;
use super::profile::{Limit, ProfileRegister, Setting};
use super::protocol::Protocol;
use super::register::{sign_magnitude, unsigned, ByteOrder};
use super::table::{LoadUnit, RegisterTable};
use std::time::Duration;

/// Status (and status byte) bit: voltage.
pub const ERR_VOLTAGE: u8 = 1 << 0;
/// Status (and status byte) bit: angle sensor.
pub const ERR_ANGLE_SENSOR: u8 = 1 << 1;
/// Status (and status byte) bit: overheating.
pub const ERR_OVERHEAT: u8 = 1 << 2;
/// Status (and status byte) bit: over-current.
pub const ERR_OVER_CURRENT: u8 = 1 << 3;
/// Status (and status byte) bit: overload.
pub const ERR_OVERLOAD: u8 = 1 << 5;

/// Status register (65) bits, which the status packet's ERR byte carries too (Feetech protocol
/// manual, "status packet"; STS3215 memory table).
pub const STATUS_BITS: AlarmBits = AlarmBits {
    input_voltage: ERR_VOLTAGE,
    overheating: ERR_OVERHEAT,
    encoder: ERR_ANGLE_SENSOR,
    electrical: ERR_OVER_CURRENT,
    overload: ERR_OVERLOAD,
};

/// Acceleration (41): 100 steps/s² per unit, 0–254; 0 = no limit. keypose writes no
/// Goal_Speed: 0 there is "as fast as it can".
static STS3215_PROFILE: [ProfileRegister; 1] = [ProfileRegister {
    setting: Setting::Acceleration,
    limit: Limit::Acceleration,
    unit: 100.0,
    max: 254,
}];

/// STS3215 (Feetech STS3215 memory table rev. 220328); negative values are sign-magnitude with
/// the sign at the bit given per register (`scservo_sdk` `SCS_TOSCS`).
static STS3215_TABLE: RegisterTable = RegisterTable {
    byte_order: ByteOrder::Little,
    model_number_register: unsigned("Model_Number", 3, 2),
    id: unsigned("ID", 5, 1),
    baud_rate: unsigned("Baud_Rate", 6, 1),
    return_delay: unsigned("Return_Delay_Time", 7, 1),
    status_return_level: unsigned("Response_Status_Level", 8, 1),
    drive_mode: None,
    operating_mode: Some(unsigned("Operating_Mode", 33, 1)),
    homing_offset: Some(sign_magnitude("Homing_Offset", 31, 11)),
    min_position_limit: unsigned("Min_Position_Limit", 9, 2),
    max_position_limit: unsigned("Max_Position_Limit", 11, 2),
    torque_enable: unsigned("Torque_Enable", 40, 1),
    hardware_error: unsigned("Status", 65, 1),
    goal_position: sign_magnitude("Goal_Position", 42, 15),
    present_position: sign_magnitude("Present_Position", 56, 15),
    present_velocity: sign_magnitude("Present_Velocity", 58, 15),
    present_load: sign_magnitude("Present_Load", 60, 10),
    // 6.5 mA per unit (STS3215 memory table, Present current).
    present_current: Some((unsigned("Present_Current", 69, 2), 6.5)),
    load_unit: LoadUnit::TenthPercent,
    present_voltage: unsigned("Present_Voltage", 62, 1),
    present_temperature: unsigned("Present_Temperature", 63, 1),
    temperature_limit: unsigned("Max_Temperature_Limit", 13, 1),
    moving: unsigned("Moving", 66, 1),
    profile_velocity: None,
    profile_acceleration: None,
    acceleration: Some(unsigned("Acceleration", 41, 1)),
    goal_speed: Some(sign_magnitude("Goal_Speed", 46, 15)),
    lock: Some(unsigned("Lock", 55, 1)),
    alarm_bits: STATUS_BITS,
    torque_locked_below: 0,
    shuts_down_on_alarm: false,
    // Overload_Torque 80 % for Protection_Time 200 × 10 ms, from the factory (memory table).
    overload: OverloadRule::Registers {
        threshold: unsigned("Overload_Torque", 36, 1),
        factory_percent: 80.0,
        time: unsigned("Protection_Time", 35, 1),
        time_unit_s: 0.01,
        factory_seconds: 2.0,
    },
    effort_limit: (unsigned("Torque_Limit", 48, 2), 1000),
    factory_status_return_level: 1,
};

/// No-load speed about 34 rpm on the SO-101's 5 V supply: Feetech rates the STS3215 at 7.4 V,
/// and the speed scales with the supply. Present_Velocity counts steps (ticks) per second;
/// Return_Delay_Time has "no function on STS" (FT-MEM).
pub(super) static STS3215: ModelSpec = ModelSpec {
    model: ServoModel::Sts3215,
    name: "sts3215",
    protocol: Protocol::FeetechSts,
    model_number: 777,
    ticks_per_revolution: 4096.0,
    table: &STS3215_TABLE,
    no_load_speed_deg_s: 200.0,
    // Operating mode 0 (position) spans one turn; keypose uses no other mode.
    modes: Modes {
        position_mode: 0,
        position: (0, 4095),
        extended_position: None,
        position_mode_offset_limit: None,
    },
    items: &STS3215_ITEMS,
    extra_items: &[],
    operating_modes: &[0, 1, 2, 3],
    velocity_unit: 1.0,
    return_delay_unit: Duration::ZERO,
    recalibrate: Some(TORQUE_RECALIBRATE),
    profile: &STS3215_PROFILE,
    drive_mode: None,
};

/// Firmware version the emulated STS3215 reports (registers 0 and 1), **UNVERIFIED**: no
/// source read gives the version shipped; 3.10 is a plausible one.
pub const FIRMWARE: (i64, i64) = (3, 10);

/// Torque_Enable 128: the servo takes its present position as 2048 (FT-MEM address 40).
const TORQUE_RECALIBRATE: i64 = 128;

/// Magnitudes of the sign-magnitude positions and speeds (sign at bit 15): FT-MEM gives ±32766
/// for the goal.
const STEPS: (i64, i64) = (-32_766, 32_766);

/// The STS3215 memory table (FT-MEM rev. 220328 for addresses, access, the values and ranges
/// it gives; registers 5–39 are its EPROM). Factory values FT-MEM leaves open are marked; see
/// docs/protocols.md §2.6 for which are **UNVERIFIED**.
static STS3215_ITEMS: [Item; 49] = {
    use Area::{Eeprom, Ram};
    [
        read_only(
            unsigned("Firmware_Major_Version", 0, 1),
            Eeprom,
            Default::Value(FIRMWARE.0),
        ),
        read_only(
            unsigned("Firmware_Minor_Version", 1, 1),
            Eeprom,
            Default::Value(FIRMWARE.1),
        ),
        // 0: two-byte values are little-endian.
        read_only(unsigned("END", 2, 1), Eeprom, Default::Value(0)),
        read_only(unsigned("Model_Number", 3, 2), Eeprom, Default::Live),
        eeprom("ID", 5, 1, 1, (0, 253)),
        eeprom("Baud_Rate", 6, 1, 0, (0, 7)),
        // "No function on STS" (FT-MEM): kept, never applied.
        eeprom("Return_Delay_Time", 7, 1, 250, (0, 254)),
        eeprom("Response_Status_Level", 8, 1, 1, (0, 1)),
        // Both 0 selects multi-turn step mode.
        eeprom("Min_Position_Limit", 9, 2, 0, (0, 4095)),
        eeprom("Max_Position_Limit", 11, 2, 4095, (0, 4095)),
        eeprom("Max_Temperature_Limit", 13, 1, 70, (0, 100)),
        eeprom("Max_Voltage_Limit", 14, 1, 80, (0, 254)),
        eeprom("Min_Voltage_Limit", 15, 1, 40, (0, 254)),
        eeprom("Max_Torque_Limit", 16, 2, 1000, (0, 1000)),
        eeprom("Phase", 18, 1, 12, (0, 254)),
        eeprom("Unloading_Condition", 19, 1, 44, (0, 254)),
        eeprom("LED_Alarm_Condition", 20, 1, 47, (0, 254)),
        eeprom("P_Coefficient", 21, 1, 32, (0, 254)),
        eeprom("D_Coefficient", 22, 1, 32, (0, 254)),
        eeprom("I_Coefficient", 23, 1, 0, (0, 254)),
        eeprom("Minimum_Startup_Force", 24, 2, 16, (0, 1000)),
        eeprom("CW_Dead_Zone", 26, 1, 1, (0, 32)),
        eeprom("CCW_Dead_Zone", 27, 1, 1, (0, 32)),
        eeprom("Protection_Current", 28, 2, 500, (0, 511)),
        eeprom("Angular_Resolution", 30, 1, 1, (1, 3)),
        writable(
            sign_magnitude("Homing_Offset", 31, 11),
            Eeprom,
            Default::Value(0),
            (-2047, 2047),
        ),
        eeprom("Operating_Mode", 33, 1, 0, (0, 3)),
        eeprom("Protective_Torque", 34, 1, 20, (0, 100)),
        eeprom("Protection_Time", 35, 1, 200, (0, 254)),
        eeprom("Overload_Torque", 36, 1, 80, (0, 100)),
        eeprom("Velocity_Closed_Loop_P_Coefficient", 37, 1, 10, (0, 100)),
        eeprom("Over_Current_Protection_Time", 38, 1, 200, (0, 254)),
        eeprom("Velocity_Closed_Loop_I_Coefficient", 39, 1, 200, (0, 254)),
        // 0 off, 1 on, 128 recalibrate (`TORQUE_RECALIBRATE`).
        ram("Torque_Enable", 40, 1, 0, (0, 128)),
        ram("Acceleration", 41, 1, 0, (0, 254)),
        writable(
            sign_magnitude("Goal_Position", 42, 15),
            Ram,
            Default::Live,
            STEPS,
        ),
        ram("Goal_Time", 44, 2, 0, (0, 65_535)),
        writable(
            sign_magnitude("Goal_Speed", 46, 15),
            Ram,
            Default::Value(0),
            STEPS,
        ),
        // Loaded from Max_Torque_Limit (16) at power-on.
        ram("Torque_Limit", 48, 2, 1000, (0, 1000)),
        ram("Lock", 55, 1, 0, (0, 1)),
        read_only(
            sign_magnitude("Present_Position", 56, 15),
            Ram,
            Default::Live,
        ),
        read_only(
            sign_magnitude("Present_Velocity", 58, 15),
            Ram,
            Default::Live,
        ),
        read_only(sign_magnitude("Present_Load", 60, 10), Ram, Default::Live),
        live("Present_Voltage", 62, 1),
        live("Present_Temperature", 63, 1),
        read_only(unsigned("Async_Write_Flag", 64, 1), Ram, Default::Value(0)),
        live("Status", 65, 1),
        live("Moving", 66, 1),
        live("Present_Current", 69, 2),
    ]
};
