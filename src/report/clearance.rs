//! The clearance part of a check report: each contact with its bodies, its time, its keys and
//! what to do about it.

use crate::plan::{CheckReport, Contact, ContactCause};
use serde_json::{json, Value};
use std::fmt::Write;

/// The clearance lines of a check report: what was covered, then each contact (nothing when
/// the clearance was not checked, as for a report of the limits alone).
pub(super) fn text(report: &CheckReport, robot_name: &str) -> String {
    let mut out = String::new();
    let Some(scope) = &report.clearance else {
        return out;
    };
    if !scope.modelled {
        let _ = writeln!(
            out,
            "clearance: NOT CHECKED: robot {robot_name} has no collision model (the built-in \
             arms have one; a robot file named like one uses it)"
        );
        return out;
    }
    let _ = writeln!(
        out,
        "clearance {:.1} mm to the floor, the arm itself and the other arms, certified along \
         the whole motion",
        scope.margin * 1000.0
    );
    let undeclared: Vec<&Contact> = report.undeclared_contacts().collect();
    if undeclared.is_empty() {
        let _ = writeln!(out, "ok: no contact");
    } else {
        let _ = writeln!(out, "FAILED: {} contact(s)", undeclared.len());
        for c in undeclared {
            let _ = writeln!(out, "  {}", line(c));
            let _ = writeln!(out, "      fix: {}", c.advice);
        }
    }
    for c in report.declared_contacts() {
        let key = c.declared.unwrap_or_default();
        let _ = writeln!(out, "  declared by key #{key}: {}", line(c));
    }
    out
}

/// One contact: `gripper touches the floor (74.9 mm deep) at 3.000 s (from 2.340 to 3.650 s),
/// segment 0 (home → down) [path]`.
fn line(c: &Contact) -> String {
    let other = c.bodies.1.as_deref().unwrap_or("the floor");
    let how = match (c.cause, c.distance < 0.0) {
        (ContactCause::Unresolved, _) => {
            format!("may come within {:.1} mm of {other}", c.distance * 1000.0)
        }
        (ContactCause::Path, true) => format!("is {:.1} mm into {other}", -c.distance * 1000.0),
        (ContactCause::Path, false) => format!("is {:.1} mm from {other}", c.distance * 1000.0),
    };
    format!(
        "{} {how} at {:.3} s (from {:.3} to {:.3} s), segment {} ({}) [{}]",
        c.bodies.0,
        c.deepest_time,
        c.from,
        c.to,
        c.segment,
        c.segment_label,
        c.cause.name()
    )
}

/// The clearance part of the JSON report: `null` when it was not checked.
pub(super) fn json(report: &CheckReport) -> Value {
    let Some(scope) = &report.clearance else {
        return Value::Null;
    };
    json!({
        "margin_mm": scope.margin * 1000.0,
        "modelled": scope.modelled,
        "contacts": report.contacts.iter().map(|c| json!({
            "kind": c.kind.name(),
            "bodies": [c.bodies.0, c.bodies.1],
            "links": [c.links.0, c.links.1],
            "from": c.from,
            "to": c.to,
            "deepest_time": c.deepest_time,
            "distance_mm": c.distance * 1000.0,
            "cause": c.cause.name(),
            "segment": c.segment,
            "segment_label": c.segment_label,
            "key": c.key,
            "declared_by_key": c.declared,
            "advice": c.advice,
        })).collect::<Vec<_>>(),
    })
}
