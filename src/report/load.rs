//! The load part of a check report: the build judged, each servo's peak torque against its
//! torque-speed line, its RMS against its continuous rating, its droop at the keys; then
//! each overload (a failure) and each duty or droop warning, with what to do about it.

use crate::plan::{CheckReport, LoadReport, LoadScope};
use serde_json::{json, Value};
use std::fmt::Write;

/// The load lines of a check report (nothing when the loads were not checked).
pub(super) fn text(report: &CheckReport) -> String {
    let mut out = String::new();
    let Some(scope) = &report.loads else {
        return out;
    };
    let loads = match scope {
        LoadScope::Unchecked(why) => {
            let _ = writeln!(out, "torque: NOT CHECKED: {why}");
            return out;
        }
        LoadScope::Checked(loads) => loads,
    };
    let _ = writeln!(
        out,
        "torque against each servo's torque-speed line, build {}",
        loads.build
    );
    table(&mut out, loads);
    if loads.overloads.is_empty() {
        let _ = writeln!(out, "ok: every servo within its torque-speed line");
    } else {
        let _ = writeln!(out, "FAILED: {} overload(s)", loads.overloads.len());
        for o in &loads.overloads {
            let _ = writeln!(out, "  {}", o.describe());
            let _ = writeln!(out, "      fix: {}", o.advice);
        }
    }
    for j in &loads.joints {
        if let Some(advice) = &j.duty_advice {
            let _ = writeln!(out, "warning: duty: {advice}");
        }
    }
    droop_lines(&mut out, loads);
    if !loads.unrated.is_empty() {
        let _ = writeln!(
            out,
            "warning: no drive data for {}: their torque is shown, not judged",
            loads.unrated.join(", ")
        );
    }
    out
}

/// One warning per joint that droops past the tolerance at some keys: the worst, and where.
fn droop_lines(out: &mut String, loads: &LoadReport) {
    for joint in &loads.joints {
        let at: Vec<_> = loads
            .droops
            .iter()
            .filter(|d| d.joint == joint.joint)
            .collect();
        let Some(worst) = at.iter().max_by(|a, b| a.droop.total_cmp(&b.droop)) else {
            continue;
        };
        let mut seen = std::collections::HashSet::new();
        let keys: Vec<&str> = at
            .iter()
            .map(|d| d.key_label.as_str())
            .filter(|label| seen.insert(*label))
            .collect();
        let _ = writeln!(
            out,
            "warning: droop: at key(s) {}: {}",
            listed_keys(&keys),
            worst.advice
        );
    }
}

/// The most keys a warning names: a long recording's every key would bury the advice.
const LISTED_KEYS: usize = 12;

/// `keys` joined, the first [`LISTED_KEYS`] of them and how many more.
fn listed_keys(keys: &[&str]) -> String {
    match keys.len().checked_sub(LISTED_KEYS) {
        Some(more) if more > 0 => {
            format!("{} and {more} more", keys[..LISTED_KEYS].join(", "))
        }
        _ => keys.join(", "),
    }
}

fn table(out: &mut String, loads: &LoadReport) {
    let w = loads
        .joints
        .iter()
        .map(|j| j.joint.len())
        .max()
        .unwrap_or(5)
        .max(5);
    let _ = writeln!(
        out,
        "  {:<w$} {:>21} {:>11} {:>21} {:>13}",
        "joint", "peak torque", "of line", "RMS / continuous", "droop at keys"
    );
    for j in &loads.joints {
        let share = match j.line {
            // Above its no-load speed a servo gives nothing while driving: any torque is over.
            Some(_) if j.peak_share > 9.99 => "> 999 %".to_string(),
            Some(_) => format!("{:>4.0} %", 100.0 * j.peak_share),
            None => "unrated".to_string(),
        };
        let rms = match j.continuous {
            Some(c) => format!("{:.2} / {:.2} N·m", j.rms_torque, c),
            None => format!("{:.2} N·m", j.rms_torque),
        };
        let _ = writeln!(
            out,
            "  {:<w$} {:>6.2} N·m at {:>7.3} s {:>11} {:>21} {:>9.2} {:<3}",
            j.joint,
            j.peak_torque.abs(),
            j.peak_time,
            share,
            rms,
            j.max_droop,
            j.unit
        );
    }
}

/// The load part of the JSON report: `null` when not checked, `{"checked": false, "reason"}`
/// when it could not be.
pub(super) fn json(report: &CheckReport) -> Value {
    let Some(scope) = &report.loads else {
        return Value::Null;
    };
    let loads = match scope {
        LoadScope::Unchecked(why) => return json!({"checked": false, "reason": why}),
        LoadScope::Checked(loads) => loads,
    };
    json!({
        "checked": true,
        "build": loads.build,
        "joints": loads.joints.iter().map(|j| json!({
            "joint": j.joint,
            "drive": j.drive,
            "stall_torque": j.line.map(|l| l.0),
            "no_load_speed": j.line.map(|l| l.1),
            "peak_torque": j.peak_torque,
            "peak_time": j.peak_time,
            "peak_share_of_line": j.line.map(|_| j.peak_share),
            "rms_torque": j.rms_torque,
            "continuous_torque": j.continuous,
            "time_above_continuous": j.time_above_continuous,
            "max_droop": j.max_droop,
            "duty_warning": j.duty_advice,
        })).collect::<Vec<_>>(),
        "overloads": loads.overloads.iter().map(|o| json!({
            "joint": o.joint,
            "segment": o.segment,
            "segment_label": o.segment_label,
            "from": o.from,
            "to": o.to,
            "peak_time": o.peak_time,
            "torque": o.torque,
            "available": o.available,
            "speed": o.speed,
            "holding": o.holding,
            "advice": o.advice,
        })).collect::<Vec<_>>(),
        "droops": loads.droops.iter().map(|d| json!({
            "joint": d.joint,
            "key": d.key,
            "key_label": d.key_label,
            "torque": d.torque,
            "droop": d.droop,
            "tolerance": d.tolerance,
            "advice": d.advice,
        })).collect::<Vec<_>>(),
        "unrated": loads.unrated,
    })
}

#[cfg(test)]
mod tests {
    use super::listed_keys;

    #[test]
    fn a_warning_names_twelve_keys_and_counts_the_rest() {
        let labels: Vec<String> = (0..15).map(|i| format!("#{i}")).collect();
        let keys: Vec<&str> = labels.iter().map(String::as_str).collect();
        assert_eq!(
            listed_keys(&keys),
            "#0, #1, #2, #3, #4, #5, #6, #7, #8, #9, #10, #11 and 3 more"
        );
        assert_eq!(listed_keys(&keys[..12]), labels[..12].join(", "));
        assert_eq!(listed_keys(&keys[..1]), "#0");
    }
}
