//! The cubic Hermite a controller plays between two points that carry positions and velocities
//! (ros2_control's joint_trajectory_controller, docs/interop.md §2.2), judged exactly against
//! the curve it stands for and against the joint's limits.
//!
//! Where keypose's curve is a cubic in time (a segment without a timing profile) the Hermite
//! through its values and slopes is that cubic, and nothing needs judging. On a segment with a
//! timing profile the curve is a cubic of path time run at a changing path speed, a polynomial
//! of a higher degree in time (`plan::check::spans`); the Hermite through points on it only
//! approaches it, so the export cuts the stretch between two points in half until, on every
//! piece, every joint's Hermite stays within a tolerance of the curve and its position,
//! velocity and acceleration (polynomials, their extremes found exactly as the limit check
//! finds them, `plan::check::runs`) within the joint's limits.

use crate::plan::check::poly::Poly;
use crate::plan::check::runs;
use crate::plan::check::spans::Span;
use crate::plan::LimitKind;
use crate::robot::{Joint, JointKind};

/// How far (degrees, or metres) a Hermite may stray from the curve it stands for: far below
/// what a servo resolves (a 4096-tick turn is 0.088° a tick).
const TOLERANCE_DEG: f64 = 1e-3;
const TOLERANCE_M: f64 = 1e-6;

/// A joint's position and velocity at `t`, on the span that starts there where two meet (the
/// slope after a corner, as a point carries it).
pub(crate) fn state_at(spans: &[Span], t: f64) -> (f64, f64) {
    let i = spans.partition_point(|s| s.start <= t).saturating_sub(1);
    let span = &spans[i];
    let x = t - span.start;
    (span.poly.eval(x), span.poly.derivative().eval(x))
}

/// The cubic through value `p0` and slope `v0` at 0 and `p1`, `v1` at `h`, in seconds from 0.
pub(crate) fn hermite(p0: f64, v0: f64, p1: f64, v1: f64, h: f64) -> Poly {
    let secant = (p1 - p0) / h;
    Poly::cubic([
        p0,
        v0,
        (3.0 * secant - 2.0 * v0 - v1) / h,
        (v0 + v1 - 2.0 * secant) / (h * h),
    ])
}

/// What keeps a Hermite piece from standing for the curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shortfall {
    /// It strays this far (degrees or metres, the joint's units) from the curve.
    Strays(f64),
    /// It exceeds a limit: its worst value (signed; per second or per second squared for
    /// velocity and acceleration).
    Exceeds(LimitKind, f64),
}

/// What the Hermite through the points at `a` and `b` (the curve's positions and velocities
/// there, [`state_at`]; [a, b] inside one span of `spans`) misses: `None` when it follows the curve within the tolerance and keeps
/// `joint`'s limits.
pub(crate) fn judge(spans: &[Span], joint: &Joint, a: f64, b: f64) -> Option<Shortfall> {
    let h = b - a;
    // What the points at a and b carry.
    let ((p0, v0), (p1, v1)) = (state_at(spans, a), state_at(spans, b));
    let played = Span {
        start: a,
        end: b,
        poly: hermite(p0, v0, p1, v1, h),
    };
    let curve = super::polynomial_from(spans, a, b);
    let error = Span {
        poly: played.poly.add_scaled(&curve, -1.0),
        ..played
    };
    let tolerance = match joint.kind {
        JointKind::Revolute => TOLERANCE_DEG,
        JointKind::Prismatic => TOLERANCE_M,
    };
    let strays = runs::peak(&[error]);
    if strays > tolerance {
        return Some(Shortfall::Strays(strays));
    }
    let limits = joint.limits;
    let velocity = played.derivative();
    let quantities = [
        (LimitKind::Position, played, limits.min, limits.max),
        (
            LimitKind::Velocity,
            velocity,
            -limits.velocity,
            limits.velocity,
        ),
        (
            LimitKind::Acceleration,
            velocity.derivative(),
            -limits.acceleration,
            limits.acceleration,
        ),
    ];
    quantities.into_iter().find_map(|(kind, span, low, high)| {
        // The limit check's rounding slack (`runs::outside`).
        let slack = 1e-9 * (high - low).abs().max(1.0);
        let (lo, hi) = runs::range(&[span]);
        if hi > high + slack {
            Some(Shortfall::Exceeds(kind, hi))
        } else if lo < low - slack {
            Some(Shortfall::Exceeds(kind, lo))
        } else {
            None
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hermite_meets_its_ends_values_and_slopes() {
        let p = hermite(1.0, -2.0, 4.0, 0.5, 0.5);
        let v = p.derivative();
        assert!((p.eval(0.0) - 1.0).abs() < 1e-12 && (v.eval(0.0) + 2.0).abs() < 1e-12);
        assert!((p.eval(0.5) - 4.0).abs() < 1e-12 && (v.eval(0.5) - 0.5).abs() < 1e-12);
    }
}
