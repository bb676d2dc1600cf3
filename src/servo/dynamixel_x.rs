//! The ROBOTIS X series models keypose drives: XL330-M288, XL330-M077, XL430-W250, XM430-W350.
//!
//! Control tables, model numbers and no-load speeds from the ROBOTIS e-Manual (each model's
//! page and `_data/dxl_x_info.yml`). The four share one control table; only what address 126
//! measures differs (current on XL330 and XM430, load on XL430).

use super::alarms::AlarmBits;
use super::item::{eeprom, live, ram, read_only, writable, Area, Default, Item};
use super::model::{ExtendedMode, ModelSpec, Modes, ServoModel};
use super::overload::OverloadRule;
use super::profile::{DriveModeBits, Limit, ProfileRegister, Setting};
use super::protocol::Protocol;
use super::register::{signed, unsigned, ByteOrder, Register};
use super::table::{LoadUnit, RegisterTable};
use std::time::Duration;

/// Address of the X series Hardware Error Status register.
pub const HARDWARE_ERROR_STATUS: u16 = 70;
/// Hardware Error Status bit: Input Voltage Error.
pub const HW_INPUT_VOLTAGE: u8 = 1 << 0;
/// Hardware Error Status bit: Overheating Error.
pub const HW_OVERHEATING: u8 = 1 << 2;
/// Hardware Error Status bit: Motor Encoder Error.
pub const HW_MOTOR_ENCODER: u8 = 1 << 3;
/// Hardware Error Status bit: Electrical Shock Error.
pub const HW_ELECTRICAL_SHOCK: u8 = 1 << 4;
/// Hardware Error Status bit: Overload Error.
pub const HW_OVERLOAD: u8 = 1 << 5;

/// Hardware Error Status bits (bits 1, 6 and 7 are unused).
pub const HARDWARE_ERROR_BITS: AlarmBits = AlarmBits {
    input_voltage: HW_INPUT_VOLTAGE,
    overheating: HW_OVERHEATING,
    encoder: HW_MOTOR_ENCODER,
    electrical: HW_ELECTRICAL_SHOCK,
    overload: HW_OVERLOAD,
};

/// Position ticks per revolution of every X series model.
const TICKS_PER_REVOLUTION: f64 = 4096.0;

/// Operating Mode 3 (the factory mode) spans one turn; Extended Position Control Mode (4)
/// ±256 turns. In position mode a Homing Offset beyond ±1024 is ignored (e-Manual
/// `control_table_homingoffset.md`).
const X_SERIES_MODES: Modes = Modes {
    position_mode: 3,
    position: (0, 4095),
    extended_position: Some(ExtendedMode {
        mode: 4,
        range: (-1_048_575, 1_048_575),
    }),
    position_mode_offset_limit: Some(1024),
};

/// Profile_Velocity and Present_Velocity: 0.229 rev/min per unit, in ticks/s.
const VELOCITY_UNIT: f64 = 0.229 * TICKS_PER_REVOLUTION / 60.0;

/// The velocity-based profile (Drive Mode bit 2 clear, the factory setting): Profile_Velocity
/// (112) 0.229 rev/min per unit and Profile_Acceleration (108) 214.577 rev/min² per unit, both
/// up to 32 767. The e-Manual's profile table: while Profile_Velocity is 0 no profile is used
/// at all (a step, the acceleration ignored), so `--servo-profile` writes both.
static X_SERIES_PROFILE: [ProfileRegister; 2] = [
    ProfileRegister {
        setting: Setting::ProfileVelocity,
        limit: Limit::Velocity,
        unit: VELOCITY_UNIT,
        max: 32_767,
    },
    ProfileRegister {
        setting: Setting::ProfileAcceleration,
        limit: Limit::Acceleration,
        unit: 214.577 * TICKS_PER_REVOLUTION / 3600.0,
        max: 32_767,
    },
];

