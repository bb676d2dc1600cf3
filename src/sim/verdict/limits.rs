//! The joint running into its stop (a joint-limit constraint active in the physics).
//!
//! Knows nothing about tolerances: any row at the stop is a finding, reported once.

use super::column::Column;
use super::{Finding, FindingKind};

pub(super) fn check_joint_stop(column: &Column) -> Option<Finding> {
    let at_limit = &column.trace.at_limit;
    let row = (0..column.rows()).find(|&row| at_limit[row][column.index])?;
    Some(column.finding_at(
        FindingKind::JointLimit,
        row,
        "the joint ran into its stop".into(),
    ))
}
