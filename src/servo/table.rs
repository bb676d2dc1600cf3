//! One model's control table as the drivers and the emulator use it: the registers with a
//! role, their units, and the firmware behaviours around them. The full table, as the manual
//! lists it, is [`super::item`].

use super::register::{ByteOrder, Register, RegisterError};
use super::{AlarmBits, Alarms, OverloadRule};

/// What the present load/current register measures and how to express it as a percentage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoadUnit {
    /// Signed tenths of a percent of the maximum (Feetech STS: of PWM duty; XL430: of torque).
    TenthPercent,
    /// Signed current. Expressed as a percentage of the stall current at the rated voltage,
    /// which is what "100 % load" means for a servo held still at full effort.
    Current {
        /// Milliamps per register unit.
        milliamps_per_unit: f64,
        /// The stall current at the rated voltage, mA: what 100 % means.
        stall_milliamps: f64,
    },
}

/// One model's control table: the registers the drivers and the emulator use, their units,
/// and the firmware behaviours around them.
#[derive(Debug, Clone, PartialEq)]
pub struct RegisterTable {
    /// The order of multi-byte values' bytes.
    pub byte_order: ByteOrder,
    /// The model number (read-only).
    pub model_number_register: Register,
    /// The servo's id on the bus.
    pub id: Register,
    /// The bus speed, as the vendor's code for it.
    pub baud_rate: Register,
    /// Unit 2 µs. FT-MEM says it has no function on STS.
    pub return_delay: Register,
    /// Which instructions are answered (Dynamixel Status Return Level, Feetech response level).
    pub status_return_level: Register,
    /// Dynamixel only: bit 0 reverses the direction of goal and present position.
    pub drive_mode: Option<Register>,
    /// Operating_Mode, where the model can switch modes. `None`: the model is always in
    /// (single-turn) position mode, which nothing can change (an AX-12 of Protocol 1.0).
    pub operating_mode: Option<Register>,
    /// Homing_Offset, where the firmware shifts the reported position by one. `None`: Present
    /// Position is the shaft's own, so the only homing offset that describes the servo is 0
    /// (an AX-12 of Protocol 1.0).
    pub homing_offset: Option<Register>,
    /// The position limits (CW and CCW Angle Limit, where a model's manual calls them so):
    /// goals outside them are clamped in position mode; both 0 mean no range (Feetech
    /// multi-turn).
    pub min_position_limit: Register,
    /// The upper position limit (see [`Self::min_position_limit`]).
    pub max_position_limit: Register,
    /// 0 limp, 1 holding (and the model's recalibrate value, where it has one).
    pub torque_enable: Register,
    /// Dynamixel Hardware Error Status (70) or Feetech Status (65); see [`Self::alarms`].
    pub hardware_error: Register,
    /// Where the servo is told to go, ticks.
    pub goal_position: Register,
    /// Where the servo is, ticks.
    pub present_position: Register,
    /// Its speed now, in the model's velocity unit.
    pub present_velocity: Register,
    /// Present Load (XL430, STS) or Present Current (XL330, XM430); see [`Self::load_unit`].
    pub present_load: Register,
    /// A present-current register beside [`Self::present_load`] and its unit, mA (the
    /// STS3215's; where the load register measures current, none).
    pub present_current: Option<(Register, f64)>,
    /// What [`Self::present_load`] measures.
    pub load_unit: LoadUnit,
    /// 0.1 V per unit on every model.
    pub present_voltage: Register,
    /// °C.
    pub present_temperature: Register,
    /// °C: the temperature at which the servo's heat protection trips (STS Max_Temperature_Limit,
    /// X series Temperature_Limit).
    pub temperature_limit: Register,
    /// 1 while the servo moves toward its goal.
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
    /// Where the firmware counts an overload.
    pub overload: OverloadRule,
    /// The RAM register that caps the motor's output while it runs, and the value that is
    /// its full output: Feetech Torque_Limit (1000), the X series' Goal_PWM (885), which caps
    /// the PWM in every position mode (the XL430 has no current control). A grasp's effort is
    /// written here.
    pub effort_limit: (Register, i64),
    /// What the status return level register holds from the factory: 2 (answer every
    /// instruction) on the X series, 1 on the STS3215.
    pub factory_status_return_level: i64,
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
            self.operating_mode,
            self.homing_offset,
            Some(self.min_position_limit),
            Some(self.max_position_limit),
            Some(self.torque_enable),
            Some(self.hardware_error),
            Some(self.goal_position),
            Some(self.present_position),
            Some(self.present_velocity),
            Some(self.present_load),
            Some(self.present_voltage),
            Some(self.present_temperature),
            Some(self.temperature_limit),
            Some(self.moving),
            self.profile_velocity,
            self.profile_acceleration,
            self.acceleration,
            self.goal_speed,
            self.lock,
            Some(self.effort_limit.0),
        ]
        .into_iter()
        .flatten()
        .collect();
        all.sort_by_key(|r| r.address);
        all
    }

    /// The register with a role called `name`.
    pub fn find(&self, name: &str) -> Option<Register> {
        self.registers().into_iter().find(|r| r.name == name)
    }

    /// The bytes of `value` in `register`, in this table's byte order.
    pub fn encode(&self, register: &Register, value: i64) -> Result<Vec<u8>, RegisterError> {
        register.encode(value, self.byte_order)
    }

    /// Writes `value` into `register`'s bytes of `memory` (a control table laid out by
    /// address, which holds every register of this table), in this table's byte order:
    /// [`Self::encode`] without allocating. Only a value the register cannot hold is refused.
    pub fn encode_into(
        &self,
        register: &Register,
        value: i64,
        memory: &mut [u8],
    ) -> Result<(), RegisterError> {
        let start = usize::from(register.address);
        let bytes = &mut memory[start..start + usize::from(register.size)];
        self.byte_order.put_bytes(register.to_raw(value)?, bytes);
        Ok(())
    }

    /// The value of `register` in `bytes`, in this table's byte order.
    pub fn decode(&self, register: &Register, bytes: &[u8]) -> Result<i64, RegisterError> {
        register.decode(bytes, self.byte_order)
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

    /// The registers a health reading needs, for [`super::span`]: load, voltage, temperature,
    /// the alarm register, and the current register where the model has one beside the load.
    pub fn health_registers(&self) -> Vec<Register> {
        let mut registers = vec![
            self.present_load,
            self.present_voltage,
            self.present_temperature,
            self.hardware_error,
        ];
        registers.extend(self.present_current.map(|(register, _)| register));
        registers
    }

    /// Amperes, from a decoded [`Self::present_load`] value and, where the model has one, a
    /// decoded [`Self::present_current`] value; `None` for a model that measures no current
    /// (the XL430).
    pub fn current_a(&self, load: i64, current: Option<i64>) -> Option<f64> {
        match (self.present_current, current) {
            (Some((_, milliamps_per_unit)), Some(value)) => {
                Some(value as f64 * milliamps_per_unit / 1000.0)
            }
            _ => self.current_milliamps(load).map(|ma| ma.abs() / 1000.0),
        }
    }
}
