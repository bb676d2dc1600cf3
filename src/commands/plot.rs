//! `keypose plot`: position and velocity of every joint as an SVG picture.

use super::{parse_rate, write_output, CommandError, SequenceInput, Verdict};
use crate::plan::Trajectory;
use crate::report;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct PlotArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// SVG file to write.
    #[arg(short, long, value_name = "FILE.svg")]
    pub output: PathBuf,
    /// Sampling rate of the drawn curves.
    #[arg(long, value_name = "HZ", default_value = "200", value_parser = parse_rate)]
    pub rate: f64,
}

pub fn run(args: &PlotArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    super::check_sample_budget(&sequence.file, &trajectory, args.rate)?;
    let title = format!(
        "{} — {} ({}, {:.2} s)",
        sequence.file,
        robot.name,
        sequence.interpolation,
        trajectory.duration()
    );
    let data = report::plot_data(&title, &trajectory, &robot, args.rate, Vec::new());
    write_output(Some(&args.output), &report::plot::render_svg(&data))?;
    Ok(Verdict::Pass)
}
