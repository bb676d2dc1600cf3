//! `keypose check`: the sampled curve against the robot's limits.

use super::{parse_check_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::{check, Trajectory};
use keypose::report;

#[derive(Debug, Clone, clap::Args)]
pub struct CheckArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Rate at which velocity and acceleration are differenced [default: the robot's control
    /// rate]; a lower rate is raised to the control rate, which would otherwise hide violations.
    #[arg(long, value_name = "HZ", value_parser = parse_check_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Report format.
    #[arg(long, value_enum, default_value_t = ReportFormat::Text)]
    pub format: ReportFormat,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportFormat {
    Text,
    Json,
}

pub fn run(args: &CheckArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    let rate = super::limit_check_rate(args.rate, &robot);
    super::check_sample_budget(&sequence.file, &trajectory, rate)?;
    let result = check(&trajectory, &robot, rate);
    let text = match args.format {
        ReportFormat::Text => report::check_text(&result, &sequence.file, &robot),
        ReportFormat::Json => {
            let mut s = report::check_json(&result, &sequence.file, &robot).to_string();
            s.push('\n');
            s
        }
    };
    write_output(None, &text)?;
    Ok(if result.passed() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}
