//! Motion in and out of keypose's own formats: LeRobot dataset episodes in ([`lerobot`]);
//! ROS 2 `JointTrajectory` ([`ros2`]) and play_motion2 motions ([`play_motion2`]) out, written
//! as YAML; C headers for the stand-alone player ([`c_export`]). Knows nothing about servos: everything here is joint values over time.

pub mod c_export;
mod hermite_fit;
pub mod lerobot;
pub mod play_motion2;
pub mod ros2;
mod yaml;

use crate::plan::check::poly::Poly;
use crate::plan::check::spans::{JointCurve, Span};
use crate::plan::Trajectory;

/// Times closer than this are one (seconds; a nanosecond stamp's resolution).
const SAME_TIME: f64 = 1e-9;

/// Every joint's played curve over the trajectory's window, as the limit check judges it
/// (`plan::check`): exact polynomials in sequence time, one span per key segment, hold, step
/// and piece of a timing profile (`played`), at rest before and after (`extended`, for
/// `discontinuities`).
pub(crate) fn joint_curves(trajectory: &Trajectory) -> Vec<JointCurve> {
    JointCurve::of_trajectory(trajectory)
}

/// Every joint's played spans ([`joint_curves`]).
pub(crate) fn played_spans(trajectory: &Trajectory) -> Vec<Vec<Span>> {
    joint_curves(trajectory)
        .into_iter()
        .map(|c| c.played)
        .collect()
}

/// Where any joint's span starts or ends, sorted, each once: between two of them every
/// joint's curve is one polynomial.
pub(crate) fn span_boundaries(curves: &[Vec<Span>]) -> Vec<f64> {
    let mut times: Vec<f64> = curves
        .iter()
        .flatten()
        .flat_map(|s| [s.start, s.end])
        .collect();
    sorted_once(&mut times);
    times
}

/// Sorts `times` and keeps one of any that are closer than [`SAME_TIME`].
pub(crate) fn sorted_once(times: &mut Vec<f64>) {
    times.sort_by(f64::total_cmp);
    times.dedup_by(|later, earlier| *later - *earlier < SAME_TIME);
}

/// The polynomial of `spans` that plays on [a, b] (the span holding its middle), with its
/// origin at `a`.
pub(crate) fn polynomial_from(spans: &[Span], a: f64, b: f64) -> Poly {
    let middle = 0.5 * (a + b);
    let i = spans
        .partition_point(|s| s.start <= middle)
        .saturating_sub(1);
    spans[i].origin_at(a)
}
