//! The servo side of a joint: id, model, and the mapping between joint values and ticks.
//!
//! A tick is the servo's raw position unit; how many make a revolution is the model's
//! ([`crate::servo::ModelSpec::ticks_per_revolution`]: 4096 on every supported model). The
//! mapping is affine: `tick = zero_tick + direction · value / units_per_tick`. On the wire the
//! tick is then encoded the protocol's way ([`PositionEncoding`]): Dynamixel uses 32-bit two's
//! complement, Feetech STS a sign bit over a magnitude, Feetech SCS plain unsigned 16 bits.

pub use crate::servo::{Drive, PositionEncoding, ServoModel, TickError, Variant, Vendor};

/// A joint's servo: which one on the bus, what model, and how its ticks map to joint values.
#[derive(Debug, Clone, PartialEq)]
pub struct Servo {
    /// Its id on the bus.
    pub id: u8,
    /// Its model, which gives its control table and units.
    pub model: ServoModel,
    /// Tick at joint value 0. Fractional when it comes from a calibration range midpoint.
    pub zero_tick: f64,
    /// +1 when ticks increase with the joint value, −1 when they decrease.
    pub direction: f64,
    /// Joint units per tick: degrees for a revolute joint, metres for a prismatic one.
    pub units_per_tick: f64,
    /// The homing offset the servo is calibrated with, when known; checked against the servo.
    pub homing_offset: Option<i64>,
    /// Its variant (gear and winding): the robot file's `variant`, else the model's default.
    pub variant: &'static Variant,
    /// Its supply, volts: the servo's `supply_v`, else the robot's, else the variant's first.
    pub supply_v: f64,
}

impl Servo {
    /// What it drives at its supply; `None` where its variant has no published data.
    pub fn drive(&self) -> Option<&'static Drive> {
        self.variant.at(self.supply_v)
    }

    /// Joint units, SI (radians of a revolute joint, metres of a prismatic one), per radian
    /// of the servo's output shaft: 1 for a revolute joint on the shaft, the pinion's radius
    /// for a rack. A joint's torque (or force) times it is the servo's torque; the servo's
    /// speed is the joint's over it.
    pub fn transmission(&self, kind: super::JointKind) -> f64 {
        let per_revolution = self.units_per_tick * self.model.spec().ticks_per_revolution;
        match kind {
            super::JointKind::Revolute => per_revolution / 360.0,
            super::JointKind::Prismatic => per_revolution / std::f64::consts::TAU,
        }
    }

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