/// Drive Mode bit 0 reverses the direction, bit 2 selects the time-based profile (e-Manual
/// `control_table_drivemode.md`).
const X_SERIES_DRIVE_MODE: DriveModeBits = DriveModeBits {
    reverse: 1 << 0,
    time_based: 1 << 2,
};

/// The X series control table (ROBOTIS e-Manual, XL330-M288, XL430-W250 and XM430-W350
/// control tables, Protocol 2.0); the models differ only in the model number and in what
/// address 126 measures.
const DXL_X: RegisterTable = RegisterTable {
    byte_order: ByteOrder::Little,
    model_number_register: unsigned("Model_Number", 0, 2),
    id: unsigned("ID", 7, 1),
    baud_rate: unsigned("Baud_Rate", 8, 1),
    return_delay: unsigned("Return_Delay_Time", 9, 1),
    status_return_level: unsigned("Status_Return_Level", 68, 1),
    drive_mode: Some(unsigned("Drive_Mode", 10, 1)),
    operating_mode: Some(unsigned("Operating_Mode", 11, 1)),
    homing_offset: Some(signed("Homing_Offset", 20, 4)),
    min_position_limit: unsigned("Min_Position_Limit", 52, 4),
    max_position_limit: unsigned("Max_Position_Limit", 48, 4),
    torque_enable: unsigned("Torque_Enable", 64, 1),
    hardware_error: unsigned("Hardware_Error_Status", HARDWARE_ERROR_STATUS, 1),
    goal_position: signed("Goal_Position", 116, 4),
    present_position: signed("Present_Position", 132, 4),
    present_velocity: signed("Present_Velocity", 128, 4),
    present_load: signed("Present_Current", 126, 2),
    present_current: None,
    load_unit: XL330_CURRENT,
    present_voltage: unsigned("Present_Input_Voltage", 144, 2),
    present_temperature: unsigned("Present_Temperature", 146, 1),
    temperature_limit: unsigned("Temperature_Limit", 31, 1),
    moving: unsigned("Moving", 122, 1),
    profile_velocity: Some(unsigned("Profile_Velocity", 112, 4)),
    profile_acceleration: Some(unsigned("Profile_Acceleration", 108, 4)),
    acceleration: None,
    goal_speed: None,
    lock: None,
    alarm_bits: HARDWARE_ERROR_BITS,
    torque_locked_below: 64,
    shuts_down_on_alarm: true,
    // ROBOTIS publishes neither threshold nor time ("when a high current flows for a few
    // seconds"): an XM430-W350 holding 41 % of its stall current tripped after about 5 s
    // (DynamixelSDK #285), the one measurement found. UNVERIFIED.
    overload: OverloadRule::Fixed {
        percent: 40.0,
        seconds: 5.0,
    },
    effort_limit: (signed("Goal_PWM", 100, 2), PWM_LIMIT),
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

static XL430_W250_TABLE: RegisterTable = RegisterTable {
    present_load: signed("Present_Load", 126, 2),
    load_unit: LoadUnit::TenthPercent,
    ..DXL_X
};

/// XM430-W350: 2.69 mA per unit, stall current 2.3 A at 12 V (ROBOTIS e-Manual, XM430-W350).
static XM430_W350_TABLE: RegisterTable = RegisterTable {
    load_unit: LoadUnit::Current {
        milliamps_per_unit: 2.69,
        stall_milliamps: 2300.0,
    },
    ..DXL_X
};

/// No-load speeds: XL330 at 5 V (103 and 383 rpm), XL430 and XM430 at 12 V (61 and 46 rpm),
/// the supplies these arms use.
/// Return_Delay_Time is 2 µs per unit; no Torque_Enable value recalibrates.
pub(super) static XL330_M288: ModelSpec = ModelSpec {
    model: ServoModel::Xl330M288,
    name: "xl330-m288",
    protocol: Protocol::Dynamixel2,
    model_number: 1200,
    ticks_per_revolution: TICKS_PER_REVOLUTION,
    table: &DXL_X,
    no_load_speed_deg_s: 618.0,
    modes: X_SERIES_MODES,
    items: &XL330_ITEMS,
    extra_items: &XL330_EXTRA_ITEMS,
    operating_modes: &[0, 1, 3, 4, 5, 16],
    velocity_unit: VELOCITY_UNIT,
    return_delay_unit: Duration::from_micros(2),
    recalibrate: None,
    profile: &X_SERIES_PROFILE,
    drive_mode: Some(X_SERIES_DRIVE_MODE),
};

pub(super) static XL330_M077: ModelSpec = ModelSpec {
    model: ServoModel::Xl330M077,
    name: "xl330-m077",
    model_number: 1190,
    no_load_speed_deg_s: 2298.0,
    ..XL330_M288
};

pub(super) static XL430_W250: ModelSpec = ModelSpec {
    model: ServoModel::Xl430W250,
    name: "xl430-w250",
    model_number: 1060,
    table: &XL430_W250_TABLE,
    no_load_speed_deg_s: 366.0,
    items: &XL430_ITEMS,
    extra_items: &XL430_EXTRA_ITEMS,
    // No current control (0) nor current-based position control (5) on the XL430.
    operating_modes: &[1, 3, 4, 16],
    ..XL330_M288
};

pub(super) static XM430_W350: ModelSpec = ModelSpec {
    model: ServoModel::Xm430W350,
    name: "xm430-w350",
    model_number: 1020,
    table: &XM430_W350_TABLE,
    no_load_speed_deg_s: 276.0,
    items: &XM430_ITEMS,
    extra_items: &XM430_EXTRA_ITEMS,
    ..XL330_M288
};

/// Not a model of the catalogue: the XL330-M288 as a model without Homing_Offset, Operating_Mode
/// and Drive_Mode would be described (Protocol 1.0's AX-12 has none of them), for the tests of
/// the code that reads those registers. Its full item table is still the XL330's.
#[cfg(test)]
pub(crate) static WITHOUT_OFFSET_OR_MODE: ModelSpec = ModelSpec {
    name: "without-offset-or-mode",
    table: &RegisterTable {
        drive_mode: None,
        operating_mode: None,
        homing_offset: None,
        ..DXL_X
    },
    modes: Modes {
        extended_position: None,
        position_mode_offset_limit: None,
        ..X_SERIES_MODES
    },
    operating_modes: &[],
    drive_mode: None,
    ..XL330_M288
};

/// What the X-series control tables of the supported models differ in (ROBOTIS e-Manual,
/// each model's EEPROM and RAM tables: initial value and range columns).
struct XFactory {
    load: Register,
    baud_rate_max: i64,
    drive_mode_max: i64,
    protocol_types: (i64, i64),
    temperature_limit: i64,
    max_voltage: i64,
    min_voltage: i64,
    voltage_range: (i64, i64),
    velocity_limit: i64,
    velocity_limit_max: i64,
    shutdown: i64,
    /// Velocity I, velocity P, position D, position P.
    gains: [i64; 4],
}

/// The ROBOTIS X-series firmware version the emulated servos report (register 6 and the ping
/// answer). Any version from 45 on has every item emulated here; 52 is one that shipped.
pub const FIRMWARE_VERSION: i64 = 52;

/// Goal positions in the extended and current-based position modes, ±256 turns.
const EXTENDED_RANGE: (i64, i64) = (-1_048_575, 1_048_575);
const GAIN: (i64, i64) = (0, 16_383);
/// PWM_Limit's factory value and its most: 885 is the full supply (e-Manual, PWM Limit).
pub const PWM_LIMIT: i64 = 885;
/// Operating_Mode of current-based position control (e-Manual, Operating Mode).
pub const CURRENT_BASED_POSITION_MODE: i64 = 5;

/// The items the four models share, at the same addresses; [`XL330_EXTRA_ITEMS`] and its
/// siblings hold the rest.
const fn x_series(f: XFactory) -> [Item; 50] {
    use Area::{Eeprom, Ram};
    let position = (0, 4095);
    let [velocity_i, velocity_p, position_d, position_p] = f.gains;
    [
        read_only(unsigned("Model_Number", 0, 2), Eeprom, Default::Live),
        read_only(
            unsigned("Model_Information", 2, 4),
            Eeprom,
            Default::Value(0),
        ),
        read_only(
            unsigned("Firmware_Version", 6, 1),
            Eeprom,
            Default::Value(FIRMWARE_VERSION),
        ),
        eeprom("ID", 7, 1, 1, (0, 252)),
        eeprom("Baud_Rate", 8, 1, 1, (0, f.baud_rate_max)),
        eeprom("Return_Delay_Time", 9, 1, 250, (0, 254)),
        eeprom("Drive_Mode", 10, 1, 0, (0, f.drive_mode_max)),
        // Which of 0…16 a model has is `ModelSpec::operating_modes`.
        eeprom("Operating_Mode", 11, 1, 3, (0, 16)),
        // 255 (from the factory) switches the secondary id off.
        eeprom("Secondary_ID", 12, 1, 255, (0, 255)),
        eeprom("Protocol_Type", 13, 1, 2, f.protocol_types),
        writable(
            signed("Homing_Offset", 20, 4),
            Eeprom,
            Default::Value(0),
            (-1_044_479, 1_044_479),
        ),
        eeprom("Moving_Threshold", 24, 4, 10, (0, 1023)),
        eeprom("Temperature_Limit", 31, 1, f.temperature_limit, (0, 100)),
        eeprom("Max_Voltage_Limit", 32, 2, f.max_voltage, f.voltage_range),
        eeprom("Min_Voltage_Limit", 34, 2, f.min_voltage, f.voltage_range),
        eeprom("PWM_Limit", 36, 2, PWM_LIMIT, (0, PWM_LIMIT)),
        eeprom(
            "Velocity_Limit",
            44,
            4,
            f.velocity_limit,
            (0, f.velocity_limit_max),
        ),
        eeprom("Max_Position_Limit", 48, 4, 4095, position),
        eeprom("Min_Position_Limit", 52, 4, 0, position),
        eeprom("Shutdown", 63, 1, f.shutdown, (0, 255)),
        ram("Torque_Enable", 64, 1, 0, (0, 1)),
        ram("LED", 65, 1, 0, (0, 1)),
        ram("Status_Return_Level", 68, 1, 2, (0, 2)),
        read_only(
            unsigned("Registered_Instruction", 69, 1),
            Ram,
            Default::Value(0),
        ),
        read_only(
            unsigned("Hardware_Error_Status", HARDWARE_ERROR_STATUS, 1),
            Ram,
            Default::Live,
        ),
        ram("Velocity_I_Gain", 76, 2, velocity_i, GAIN),
        ram("Velocity_P_Gain", 78, 2, velocity_p, GAIN),
        ram("Position_D_Gain", 80, 2, position_d, GAIN),
        ram("Position_I_Gain", 82, 2, 0, GAIN),
        ram("Position_P_Gain", 84, 2, position_p, GAIN),
        ram("Feedforward_2nd_Gain", 88, 2, 0, GAIN),
        ram("Feedforward_1st_Gain", 90, 2, 0, GAIN),
        // The table gives 1–127; 0 (the factory value) switches the watchdog off.
        ram("Bus_Watchdog", 98, 1, 0, (0, 127)),
        writable(
            signed("Goal_PWM", 100, 2),
            Ram,
            Default::Value(PWM_LIMIT),
            (-PWM_LIMIT, PWM_LIMIT),
        ),
        writable(
            signed("Goal_Velocity", 104, 4),
            Ram,
            Default::Value(0),
            (-f.velocity_limit, f.velocity_limit),
        ),
        ram("Profile_Acceleration", 108, 4, 0, (0, 32_767)),
        ram("Profile_Velocity", 112, 4, 0, (0, 32_767)),
        // In position mode the limits (48, 52) bound it; the servo clamps to them.
        writable(
            signed("Goal_Position", 116, 4),
            Ram,
            Default::Live,
            EXTENDED_RANGE,
        ),
        live("Realtime_Tick", 120, 2),
        live("Moving", 122, 1),
        live("Moving_Status", 123, 1),
        read_only(signed("Present_PWM", 124, 2), Ram, Default::Live),
        read_only(f.load, Ram, Default::Live),
        read_only(signed("Present_Velocity", 128, 4), Ram, Default::Live),
        read_only(signed("Present_Position", 132, 4), Ram, Default::Live),
        read_only(signed("Velocity_Trajectory", 136, 4), Ram, Default::Live),
        read_only(signed("Position_Trajectory", 140, 4), Ram, Default::Live),
        live("Present_Input_Voltage", 144, 2),
        live("Present_Temperature", 146, 1),
        read_only(unsigned("Backup_Ready", 147, 1), Ram, Default::Value(0)),
    ]
}

/// XL430-W250 (e-Manual `xl430-w250.md`).
static XL430_ITEMS: [Item; 50] = x_series(XFactory {
    load: signed("Present_Load", 126, 2),
    baud_rate_max: 7,
    drive_mode_max: 13,
    protocol_types: (1, 2),
    temperature_limit: 72,
    max_voltage: 140,
    min_voltage: 60,
    voltage_range: (60, 140),
    velocity_limit: 265,
    velocity_limit_max: 1023,
    shutdown: 52,
    gains: [1000, 100, 4000, 640],
});

static XL430_EXTRA_ITEMS: [Item; 1] = [eeprom("Startup_Configuration", 60, 1, 0, (0, 3))];

/// XL330-M288 (e-Manual `xl330-m288.md`); the XL330-M077 is taken to have the same table.
static XL330_ITEMS: [Item; 50] = x_series(XFactory {
    load: signed("Present_Current", 126, 2),
    baud_rate_max: 6,
    drive_mode_max: 5,
    protocol_types: (2, 22),
    temperature_limit: 70,
    max_voltage: 70,
    min_voltage: 35,
    voltage_range: (31, 70),
    velocity_limit: 445,
    velocity_limit_max: 2047,
    shutdown: 53,
    gains: [1600, 180, 0, 400],
});

const XL330_CURRENT_LIMIT: i64 = 1750;

static XL330_EXTRA_ITEMS: [Item; 4] = [
    eeprom(
        "Current_Limit",
        38,
        2,
        XL330_CURRENT_LIMIT,
        (0, XL330_CURRENT_LIMIT),
    ),
    eeprom("Startup_Configuration", 60, 1, 0, (0, 3)),
    eeprom("PWM_Slope", 62, 1, 140, (1, 255)),
    goal_current(XL330_CURRENT_LIMIT),
];

/// XM430-W350 (e-Manual `xm430-w350.md`, whose tables have no range column: the ranges are
/// the XL430's, the same X430 family).
static XM430_ITEMS: [Item; 50] = x_series(XFactory {
    load: signed("Present_Current", 126, 2),
    baud_rate_max: 7,
    drive_mode_max: 13,
    protocol_types: (1, 2),
    temperature_limit: 80,
    max_voltage: 160,
    min_voltage: 95,
    voltage_range: (95, 160),
    velocity_limit: 350,
    velocity_limit_max: 1023,
    shutdown: 52,
    gains: [1920, 100, 0, 800],
});

const XM430_CURRENT_LIMIT: i64 = 1193;

static XM430_EXTRA_ITEMS: [Item; 2] = [
    eeprom(
        "Current_Limit",
        38,
        2,
        XM430_CURRENT_LIMIT,
        (0, XM430_CURRENT_LIMIT),
    ),
    goal_current(XM430_CURRENT_LIMIT),
];

/// Goal Current (102): within ±Current Limit, which it is reset to on a mode change.
const fn goal_current(limit: i64) -> Item {
    writable(
        signed("Goal_Current", 102, 2),
        Area::Ram,
        Default::Value(limit),
        (-limit, limit),
    )
}
