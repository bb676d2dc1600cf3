//! `keypose plot`: position and velocity of every joint as an SVG picture.

use super::{parse_check_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::Trajectory;
use keypose::report;
use keypose::report::plot::PlotJoint;
use keypose::robot::Robot;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, clap::Args)]
pub struct PlotArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// SVG file to write.
    #[arg(short, long, value_name = "FILE.svg")]
    pub output: PathBuf,
    /// Draw only these joints (comma-separated names) [default: all].
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub joints: Vec<String>,
    /// A playback log (`keypose play --log`) whose measured positions to overlay.
    #[arg(long, value_name = "FILE.csv")]
    pub log: Option<PathBuf>,
    /// Sampling rate of the drawn curves; never below the robot's control rate, so the velocity
    /// drawn is the one the servos will be asked for.
    #[arg(long, value_name = "HZ", default_value = "200", value_parser = parse_check_rate, allow_negative_numbers = true)]
    pub rate: f64,
    /// Also draw the tool path: rows tool_x, tool_y, tool_z, the robot's tcp in its base frame
    /// (mm), with its speed along each axis.
    #[arg(long)]
    pub tool: bool,
}

pub fn run(args: &PlotArgs) -> Result<Verdict, CommandError> {
    check_svg_extension(&args.output)?;
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    let rate = super::limit_check_rate(Some(args.rate), &robot);
    super::check_sample_budget(&sequence.file, &trajectory, rate)?;
    let title = format!(
        "{} — {} ({}, {:.2} s)",
        sequence.file,
        robot.name,
        sequence.interpolation,
        trajectory.duration()
    );
    let measured = match &args.log {
        Some(path) => report::log::measured_traces(path, &trajectory.joint_names)?,
        None => Vec::new(),
    };
    let mut data = report::plot_data(&title, &trajectory, &robot, rate, measured);
    if let Some(path) = &args.log {
        let telemetry = report::log::telemetry(path, &trajectory.joint_names)?;
        data.telemetry = report::telemetry_rows(&robot, telemetry);
    }
    if !args.joints.is_empty() {
        super::joint_indices(&robot, &args.joints)?;
        data.joints.retain(|j| args.joints.contains(&j.name));
        data.telemetry.retain(|t| args.joints.contains(&t.name));
    }
    if args.tool {
        data.joints
            .extend(tool_rows(&trajectory, &robot, &data.times));
    }
    write_output(Some(&args.output), &report::plot::render_svg(&data))?;
    Ok(Verdict::Pass)
}

/// keypose draws SVG only: a `.png` name would get SVG text under a PNG name, which viewers
/// refuse. (Rasterising in-process would need a renderer and its fonts, far heavier than the
/// rest of keypose; `rsvg-convert` or a browser does it from the SVG.)
fn check_svg_extension(output: &Path) -> Result<(), CommandError> {
    let extension = output.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("svg") {
        return Ok(());
    }
    Err(CommandError::Usage(format!(
        "-o {}: expected a .svg file (keypose draws SVG; convert it to PNG with e.g. rsvg-convert)",
        output.display()
    )))
}

/// The tool path as three rows (per arm, on a cell), x, y and z in mm at the plot's sample
/// times, with velocities by central differences, unlimited (a tool coordinate has no limits of
/// its own).
fn tool_rows(trajectory: &Trajectory, robot: &Robot, times: &[f64]) -> Vec<PlotJoint> {
    let tools_mm = |t: f64| -> Vec<[f64; 3]> {
        robot
            .tool_positions(&trajectory.sample(t))
            .iter()
            .map(|p| (*p * 1000.0).to_array())
            .collect()
    };
    let path: Vec<Vec<[f64; 3]>> = times.iter().map(|&t| tools_mm(t)).collect();
    let keys: Vec<(f64, Vec<[f64; 3]>)> = trajectory
        .key_times
        .iter()
        .filter(|&&t| t >= trajectory.start && t <= trajectory.end)
        .map(|&t| (t, tools_mm(t)))
        .collect();
    let mut rows = Vec::new();
    for (tool, prefix) in robot.tool_prefixes().iter().enumerate() {
        for axis in 0..3 {
            let positions: Vec<f64> = path.iter().map(|p| p[tool][axis]).collect();
            rows.push(PlotJoint {
                name: format!("{prefix}tool_{}", ["x", "y", "z"][axis]),
                unit: "mm".into(),
                min: f64::NEG_INFINITY,
                max: f64::INFINITY,
                velocity_limit: f64::INFINITY,
                velocities: differences(times, &positions),
                positions,
                keys: keys.iter().map(|(t, p)| (*t, p[tool][axis])).collect(),
                measured: None,
            });
        }
    }
    rows
}

/// Central differences (one-sided at the ends).
fn differences(times: &[f64], values: &[f64]) -> Vec<f64> {
    let n = values.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n.saturating_sub(1)));
            if b > a {
                (values[b] - values[a]) / (times[b] - times[a])
            } else {
                0.0
            }
        })
        .collect()
}
