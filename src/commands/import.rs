//! `keypose import lerobot`: a LeRobotDataset v3.0 episode as the fewest keyframes within a
//! tolerance, clamped and retimed so that the sequence passes `check`.

use super::record::{
    check_output_dir, parse_mode, parse_tolerance, parse_tolerance_m, print_summary,
    robot_reference,
};
use super::{CalibrationArgs, CommandError, Verdict};
use keypose::curve::Interp;
use keypose::interop::lerobot::{self, BodyUnits, DatasetInfo, ImportOptions, Imported};
use keypose::json::{InputError, Location};
use keypose::record::KeyframeOptions;
use keypose::robot::Robot;
use keypose::sequence::ArmSpec;
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
    /// Clip values outside a joint's limits to the limits (each clipped joint is reported)
    /// instead of refusing the episode.
    #[arg(long)]
    pub clip: bool,
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

pub(super) fn parse_units(s: &str) -> Result<BodyUnits, String> {
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
    refuse_output_inside(&args.output, &args.dir)?;
    let choice = RobotChoice {
        robot: args.robot.as_deref(),
        calibration: &args.calibration,
        interpolation: args.interpolation,
    };
    let (imported, robot, _) = import_episode(&args.dir, &args.episode, choice)?;
    let mut sequence = imported.keyframes.sequence.clone();
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
        imported.units_text()
    );
    print_summary(&imported.keyframes, &args.output, args.calibration.given());
    if !imported.keyframes.check.passed() {
        let text = keypose::report::check_text(&imported.keyframes.check, &sequence.file, &robot);
        eprint!("{}", escape_controls(&text));
        eprintln!("the keyframes are saved, but they fail the check above");
        return Ok(Verdict::Fail);
    }
    Ok(Verdict::Pass)
}

/// Imports the episode in memory: the keys (naming their robot, or for a bimanual dataset their
/// arms), the robot they are for (calibrated; a cell for a bimanual dataset), and how the robot
/// was named (the dataset's robot_type or --robot).
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
    let arms = lerobot::dataset_arms(&info, &args.field, &names).map_err(CommandError::LeRobot)?;
    let (spec, spec_notice) = robot_spec(&info, choice.robot, !arms.is_empty())?;
    // A name from the dataset is the dataset's to blame, one from --robot the option's; a
    // bimanual robot_type is named as the dataset gives it, not only its arms' type.
    let resolve = |name: &str| {
        Robot::resolve(name, None).map_err(|e| {
            super::resolve_error(e, |m| match (choice.robot, &info.robot_type) {
                (Some(_), _) => InputError::new("--robot", Location::File, m),
                (None, Some(bimanual)) if !arms.is_empty() => InputError::at_path(
                    &info.file,
                    "$.robot_type",
                    format!("{bimanual:?} is LeRobot's bimanual robot of two {name:?} arms: {m}"),
                ),
                (None, _) => InputError::at_path(&info.file, "$.robot_type", m),
            })
        })
    };
    let (robot, arm_specs) = if arms.is_empty() {
        let robot = super::finish_robot(resolve(&spec)?, choice.calibration)?;
        (robot, Vec::new())
    } else {
        dataset_cell(&spec, &arms, choice.calibration, resolve)?
    };
    let options = ImportOptions {
        episode,
        field: args.field.clone(),
        units: args.units,
        clip: args.clip,
        keyframes: KeyframeOptions {
            interpolation: choice.interpolation,
            tolerance_deg: args.tolerance,
            tolerance_m: args.tolerance_m,
            check_rate_hz: robot.control_hz,
        },
    };
    let mut imported =
        lerobot::import(dir, &info, &robot, &options).map_err(CommandError::LeRobot)?;
    let clipped = imported.clipped.iter().map(|c| c.notice());
    imported.notices.extend(clipped.collect::<Vec<_>>());
    imported.notices.extend(spec_notice);
    let sequence = &mut imported.keyframes.sequence;
    if arm_specs.is_empty() {
        sequence.robot = robot_reference(&spec);
    } else {
        imported.notices.push(placement_notice(&arm_specs));
        sequence.robot.clear();
        sequence.arms = arm_specs;
    }
    Ok((imported, robot, spec))
}

