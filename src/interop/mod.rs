//! Motion in and out of keypose's own formats: LeRobot dataset episodes in ([`lerobot`]);
//! ROS 2 `JointTrajectory` ([`ros2`]) and play_motion2 motions ([`play_motion2`]) out, written
//! as YAML; C headers for the stand-alone player ([`c_export`]). Knows nothing about servos: everything here is joint values over time.

pub mod c_export;
pub mod lerobot;
pub mod play_motion2;
pub mod ros2;
mod yaml;

use crate::plan::Trajectory;

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
