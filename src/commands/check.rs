//! `keypose check`: the curve against the robot's limits, exactly (`plan::check`).

use super::{parse_check_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::{check, radians_warning, CheckReport, LimitKind, Trajectory};
use keypose::plan::{ToolKeyReport, ToolSolve};
use keypose::report;
use keypose::robot::Robot;
use keypose::sequence::ToolApproach;

#[derive(Debug, Clone, clap::Args)]
pub struct CheckArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Accepted for scripts written for the sampled check of earlier versions: the check is
    /// exact, so the rate changes neither the verdict nor the peaks (a step or a linear corner
    /// is judged as the player turns it, within one period of the robot's control rate).
    #[arg(long, value_name = "HZ", value_parser = parse_check_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Report format.
    #[arg(long, value_enum, default_value_t = ReportFormat::Text)]
    pub format: ReportFormat,
    /// Largest orientation a tool key with "r" may miss by about any tool axis, degrees: a
    /// 5-joint arm cannot reach every orientation, and more than this fails the check.
    #[arg(long, value_name = "DEG", default_value_t = 2.0)]
    pub orientation_tolerance: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportFormat {
    Text,
    Json,
}

pub fn run(args: &CheckArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    let rate = robot.control_hz;
    super::check_sample_budget(&sequence.file, &trajectory, rate)?;
    let result = check(&trajectory, &robot, rate);
    let tools = &trajectory.tools;
    let tolerance = args.orientation_tolerance;
    let text = match args.format {
        ReportFormat::Text => {
            let units = match radians_warning(&sequence, &robot) {
                Some(w) => format!("warning: {w}\n"),
                None => String::new(),
            };
            report::check_text(&result, &sequence.file, &robot)
                + &tool_text(tools, tolerance, &robot, &result)
                + &units
        }
        ReportFormat::Json => {
            let mut json = report::check_json(&result, &sequence.file, &robot);
            if let Some(w) = radians_warning(&sequence, &robot) {
                json["units_warning"] = w.into();
            }
            if !(tools.keys.is_empty() && tools.lines.is_empty()) {
                json["tool"] = tool_json(tools, tolerance, &robot, &result);
            }
            let mut s = json.to_string();
            s.push('\n');
            s
        }
    };
    write_output(None, &text)?;
    Ok(if result.passed() && tools_pass(tools, tolerance) {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

/// Whether every tool key is oriented within `tolerance` and every line can be followed.
pub fn tools_pass(tools: &ToolSolve, tolerance: f64) -> bool {
    tools.keys.iter().all(|k| residual_max(k) <= tolerance)
        && tools.lines.iter().all(|l| l.problem.is_none())
}

fn residual_max(key: &ToolKeyReport) -> f64 {
    key.residual_deg.map_or(0.0, |r| r.abs().max_element())
}

/// The tool keys (orientation residual, approach, smallest margin) and the lines, one line
/// each ("" without any).
pub fn tool_text(tools: &ToolSolve, tolerance: f64, robot: &Robot, result: &CheckReport) -> String {
    let mut out = String::new();
    for key in &tools.keys {
        if let Some(r) = key.residual_deg {
            let verdict = if residual_max(key) <= tolerance {
                "ok"
            } else {
                "FAIL"
            };
            out += &format!(
                "tool key {}: orientation off by {:.2}°, {:.2}°, {:.2}° about the tool's x, y, z \
                 (tolerance {tolerance}°) {verdict}\n",
                key.label, r.x, r.y, r.z
            );
        }
        let mut said = Vec::new();
        if let Some((approach, tilt)) = key.approach {
            said.push(approach_words(approach, tilt));
        }
        if let Some(m) = &key.margin {
            said.push(format!(
                "smallest margin {} {:.2} {} ({:.0} % of its half range)",
                m.joint,
                m.value,
                m.unit,
                m.share * 100.0
            ));
        }
        if !said.is_empty() {
            out += &format!("tool key {}: {}\n", key.label, said.join("; "));
        }
    }
    for line in &tools.lines {
        let speed = line.speed(robot, &result.violations);
        match (&line.problem, speed) {
            (None, None) => {
                out += &format!(
                    "tool line from key {}: straight, {} samples, ok\n",
                    line.label,
                    line.samples.len()
                )
            }
            (None, Some(speed)) => {
                let worst: Vec<String> = speed
                    .worst
                    .iter()
                    .map(|e| {
                        let per = match e.kind {
                            LimitKind::Acceleration => "/s²",
                            LimitKind::Jerk => "/s³",
                            _ => "/s",
                        };
                        format!(
                            "{} {} {:.1} {}{per} (limit {:.1} {}{per})",
                            e.joint,
                            e.kind.name(),
                            e.peak,
                            e.unit,
                            e.limit,
                            e.unit
                        )
                    })
                    .collect();
                out += &format!(
                    "tool line from key {}: straight, {} samples, FAIL: faster than the joints \
                     allow: {}; `keypose retime` slows the line (it needs about {:.2} s, it has \
                     {:.2} s)\n",
                    line.label,
                    line.samples.len(),
                    worst.join(", "),
                    speed.needed,
                    line.span.1 - line.span.0
                )
            }
            (Some(problem), _) => {
                out += &format!(
                    "tool line from key {}: FAIL, {:.0} % feasible: {problem}\n",
                    line.label,
                    line.fraction * 100.0
                )
            }
        }
    }
    out
}

/// A key's approach in words: pointing down, or tilted from it.
fn approach_words(approach: ToolApproach, tilt: f64) -> String {
    if tilt < 0.05 {
        "pointing down".to_string()
    } else {
        format!(
            "tilted {tilt:.1}° from down (\"{}\": the arm cannot point it down there)",
            approach.spelling()
        )
    }
}

fn tool_json(
    tools: &ToolSolve,
    tolerance: f64,
    robot: &Robot,
    result: &CheckReport,
) -> serde_json::Value {
    let keys: Vec<_> = tools
        .keys
        .iter()
        .map(|k| {
            serde_json::json!({
                "key": k.label,
                "orientation_residual_deg": k.residual_deg.map(|r| r.to_array()),
                "approach": k.approach.map(|(a, _)| a.spelling()),
                "tilt_deg": k.approach.map(|(_, t)| t),
                "smallest_margin": k.margin.as_ref().map(|m| serde_json::json!({
                    "joint": m.joint, "margin": m.value, "unit": m.unit,
                    "share_of_half_range": m.share,
                })),
                "ok": residual_max(k) <= tolerance,
            })
        })
        .collect();
    let lines: Vec<_> = tools
        .lines
        .iter()
        .map(|l| {
            let speed = l.speed(robot, &result.violations).map(|s| {
                let worst: Vec<_> = s
                    .worst
                    .iter()
                    .map(|e| {
                        serde_json::json!({
                            "joint": e.joint, "kind": e.kind.name(), "peak": e.peak,
                            "limit": e.limit, "unit": e.unit,
                        })
                    })
                    .collect();
                serde_json::json!({ "worst": worst, "needed_s": s.needed, "span_s": l.span.1 - l.span.0 })
            });
            serde_json::json!({
                "from_key": l.label,
                "feasible_fraction": l.fraction,
                "problem": l.problem,
                "too_fast": speed,
            })
        })
        .collect();
    serde_json::json!({ "orientation_tolerance_deg": tolerance, "keys": keys, "lines": lines })
}
