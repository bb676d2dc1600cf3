//! A joint's limits in its servo's own motion-profile registers, for `--servo-profile`: the
//! acceleration (and, on Dynamixel, velocity) limit a servo applies between the goals it
//! receives, so it smooths a streamed trajectory itself. Which registers, their units and
//! their largest values are the model's ([`crate::servo::ModelSpec::profile`]; docs/protocols.md).
//!
//! A joint limit becomes register units **rounded down**: the servo then never accelerates (or
//! moves) faster than the joint's limit allows, at the price of lagging a goal stream that uses
//! the whole limit by under one unit's worth. Rounding up would let it exceed the limit that
//! the plan was checked against. A limit below one unit cannot be expressed (0 means "no
//! limit", the opposite of what is wanted) and is refused.

use super::Joint;
use crate::servo::{Limit, ProfileRegister, Setting};

/// A joint limit below one unit of the servo's profile register: it cannot be expressed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("--servo-profile: joint {joint}'s {what} limit {limit} {unit} is below one unit of the servo's {register} ({unit_value:.3} {unit}); nothing was written")]
pub struct ProfileError {
    /// The joint's name.
    pub joint: String,
    /// Which limit: "acceleration" or "velocity".
    pub what: &'static str,
    /// The register's name in the control table.
    pub register: &'static str,
    /// The joint's limit, in `unit`.
    pub limit: f64,
    /// What one unit of the register is, in `unit`.
    pub unit_value: f64,
    /// The limit's unit ("deg/s²", "m/s", …).
    pub unit: String,
}

/// The settings to write for `joint` (register, value), from its limits, in the order the
/// model's description lists its profile registers.
pub fn settings_for(joint: &Joint) -> Result<Vec<(Setting, i64)>, ProfileError> {
    let values: Vec<Result<(Setting, i64), ProfileError>> = joint
        .servo
        .model
        .spec()
        .profile
        .iter()
        .map(|register| Ok((register.setting, units(joint, register)?.min(register.max))))
        .collect();
    // Of two limits below one unit, the acceleration's (which every model bounds) is reported.
    let refused = values
        .iter()
        .filter_map(|value| value.as_ref().err())
        .min_by_key(|error| error.what != Limit::Acceleration.name());
    match refused {
        Some(error) => Err(error.clone()),
        None => values.into_iter().collect(),
    }
}

/// What the servo will really apply for `joint` once [`settings_for`] is written, in joint
/// units: (acceleration limit per s², velocity limit per s if the servo has one), from the
/// rounded register values. The simulation models these, so its verdict reflects the rounding.
pub fn applied_limits(joint: &Joint) -> Result<(f64, Option<f64>), ProfileError> {
    let per_tick = joint.servo.units_per_tick.abs();
    let spec = joint.servo.model.spec();
    let mut acceleration = 0.0;
    let mut velocity = None;
    for (setting, value) in settings_for(joint)? {
        let Some(register) = spec.profile_register(setting) else {
            continue;
        };
        let applied = value as f64 * register.unit * per_tick;
        match register.limit {
            Limit::Acceleration => acceleration = applied,
            Limit::Velocity => velocity = Some(applied),
        }
    }
    Ok((acceleration, velocity))
}

/// The joint's limit for `register` in its units (ticks each), rounded down; refused below one
/// unit.
fn units(joint: &Joint, register: &ProfileRegister) -> Result<i64, ProfileError> {
    let limit = match register.limit {
        Limit::Acceleration => joint.limits.acceleration,
        Limit::Velocity => joint.limits.velocity,
    };
    let limit_ticks = limit / joint.servo.units_per_tick;
    let value = (limit_ticks.abs() / register.unit).floor();
    if value >= 1.0 {
        return Ok(value.min(i64::MAX as f64) as i64);
    }
    let unit = format!("{}{}", joint.kind.unit(), register.limit.per_time());
    Err(ProfileError {
        joint: joint.name.clone(),
        what: register.limit.name(),
        register: register.setting.name(),
        limit,
        unit_value: register.unit * joint.servo.units_per_tick.abs(),
        unit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    #[test]
    fn a_limit_below_one_register_unit_is_refused_rather_than_written_as_no_limit() {
        // STS: one unit = 100 steps/s² = 100 · 360/4096 = 8.789 °/s²; 5 °/s² is below it.
        let mut robot = Robot::builtin("so101").unwrap();
        robot.joints[0].limits.acceleration = 5.0;
        let error = settings_for(&robot.joints[0]).unwrap_err();
        assert_eq!(error.register, "Acceleration");
        assert!((error.unit_value - 8.789).abs() < 1e-3, "{error}");
    }

    #[test]
    fn the_simulated_profile_is_the_rounded_register_value_in_joint_units() {
        // so101: 344 °/s² → 39 units → 39 · 100 · 360/4096 = 342.77 °/s², no velocity register.
        let robot = Robot::builtin("so101").unwrap();
        let (a, v) = applied_limits(&robot.joints[0]).unwrap();
        assert!((a - 342.773).abs() < 1e-3, "{a}");
        assert_eq!(v, None);
        // koch shoulder_pan (XL430): 32 · 21.4577 = 686.65 °/s²; 160 · 1.374 = 219.84 °/s.
        let koch = Robot::builtin("koch").unwrap();
        let (a, v) = applied_limits(&koch.joints[0]).unwrap();
        assert!((a - 686.65).abs() < 1e-2, "{a}");
        assert!((v.unwrap() - 219.84).abs() < 1e-2, "{v:?}");
    }
}
