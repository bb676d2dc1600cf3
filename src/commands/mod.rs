//! The command-line verbs. Each takes its parsed arguments and returns a [`Verdict`] or a
//! [`CommandError`]; `main.rs` turns those into exit codes.

pub mod args;
pub mod calibration;
pub mod check;
pub mod doctor;
pub mod export;
pub mod import;
pub mod mirror;
pub mod option_values;
pub mod play;
pub mod plot;
pub mod ports;
pub mod pose;
pub mod read;
pub mod record;
pub mod retime;
pub mod sample;
pub mod scan;
pub mod sim;
pub mod studio;
pub mod teach;
pub mod torque;
pub mod virtual_bus;

pub use args::{
    BusArgs, PhysicsArgs, RealtimeArgs, RobotArgs, SequenceInput, SequenceOptions, WireArgs,
};
pub use calibration::CalibrationArgs;

use keypose::error::ErrorKind;
use keypose::json::{InputError, Location};
use keypose::robot::{import_lerobot_calibration, LeRobotRole, ResolveError, Robot};
use keypose::sequence::Sequence;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether `-v/--verbose` was given: commands then say which inputs they use.
static VERBOSE: AtomicBool = AtomicBool::new(false);

pub fn set_verbose(on: bool) {
    VERBOSE.store(on, Ordering::Relaxed);
}

pub fn verbose() -> bool {
    VERBOSE.load(Ordering::Relaxed)
}

/// The robot of the commands that take no sequence (`read`, `torque`, `record`, `teach`,
/// `scan --port virtual`) when `--robot` does not say: one rule for all of them.
pub const DEFAULT_ROBOT: &str = "so101";

/// Says on standard error which robot a command without a sequence drives, since the default
/// may not be the arm on the port (`-v` already says it).
pub fn announce_robot(robot: &Robot) {
    if !verbose() {
        let line = format!("robot {} ({})", robot.name, robot.source);
        eprintln!("{}", keypose::terminal_text::escape_message(&line));
    }
}

/// Exit code for a failed check or simulation verdict.
pub const EXIT_VERDICT_FAILED: i32 = 1;
/// Exit code for bad input: files, arguments.
pub const EXIT_BAD_INPUT: i32 = 2;
/// Exit code for a hardware or bus error.
pub const EXIT_HARDWARE: i32 = 3;

/// What a command concluded, when it ran to the end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    Pass,
    Fail,
}

impl Verdict {
    pub fn exit_code(self) -> i32 {
        match self {
            Verdict::Pass => 0,
            Verdict::Fail => EXIT_VERDICT_FAILED,
        }
    }
}

/// Exit code when a stop request (Ctrl-C) ended the command.
pub const EXIT_INTERRUPTED: i32 = 130;

