//! `keypose export`: a sequence, checked against the robot's limits, in another program's
//! format: a ROS 2 JointTrajectory or a play_motion2 motion.

use super::{parse_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::interop::lerobot::{self, BodyUnits};
use keypose::interop::{c_export, play_motion2, ros2};
use keypose::plan::{check, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::terminal_text::escape_controls;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Subcommand)]
pub enum ExportFormat {
    /// A trajectory_msgs/msg/JointTrajectory as YAML: positions (rad, m) and velocities at
    /// every key, holds as two points, corners approached over a period, segments with a
    /// timing profile densified until the controller's cubics follow them within the limits.
    Ros2(Ros2Args),
    /// A play_motion2 motion (parameter YAML): positions sampled at --rate.
    #[command(name = "play_motion2")]
    PlayMotion2(PlayMotion2Args),
    /// A C header for the stand-alone player (players/c/): per-piece polynomials in servo
    /// ticks (Q16.16 fixed point; cubics, of a higher degree on a timing profile), servo ids
    /// and tick limits.
    C(CArgs),
    /// A LeRobotDataset v3.0 of one episode: `action` and `observation.state` sampled at
    /// --fps in LeRobot's units (docs/interop.md §1.7).
    Lerobot(LeRobotArgs),
}

#[derive(Debug, Clone, clap::Args)]
pub struct LeRobotArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Frames per second (LeRobot's dataset fps; lerobot-record's default is 30).
    #[arg(long, value_name = "FPS", default_value = "30", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub fps: u32,
    /// The episode's task, in words [default: the sequence's description, else its file name].
    #[arg(long, value_name = "TEXT")]
    pub task: Option<String>,
    /// LeRobot's robot type for meta/info.json [default: the arm's follower type, so101_follower,
    /// koch_follower …; bi_… for two arms].
    #[arg(long, value_name = "TYPE")]
    pub robot_type: Option<String>,
    /// Units of the body joints: degrees (LeRobot's use_degrees=True, its default) or range
    /// (−100…100 of the calibrated range; needs --calibration or --robot-id). The gripper is
    /// always 0…100 % of its calibrated range.
    #[arg(long, value_name = "UNITS", default_value = "degrees", value_parser = super::import::parse_units)]
    pub units: BodyUnits,
    /// The dataset folder to create (it must not exist).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
}

#[derive(Debug, Clone, clap::Args)]
pub struct CArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Output header (replaced atomically).
    #[arg(short, long, value_name = "FILE.h")]
    pub output: PathBuf,
    /// On a sequence of several arms: the arm whose part to export (the stand-alone player
    /// drives one bus).
    #[arg(long, value_name = "ARM")]
    pub arm: Option<String>,
}

#[derive(Debug, Clone, clap::Args)]
pub struct Ros2Args {
    #[command(flatten)]
    pub input: SequenceInput,
    /// A corner (linear segments meeting, a hold next to a linear segment, a step) is
    /// approached over one period at this rate: the controller's cubic cannot turn it at a
    /// point.
    #[arg(long, value_name = "HZ", default_value = "100", value_parser = parse_rate)]
    pub corner_rate: f64,
    /// Output file (replaced atomically).
    #[arg(short, long, value_name = "FILE.yaml")]
    pub output: PathBuf,
}

#[derive(Debug, Clone, clap::Args)]
pub struct PlayMotion2Args {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Samples per second (play_motion2 carries positions only).
    #[arg(long, value_name = "HZ", default_value = "20", value_parser = parse_rate)]
    pub rate: f64,
    /// The motion's name [default: the sequence file's name].
    #[arg(long, value_name = "NAME")]
    pub name: Option<String>,
    /// Output file (replaced atomically).
    #[arg(short, long, value_name = "FILE.yaml")]
    pub output: PathBuf,
}

pub fn run(format: &ExportFormat) -> Result<Verdict, CommandError> {
    match format {
        ExportFormat::Ros2(args) => export_ros2(args),
        ExportFormat::PlayMotion2(args) => export_play_motion2(args),
        ExportFormat::C(args) => export_c(args),
        ExportFormat::Lerobot(args) => export_lerobot(args),
    }
}

fn export_lerobot(args: &LeRobotArgs) -> Result<Verdict, CommandError> {
    let Some((sequence, robot, trajectory)) = checked(&args.input)? else {
        return Ok(Verdict::Fail);
    };
    super::check_sample_budget(&sequence.file, &trajectory, f64::from(args.fps))?;
    let robot_type = match &args.robot_type {
        Some(name) => name.clone(),
        None => lerobot::export::follower_type(&robot).ok_or_else(|| {
            CommandError::Usage(format!(
                "{}: LeRobot has no robot type for {}; give --robot-type",
                sequence.file, robot.name
            ))
        })?,
    };
    let task = args.task.clone().unwrap_or_else(|| {
        sequence
            .description
            .clone()
            .filter(|d| !d.trim().is_empty())
            .unwrap_or_else(|| motion_stem(&args.input))
    });
    let options = lerobot::export::ExportOptions {
        fps: args.fps,
        task,
        robot_type,
        units: args.units,
    };
    let exported = lerobot::export::export(&trajectory, &robot, &options, &args.output)
        .map_err(CommandError::LeRobot)?;
    for notice in &exported.notices {
        eprintln!("{}", escape_controls(notice));
    }
    println!(
        "wrote {} (LeRobotDataset v3.0, 1 episode of {} frames at {} fps, {} {} units: {})",
        args.output.display(),
        exported.frames,
        args.fps,
        options.robot_type,
        args.units.name(),
        exported.names.join(", ")
    );
    Ok(Verdict::Pass)
}

