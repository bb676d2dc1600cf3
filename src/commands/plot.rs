//! `keypose plot`: position and velocity of every joint as an SVG picture.

use super::{parse_check_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::Trajectory;
use keypose::report;
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
    if !args.joints.is_empty() {
        super::joint_indices(&robot, &args.joints)?;
        data.joints.retain(|j| args.joints.contains(&j.name));
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
