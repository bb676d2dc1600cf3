//! `keypose import lerobot`: a LeRobotDataset v3.0 episode as the fewest keyframes within a
//! tolerance, clamped and retimed so that the sequence passes `check`.

use super::record::{
    check_output_dir, parse_mode, parse_tolerance, parse_tolerance_m, print_summary,
    robot_reference,
};
use super::{CalibrationArgs, CommandError, Verdict};
use keypose::curve::Interp;
use keypose::interop::lerobot::{self, BodyUnits, DatasetInfo, ImportOptions, Imported};
use keypose::record::KeyframeOptions;
use keypose::robot::Robot;
use keypose::terminal_text::escape_controls;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, clap::Subcommand)]
pub enum ImportFormat {
    /// One episode of a LeRobotDataset v3.0 folder (meta/info.json, meta/episodes/, data/).
    Lerobot(LeRobotArgs),
}

/// The dataset options `import lerobot` and `play --lerobot` share (the robot, calibration and
/// interpolation options are each command's own).
#[derive(Debug, Clone, clap::Args)]
pub struct EpisodeArgs {
    /// The episode (its episode_index).
    #[arg(long, value_name = "N")]
    pub episode: Option<u64>,
    /// Which feature to read: the commanded positions or the measured ones.
    #[arg(long, value_name = "FEATURE", default_value = "action", value_parser = ["action", "observation.state"])]
    pub field: String,
    /// Units of the joints other than the gripper: degrees (LeRobot's use_degrees=True) or
    /// range (−100…100 of the calibrated range; needs the calibration) [default: degrees, or
    /// as the values show].
    #[arg(long, value_name = "UNITS", value_parser = parse_units)]
    pub units: Option<BodyUnits>,
    /// Largest deviation of the keys' curve from every frame, degrees (revolute joints).
    #[arg(long, value_name = "DEG", default_value = "1", value_parser = parse_tolerance, allow_negative_numbers = true)]
    pub tolerance: f64,
    /// Largest deviation for prismatic joints, metres.
    #[arg(long, value_name = "M", default_value = "0.001", value_parser = parse_tolerance_m, allow_negative_numbers = true)]
    pub tolerance_m: f64,
}

/// Where the robot comes from and how the keys interpolate.
#[derive(Debug, Clone, Copy)]
pub struct RobotChoice<'a> {
    /// `--robot`; else the dataset's robot_type.
    pub robot: Option<&'a str>,
    pub calibration: &'a CalibrationArgs,
    pub interpolation: Interp,
}

#[derive(Debug, Clone, clap::Args)]
#[command(mut_arg("episode", |a| a.required(true)))]
pub struct LeRobotArgs {
    /// The dataset folder.
    pub dir: PathBuf,
    #[command(flatten)]
    pub episode: EpisodeArgs,
    /// The robot instead of the dataset's robot_type: a built-in name, a LeRobot type or a
    /// robot file.
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: Option<String>,
    #[command(flatten)]
    pub calibration: CalibrationArgs,
    /// Interpolation of the keys (step is refused: it jumps).
    #[arg(long, value_name = "MODE", default_value = "monotone", value_parser = parse_mode)]
    pub interpolation: Interp,
    /// Where to write the keyframes (keypose-sequence/1 JSON; replaced atomically).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

fn parse_units(s: &str) -> Result<BodyUnits, String> {
    match s {
        "degrees" | "deg" => Ok(BodyUnits::Degrees),
        "range" => Ok(BodyUnits::Range),
        _ => Err(format!("expected degrees or range, found {s:?}")),
    }
}

pub fn run(format: &ImportFormat) -> Result<Verdict, CommandError> {
    match format {
        ImportFormat::Lerobot(args) => run_lerobot(args),
    }
}

fn run_lerobot(args: &LeRobotArgs) -> Result<Verdict, CommandError> {
    check_output_dir(&args.output)?;
    let choice = RobotChoice {
        robot: args.robot.as_deref(),
        calibration: &args.calibration,
        interpolation: args.interpolation,
    };
    let (imported, robot, spec) = import_episode(&args.dir, &args.episode, choice)?;
    let mut sequence = imported.keyframes.sequence.clone();
    sequence.robot = robot_reference(&spec);
    sequence.file = args.output.display().to_string();
    sequence.save(&args.output)?;
    for notice in &imported.notices {
        eprintln!("{}", escape_controls(notice));
    }
    println!(
        "episode {} of {} ({}, {} column, {} units)",
        args.episode.episode.unwrap_or_default(),
        args.dir.display(),
        imported.data_file,
        imported.column_type,
        imported.units.name()
    );
    print_summary(&imported.keyframes, &args.output, args.calibration.given());
    if !imported.keyframes.check.passed() {
        let text = keypose::report::check_text(&imported.keyframes.check, &sequence.file, &robot);
        eprint!("{}", escape_controls(&text));
        eprintln!("the keyframes are saved, but they break the limits above");
        return Ok(Verdict::Fail);
    }
    Ok(Verdict::Pass)
}

/// Imports the episode in memory: the keys, the robot they are for (calibrated), and how the
/// robot was named (the dataset's robot_type or --robot).
pub fn import_episode(
    dir: &Path,
    args: &EpisodeArgs,
    choice: RobotChoice,
) -> Result<(Imported, Robot, String), CommandError> {
    let episode = args
        .episode
        .ok_or_else(|| CommandError::Usage("--episode N is required with a dataset".into()))?;
    let info = DatasetInfo::read(dir).map_err(CommandError::LeRobot)?;
    let names = info.names(&args.field).map_err(CommandError::LeRobot)?;
    lerobot::refuse_two_arms(&info, &args.field, &names).map_err(CommandError::LeRobot)?;
    let spec = match (choice.robot, &info.robot_type) {
        (Some(spec), _) => spec.to_string(),
        (None, Some(robot_type)) => robot_type.clone(),
        (None, None) => {
            return Err(CommandError::Usage(format!(
                "{}: no robot_type: give --robot",
                info.file
            )))
        }
    };
    let robot = super::load_robot(&spec, choice.calibration)?;
    let options = ImportOptions {
        episode,
        field: args.field.clone(),
        units: args.units,
        keyframes: KeyframeOptions {
            interpolation: choice.interpolation,
            tolerance_deg: args.tolerance,
            tolerance_m: args.tolerance_m,
            check_rate_hz: robot.control_hz,
        },
    };
    let imported = lerobot::import(dir, &info, &robot, &options).map_err(CommandError::LeRobot)?;
    Ok((imported, robot, spec))
}