/// The sequence file's name without its extension.
fn motion_stem(input: &SequenceInput) -> String {
    input
        .sequence
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "motion".into())
}

fn export_ros2(args: &Ros2Args) -> Result<Verdict, CommandError> {
    let Some((sequence, robot, trajectory)) = checked(&args.input)? else {
        return Ok(Verdict::Fail);
    };
    super::check_sample_budget(&sequence.file, &trajectory, args.corner_rate)?;
    let message = ros2::joint_trajectory(&trajectory, &robot, args.corner_rate)
        .map_err(|e| CommandError::Usage(format!("{}: {e}", sequence.file)))?;
    write_output(Some(&args.output), &ros2::to_yaml(&message))?;
    println!(
        "wrote {} ({} points, {:.3} s)",
        args.output.display(),
        message.points.len(),
        trajectory.duration()
    );
    Ok(Verdict::Pass)
}

fn export_play_motion2(args: &PlayMotion2Args) -> Result<Verdict, CommandError> {
    let Some((sequence, robot, trajectory)) = checked(&args.input)? else {
        return Ok(Verdict::Fail);
    };
    super::check_sample_budget(&sequence.file, &trajectory, args.rate)?;
    let name = motion_name(args);
    let description = sequence.description.clone().unwrap_or_default();
    let text = play_motion2::motion_yaml(&trajectory, &robot, args.rate, &name, &description);
    write_output(Some(&args.output), &text)?;
    println!("wrote {} (motion {name})", args.output.display());
    Ok(Verdict::Pass)
}

fn export_c(args: &CArgs) -> Result<Verdict, CommandError> {
    let Some((sequence, robot, trajectory)) = checked(&args.input)? else {
        return Ok(Verdict::Fail);
    };
    let (robot, trajectory) = one_bus(robot, trajectory, args.arm.as_deref(), &sequence.file)?;
    let text = c_export::header(&trajectory, &robot, &sequence.file)
        .map_err(|e| CommandError::Usage(format!("{}: {e}", sequence.file)))?;
    write_output(Some(&args.output), &text)?;
    println!(
        "wrote {} ({} pieces, {:.3} s; play it with players/c/keypose_player.c)",
        args.output.display(),
        c_export::pieces(&trajectory, &robot).len(),
        trajectory.duration()
    );
    Ok(Verdict::Pass)
}

/// The robot and trajectory of one bus: the robot itself, or the arm `--arm` names of a cell
/// (whose joints' servo ids are the cell's, not those of any bus).
fn one_bus(
    robot: Robot,
    trajectory: Trajectory,
    arm: Option<&str>,
    file: &str,
) -> Result<(Robot, Trajectory), CommandError> {
    let names = || {
        let names: Vec<&str> = robot.arms.iter().map(|a| a.name.as_str()).collect();
        names.join(", ")
    };
    match arm {
        None if robot.is_cell() => Err(CommandError::Usage(format!(
            "{file} names several arms; the stand-alone player drives one bus: give --arm, one of {}",
            names()
        ))),
        None => Ok((robot, trajectory)),
        Some(name) => {
            let Some(arm) = robot.arm(name) else {
                return Err(CommandError::Usage(if robot.is_cell() {
                    format!("--arm {name:?}: expected one of {}", names())
                } else {
                    format!("--arm {name:?}: {file} is for one arm; expected no --arm")
                }));
            };
            Ok((arm.robot.clone(), trajectory.for_arm(arm)))
        }
    }
}

/// The sequence, its robot and trajectory when it passes the limit check at the robot's control
/// rate; else the report on stderr and `None`: nothing is written that the arm may not do.
fn checked(input: &SequenceInput) -> Result<Option<(Sequence, Robot, Trajectory)>, CommandError> {
    let (sequence, robot) = input.load()?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    refuse_efforts(&sequence, &trajectory)?;
    let report = check(&trajectory, &robot, robot.control_hz);
    if !report.passed() {
        let text = keypose::report::check_text(&report, &sequence.file, &robot);
        eprint!("{}", escape_controls(&text));
        let hint = if report.violations.is_empty() {
            "move the keys the contacts name".to_string()
        } else {
            super::limits_hint(&sequence, &report, "try `keypose retime`")
        };
        eprintln!("refusing to export: the sequence fails the check above ({hint})");
        return Ok(None);
    }
    Ok(Some((sequence, robot, trajectory)))
}

/// No export format carries a key's effort limit: the exported motion would squeeze what a
/// grasp holds at full output, so it is refused until the keys say so themselves.
fn refuse_efforts(sequence: &Sequence, trajectory: &Trajectory) -> Result<(), CommandError> {
    let Some(first) = trajectory.efforts.first() else {
        return Ok(());
    };
    Err(CommandError::Usage(format!(
        "{}: key {} limits {}'s effort, which no export format carries (the servos would push at full output, squeezing what a grasp holds); play it with `keypose play`, or remove the keys' \"effort\" to export the motion at full effort",
        sequence.file,
        trajectory.key_labels[first.key],
        trajectory.joint_names[first.joint]
    )))
}

/// A YAML key of letters, digits and underscores.
fn motion_name(args: &PlayMotion2Args) -> String {
    let raw = args
        .name
        .clone()
        .unwrap_or_else(|| motion_stem(&args.input));
    let name: String = raw
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        "motion".into()
    } else {
        name
    }
}
