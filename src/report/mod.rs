//! Turning trajectories and checks into what people and programs read: text, JSON, SVG.

mod clearance;
mod load;
pub mod log;
pub mod plot;
pub(crate) mod units;

use crate::plan::{Cause, CheckReport, LimitKind, Sampled, Trajectory, Violation};
use crate::robot::{Robot, RobotSource};
use serde_json::{json, Value};
use std::fmt::Write;

/// The check report as text: one line per violation, then each joint's margins.
pub fn check_text(report: &CheckReport, sequence_file: &str, robot: &Robot) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{sequence_file}: robot {} ({}), {:.3} s … {:.3} s, checked exactly, steps and corners at the {} Hz control rate",
        robot.name, robot.source, report.start, report.end, report.rate
    );
    if report.speed != 1.0 {
        let _ = writeln!(
            out,
            "at speed {}: velocities and accelerations as the servos would see them, against the robot's limits; times are the sequence's",
            report.speed
        );
    }
    if report.violations.is_empty() {
        let _ = writeln!(out, "ok: no limit violations");
    } else {
        let _ = writeln!(
            out,
            "FAILED: {} limit violation(s)",
            report.violations.len()
        );
        for v in &report.violations {
            let _ = writeln!(
                out,
                "  {:<14} {:<12} segment {} ({}), {}",
                v.joint,
                v.kind.name(),
                v.segment,
                v.segment_label,
                violation_measure(v, report.rate)
            );
        }
    }
    // Wide enough for a cell's `ARM/JOINT` names; one arm's names fit the usual 14.
    let w = report
        .joints
        .iter()
        .map(|j| j.joint.chars().count())
        .fold(14, usize::max);
    let jerk_header = if report.joints.iter().any(|j| j.jerk_limit.is_some()) {
        format!(" {:>26}", "peak jerk")
    } else {
        String::new()
    };
    let _ = writeln!(
        out,
        "  {:<w$} {:>22} {:>24} {:>26}{jerk_header}",
        "joint", "range", "peak velocity", "peak acceleration"
    );
    for j in &report.joints {
        let (scale, unit) = units::display_scale(j.unit);
        let jerk = match j.jerk_limit {
            // Only a robot with jerk limits gets the column: other reports read as before.
            Some(limit) => format!(
                " {:>10.0} {:<7} ({:>4.0} %), acceleration jumps {:.1} {}",
                j.peak_jerk * scale,
                per_unit(unit, LimitKind::Jerk),
                100.0 * j.peak_jerk / limit,
                j.acceleration_jump * scale,
                per_unit(unit, LimitKind::Acceleration),
            ),
            None => String::new(),
        };
        let _ = writeln!(
            out,
            "  {:<w$} {:>9.2} … {:>7.2} {:<3} {:>8.1} {:<6} ({:>4.0} %) {:>9.1} {:<7} ({:>4.0} %){jerk}",
            j.joint,
            units::no_negative_zero(j.min_position * scale, 2),
            units::no_negative_zero(j.max_position * scale, 2),
            unit,
            j.peak_velocity * scale,
            per_unit(unit, LimitKind::Velocity),
            100.0 * j.peak_velocity / j.velocity_limit,
            j.peak_acceleration * scale,
            per_unit(unit, LimitKind::Acceleration),
            100.0 * j.peak_acceleration / j.acceleration_limit,
        );
    }
    out += &clearance::text(report, &robot.name);
    out += &load::text(report);
    out
}

/// What a violation measured, in the units of its limit (deg, deg/s, deg/s²; mm for a
/// prismatic joint): "t = 1.234 s (from 1.100 to 1.300 s): 130.000 deg/s > limit 115.000
/// deg/s, by 15.000 deg/s", and what a step or a corner asks of the servos checked at `rate`.
pub fn violation_measure(v: &Violation, rate: f64) -> String {
    let (scale, shown_unit) = units::display_scale(v.unit);
    if let Some(jump) = v.acceleration_jump {
        return format!(
            "t = {:.3} s: the acceleration jumps by {:.3} {}, an infinite jerk (limit {:.3} {}){}",
            v.peak_time,
            jump * scale,
            per_unit(shown_unit, LimitKind::Acceleration),
            v.limit.abs() * scale,
            per_unit(shown_unit, LimitKind::Jerk),
            cause_note(v.cause, rate)
        );
    }
    let unit = per_unit(shown_unit, v.kind);
    let relation = if v.peak > v.limit { ">" } else { "<" };
    let bound = match (v.kind, v.peak > v.limit) {
        (LimitKind::Position, true) => "max",
        (LimitKind::Position, false) => "min",
        _ => "limit",
    };
    format!(
        "t = {:.3} s (from {:.3} to {:.3} s): {:.3} {unit} {relation} {bound} {:.3} {unit}, by {:.3} {unit}{}",
        v.peak_time,
        v.from,
        v.to,
        v.peak * scale,
        v.limit * scale,
        v.excess * scale,
        cause_note(v.cause, rate)
    )
}

/// What a step or a corner asks of the servos, said after its violation ("" for the curve's own).
fn cause_note(cause: Cause, rate: f64) -> String {
    let period = format!("{:.1}", 1000.0 / rate);
    let period = period.trim_end_matches(".0");
    match cause {
        Cause::Curve => String::new(),
        Cause::Step => format!(" (a step: the goals jump within one {period} ms period)"),
        Cause::Corner => format!(" (a corner: the velocity turns within one {period} ms period)"),
        Cause::AccelerationJump => String::new(),
    }
}