/// An output inside the dataset being read would overwrite its own files (`-o ds/meta/info.json`)
/// or leave a stray file in it: refused, whatever the path's spelling (compared resolved).
fn refuse_output_inside(output: &Path, dataset: &Path) -> Result<(), CommandError> {
    let resolved = |p: &Path| std::fs::canonicalize(p).ok();
    let parent = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let (Some(dir), Some(dataset)) = (resolved(parent), resolved(dataset)) else {
        return Ok(());
    };
    if dir.starts_with(&dataset) {
        return Err(CommandError::Usage(format!(
            "-o {}: inside the dataset {} being read; expected a path outside it (the sequence \
             is a file of its own, and the dataset's files stay as LeRobot wrote them)",
            output.display(),
            dataset.display()
        )));
    }
    Ok(())
}

/// `--robot`, else the dataset's robot_type; for a bimanual dataset the type of its arms
/// (`bi_so100_follower` → `so100_follower`), `--robot` naming both arms' robot. With it, what
/// was assumed to get there, for the user to hear.
fn robot_spec(
    info: &DatasetInfo,
    option: Option<&str>,
    bimanual: bool,
) -> Result<(String, Option<String>), CommandError> {
    let robot_type = match (option, &info.robot_type) {
        (Some(spec), _) => return Ok((spec.to_string(), None)),
        (None, Some(robot_type)) if bimanual => lerobot::arm_robot_type(robot_type),
        (None, Some(robot_type)) => robot_type.as_str(),
        (None, None) => {
            return Err(CommandError::Usage(format!(
                "{}: no robot_type: give --robot",
                info.file
            )))
        }
    };
    Ok(match so_class_as_so101(robot_type) {
        Some(so101) => (
            so101.to_string(),
            Some(format!(
                "robot_type {robot_type:?} is LeRobot's class of both the SO-100 and the SO-101 \
                 (lerobot-record writes it for either): taken as the SO-101 ({so101}); give \
                 --robot so100 for an SO-100, whose kinematics differ"
            )),
        ),
        None => (robot_type.to_string(), None),
    })
}

/// LeRobot's merged SO class names (since 2026-01), which `lerobot-record` writes as a
/// dataset's robot_type for an SO-100 and an SO-101 alike, as the SO-101's type: the arm
/// LeRobot builds and documents today.
fn so_class_as_so101(robot_type: &str) -> Option<&'static str> {
    match robot_type {
        "so_follower" => Some("so101_follower"),
        "so_leader" => Some("so101_leader"),
        _ => None,
    }
}

/// The cell of a bimanual dataset: one robot `spec` per arm, each with its own calibration, at
/// the default bases; and the arms as the sequence names them.
fn dataset_cell(
    spec: &str,
    arms: &[&str],
    calibration: &CalibrationArgs,
    resolve: impl Fn(&str) -> Result<Robot, InputError>,
) -> Result<(Robot, Vec<ArmSpec>), CommandError> {
    let arms: Vec<(String, String)> = arms
        .iter()
        .map(|&arm| (arm.to_string(), spec.to_string()))
        .collect();
    let names: Vec<&str> = arms.iter().map(|(arm, _)| arm.as_str()).collect();
    let calibration = bimanual_robot_ids(calibration, &names);
    super::default_placed_cell(&arms, &calibration, resolve)
}

/// LeRobot calibrates the arms of a bimanual robot of id NAME as ids `NAME_left` and
/// `NAME_right` (`bi_so_follower.py`): `--robot-id NAME` without an arm means those.
fn bimanual_robot_ids(calibration: &CalibrationArgs, arms: &[&str]) -> CalibrationArgs {
    let robot_id = calibration
        .robot_id
        .iter()
        .flat_map(|id| {
            if id.contains('=') {
                vec![id.clone()]
            } else {
                arms.iter().map(|arm| format!("{arm}={id}_{arm}")).collect()
            }
        })
        .collect();
    CalibrationArgs {
        calibration: calibration.calibration.clone(),
        robot_id,
    }
}

/// Says where the arms were placed: a dataset does not record it.
fn placement_notice(arms: &[ArmSpec]) -> String {
    let bases: Vec<String> = arms
        .iter()
        .map(|arm| {
            let t = arm.base.map_or(glam::DVec3::ZERO, |b| b.xyz);
            format!("{} at y = {:+} m", arm.name, t.y)
        })
        .collect();
    format!(
        "note: a bimanual dataset does not say where its arms stand: placed {} (x forward, both \
         facing +x); edit each arm's \"base\" in \"robots\" for the real bench",
        bases.join(", ")
    )
}
