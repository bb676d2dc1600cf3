//! Control tables: where each register the drivers use lives on each supported model, how its
//! value is encoded, and how raw health readings become physical units.
//!
//! Addresses, sizes and encodings are from PROTOCOLS.md §1.8 (ROBOTIS X series) and §2.6
//! (Feetech STS3215, memory table rev. 220328). Signed positions reuse
//! [`PositionEncoding`], the tick representation the robot description already defines, so a
//! register and the joint mapping cannot disagree about a negative tick.

use super::protocol::{dynamixel, feetech};
use super::{AlarmBits, Alarms};
use crate::robot::{PositionEncoding, Protocol, ServoModel};

/// The order of a register value's bytes in memory and on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ByteOrder {
    /// Low byte at the lower address: Dynamixel, Feetech STS/SMS.
    Little,
    /// High byte at the lower address: Feetech SCS.
    Big,
}

impl ByteOrder {
    /// The register order of a bus protocol.
    pub fn of(protocol: Protocol) -> ByteOrder {
        super::protocol::codec(protocol).byte_order()
    }

    /// The low `size` bytes of `raw` (at most 4).
    pub fn to_bytes(self, raw: u32, size: u8) -> Vec<u8> {
        let size = usize::from(size.min(4));
        match self {
            ByteOrder::Little => raw.to_le_bytes()[..size].to_vec(),
            ByteOrder::Big => raw.to_be_bytes()[4 - size..].to_vec(),
        }
    }

    /// The value of up to 4 bytes; `None` for more.
    pub fn from_bytes(self, bytes: &[u8]) -> Option<u32> {
        if bytes.len() > 4 {
            return None;
        }
        let fold = |acc: u32, &b: &u8| (acc << 8) | u32::from(b);
        Some(match self {
            ByteOrder::Little => bytes.iter().rev().fold(0, fold),
            ByteOrder::Big => bytes.iter().fold(0, fold),
        })
    }
}

/// How a register represents a signed or unsigned value in its bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Unsigned,
    /// Two's complement over the register's whole width (Dynamixel).
    TwosComplement,
    /// Magnitude in the bits below `sign_bit`, `sign_bit` set for negative values (Feetech
    /// STS/SMS). Always a 2-byte register.
    SignMagnitude {
        sign_bit: u8,
    },
}

/// One control-table entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Register {
    pub name: &'static str,
    pub address: u16,
    /// In bytes: 1, 2 or 4.
    pub size: u8,
    pub encoding: Encoding,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegisterError {
    #[error("{register}: value {value} does not fit the register ({min} to {max})")]
    OutOfRange {
        register: &'static str,
        value: i64,
        min: i64,
        max: i64,
    },
    #[error("{register}: {found} bytes where the register has {expected}")]
    Size {
        register: &'static str,
        expected: u8,
        found: usize,
    },
    #[error("{register} (address {address}, {size} bytes) is not inside the {len} bytes read from address {start}")]
    OutsideBlock {
        register: &'static str,
        address: u16,
        size: u8,
        start: u16,
        len: usize,
    },
    #[error("{register}: address {address} does not fit a one-byte (Feetech) address")]
    Address {
        register: &'static str,
        address: u16,
    },
}

impl Register {
    pub const fn new(name: &'static str, address: u16, size: u8, encoding: Encoding) -> Register {
        Register {
            name,
            address,
            size,
            encoding,
        }
    }

    /// One past the last address.
    pub fn end(&self) -> u16 {
        self.address.saturating_add(u16::from(self.size))
    }

    /// The address as the one byte Feetech packets carry.
    pub fn short_address(&self) -> Result<u8, RegisterError> {
        u8::try_from(self.address).map_err(|_| RegisterError::Address {
            register: self.name,
            address: self.address,
        })
    }

    /// The tick representation this register shares with the robot's servo mapping, when its
    /// encoding and width are one of those.
    pub fn position_encoding(&self) -> Option<PositionEncoding> {
        match (self.encoding, self.size) {
            (Encoding::TwosComplement, 4) => Some(PositionEncoding::TwosComplement32),
            (Encoding::SignMagnitude { sign_bit }, 2) if sign_bit < 16 => {
                Some(PositionEncoding::SignMagnitude16 { sign_bit })
            }
            (Encoding::Unsigned, 2) => Some(PositionEncoding::Unsigned16),
            _ => None,
        }
    }