fn per_unit(unit: &str, kind: LimitKind) -> String {
    match kind {
        LimitKind::Position => unit.to_string(),
        LimitKind::Velocity => format!("{unit}/s"),
        LimitKind::Acceleration => format!("{unit}/s²"),
        LimitKind::Jerk => format!("{unit}/s³"),
    }
}

/// The torque part of the JSON report alone (`null` when the loads were not checked).
pub fn torque_json(report: &CheckReport) -> Value {
    load::json(report)
}

/// The check report as JSON, for scripts and CI.
pub fn check_json(report: &CheckReport, sequence_file: &str, robot: &Robot) -> Value {
    json!({
        "sequence": sequence_file,
        "robot": robot.name,
        "robot_source": match &robot.source {
            RobotSource::Builtin(name) => json!({ "builtin": name }),
            RobotSource::File(path) => json!({ "file": path.display().to_string() }),
            RobotSource::Cell => json!({ "cell": robot.arms.iter().map(|a| json!({
                "arm": a.name, "robot": a.robot.name,
            })).collect::<Vec<_>>() }),
        },
        "passed": report.passed(),
        "rate_hz": report.rate,
        "start": report.start,
        "end": report.end,
        "violations": report.violations.iter().map(|v| json!({
            "joint": v.joint,
            "kind": v.kind.name(),
            "unit": per_unit(v.unit, v.kind),
            "segment": v.segment,
            "segment_label": v.segment_label,
            "from": v.from,
            "to": v.to,
            "peak_time": v.peak_time,
            "peak": v.peak,
            "limit": v.limit,
            "excess": v.excess,
            "cause": v.cause.name(),
            "acceleration_jump": v.acceleration_jump,
        })).collect::<Vec<_>>(),
        "joints": report.joints.iter().map(|j| json!({
            "joint": j.joint,
            "unit": j.unit,
            "min_position": j.min_position,
            "max_position": j.max_position,
            "peak_velocity": j.peak_velocity,
            "velocity_limit": j.velocity_limit,
            "peak_acceleration": j.peak_acceleration,
            "acceleration_limit": j.acceleration_limit,
            "peak_jerk": j.peak_jerk,
            "acceleration_jump": j.acceleration_jump,
            "jerk_limit": j.jerk_limit,
        })).collect::<Vec<_>>(),
        "clearance": clearance::json(report),
        "torque": load::json(report),
    })
}

/// The telemetry rows of `robot`'s joints whose log has it ([`log::telemetry`]), loads in the
/// joints' directions, with each servo's factory heat protection.
pub fn telemetry_rows(
    robot: &Robot,
    telemetry: Vec<Option<log::Telemetry>>,
) -> Vec<plot::TelemetryRow> {
    robot
        .joints
        .iter()
        .zip(telemetry)
        .filter_map(|(joint, t)| {
            let t = t?;
            // The log has the load as the servo reports it, in its shaft's direction.
            let direction = joint.servo.direction;
            Some(plot::TelemetryRow {
                name: joint.name.clone(),
                load: t.load.iter().map(|&(s, l)| (s, l * direction)).collect(),
                need: t.need,
                temperature: t.temperature,
                temperature_limit: joint.servo.model.spec().factory_temperature_limit_c(),
                push_line: joint
                    .servo
                    .drive()
                    .map(|d| 100.0 * d.continuous_torque() / d.stall_torque.value),
            })
        })
        .collect()
}

/// Everything the SVG plot needs, sampled at `rate` Hz. `measured` holds, per joint, an optional
/// measured trace to overlay.
pub fn plot_data(
    title: &str,
    trajectory: &Trajectory,
    robot: &Robot,
    rate: f64,
    measured: Vec<Option<log::Trace>>,
) -> plot::PlotData {
    let sampled = Sampled::new(trajectory, rate);
    let mut measured = measured.into_iter();
    let joints = robot
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let track = &trajectory.tracks()[j];
            // The track's keys are at path times; the sequence's keys at these (the same
            // unless a segment has a timing profile).
            let key_times: Vec<(f64, f64)> = trajectory
                .key_times
                .iter()
                .map(|&t| (trajectory.path_time(t), t))
                .collect();
            let keys = track
                .times()
                .iter()
                .zip(track.values())
                // A straight tool line's samples are track keys too; only the sequence's are dots.
                .filter_map(|(u, v)| {
                    let (_, t) = key_times.iter().find(|(path, _)| path == u)?;
                    Some((*t, *v))
                })
                .filter(|(t, _)| *t >= trajectory.start && *t <= trajectory.end)
                .collect();
            plot::PlotJoint {
                name: joint.name.clone(),
                unit: joint.kind.unit().to_string(),
                min: joint.limits.min,
                max: joint.limits.max,
                velocity_limit: joint.limits.velocity,
                positions: sampled.positions[j].clone(),
                velocities: sampled.velocity_at_samples(j),
                keys,
                measured: measured.next().flatten(),
            }
        })
        .collect();
    plot::PlotData {
        telemetry: Vec::new(),
        title: title.to_string(),
        times: sampled.times,
        joints,
        key_marks: trajectory
            .key_times
            .iter()
            .zip(&trajectory.key_labels)
            .filter(|(t, _)| **t >= trajectory.start && **t <= trajectory.end)
            .map(|(t, l)| (*t, l.clone()))
            .collect(),
    }
}
