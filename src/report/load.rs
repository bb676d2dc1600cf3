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
        let mut keys: Vec<String> = Vec::new();
        for d in &at {
            if !keys.contains(&d.key_label) {
                keys.push(d.key_label.clone());
            }
        }
        let _ = writeln!(
            out,
            "warning: droop: at key(s) {}: {}",
            keys.join(", "),
            worst.advice
        );
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
