//! The actuator held at its force limit for longer than a fast move explains.
//!
//! Knows nothing about positions or speeds.

use super::column::{longest_run, Column};
use super::{Finding, FindingKind, Thresholds};

/// The longest run at the force limit, when it lasts [`Thresholds::saturation_time`] or more.
pub(super) fn check_saturation(column: &Column, t: &Thresholds) -> Option<Finding> {
    let trace = column.trace;
    let limit = trace.force_limits.get(column.index).copied().flatten()?;
    let saturated = |row: usize| trace.force[row][column.index].abs() >= t.saturation_share * limit;
    let (start, end) = longest_run(column.rows(), saturated)?;
    let seconds = trace.time[end] - trace.time[start];
    (seconds >= t.saturation_time).then(|| {
        column.finding_at(
            FindingKind::Saturation,
            start,
            format!(
                "actuator at its force limit ({limit:.2} {}) for {seconds:.2} s",
                super::force_unit(column.joint.kind)
            ),
        )
    })
}
