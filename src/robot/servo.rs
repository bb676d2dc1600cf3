//! The servo side of a joint: id, model, and the mapping between joint values and ticks.
//!
//! A tick is the servo's raw position unit, 4096 per revolution on every supported model. The
//! mapping is affine: `tick = zero_tick + direction · value / units_per_tick`. On the wire the
//! tick is then encoded the protocol's way: Dynamixel uses 32-bit two's complement, Feetech STS
//! a sign bit over a magnitude, Feetech SCS plain unsigned 16 bits.

pub const TICKS_PER_REVOLUTION: f64 = 4096.0;
pub const DEGREES_PER_TICK: f64 = 360.0 / TICKS_PER_REVOLUTION;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoModel {
    Sts3215,
    Xl330M288,
    Xl330M077,
    Xl430W250,
    Xm430W350,
}

/// Which vendor made a servo: whose protocol it speaks, whose model numbers and control tables
/// it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Vendor {
    Dynamixel,
    Feetech,
}

/// A servo model as a robot file names it. What the bus knows of each model (model number,
/// control table, units, speeds, the ranges of its modes) is its `bus::models::ModelSpec`,
/// reached through `ServoModel::spec`; a robot needs only its name and vendor.
impl ServoModel {
    pub const ALL: [ServoModel; 5] = [
        ServoModel::Sts3215,
        ServoModel::Xl330M288,
        ServoModel::Xl330M077,
        ServoModel::Xl430W250,
        ServoModel::Xm430W350,
    ];

    /// The name robot files use.
    pub fn name(self) -> &'static str {
        match self {
            ServoModel::Sts3215 => "sts3215",
            ServoModel::Xl330M288 => "xl330-m288",
            ServoModel::Xl330M077 => "xl330-m077",
            ServoModel::Xl430W250 => "xl430-w250",
            ServoModel::Xm430W350 => "xm430-w350",
        }
    }

    pub fn parse(s: &str) -> Option<ServoModel> {
        ServoModel::ALL.into_iter().find(|m| m.name() == s)
    }

    pub fn vendor(self) -> Vendor {
        match self {
            ServoModel::Sts3215 => Vendor::Feetech,
            _ => Vendor::Dynamixel,
        }
    }

    /// Whether a bus of `protocol` can address this model.
    pub fn speaks(self, protocol: super::Protocol) -> bool {
        self.vendor() == protocol.vendor()
    }
}

/// How a signed tick count is represented in a position register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PositionEncoding {
    /// Dynamixel X series: 4-byte two's complement.
    TwosComplement32,
    /// Feetech STS/SMS: magnitude in the low bits, `sign_bit` set for negative values.
    SignMagnitude16 { sign_bit: u8 },
    /// Feetech SCS: unsigned positions only.
    Unsigned16,
}

#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TickError {
    #[error("tick {tick} does not fit the servo's position register ({min} to {max})")]
    OutOfRange { tick: i64, min: i64, max: i64 },
    #[error("joint value {0} has no tick: it is not a finite number")]
    NotFinite(f64),
    #[error("joint value {value} is outside the limits {min} … {max}")]
    OutsideLimits { value: f64, min: f64, max: f64 },
}

impl PositionEncoding {
    /// The range of ticks the register can hold.
    pub fn range(self) -> (i64, i64) {
        match self {
            PositionEncoding::TwosComplement32 => (i32::MIN as i64, i32::MAX as i64),
            PositionEncoding::SignMagnitude16 { sign_bit } => {
                let magnitude = (1i64 << sign_bit) - 1;
                (-magnitude, magnitude)
            }
            PositionEncoding::Unsigned16 => (0, u16::MAX as i64),
        }
    }

    /// The register's raw bits for a tick count.
    pub fn encode(self, tick: i64) -> Result<u32, TickError> {
        let (min, max) = self.range();
        if tick < min || tick > max {
            return Err(TickError::OutOfRange { tick, min, max });
        }
        Ok(match self {
            PositionEncoding::TwosComplement32 => tick as i32 as u32,
            PositionEncoding::SignMagnitude16 { sign_bit } => {
                let magnitude = tick.unsigned_abs() as u32;
                if tick < 0 {
                    magnitude | (1 << sign_bit)
                } else {
                    magnitude
                }
            }
            PositionEncoding::Unsigned16 => tick as u32,
        })
    }

    /// The tick count in a register's raw bits.
    pub fn decode(self, raw: u32) -> i64 {
        match self {
            PositionEncoding::TwosComplement32 => raw as i32 as i64,
            PositionEncoding::SignMagnitude16 { sign_bit } => {
                let magnitude = (raw & ((1 << sign_bit) - 1)) as i64;
                if raw & (1 << sign_bit) != 0 {
                    -magnitude
                } else {
                    magnitude
                }
            }
            PositionEncoding::Unsigned16 => (raw & 0xFFFF) as i64,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Servo {
    pub id: u8,
    pub model: ServoModel,
    /// Tick at joint value 0. Fractional when it comes from a calibration range midpoint.
    pub zero_tick: f64,
    /// +1 when ticks increase with the joint value, −1 when they decrease.
    pub direction: f64,
    /// Joint units per tick: degrees for a revolute joint, metres for a prismatic one.
    pub units_per_tick: f64,
    /// The homing offset the servo is calibrated with, when known; checked against the servo.
    pub homing_offset: Option<i64>,
}

impl Servo {
    /// Exact (unrounded) tick for a joint value.
    pub fn tick_exact(&self, value: f64) -> f64 {
        self.zero_tick + self.direction * value / self.units_per_tick
    }

    /// The tick sent to the servo for a joint value: the nearest whole tick.
    pub fn tick(&self, value: f64) -> Result<i64, TickError> {
        if !value.is_finite() {
            return Err(TickError::NotFinite(value));
        }
        let tick = self.tick_exact(value).round();
        if tick.abs() > i64::MAX as f64 / 2.0 {
            return Err(TickError::OutOfRange {
                tick: tick as i64,
                min: i32::MIN as i64,
                max: i32::MAX as i64,
            });
        }
        Ok(tick as i64)
    }

    /// The joint value a tick stands for.
    pub fn value(&self, tick: i64) -> f64 {
        self.value_exact(tick as f64)
    }

    /// The joint value at a fractional tick: the inverse of [`Servo::tick_exact`].
    pub fn value_exact(&self, tick: f64) -> f64 {
        (tick - self.zero_tick) * self.units_per_tick * self.direction
    }
}
