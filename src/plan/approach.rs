//! The approach ramp: from wherever the arm is to the first pose of playback, never a jump.
//!
//! Every joint follows the same minimum-jerk profile `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵`, which starts and
//! ends at rest with zero acceleration, so all joints arrive together. Its peak velocity is
//! `15/8 · Δ/T` and its peak acceleration `10/√3 · Δ/T²`; the duration is the shortest that keeps
//! every joint within a fraction of its limits — the arm starts from an unknown pose, so the
//! approach is deliberately gentler than the sequence may be.

use crate::robot::Robot;

/// Peak of ds/dτ for the minimum-jerk profile.
const PEAK_VELOCITY_FACTOR: f64 = 15.0 / 8.0;
/// Peak of |d²s/dτ²| for the minimum-jerk profile, 10/√3.
const PEAK_ACCELERATION_FACTOR: f64 = 5.773_502_691_896_258;
/// Share of each joint's velocity and acceleration limits the approach may use.
pub const APPROACH_LIMIT_SHARE: f64 = 0.5;
/// Shortest approach, seconds: even a tiny correction is a visible, deliberate motion.
pub const MIN_APPROACH_SECONDS: f64 = 0.5;

/// A minimum-jerk ramp of every joint at once, in joint units.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Approach {
    /// Where it starts, in robot joint order.
    pub from: Vec<f64>,
    /// Where it ends.
    pub to: Vec<f64>,
    /// Seconds.
    pub duration: f64,
}

impl Approach {
    /// A ramp from `from` to `to` (joint values in robot order), timed by `robot`'s limits.
    pub fn new(robot: &Robot, from: &[f64], to: &[f64]) -> Approach {
        Self::at_least(robot, from, to, MIN_APPROACH_SECONDS)
    }

    /// [`Approach::new`] with another shortest duration (a jog of a joint held where it is,
    /// whose start is known exactly, needs no deliberate half second).
    pub fn at_least(robot: &Robot, from: &[f64], to: &[f64], shortest: f64) -> Approach {
        let duration = robot
            .joints
            .iter()
            .zip(from.iter().zip(to))
            .map(|(joint, (a, b))| {
                let distance = (b - a).abs();
                let v = joint.limits.velocity * APPROACH_LIMIT_SHARE;
                let acc = joint.limits.acceleration * APPROACH_LIMIT_SHARE;
                (PEAK_VELOCITY_FACTOR * distance / v)
                    .max((PEAK_ACCELERATION_FACTOR * distance / acc).sqrt())
            })
            .fold(shortest, f64::max);
        Approach {
            from: from.to_vec(),
            to: to.to_vec(),
            duration,
        }
    }

    /// Joint values at `t` seconds into the ramp (held at the ends outside it).
    pub fn sample_into(&self, t: f64, out: &mut [f64]) {
        let tau = (t / self.duration).clamp(0.0, 1.0);
        let s = tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau));
        for ((slot, a), b) in out.iter_mut().zip(&self.from).zip(&self.to) {
            *slot = a + (b - a) * s;
        }
    }
}