#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    #[error(transparent)]
    Input(#[from] InputError),
    /// The servos, the bus or the port failed (or, for a homing offset that is not the
    /// calibration's, the input did).
    #[error(transparent)]
    Bus(#[from] keypose::bus::BusError),
    #[error("playback stopped")]
    Play(#[source] keypose::player::PlayError),
    /// The fault is said within the sentence, so it is not the error's `source()` as well.
    #[error("recording stopped: {0}; the limp joints were asked to hold where they are")]
    RecordFault(keypose::record::RecordError),
    #[error(transparent)]
    Record(keypose::record::RecordError),
    #[error("simulation")]
    Sim(#[source] keypose::sim::SimError),
    #[error(transparent)]
    Model(keypose::sim::SimError),
    #[error(transparent)]
    Teach(keypose::teach::TeachError),
    #[error(transparent)]
    LeRobot(keypose::interop::lerobot::LeRobotError),
    #[error(transparent)]
    Mirror(#[from] keypose::mirror::MirrorError),
    /// The teaching session's bus failed (reading the pose it starts from).
    #[error(transparent)]
    Session(#[from] keypose::teach::BusCommandError),
    /// Something else about the servos, in words.
    #[error("{0}")]
    Hardware(String),
    /// A stop request ended the command (the arm holds where it stopped).
    #[error("{0}")]
    Interrupted(String),
    #[error("{0}")]
    Usage(String),
    #[error("cannot write {path}")]
    Output {
        path: String,
        source: std::io::Error,
    },
}

/// A model MuJoCo refuses, or a servo profile that cannot be modelled, is the user's to mend
/// (exit 2); anything else is the simulation's.
impl From<keypose::sim::SimError> for CommandError {
    fn from(e: keypose::sim::SimError) -> Self {
        match e {
            keypose::sim::SimError::Model { .. } | keypose::sim::SimError::ServoProfile(_) => {
                CommandError::Model(e)
            }
            other => CommandError::Sim(other),
        }
    }
}

impl CommandError {
    /// What kind of failure this is: the library's error says so itself.
    pub fn kind(&self) -> ErrorKind {
        match self {
            CommandError::Input(e) => e.kind(),
            CommandError::Bus(e) => e.kind(),
            CommandError::Play(e) => e.kind(),
            CommandError::RecordFault(e) | CommandError::Record(e) => e.kind(),
            CommandError::Sim(e) | CommandError::Model(e) => e.kind(),
            CommandError::Teach(e) => e.kind(),
            CommandError::LeRobot(e) => e.kind(),
            CommandError::Session(e) => e.kind(),
            CommandError::Hardware(_) => ErrorKind::Hardware,
            CommandError::Interrupted(_) => ErrorKind::Interrupted,
            CommandError::Mirror(_) | CommandError::Usage(_) | CommandError::Output { .. } => {
                ErrorKind::BadInput
            }
        }
    }

    pub fn exit_code(&self) -> i32 {
        match self.kind() {
            ErrorKind::VerdictFailed => EXIT_VERDICT_FAILED,
            ErrorKind::BadInput => EXIT_BAD_INPUT,
            ErrorKind::Hardware => EXIT_HARDWARE,
            ErrorKind::Interrupted => EXIT_INTERRUPTED,
        }
    }
}

/// The robot `--robot` names (a built-in name, a LeRobot type, or a path to a robot file), with
/// a LeRobot calibration applied when asked for.
pub fn load_robot(spec: &str, calibration: &CalibrationArgs) -> Result<Robot, CommandError> {
    finish_robot(resolve_option_robot(spec)?, calibration)
}

/// The robot `--robot` names, without calibration; errors are `--robot`'s.
pub(super) fn resolve_option_robot(spec: &str) -> Result<Robot, InputError> {
    Robot::resolve(spec, None)
        .map_err(|e| resolve_error(e, |m| InputError::new("--robot", Location::File, m)))
}

/// The robot a sequence names: a built-in name, a LeRobot type, or a path to a robot file
/// relative to the sequence.
fn resolve_sequence_robot(sequence: &Sequence, sequence_path: &Path) -> Result<Robot, InputError> {
    Robot::resolve(&sequence.robot, sequence_path.parent())
        .map_err(|e| resolve_error(e, |m| InputError::at_path(&sequence.file, "$.robot", m)))
}

/// The cell of a sequence's arms (`"robots"`): each arm's robot resolved as a sequence's robot
/// is, with its own calibration (`--calibration ARM=FILE`, `--robot-id ARM=NAME`), placed at its
/// base.
pub fn load_cell(
    sequence: &Sequence,
    sequence_path: &Path,
    calibration: &CalibrationArgs,
) -> Result<Robot, CommandError> {
    let arms = cell_arms(&sequence.arms, calibration, |arm| {
        Robot::resolve(&arm.robot, sequence_path.parent()).map_err(|e| {
            resolve_error(e, |m| {
                InputError::at_path(&sequence.file, &format!("$.robots.{}", arm.name), m)
            })
        })
    })?;
    Robot::cell(arms)
        .map_err(|e| InputError::at_path(&sequence.file, "$.robots", e.to_string()).into())
}

/// Each of `arms` as [`Robot::cell`] takes it: its robot as `resolve` finds it, with the
/// calibration the options give that arm, at its base (the cell's origin when it has none).
pub fn cell_arms(
    arms: &[keypose::sequence::ArmSpec],
    calibration: &CalibrationArgs,
    resolve: impl Fn(&keypose::sequence::ArmSpec) -> Result<Robot, InputError>,
) -> Result<Vec<(String, Robot, keypose::pose::RigidTransform)>, CommandError> {
    let names: Vec<&str> = arms.iter().map(|a| a.name.as_str()).collect();
    let mut out = Vec::with_capacity(arms.len());
    for arm in arms {
        let robot = finish_robot(resolve(arm)?, &calibration.for_arm(&arm.name, &names)?)?;
        let base = arm
            .base
            .map_or(keypose::pose::RigidTransform::IDENTITY, |b| b.transform());
        out.push((arm.name.clone(), robot, base));
    }
    Ok(out)
}

/// The cell of arms named where no file places them (a bimanual dataset, `record --robot
/// ARM=ROBOT`): each (arm, robot spec) resolved by `resolve`, with the calibration the options
/// give that arm, at [`Placement::default_for`](keypose::sequence::Placement::default_for); and
/// the arms as a sequence names them.
pub fn default_placed_cell(
    arms: &[(String, String)],
    calibration: &CalibrationArgs,
    resolve: impl Fn(&str) -> Result<Robot, InputError>,
) -> Result<(Robot, Vec<keypose::sequence::ArmSpec>), CommandError> {
    let specs: Vec<keypose::sequence::ArmSpec> = arms
        .iter()
        .map(|(arm, spec)| keypose::sequence::ArmSpec {
            name: arm.clone(),
            robot: record::robot_reference(spec),
            base: Some(keypose::sequence::Placement::default_for(arm)),
        })
        .collect();
    let cell_arms = cell_arms(&specs, calibration, |arm| resolve(&arm.robot))?;
    let robot = Robot::cell(cell_arms).map_err(|e| CommandError::Usage(e.to_string()))?;
    Ok((robot, specs))
}

/// A resolution error as input error: a robot file's own error as it is, a name's at `at`.
fn resolve_error(error: ResolveError, at: impl Fn(String) -> InputError) -> InputError {
    match error {
        ResolveError::Input(e) => e,
        named => at(named.to_string()),
    }
}

/// Applies the calibration, then says which robot (and calibration) is in use: under `-v`, and
/// always for what the user may not expect (a leader read as its follower, a calibration found
/// by id).
fn finish_robot(mut robot: Robot, calibration: &CalibrationArgs) -> Result<Robot, CommandError> {
    let file = calibration.file_for(&robot)?;
    if let Some(file) = &file {
        let text = keypose::json::read_text(&file.path)?;
        import_lerobot_calibration(&mut robot, &file.path.display().to_string(), &text)?;
    }
    if let Some(lerobot) = robot.lerobot.filter(|t| t.role == LeRobotRole::Leader) {
        eprintln!(
            "note: {} is LeRobot's leader arm, read as the built-in {} (the follower's joints, \
             servo ids and kinematics; its limits are the follower's)",
            lerobot.name, robot.name
        );
    }
    if verbose() {
        let lerobot = robot
            .lerobot
            .map_or(String::new(), |t| format!(" (LeRobot {})", t.name));
        eprintln!("robot {}: {}{lerobot}", robot.name, robot.source);
    }
    if let Some(file) = &file {
        calibration::announce(file, verbose());
    }
    Ok(robot)
}

/// Most samples a command computes per joint: at 100 Hz that is nearly 14 hours of motion, far
/// beyond any sequence, while the memory it takes stays small.
pub const MAX_SAMPLES: f64 = 5_000_000.0;

/// Refuses a rate that would sample `trajectory` more than [`MAX_SAMPLES`] times.
pub fn check_sample_budget(
    file: &str,
    trajectory: &keypose::plan::Trajectory,
    rate: f64,
) -> Result<(), CommandError> {
    let samples = trajectory.duration() * rate;
    if samples > MAX_SAMPLES {
        return Err(CommandError::Usage(format!(
            "{file}: {:.1} s at {rate} Hz is {samples:.0} samples; expected at most {MAX_SAMPLES:.0}: lower --rate",
            trajectory.duration()
        )));
    }
    Ok(())
}

/// Robot joint indices for `--joints` names, in the order given, each once; all joints when
/// none are given.
/// What to try when `report` fails on its limits: `fix` (a stretch of time: `keypose retime`,
/// a lower speed) where stretching mends every violation, else how to mend the first that no
/// stretch mends.
pub fn limits_hint(
    sequence: &keypose::sequence::Sequence,
    report: &keypose::plan::CheckReport,
    fix: &str,
) -> String {
    let unmendable = report
        .violations
        .iter()
        .find(|v| !keypose::plan::stretch_mends(sequence, v));
    match unmendable {
        None => fix.to_string(),
        Some(v) => format!(
            "{} {} in {}: {}",
            v.joint,
            v.kind.name(),
            v.segment_label,
            keypose::plan::advice(sequence, v)
        ),
    }
}

/// `--compensate-droop`: the goals' lead for `robot`'s servos, or why it has none (bad
/// input: the robot's masses are not known, so no lead could be trusted).
pub fn droop_compensation(
    asked: bool,
    robot: &Robot,
) -> Result<Option<std::sync::Arc<keypose::dynamics::Compensation>>, CommandError> {
    if !asked {
        return Ok(None);
    }
    keypose::dynamics::Compensation::for_robot(robot)
        .map(|c| Some(std::sync::Arc::new(c)))
        .map_err(|e| CommandError::Usage(format!("--compensate-droop: {e}")))
}

pub fn joint_indices(robot: &Robot, names: &[String]) -> Result<Vec<usize>, CommandError> {
    if names.is_empty() {
        return Ok((0..robot.joints.len()).collect());
    }
    let mut indices = Vec::new();
    for name in names {
        let index = robot.joint_index(name).ok_or_else(|| {
            CommandError::Usage(format!(
                "--joints: unknown joint {name:?}; expected names from: {}",
                robot.joint_names().join(", ")
            ))
        })?;
        if !indices.contains(&index) {
            indices.push(index);
        }
    }
    Ok(indices)
}

/// Parses the rate of a limit check (`check`, `retime`, `plot`): at least the lowest control
/// rate, since a check on a coarser grid would only ever be raised to the control rate, and
/// at most 100 kHz.
pub fn parse_check_rate(s: &str) -> Result<f64, String> {
    let lowest = *keypose::pacing::RATE_RANGE_HZ.start();
    match parse_rate(s) {
        Ok(rate) if rate >= lowest => Ok(rate),
        _ => Err(format!(
            "expected a rate from {lowest} to 100000 Hz (the limits are checked at least at the robot's control rate), found {s:?}"
        )),
    }
}

/// Parses a rate in Hz for clap: a finite number above 0 and at most 100 kHz.
pub fn parse_rate(s: &str) -> Result<f64, String> {
    let rate: f64 = s
        .parse()
        .map_err(|_| format!("expected a rate in Hz, found {s:?}"))?;
    if rate.is_finite() && rate > 0.0 && rate <= 100_000.0 {
        Ok(rate)
    } else {
        Err(format!(
            "expected a rate above 0 and at most 100000 Hz, found {s}"
        ))
    }
}

/// Parses a control rate for clap (`play`, `record`): a finite number within
/// [`keypose::pacing::RATE_RANGE_HZ`].
pub fn parse_control_rate(s: &str) -> Result<f64, String> {
    let range = keypose::pacing::RATE_RANGE_HZ;
    match s.parse::<f64>() {
        Ok(rate) if range.contains(&rate) => Ok(rate),
        _ => Err(format!(
            "expected a control rate from {} to {} Hz, found {s:?}",
            range.start(),
            range.end()
        )),
    }
}

/// The rate a loop that drives servos runs at: `--rate`, or the robot's own control rate, which
/// a robot file may set outside what the player can keep; checked before anything is opened.
pub fn control_rate(rate: Option<f64>, robot: &Robot) -> Result<f64, CommandError> {
    let range = keypose::pacing::RATE_RANGE_HZ;
    match rate {
        Some(rate) => Ok(rate),
        None if range.contains(&robot.control_hz) => Ok(robot.control_hz),
        None => Err(CommandError::Usage(format!(
            "robot {}: control_hz {} is outside the {} … {} Hz the player can keep: give --rate",
            robot.name,
            robot.control_hz,
            range.start(),
            range.end()
        ))),
    }
}

/// The rate at which limits are checked: never below the robot's control rate, since velocity
/// and acceleration differenced at a coarser rate would hide what the servos will be asked to do.
pub fn limit_check_rate(rate: Option<f64>, robot: &Robot) -> f64 {
    rate.map_or(robot.control_hz, |r| r.max(robot.control_hz))
}

/// Writes `text` to `path` (atomically), or to standard output when there is no path. A closed pipe on
/// standard output (`keypose sample … | head`) is not an error.
pub fn write_output(path: Option<&Path>, text: &str) -> Result<(), CommandError> {
    match path {
        Some(path) => keypose::atomic_file::write(path, text.as_bytes()).map_err(|source| {
            CommandError::Output {
                path: path.display().to_string(),
                source,
            }
        }),
        None => {
            // Reports quote file text (key and joint names); a terminal must not run it.
            let text = keypose::terminal_text::escape_controls(text);
            let mut stdout = std::io::stdout().lock();
            match stdout
                .write_all(text.as_bytes())
                .and_then(|_| stdout.flush())
            {
                Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CommandError::Output {
                    path: "standard output".into(),
                    source: e,
                }),
                _ => Ok(()),
            }
        }
    }
}
