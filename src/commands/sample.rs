//! `keypose sample`: the trajectory at a fixed rate, as CSV or JSON.

use super::{parse_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::Trajectory;
use keypose::robot::{JointKind, Robot};
use serde_json::json;
use std::fmt::Write;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct SampleArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Samples per second.
    #[arg(long, value_name = "HZ", default_value = "100", value_parser = parse_rate)]
    pub rate: f64,
    /// Unit of revolute joints (prismatic joints are always in metres, except in ticks).
    #[arg(long, value_enum, default_value_t = Units::Deg)]
    pub units: Units,
    /// Output format.
    #[arg(long, value_enum, default_value_t = SampleFormat::Csv)]
    pub format: SampleFormat,
    /// Output file [default: standard output].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Also output the tool path: tool_x, tool_y, tool_z columns, the position of the robot's
    /// tcp in its base frame at each sample (metres).
    #[arg(long)]
    pub tool: bool,
    /// Also output each servo's torque: a JOINT.torque column per joint, N·m at the servo's
    /// output, from the arm's inverse dynamics (gravity, inertia, the rotors, the payload), as
    /// the check computes it.
    #[arg(long)]
    pub torque: bool,
}

/// The tool path's columns, after the joints'.
const TOOL_COLUMNS: [&str; 3] = ["tool_x", "tool_y", "tool_z"];

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Units {
    Deg,
    Rad,
    /// Servo ticks through the robot's calibration.
    Ticks,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SampleFormat {
    Csv,
    Json,
}

pub fn run(args: &SampleArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    super::check_sample_budget(&sequence.file, &trajectory, args.rate)?;
    let mut rows = sample_rows(&trajectory, &robot, args.rate, args.units)?;
    let mut columns = trajectory.joint_names.clone();
    if args.tool {
        append_tool_path(&trajectory, &robot, &mut rows);
        for prefix in robot.tool_prefixes() {
            columns.extend(TOOL_COLUMNS.map(|c| format!("{prefix}{c}")));
        }
    }
    if args.torque {
        append_torques(&trajectory, &robot, &mut rows)?;
        columns.extend(robot.joints.iter().map(|j| format!("{}.torque", j.name)));
    }
    let text = match args.format {
        SampleFormat::Csv => to_csv(&columns, &rows),
        SampleFormat::Json => {
            let units = match args.units {
                Units::Deg => "deg",
                Units::Rad => "rad",
                Units::Ticks => "ticks",
            };
            let mut s = json!({
                "format": "keypose-samples/1",
                "robot": robot.name,
                "rate_hz": args.rate,
                "units": units,
                "columns": std::iter::once("time").chain(columns.iter().map(String::as_str)).collect::<Vec<_>>(),
                "rows": rows,
            })
            .to_string();
            s.push('\n');
            s
        }
    };
    write_output(args.output.as_deref(), &text)?;
    Ok(Verdict::Pass)
}

/// Rows of [time, joint values…] at t = start + k/rate, from the first to the last played time.
pub fn sample_rows(
    trajectory: &Trajectory,
    robot: &Robot,
    rate: f64,
    units: Units,
) -> Result<Vec<Vec<f64>>, CommandError> {
    let mut sampler = trajectory.sampler();
    let mut pose = vec![0.0; robot.joints.len()];
    let mut rows = Vec::new();
    for t in trajectory.grid(rate) {
        sampler.sample_into(t, &mut pose);
        let mut row = Vec::with_capacity(pose.len() + 1);
        row.push(t);
        for (joint, &value) in robot.joints.iter().zip(&pose) {
            row.push(match (units, joint.kind) {
                (Units::Ticks, _) => joint
                    .servo
                    .tick(value)
                    .map_err(|e| CommandError::Usage(format!("joint {}: {e}", joint.name)))?
                    as f64,
                (Units::Rad, JointKind::Revolute) => value.to_radians(),
                _ => value,
            });
        }
        rows.push(row);
    }
    Ok(rows)
}

/// Appends the tool position (each arm's, on a cell) at each row's time (its first column) to
/// the row.
fn append_tool_path(trajectory: &Trajectory, robot: &Robot, rows: &mut [Vec<f64>]) {
    for row in rows {
        for tool in robot.tool_positions(&trajectory.sample(row[0])) {
            row.extend(tool.to_array());
        }
    }
}

/// Appends each servo's torque at each row's time (from after an instant where an
/// acceleration jumps), N·m.
fn append_torques(
    trajectory: &Trajectory,
    robot: &Robot,
    rows: &mut [Vec<f64>],
) -> Result<(), CommandError> {
    let dynamics = keypose::dynamics::Dynamics::for_robot(robot)
        .map_err(|e| CommandError::Usage(format!("--torque: {e}")))?;
    let states = keypose::plan::States::of(trajectory);
    for row in rows {
        let s = states.at(row[0], keypose::plan::Side::After);
        row.extend(dynamics.servo_torques(&s.values, &s.velocities, &s.accelerations));
    }
    Ok(())
}

fn to_csv(joint_names: &[String], rows: &[Vec<f64>]) -> String {
    let mut out = String::from("time");
    for name in joint_names {
        out.push(',');
        out.push_str(&keypose::csv::field(name));
    }
    out.push('\n');
    for row in rows {
        for (i, value) in row.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            let _ = write!(out, "{}", trim_number(*value));
        }
        out.push('\n');
    }
    out
}

/// Up to 9 decimals without trailing zeros: enough for nanoradians and microseconds, and
/// short and stable (no 0.30000000000000004) for times computed as k/rate.
fn trim_number(x: f64) -> String {
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}
