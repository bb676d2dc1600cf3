//! Motion in and out of keypose's own formats: LeRobot dataset episodes in ([`lerobot`]);
//! ROS 2 `JointTrajectory` ([`ros2`]) and play_motion2 motions ([`play_motion2`]) out, written
//! as YAML; C headers for the stand-alone player ([`c_export`]). Knows nothing about servos: everything here is joint values over time.

pub mod c_export;
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
/// and piece of a timing profile.
pub(crate) fn played_spans(trajectory: &Trajectory) -> Vec<Vec<Span>> {
    trajectory
        .tracks()
        .iter()
        .map(|track| {
            JointCurve::new(
                track,
                trajectory.timing(),
                trajectory.start,
                trajectory.end,
                &trajectory.key_times,
                0.0,
            )
            .played
        })
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

/// A segment with a timing profile (`"timing"`, as `retime --fastest` writes) in a trajectory
/// for an export that carries the curve as cubics in time (ROS 2 points joined by
/// ros2_control's Hermites, the C player's pieces): a profiled segment is a cubic of a quadratic
/// of time, which such pieces would only approximate, so the export refuses it rather than send
/// a curve the limit check did not pass.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "segment {segment} ({label}) has a timing profile (\"timing\", as `retime --fastest` \
     writes), which {export} cannot carry: it joins key points with cubics in time; export the \
     sequence as timed by its keys (before `retime --fastest`, or `retime` without it), or \
     use `export play_motion2`, which samples the profile"
)]
pub struct TimingNotExportable {
    /// The export refusing, as the command names it (`export ros2`).
    pub export: &'static str,
    /// The first profiled segment (from key `segment` to the next).
    pub segment: usize,
    /// Its "from → to" label.
    pub label: String,
}

/// Refuses a trajectory with a timing profile for `export`, naming its first profiled segment.
pub fn refuse_timing(
    trajectory: &Trajectory,
    export: &'static str,
) -> Result<(), TimingNotExportable> {
    let Some(piece) = trajectory
        .timing()
        .pieces()
        .iter()
        .find(|p| p.v0 != 1.0 || p.a != 0.0)
    else {
        return Ok(());
    };
    let segment = trajectory.segment_at(piece.t0);
    Err(TimingNotExportable {
        export,
        segment,
        label: trajectory.segment_label(segment),
    })
}
