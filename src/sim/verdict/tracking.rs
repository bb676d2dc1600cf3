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
    (figures.max > allowed).then(|| {
        column.finding(
            FindingKind::Tracking,
            figures.max_time,
            format!(
                "tracking error {} exceeds {} while moving",
                column.format_value(figures.max),
                column.format_value(allowed)
            ),
        )
    })
}

/// The error once the commanded motion has rested at each key: (key label, sequence time,
/// error) for the report, and a finding for each beyond what is allowed once settled.
///
/// A key is judged only where this joint's command stays at rest (within
/// [`Thresholds::rest_allowed`]) for the whole settling window before the judged row: a joint
/// still moving along its path, as a retimed move keeps moving through its keys, is lagging, and
/// lag is the tracking check's to bound.
pub(super) fn check_settling(
    column: &Column,
    keys: &[KeyMark],
    t: &Thresholds,
) -> (Vec<(String, f64, f64)>, Vec<Finding>) {
    let (_, allowed) = t.error_allowed(column.is_revolute());
    let mut settled = Vec::new();
    let mut findings = Vec::new();
    for key in keys {
        let Some((reached, row)) = judged_row(column, key, t) else {
            continue;
        };
        let e = column.error(row);
        if e > allowed {
            let time = &column.trace.time;
            let message = format!(
                "{} off key {}, {:.2} s after reaching it, the command at rest (allowed {})",
                column.format_value(e),
                key.label,
                time[row] - time[reached],
                column.format_value(allowed)
            );
            findings.push(column.finding_at(FindingKind::Settling, row, message));
        }
        settled.push((key.label.clone(), key.time, e));
    }
    (settled, findings)
}

/// The row where `key` is reached and the row where it is judged: the end of its hold or
/// `settle_time` after it is reached, whichever is later, provided the command rested through
/// the window before it.
fn judged_row(column: &Column, key: &KeyMark, t: &Thresholds) -> Option<(usize, usize)> {
    let time = &column.trace.time;
    let reached = first_row_at(column, key.time)?;
    let held = first_row_at(column, key.time + key.hold)?;
    // Settle time is wall-clock (the servo's), the hold sequence time (scaled by --speed).
    let settled =
        (reached..column.rows()).find(|&r| time[r] >= time[reached] + t.settle_time - 1e-9)?;
    let row = held.max(settled);
    command_rests(column, row, t).then_some((reached, row))
}

/// Whether the command (where the arm should be) stayed within the rest tolerance of its value
/// at `row` for the `settle_time` up to it.
fn command_rests(column: &Column, row: usize, t: &Thresholds) -> bool {
    let (time, commanded) = (&column.trace.time, &column.trace.intended);
    let at = commanded[row][column.index];
    let tolerance = t.rest_allowed(column.is_revolute());
    (0..=row)
        .rev()
        .take_while(|&r| time[r] >= time[row] - t.settle_time - 1e-9)
        .all(|r| (commanded[r][column.index] - at).abs() <= tolerance)
}

/// The first row at or after sequence time `at`, if the run gets there.
fn first_row_at(column: &Column, at: f64) -> Option<usize> {
    column
        .trace
        .sequence_time
        .iter()
        .position(|s| s.is_some_and(|s| s >= at - 1e-9))
}
