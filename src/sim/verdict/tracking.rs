//! Tracking in motion (the largest error) and settling at keys (the error a moment after each).
//!
//! Knows nothing about speeds, forces or contacts.

use super::column::{peak, Column};
use super::{Finding, FindingKind, KeyMark, Thresholds};

/// The error figures of one joint over the whole run.
pub(super) struct ErrorFigures {
    pub max: f64,
    pub max_time: f64,
    pub rms: f64,
}

pub(super) fn error_figures(column: &Column) -> ErrorFigures {
    let rows = column.rows();
    let (max, max_time) = peak(column.trace, |row| column.error(row));
    let sum_sq: f64 = (0..rows).map(|row| column.error(row).powi(2)).sum();
    ErrorFigures {
        max,
        max_time,
        rms: if rows > 0 {
            (sum_sq / rows as f64).sqrt()
        } else {
            0.0
        },
    }
}

/// The largest error in motion beyond what is allowed.
pub(super) fn check_tracking(
    column: &Column,
    figures: &ErrorFigures,
    t: &Thresholds,
) -> Option<Finding> {
    let (allowed, _) = t.error_allowed(column.is_revolute());
    let unit = column.joint.kind.unit();
    (figures.max > allowed).then(|| {
        column.finding(
            FindingKind::Tracking,
            figures.max_time,
            format!(
                "tracking error {:.3} {unit} exceeds {allowed} {unit}",
                figures.max
            ),
        )
    })
}

/// The error `settle_time` after each key: (key label, sequence time, error) for the report,
/// and a finding for each beyond what is allowed once settled.
pub(super) fn check_settling(
    column: &Column,
    keys: &[KeyMark],
    t: &Thresholds,
) -> (Vec<(String, f64, f64)>, Vec<Finding>) {
    let (_, allowed) = t.error_allowed(column.is_revolute());
    let mut settled = Vec::new();
    let mut findings = Vec::new();
    for key in keys {
        let Some(row) = settle_row(column, key.settle_from + t.settle_time) else {
            continue;
        };
        let e = column.error(row);
        if e > allowed {
            let message = format!(
                "{e:.3} {} off key {} {:.2} s after it (allowed {allowed})",
                column.joint.kind.unit(),
                key.label,
                t.settle_time
            );
            findings.push(column.finding_at(FindingKind::Settling, row, message));
        }
        settled.push((key.label.clone(), key.settle_from, e));
    }
    (settled, findings)
}

/// The first row at or after sequence time `at`, if the run gets there.
fn settle_row(column: &Column, at: f64) -> Option<usize> {
    column
        .trace
        .sequence_time
        .iter()
        .position(|s| s.is_some_and(|s| s >= at - 1e-9))
}
