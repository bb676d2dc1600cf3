//! One joint's column of a [`Trace`], the view every per-joint check works on, and the two
//! scans they share (the peak of a value, the longest run of a condition).
//!
//! Knows nothing about thresholds or what the checks decide.

use super::{Finding, FindingKind, Trace};
use crate::robot::{Joint, JointKind};

/// Joint `index` of the robot and its column of the trace.
pub(super) struct Column<'a> {
    pub trace: &'a Trace,
    pub index: usize,
    pub joint: &'a Joint,
    /// The arm of a cell the joint belongs to.
    pub arm: Option<&'a str>,
}

impl Column<'_> {
    pub fn rows(&self) -> usize {
        self.trace.time.len()
    }

    pub fn is_revolute(&self) -> bool {
        self.joint.kind == JointKind::Revolute
    }

    /// `value` (this joint's unit) as a person reads it.
    pub fn format_value(&self, value: f64) -> super::Shown {
        super::shown(self.joint.kind, value)
    }

    /// |position - intended| at `row`.
    pub fn error(&self, row: usize) -> f64 {
        (self.trace.position[row][self.index] - self.trace.intended[row][self.index]).abs()
    }

    /// A finding about this joint at `row`'s time.
    pub fn finding_at(&self, kind: FindingKind, row: usize, message: String) -> Finding {
        self.finding(kind, self.trace.time[row], message)
    }

    pub fn finding(&self, kind: FindingKind, time: f64, message: String) -> Finding {
        Finding {
            kind,
            joint: Some(self.joint.name.clone()),
            arms: self.arm.into_iter().map(str::to_string).collect(),
            time,
            message,
        }
    }
}

/// The largest `value(row)` over the trace (at least 0) and the time of its first row.
pub(super) fn peak(trace: &Trace, value: impl Fn(usize) -> f64) -> (f64, f64) {
    (0..trace.time.len()).fold((0.0, 0.0), |(best, at), row| {
        let v = value(row);
        if v > best {
            (v, trace.time[row])
        } else {
            (best, at)
        }
    })
}

/// The longest run of consecutive rows where `hit` holds: (first row, last row).
pub(super) fn longest_run(rows: usize, hit: impl Fn(usize) -> bool) -> Option<(usize, usize)> {
    let mut best: Option<(usize, usize)> = None;
    let mut start = None;
    for r in 0..rows {
        match (hit(r), start) {
            (true, None) => start = Some(r),
            (false, Some(s)) => {
                if best.is_none_or(|(a, b)| r - 1 - s > b - a) {
                    best = Some((s, r - 1));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        if best.is_none_or(|(a, b)| rows - 1 - s > b - a) {
            best = Some((s, rows - 1));
        }
    }
    best
}
