//! Jerk, for a joint with a jerk limit: the curve's own third derivative on each span, and the
//! places where its acceleration jumps.
//!
//! On a span the jerk is a polynomial like position, velocity and acceleration, so its peaks
//! are found exactly the same way. Where two spans meet, the acceleration may jump: at a key of
//! a key-time cubic (its second derivative is not continuous there), where a constant-path-
//! acceleration timing profile changes its path acceleration while the joint moves, where the
//! motion starts or ends with an acceleration other than zero, and at every step or corner. A
//! jump of the acceleration is an infinite jerk, whatever the control rate: the servo is asked
//! to change its torque at once, which is what a jerk limit is there to prevent. So each one is
//! a violation of its own, reported with its time and its size.

use super::spans::{JointCurve, Span};
use super::Cause;

/// Where the acceleration of a curve (with its rest before and after) jumps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccelerationJump {
    /// Sequence time, seconds.
    pub time: f64,
    /// Acceleration just after minus just before, per second squared (for a step or a corner,
    /// the curve's own on either side; the jump in value or velocity is worse still).
    pub jump: f64,
    /// A step (the value jumps), a corner (the velocity jumps) or a jump of the acceleration
    /// alone.
    pub cause: Cause,
}

/// The third derivative of a span, per second cubed.
pub fn jerk(span: &Span) -> Span {
    span.derivative().derivative().derivative()
}

/// Every place where the curve's acceleration, velocity or value jumps beyond rounding.
pub fn acceleration_jumps(curve: &JointCurve) -> Vec<AccelerationJump> {
    let steps_and_corners = curve.discontinuities();
    curve
        .extended
        .windows(2)
        .filter_map(|w| {
            let (left, right) = (&w[0], &w[1]);
            let a = left.derivative().derivative().at_end();
            let b = right.derivative().derivative().at_start();
            let time = right.start;
            let other = steps_and_corners.iter().find(|d| d.time == time);
            // The spans of one polynomial split at a key agree to rounding; a real jump is
            // far above it (composed timing pieces round a little more than the cubic alone).
            let real = (b - a).abs() > 1e-7 * (1.0 + a.abs() + b.abs());
            let cause = match other {
                Some(d) if d.jump != 0.0 => Cause::Step,
                Some(_) => Cause::Corner,
                None if real => Cause::AccelerationJump,
                None => return None,
            };
            Some(AccelerationJump {
                time,
                jump: if real { b - a } else { 0.0 },
                cause,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curve::{Interp, Track, TrackKey};
    use crate::plan::Timing;

    #[test]
    fn a_smoothstep_jumps_by_six_distance_over_duration_squared_at_each_end() {
        // 0 → 30 in 2 s with zero slopes: 30·(3f² − 2f³), f = t/2. Its acceleration is
        // 30·(6 − 12f)/4: 45 at the start and −45 at the end, from and to rest; its jerk is
        // −30·12/8 = −45 throughout.
        let keys = [0.0, 30.0].map(|v| TrackKey::new(2.0 * v / 30.0, v, Interp::Cubic));
        let track = Track::new(&keys).unwrap();
        let curve = JointCurve::new(&track, &Timing::default(), 0.0, 2.0, &[0.0, 2.0], 0.1);
        let jumps = acceleration_jumps(&curve);
        assert_eq!(jumps.len(), 2, "{jumps:?}");
        assert_eq!(jumps[0].cause, Cause::AccelerationJump);
        assert!((jumps[0].time - 0.0).abs() < 1e-12 && (jumps[0].jump - 45.0).abs() < 1e-9);
        assert!((jumps[1].time - 2.0).abs() < 1e-12 && (jumps[1].jump - 45.0).abs() < 1e-9);
        for span in &curve.played {
            let j = jerk(span);
            assert!((j.at_start() + 45.0).abs() < 1e-9 && (j.at_end() + 45.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_smooth_move_starts_and_stops_without_a_jump_at_sixty_distance_over_duration_cubed() {
        // The same 0 → 30 in 2 s, smooth: 30·(10f³ − 15f⁴ + 6f⁵). Its acceleration is zero at
        // both ends, so nothing jumps; its jerk 30·(60 − 360f + 360f²)/8 is 225 at either end
        // and −112.5 at the middle.
        let keys = [0.0, 30.0].map(|v| TrackKey::new(2.0 * v / 30.0, v, Interp::Smooth));
        let track = Track::new(&keys).unwrap();
        let curve = JointCurve::new(&track, &Timing::default(), 0.0, 2.0, &[0.0, 2.0], 0.1);
        assert_eq!(acceleration_jumps(&curve), vec![]);
        let moving: Vec<_> = curve.played.iter().filter(|s| s.len() > 0.0).collect();
        let (first, last) = (moving[0], moving[moving.len() - 1]);
        assert!((jerk(first).at_start() - 225.0).abs() < 1e-9);
        assert!((jerk(last).at_end() - 225.0).abs() < 1e-9);
        let middle = curve.span_at(1.0);
        let j = jerk(middle).poly.eval(1.0 - middle.start);
        assert!((j + 112.5).abs() < 1e-9, "{j}");
    }
}
