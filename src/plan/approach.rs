//! The approach ramp: from wherever the arm is to the first pose of playback, never a jump.
//!
//! Every joint follows the same profile `s` from 0 to 1 along the straight line between the two
//! poses, which starts and ends at rest with zero acceleration, so all joints arrive together.
//! Without jerk limits it is the minimum-jerk profile `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵` ([`minimum_jerk`]),
//! whose peak velocity is `15/8 · Δ/T` and peak acceleration `10/√3 · Δ/T²`. A robot with jerk
//! limits gets the S-curve of `plan::scurve` instead, time-optimal under every joint's velocity,
//! acceleration and jerk limit (its jerk bounded, where the minimum-jerk profile's is not set by
//! any limit). Either way the duration is the shortest that keeps every joint within a fraction
//! of its limits — the arm starts from an unknown pose, so the approach is deliberately gentler
//! than the sequence may be.

use super::scurve::{point_to_point, SCurve};
use crate::robot::Robot;

/// Peak of ds/dτ for the minimum-jerk profile.
const PEAK_VELOCITY_FACTOR: f64 = 15.0 / 8.0;
/// Peak of |d²s/dτ²| for the minimum-jerk profile, 10/√3.
const PEAK_ACCELERATION_FACTOR: f64 = 5.773_502_691_896_258;
/// Share of each joint's velocity and acceleration limits the approach may use.
pub const APPROACH_LIMIT_SHARE: f64 = 0.5;
/// Shortest approach, seconds: even a tiny correction is a visible, deliberate motion.
pub const MIN_APPROACH_SECONDS: f64 = 0.5;

/// A ramp of every joint at once, in joint units.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Approach {
    /// Where it starts, in robot joint order.
    pub from: Vec<f64>,
    /// Where it ends.
    pub to: Vec<f64>,
    /// Seconds.
    pub duration: f64,
    /// How the share of the way runs over time.
    profile: Profile,
}

/// The ramp's profile, from rest to rest.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Profile {
    /// 10τ³ − 15τ⁴ + 6τ⁵ of the share of the time τ.
    MinimumJerk,
    /// An S-curve over the distance 1 (the robot has jerk limits).
    SCurve(SCurve),
}

/// The minimum-jerk share of the way at the share `u` of the time: 10u³ − 15u⁴ + 6u⁵, at rest
/// (zero velocity and acceleration) at both ends.
pub(crate) fn minimum_jerk(u: f64) -> f64 {
    u * u * u * (10.0 + u * (-15.0 + 6.0 * u))
}

impl Approach {
    /// A ramp from `from` to `to` (joint values in robot order), timed by `robot`'s limits.
    pub fn new(robot: &Robot, from: &[f64], to: &[f64]) -> Approach {
        Self::at_least(robot, from, to, MIN_APPROACH_SECONDS)
    }

    /// [`Approach::new`] with another shortest duration (a jog of a joint held where it is,
    /// whose start is known exactly, needs no deliberate half second).
    pub fn at_least(robot: &Robot, from: &[f64], to: &[f64], shortest: f64) -> Approach {
        if robot.joints.iter().any(|j| j.limits.jerk.is_some()) {
            if let Some(curve) = point_to_point(robot, from, to, APPROACH_LIMIT_SHARE) {
                // Stretched to the shortest duration, the same shape at a lower jerk.
                let curve = if curve.duration() < shortest {
                    SCurve::shaped(curve.shape(), shortest, 1.0)
                } else {
                    curve
                };
                return Approach {
                    from: from.to_vec(),
                    to: to.to_vec(),
                    duration: curve.duration(),
                    profile: Profile::SCurve(curve),
                };
            }
        }
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
            profile: Profile::MinimumJerk,
        }
    }

    /// Joint values at `t` seconds into the ramp (held at the ends outside it).
    pub fn sample_into(&self, t: f64, out: &mut [f64]) {
        let s = match self.profile {
            Profile::MinimumJerk => minimum_jerk((t / self.duration).clamp(0.0, 1.0)),
            Profile::SCurve(curve) if t >= curve.duration() => 1.0,
            Profile::SCurve(curve) => curve.state_at(t).position,
        };
        for ((slot, a), b) in out.iter_mut().zip(&self.from).zip(&self.to) {
            *slot = a + (b - a) * s;
        }
    }
}