    /// The width in bits, with nonsensical sizes clamped so that no shift overflows.
    fn bits(&self) -> u32 {
        8 * u32::from(self.size.clamp(1, 4))
    }

    /// The values the register can hold.
    pub fn range(&self) -> (i64, i64) {
        if let Some(encoding) = self.position_encoding() {
            return encoding.range();
        }
        let bits = self.bits();
        match self.encoding {
            Encoding::Unsigned => (0, (1i64 << bits) - 1),
            Encoding::TwosComplement => (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1),
            // A sign bit outside the register's width cannot be set: nothing negative fits.
            Encoding::SignMagnitude { sign_bit } if u32::from(sign_bit) >= bits => {
                (0, (1i64 << bits) - 1)
            }
            Encoding::SignMagnitude { sign_bit } => {
                let magnitude = (1i64 << sign_bit) - 1;
                (-magnitude, magnitude)
            }
        }
    }

    /// The register's raw bits for `value`.
    pub fn to_raw(&self, value: i64) -> Result<u32, RegisterError> {
        let (min, max) = self.range();
        let out_of_range = RegisterError::OutOfRange {
            register: self.name,
            value,
            min,
            max,
        };
        if value < min || value > max {
            return Err(out_of_range);
        }
        if let Some(encoding) = self.position_encoding() {
            return encoding.encode(value).map_err(|_| out_of_range);
        }
        let mask = if self.bits() >= 32 {
            u32::MAX
        } else {
            (1u32 << self.bits()) - 1
        };
        Ok(match self.encoding {
            Encoding::SignMagnitude { sign_bit } if value < 0 => {
                value.unsigned_abs() as u32 | (1u32 << sign_bit)
            }
            // Truncating a two's complement i64 to the width keeps its representation.
            _ => value as u32 & mask,
        })
    }

    /// The value in the register's raw bits (bits above the width are ignored).
    pub fn from_raw(&self, raw: u32) -> i64 {
        if let Some(encoding) = self.position_encoding() {
            return encoding.decode(raw);
        }
        match (self.encoding, self.size) {
            (Encoding::TwosComplement, 1) => i64::from(raw as u8 as i8),
            (Encoding::TwosComplement, 2) => i64::from(raw as u16 as i16),
            (Encoding::TwosComplement, _) => i64::from(raw as i32),
            (Encoding::SignMagnitude { sign_bit }, _) => {
                let sign = 1u32.checked_shl(u32::from(sign_bit)).unwrap_or(0);
                let magnitude = i64::from(raw & sign.wrapping_sub(1));
                if sign != 0 && raw & sign != 0 {
                    -magnitude
                } else {
                    magnitude
                }
            }
            (Encoding::Unsigned, 1) => i64::from(raw & 0xFF),
            (Encoding::Unsigned, 2) => i64::from(raw & 0xFFFF),
            (Encoding::Unsigned, _) => i64::from(raw),
        }
    }

    /// The bytes to write for `value`.
    pub fn encode(&self, value: i64, order: ByteOrder) -> Result<Vec<u8>, RegisterError> {
        Ok(order.to_bytes(self.to_raw(value)?, self.size))
    }

    /// The value in exactly `size` bytes read from the register.
    pub fn decode(&self, bytes: &[u8], order: ByteOrder) -> Result<i64, RegisterError> {
        if bytes.len() != usize::from(self.size) {
            return Err(RegisterError::Size {
                register: self.name,
                expected: self.size,
                found: bytes.len(),
            });
        }
        let raw = order.from_bytes(bytes).ok_or(RegisterError::Size {
            register: self.name,
            expected: self.size,
            found: bytes.len(),
        })?;
        Ok(self.from_raw(raw))
    }

    /// The value inside a block of bytes read in one go starting at `start`.
    pub fn decode_in_block(
        &self,
        block: &[u8],
        start: u16,
        order: ByteOrder,
    ) -> Result<i64, RegisterError> {
        let outside = RegisterError::OutsideBlock {
            register: self.name,
            address: self.address,
            size: self.size,
            start,
            len: block.len(),
        };
        let offset = usize::from(self.address.checked_sub(start).ok_or(outside.clone())?);
        let bytes = block
            .get(offset..offset + usize::from(self.size))
            .ok_or(outside)?;
        self.decode(bytes, order)
    }
}

/// The smallest address span covering `registers`: (start, length), for reading them in one
/// READ. `None` for no registers.
pub fn span(registers: &[Register]) -> Option<(u16, u16)> {
    let start = registers.iter().map(|r| r.address).min()?;
    let end = registers.iter().map(Register::end).max()?;
    Some((start, end - start))
}

/// What the present load/current register measures and how to express it as a percentage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoadUnit {
    /// Signed tenths of a percent of the maximum (Feetech STS: of PWM duty; XL430: of torque).
    TenthPercent,
    /// Signed current. Expressed as a percentage of the stall current at the rated voltage,
    /// which is what "100 % load" means for a servo held still at full effort.
    Current {
        milliamps_per_unit: f64,
        stall_milliamps: f64,
    },
}

/// Everything the drivers and the emulator need to know about one servo model.
#[derive(Debug, Clone, PartialEq)]
pub struct RegisterTable {
    pub model: ServoModel,
    /// What the model number register (and a Dynamixel ping) reports.
    pub model_number: u16,
    pub byte_order: ByteOrder,
    /// Sign of the homing offset: Present = Actual + sign · Homing_Offset (+1 Dynamixel,
    /// −1 Feetech).
    pub homing_offset_sign: i64,
    pub model_number_register: Register,
    pub id: Register,
    pub baud_rate: Register,
    /// Unit 2 µs. FT-MEM says it has no function on STS.
    pub return_delay: Register,
    /// Which instructions are answered (Dynamixel Status Return Level, Feetech response level).
    pub status_return_level: Register,
    /// Dynamixel only: bit 0 reverses the direction of goal and present position.
    pub drive_mode: Option<Register>,
    pub operating_mode: Register,
    pub homing_offset: Register,
    pub torque_enable: Register,
    /// Dynamixel Hardware Error Status (70) or Feetech Status (65); see [`Self::alarms`].
    pub hardware_error: Register,
    pub goal_position: Register,
    pub present_position: Register,
    pub present_velocity: Register,
    /// Present Load (XL430, STS) or Present Current (XL330, XM430); see [`Self::load_unit`].
    pub present_load: Register,
    pub load_unit: LoadUnit,
    /// 0.1 V per unit on every model.
    pub present_voltage: Register,
    /// °C.
    pub present_temperature: Register,
    pub moving: Register,
    /// Dynamixel only.
    pub profile_velocity: Option<Register>,
    /// Dynamixel only.
    pub profile_acceleration: Option<Register>,
    /// Feetech only: 100 steps/s² per unit.
    pub acceleration: Option<Register>,
    /// Feetech only: steps/s.
    pub goal_speed: Option<Register>,
    /// Feetech only: 0 lets EEPROM writes persist, 1 locks.
    pub lock: Option<Register>,
    /// The bits of [`Self::hardware_error`].
    pub alarm_bits: AlarmBits,
    /// Registers below this address (EEPROM) are writable only with torque off: 64 on the X
    /// series, 0 (no such lock) on the STS3215.
    pub torque_locked_below: u16,
    /// Whether an alarm switches the torque off until a reboot (X series Shutdown register,
    /// factory default).
    pub shuts_down_on_alarm: bool,
    /// What the status return level register holds from the factory: 2 (answer every
    /// instruction) on the X series, 1 on the STS3215.
    pub factory_status_return_level: i64,
}

const fn unsigned(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::Unsigned)
}

const fn signed(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::TwosComplement)
}

const fn sign_magnitude(name: &'static str, address: u16, sign_bit: u8) -> Register {
    Register::new(name, address, 2, Encoding::SignMagnitude { sign_bit })
}

/// The X series table (PROTOCOLS.md §1.8); the models differ only in the model number and in
/// what address 126 measures.
const DXL_X: RegisterTable = RegisterTable {
    model: ServoModel::Xl330M288,
    model_number: 1200,
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
/// Current units; PROTOCOLS.md §1.8 notes the page is inconsistent, so this is not certain).
/// Stall current 1.47 A at the recommended 5.0 V for both XL330-M288 and XL330-M077
/// (ROBOTS.md §4; e-Manual `_data/dxl_x_info.yml`). XL330 measures input current, not motor
/// phase current.
const XL330_CURRENT: LoadUnit = LoadUnit::Current {
    milliamps_per_unit: 1.0,
    stall_milliamps: 1470.0,
};

static XL330_M288: RegisterTable = DXL_X;

static XL330_M077: RegisterTable = RegisterTable {
    model: ServoModel::Xl330M077,
    model_number: 1190,
    ..DXL_X
};

static XL430_W250: RegisterTable = RegisterTable {
    model: ServoModel::Xl430W250,
    model_number: 1060,
    present_load: signed("Present_Load", 126, 2),
    load_unit: LoadUnit::TenthPercent,
    ..DXL_X
};

/// XM430-W350: 2.69 mA per unit (PROTOCOLS.md §1.8), stall current 2.3 A at 12 V (ROBOTS.md §4).
static XM430_W350: RegisterTable = RegisterTable {
    model: ServoModel::Xm430W350,
    model_number: 1020,
    load_unit: LoadUnit::Current {
        milliamps_per_unit: 2.69,
        stall_milliamps: 2300.0,
    },
    ..DXL_X
};

/// STS3215 (PROTOCOLS.md §2.6); negative values are sign-magnitude with the bit given in §2.5.
static STS3215: RegisterTable = RegisterTable {
    model: ServoModel::Sts3215,
    model_number: 777,
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

/// The control table of a model.
pub fn table(model: ServoModel) -> &'static RegisterTable {
    match model {
        ServoModel::Sts3215 => &STS3215,
        ServoModel::Xl330M288 => &XL330_M288,
        ServoModel::Xl330M077 => &XL330_M077,
        ServoModel::Xl430W250 => &XL430_W250,
        ServoModel::Xm430W350 => &XM430_W350,
    }
}

/// What the model number register reports for a model.
pub fn model_number(model: ServoModel) -> u16 {
    table(model).model_number
}

/// The supported model of a bus protocol with this model number. Model numbers are only
/// unique within a vendor, so the protocol says which vendor's numbers to look in.
pub fn model_from_number(protocol: Protocol, number: u16) -> Option<ServoModel> {
    let dynamixel = protocol == Protocol::Dynamixel2;
    ServoModel::ALL
        .into_iter()
        .find(|&m| m.is_dynamixel() == dynamixel && model_number(m) == number)
}

impl RegisterTable {
    /// Every register of the model, EEPROM first.
    pub fn registers(&self) -> Vec<Register> {
        let mut all: Vec<Register> = [
            Some(self.model_number_register),
            Some(self.id),
            Some(self.baud_rate),
            Some(self.return_delay),
            Some(self.status_return_level),
            self.drive_mode,
            Some(self.operating_mode),
            Some(self.homing_offset),
            Some(self.torque_enable),
            Some(self.hardware_error),
            Some(self.goal_position),
            Some(self.present_position),
            Some(self.present_velocity),
            Some(self.present_load),
            Some(self.present_voltage),
            Some(self.present_temperature),
            Some(self.moving),
            self.profile_velocity,
            self.profile_acceleration,
            self.acceleration,
            self.goal_speed,
            self.lock,
        ]
        .into_iter()
        .flatten()
        .collect();
        all.sort_by_key(|r| r.address);
        all
    }

    pub fn find(&self, name: &str) -> Option<Register> {
        self.registers().into_iter().find(|r| r.name == name)
    }

    pub fn encode(&self, register: &Register, value: i64) -> Result<Vec<u8>, RegisterError> {
        register.encode(value, self.byte_order)
    }

    pub fn decode(&self, register: &Register, bytes: &[u8]) -> Result<i64, RegisterError> {
        register.decode(bytes, self.byte_order)
    }

    /// [`Self::decode`] for servo `id`'s answer: bytes that do not fit are a corrupt answer.
    pub fn decode_answer(
        &self,
        id: u8,
        register: &Register,
        bytes: &[u8],
    ) -> Result<i64, super::BusError> {
        self.decode(register, bytes)
            .map_err(|e| super::BusError::Corrupt {
                id,
                detail: e.to_string(),
            })
    }

    pub fn is_dynamixel(&self) -> bool {
        self.model.is_dynamixel()
    }

    /// The alarms in a [`Self::hardware_error`] value.
    pub fn alarms(&self, raw: u8) -> Alarms {
        self.alarm_bits.decode(raw)
    }

    /// Signed percentage of full load for a decoded [`Self::present_load`] value.
    pub fn load_percent(&self, value: i64) -> f64 {
        match self.load_unit {
            LoadUnit::TenthPercent => value as f64 / 10.0,
            LoadUnit::Current {
                milliamps_per_unit,
                stall_milliamps,
            } => value as f64 * milliamps_per_unit / stall_milliamps * 100.0,
        }
    }

    /// Current in mA, for the models whose load register measures current.
    pub fn current_milliamps(&self, value: i64) -> Option<f64> {
        match self.load_unit {
            LoadUnit::TenthPercent => None,
            LoadUnit::Current {
                milliamps_per_unit, ..
            } => Some(value as f64 * milliamps_per_unit),
        }
    }

    /// Volts for a decoded [`Self::present_voltage`] value.
    pub fn voltage_v(&self, value: i64) -> f64 {
        value as f64 / 10.0
    }

    /// °C for a decoded [`Self::present_temperature`] value.
    pub fn temperature_c(&self, value: i64) -> f64 {
        value as f64
    }

    /// The registers a health reading needs, for [`span`]: load, voltage, temperature and the
    /// alarm register.
    pub fn health_registers(&self) -> [Register; 4] {
        [
            self.present_load,
            self.present_voltage,
            self.present_temperature,
            self.hardware_error,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn sts_present_load_minus_50_percent() {
        let t = table(ServoModel::Sts3215);
        // −50 % = −500 tenths: magnitude 500 with the sign at bit 10, 500 + 1024 = 1524 =
        // 0x05F4, little-endian F4 05.
        let bytes = t.encode(&t.present_load, -500).unwrap();
        assert_eq!(bytes, [0xF4, 0x05]);
        let value = t.decode(&t.present_load, &[0xF4, 0x05]).unwrap();
        assert_eq!(value, -500);
        assert_eq!(t.load_percent(value), -50.0);
        // The same value on a big-endian (SCS) bus.
        assert_eq!(
            t.present_load.encode(-500, ByteOrder::Big).unwrap(),
            [0x05, 0xF4]
        );
        // Beyond the 10-bit magnitude.
        assert!(matches!(
            t.encode(&t.present_load, 1024),
            Err(RegisterError::OutOfRange { max: 1023, .. })
        ));
    }

    #[test]
    fn sts_goal_position_and_homing_offset() {
        let t = table(ServoModel::Sts3215);
        // −100: 0x8064 → 64 80 (PROTOCOLS.md §2.5 SCS_TOSCS(-100, 15)).
        assert_eq!(t.encode(&t.goal_position, -100).unwrap(), [0x64, 0x80]);
        assert_eq!(t.encode(&t.goal_position, 2048).unwrap(), [0x00, 0x08]);
        // Homing offset −2047: 0x7FF | 0x800 = 0x0FFF → FF 0F.
        assert_eq!(t.encode(&t.homing_offset, -2047).unwrap(), [0xFF, 0x0F]);
        assert!(t.encode(&t.homing_offset, 2048).is_err());
        // Present position reading 0x8001 is −1.
        assert_eq!(t.decode(&t.present_position, &[0x01, 0x80]).unwrap(), -1);
    }

    #[test]
    fn dynamixel_values() {
        let t = table(ServoModel::Xl430W250);
        // −131073 = 0xFFFD_FFFF → FF FF FD FF.
        assert_eq!(
            t.encode(&t.goal_position, -131073).unwrap(),
            [0xFF, 0xFF, 0xFD, 0xFF]
        );
        // Homing offset −1024 = 0xFFFF_FC00 → 00 FC FF FF.
        assert_eq!(
            t.encode(&t.homing_offset, -1024).unwrap(),
            [0x00, 0xFC, 0xFF, 0xFF]
        );
        // Present load −1000 (−100 %) = 0xFC18 → 18 FC.
        assert_eq!(t.encode(&t.present_load, -1000).unwrap(), [0x18, 0xFC]);
        assert_eq!(t.decode(&t.present_load, &[0x18, 0xFC]).unwrap(), -1000);
        assert_eq!(t.load_percent(-1000), -100.0);
        // 12.1 V = 121 = 0x0079.
        assert_eq!(t.decode(&t.present_voltage, &[0x79, 0x00]).unwrap(), 121);
        assert!((t.voltage_v(121) - 12.1).abs() < 1e-12);
        assert_eq!(t.temperature_c(41), 41.0);
        assert!(t.encode(&t.torque_enable, 256).is_err());
        assert!(t.encode(&t.torque_enable, -1).is_err());
    }

    #[test]
    fn current_models_report_percent_of_stall_current() {
        let xm = table(ServoModel::Xm430W350);
        assert_eq!(xm.present_load.name, "Present_Current");
        // 855 units × 2.69 mA = 2300 mA (rounded) = the stall current.
        assert!((xm.load_percent(855) - 100.0).abs() < 0.01);
        assert_eq!(xm.current_milliamps(100), Some(269.0));
        let xl = table(ServoModel::Xl330M288);
        assert!((xl.load_percent(-735) + 50.0).abs() < 1e-9);
        assert_eq!(table(ServoModel::Xl430W250).current_milliamps(10), None);
    }

    #[test]
    fn control_table_addresses() {
        for model in ServoModel::ALL.into_iter().filter(|m| m.is_dynamixel()) {
            let t = table(model);
            let at = |r: Register| (r.address, r.size);
            assert_eq!(at(t.model_number_register), (0, 2));
            assert_eq!(at(t.torque_enable), (64, 1));
            assert_eq!(at(t.hardware_error), (70, 1));
            assert_eq!(at(t.goal_position), (116, 4));
            assert_eq!(at(t.present_load), (126, 2));
            assert_eq!(at(t.present_position), (132, 4));
            assert_eq!(at(t.present_voltage), (144, 2));
            assert_eq!(at(t.present_temperature), (146, 1));
            assert_eq!(t.homing_offset_sign, 1);
        }
        let sts = table(ServoModel::Sts3215);
        assert_eq!(sts.goal_position.address, 42);
        assert_eq!(sts.present_position.address, 56);
        assert_eq!(sts.homing_offset_sign, -1);
        assert_eq!(span(&sts.health_registers()), Some((60, 6)));
        assert_eq!(
            span(&table(ServoModel::Xm430W350).health_registers()),
            Some((70, 77))
        );
        assert_eq!(span(&[]), None);
    }

    #[test]
    fn tables_are_consistent() {
        for model in ServoModel::ALL {
            let t = table(model);
            assert_eq!(t.model, model);
            let registers = t.registers();
            for pair in registers.windows(2) {
                assert!(
                    pair[0].end() <= pair[1].address,
                    "{}: {} overlaps {}",
                    model.name(),
                    pair[0].name,
                    pair[1].name
                );
            }
            for r in &registers {
                assert!(matches!(r.size, 1 | 2 | 4), "{}", r.name);
                if let Encoding::SignMagnitude { sign_bit } = r.encoding {
                    assert!(r.size == 2 && sign_bit < 16, "{}", r.name);
                }
                if !model.is_dynamixel() {
                    assert!(r.short_address().is_ok(), "{}", r.name);
                }
                assert_eq!(t.find(r.name), Some(*r));
            }
        }
    }

    #[test]
    fn goal_position_encoding_agrees_with_the_protocol() {
        for model in ServoModel::ALL {
            let protocol = if model.is_dynamixel() {
                Protocol::Dynamixel2
            } else {
                Protocol::FeetechSts
            };
            let t = table(model);
            assert_eq!(
                t.goal_position.position_encoding(),
                Some(protocol.position_encoding())
            );
            assert_eq!(t.byte_order, ByteOrder::of(protocol));
        }
        assert_eq!(ByteOrder::of(Protocol::FeetechScs), ByteOrder::Big);
    }

    #[test]
    fn model_numbers() {
        let expected = [
            (ServoModel::Xl330M288, 1200),
            (ServoModel::Xl330M077, 1190),
            (ServoModel::Xl430W250, 1060),
            (ServoModel::Xm430W350, 1020),
            (ServoModel::Sts3215, 777),
        ];
        for (model, number) in expected {
            assert_eq!(model_number(model), number);
            let protocol = if model.is_dynamixel() {
                Protocol::Dynamixel2
            } else {
                Protocol::FeetechSts
            };
            assert_eq!(model_from_number(protocol, number), Some(model));
        }
        assert_eq!(model_from_number(Protocol::Dynamixel2, 777), None);
        assert_eq!(model_from_number(Protocol::FeetechSts, 1060), None);
        assert_eq!(
            model_from_number(Protocol::FeetechScs, 777),
            Some(ServoModel::Sts3215)
        );
        assert_eq!(model_from_number(Protocol::Dynamixel2, 0), None);
    }

    #[test]
    fn alarms_dispatch_by_vendor() {
        // Bit 1 is the angle sensor on Feetech and unused on Dynamixel.
        assert!(table(ServoModel::Sts3215).alarms(0b10).encoder);
        assert!(!table(ServoModel::Xl430W250).alarms(0b10).any());
        assert!(table(ServoModel::Xl430W250).alarms(0b1000).encoder);
    }

    #[test]
    fn block_decoding() {
        let t = table(ServoModel::Sts3215);
        // Load −50 %, 7.4 V, 35 °C, 0, status overheat: read from 60.
        let block = [0xF4, 0x05, 74, 35, 0, 0b100];
        let (start, len) = span(&t.health_registers()).unwrap();
        assert_eq!(usize::from(len), block.len());
        let get = |r: Register| r.decode_in_block(&block, start, t.byte_order).unwrap();
        assert_eq!(get(t.present_load), -500);
        assert_eq!(get(t.present_voltage), 74);
        assert_eq!(get(t.present_temperature), 35);
        assert!(t.alarms(get(t.hardware_error) as u8).overheating);
        assert!(matches!(
            t.present_position
                .decode_in_block(&block, start, t.byte_order),
            Err(RegisterError::OutsideBlock { .. })
        ));
        assert!(matches!(
            t.goal_position.decode(&[1], t.byte_order),
            Err(RegisterError::Size { .. })
        ));
    }

    #[test]
    fn byte_order_helpers() {
        assert_eq!(
            ByteOrder::Little.to_bytes(0x1234_5678, 4),
            [0x78, 0x56, 0x34, 0x12]
        );
        assert_eq!(ByteOrder::Big.to_bytes(0x1234_5678, 2), [0x56, 0x78]);
        assert_eq!(ByteOrder::Big.from_bytes(&[0x12, 0x34]), Some(0x1234));
        assert_eq!(ByteOrder::Little.from_bytes(&[0x12, 0x34]), Some(0x3412));
        assert_eq!(ByteOrder::Little.from_bytes(&[0; 5]), None);
    }

    fn any_register() -> impl Strategy<Value = Register> {
        let models: Vec<Register> = ServoModel::ALL
            .into_iter()
            .flat_map(|m| table(m).registers())
            .chain([
                signed("i8", 0, 1),
                signed("i16", 0, 2),
                unsigned("u32", 0, 4),
                Register::new("sm1", 0, 1, Encoding::SignMagnitude { sign_bit: 7 }),
            ])
            .collect();
        prop::sample::select(models)
    }

    proptest! {
        #[test]
        fn values_in_range_round_trip(register in any_register(), seed in any::<i64>(), big in any::<bool>()) {
            let (min, max) = register.range();
            let span = (max - min) as u64 + 1;
            let value = min + (seed as u64 % span) as i64;
            let order = if big { ByteOrder::Big } else { ByteOrder::Little };
            let bytes = register.encode(value, order).unwrap();
            prop_assert_eq!(bytes.len(), usize::from(register.size));
            prop_assert_eq!(register.decode(&bytes, order).unwrap(), value);
        }

        #[test]
        fn any_bytes_decode(register in any_register(), bytes in prop::collection::vec(any::<u8>(), 4)) {
            let bytes = &bytes[..usize::from(register.size)];
            let value = register.decode(bytes, ByteOrder::Little).unwrap();
            let (min, max) = register.range();
            prop_assert!(min <= value && value <= max);
        }

        #[test]
        fn values_out_of_range_are_refused(register in any_register(), excess in 1i64..1000) {
            let (min, max) = register.range();
            prop_assert!(register.to_raw(max + excess).is_err());
            prop_assert!(register.to_raw(min - excess).is_err());
        }
    }
}
