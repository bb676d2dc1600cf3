//! `keypose record`: move the arm by hand with torque off, then keep the fewest keyframes that
//! reproduce the motion within a tolerance.

use super::{joint_indices, option_values, parse_control_rate, CommandError, Verdict};
use super::{BusArgs, RobotArgs};
use keypose::bus::Connection;
use keypose::curve::Interp;
use keypose::player::StopSignal;
use keypose::record::{
    self, KeyframeOptions, Keyframes, RecordError, RecordOptions, Recording, Retimed, StopReason,
};
use keypose::report;
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::terminal_text::escape_controls;
use std::io::{BufRead, IsTerminal};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, clap::Args)]
pub struct RecordArgs {
    /// Where to write the keyframes (keypose-sequence/1 JSON; replaced atomically).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// A built-in robot (so101, so100, koch, omx), a LeRobot robot type (so101_follower,
    /// so100_follower, koch_follower and their leaders) or a robot file. Several arms at once:
    /// ARM=ROBOT once per arm (`--robot left=so101 --robot right=so101`, with `--port ARM=PATH`
    /// per arm), recorded into a sequence of several arms.
    #[arg(long, value_name = "[ARM=]NAME|FILE", default_value = super::DEFAULT_ROBOT)]
    pub robot: Vec<String>,
    #[command(flatten)]
    pub calibration: super::CalibrationArgs,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Joints to record, comma-separated: their torque goes off. The others keep theirs and
    /// appear in the first key only, at their starting value [default: all].
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub joints: Vec<String>,
    /// Largest deviation of the keyframes' curve from the recording, degrees (revolute joints).
    #[arg(long, value_name = "DEG", default_value = "1", value_parser = parse_tolerance, allow_negative_numbers = true)]
    pub tolerance: f64,
    /// Largest deviation for prismatic joints, metres.
    #[arg(long, value_name = "M", default_value = "0.001", value_parser = parse_tolerance_m, allow_negative_numbers = true)]
    pub tolerance_m: f64,
    /// Sampling rate, 10 to 1000 Hz; also the rate of the limit check [default: the robot's
    /// control_hz].
    #[arg(long, value_name = "HZ", value_parser = parse_control_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Interpolation of the keyframes: monotone never overshoots between keys (safe next to a
    /// limit), cubic is smoother, linear has corners. Step is refused: it jumps.
    #[arg(long, value_name = "MODE", default_value = "monotone", value_parser = parse_mode)]
    pub interpolation: Interp,
    /// Stop after this many seconds instead of waiting for Enter (for scripts).
    #[arg(long, value_name = "SECONDS", value_parser = parse_duration, allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// No progress line.
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub realtime: super::RealtimeArgs,
}

/// Recordings longer than this (samples) announce the extraction, which then takes a while.
const LONG_RECORDING_SAMPLES: usize = 3000;
/// Retiming a linear recording by more than this factor earns a hint to use a smooth mode.
const LINEAR_HINT_STRETCH: f64 = 1.25;

/// Tolerances above a turn (or a metre) are not tolerances: the whole motion is within them.
pub(super) fn parse_tolerance(s: &str) -> Result<f64, String> {
    option_values::positive_up_to(s, 360.0, "a tolerance in degrees")
}

pub(super) fn parse_tolerance_m(s: &str) -> Result<f64, String> {
    option_values::positive_up_to(s, 1.0, "a tolerance in metres")
}

pub(super) fn parse_mode(s: &str) -> Result<Interp, String> {
    match Interp::parse(s) {
        Some(mode) => match record::unfittable(mode) {
            Some(why) => Err(format!("{mode} {why}; expected linear, cubic or monotone")),
            None => Ok(mode),
        },
        None => Err(format!("expected linear, cubic or monotone, found {s:?}")),
    }
}

fn parse_duration(s: &str) -> Result<f64, String> {
    option_values::positive_up_to(s, record::MAX_SECONDS, "seconds")
}

/// What `--robot` names: one robot, or the arms of a cell (ARM=ROBOT each).
enum Recorded {
    One(String),
    Cell(Vec<keypose::sequence::ArmSpec>),
}

pub fn run(args: &RecordArgs) -> Result<Verdict, CommandError> {
    let (robot, recorded) = load_robot(args)?;
    let joints = joint_indices(&robot, &args.joints)?;
    // The port is checked before the user spends minutes moving the arm.
    args.bus.check_ports(&robot)?;
    // Refuse a place the file cannot go before the user spends minutes moving the arm.
    check_output_dir(&args.output)?;
    let rate = super::control_rate(args.rate, &robot)?;
    // The connection stays open to the end, as the emulated servos of `--port virtual` do.
    let (_connection, recording) = capture(args, &robot, joints, rate)?;
    let (result, sequence) = fit_and_save(args, &robot, &recorded, &recording, rate)?;
    print_summary(&result, &args.output, args.calibration.given());
    hint_at_linear(args, &result);
    conclude(&recording, &result, &sequence, &robot)
}

/// The robot `--robot` names, or the cell of the arms it names (`ARM=ROBOT` each, at the
/// default bases, which the file then says).
fn load_robot(args: &RecordArgs) -> Result<(Robot, Recorded), CommandError> {
    let arms: Vec<Option<(String, String)>> = args
        .robot
        .iter()
        .map(|value| {
            value
                .split_once('=')
                .filter(|(arm, _)| keypose::sequence::valid_arm_name(arm))
                .map(|(arm, spec)| (arm.to_string(), spec.to_string()))
        })
        .collect();
    match (args.robot.as_slice(), arms.iter().all(Option::is_some)) {
        ([spec], false) => {
            let robot = RobotArgs {
                robot: spec.clone(),
                calibration: args.calibration.clone(),
            }
            .load()?;
            Ok((robot, Recorded::One(spec.clone())))
        }
        (_, true) => {
            let arms: Vec<(String, String)> = arms.into_iter().flatten().collect();
            let (robot, specs) =
                super::default_placed_cell(&arms, &args.calibration, super::resolve_option_robot)?;
            eprintln!(
                "note: the arms are placed at default bases (left at y = +{0} m, right at y = -{0} m, both facing +x); edit each arm's \"base\" in \"robots\" for the real bench",
                keypose::sequence::DEFAULT_ARM_HALF_SPACING_M
            );
            Ok((robot, Recorded::Cell(specs)))
        }
        _ => Err(CommandError::Usage(format!(
            "--robot {}: expected one robot, or ARM=ROBOT once per arm for several",
            args.robot.join(" --robot ")
        ))),
    }
}

/// Limps the joints and records until Enter, Ctrl-C or the duration; says what is missing.
fn capture(
    args: &RecordArgs,
    robot: &Robot,
    joints: Vec<usize>,
    rate: f64,
) -> Result<(Connection, Recording), CommandError> {
    let mut connection = args.bus.open(robot)?;
    let stop = keypose::stop::stop_on_signal();
    watch_stdin(stop.clone(), args.duration.is_none());
    args.realtime.enter();
    if !args.quiet {
        announce(args, robot, &joints, &connection.bus.describe(), rate);
    }
    let options = RecordOptions {
        rate_hz: rate,
        joints,
        duration: args.duration,
        // A progress line rewrites itself with \r: only on a terminal.
        progress: !args.quiet && std::io::stderr().is_terminal(),
    };
    let recording =
        record::record(connection.bus.as_mut(), robot, &options, &stop).map_err(|e| match e {
            RecordError::Fault { .. } => CommandError::RecordFault(e),
            other => CommandError::Record(other),
        })?;
    warn_about_gaps(&recording.gaps, rate);
    if recording.stopped == StopReason::Longest && !args.quiet {
        eprintln!(
            "stopped after {} s, the longest recording",
            record::MAX_SECONDS
        );
    }
    Ok((connection, recording))
}

/// What is about to happen, and how to end it.
fn announce(args: &RecordArgs, robot: &Robot, joints: &[usize], bus: &str, rate: f64) {
    let names: Vec<&str> = joints
        .iter()
        .map(|&j| robot.joints[j].name.as_str())
        .collect();
    eprintln!(
        "recording {} on {bus} at {rate} Hz: torque is off on {}; move the arm by hand, then {}",
        robot.name,
        names.join(", "),
        match args.duration {
            Some(d) => format!("wait {d} s (or press Enter)"),
            None => "press Enter (or Ctrl-C)".into(),
        }
    );
}

/// The keyframes of `recording`, saved to `-o` under the robot's name as given.
fn fit_and_save(
    args: &RecordArgs,
    robot: &Robot,
    recorded: &Recorded,
    recording: &Recording,
    rate: f64,
) -> Result<(Keyframes, Sequence), CommandError> {
    if !args.quiet && recording.times.len() > LONG_RECORDING_SAMPLES {
        // Extraction grows with the length: a long recording takes seconds, so say what runs.
        eprintln!(
            "extracting keyframes from {} samples…",
            recording.times.len()
        );
    }
    let result = record::keyframes(
        recording,
        robot,
        &KeyframeOptions {
            interpolation: args.interpolation,
            tolerance_deg: args.tolerance,
            tolerance_m: args.tolerance_m,
            check_rate_hz: rate,
        },
    )
    .map_err(CommandError::Record)?;
    let mut sequence = result.sequence.clone();
    match recorded {
        Recorded::One(spec) => sequence.robot = robot_reference(spec),
        Recorded::Cell(arms) => {
            sequence.robot.clear();
            sequence.arms.clone_from(arms);
        }
    }
    sequence.file = args.output.display().to_string();
    sequence.save(&args.output)?;
    Ok((result, sequence))
}

/// Linear keys that had to be slowed down much, or that still break the limits, would keep
/// the recorded timing in a smooth mode.
fn hint_at_linear(args: &RecordArgs, result: &Keyframes) {
    let slowed = result
        .retimed
        .as_ref()
        .is_some_and(|r| r.after() > LINEAR_HINT_STRETCH * r.before());
    if args.interpolation == Interp::Linear && (slowed || !result.check.violations.is_empty()) {
        eprintln!(
            "hint: a linear corner changes velocity within one control period, which the acceleration limits allow only when slow; monotone or cubic keep the recorded timing"
        );
    }
}

/// The file is saved either way; an arm that may still be limp is the worse news, then the
/// limits the keys break.
fn conclude(
    recording: &Recording,
    result: &Keyframes,
    sequence: &Sequence,
    robot: &Robot,
) -> Result<Verdict, CommandError> {
    if let Some(e) = &recording.hold_error {
        return Err(CommandError::Hardware(format!(
            "the keyframes are saved, but the limp joints could not be made to hold again ({e}): the arm may be limp, support it"
        )));
    }
    if !result.check.passed() {
        let text = report::check_text(&result.check, &sequence.file, robot);
        eprint!("{}", escape_controls(&text));
        eprintln!("the keyframes are saved, but they fail the check above");
        return Ok(Verdict::Fail);
    }
    Ok(Verdict::Pass)
}

pub(super) fn check_output_dir(output: &Path) -> Result<(), CommandError> {
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if dir.is_dir() {
        Ok(())
    } else {
        Err(CommandError::Usage(format!(
            "-o {}: the directory {} does not exist",
            output.display(),
            dir.display()
        )))
    }
}

/// What the sequence's "robot" says: a built-in name as given, a robot file as an absolute path,
/// so that `keypose check` finds the same robot from anywhere.
pub(super) fn robot_reference(spec: &str) -> String {
    let path = Path::new(spec);
    if keypose::robot::names_a_file(spec) {
        if let Ok(absolute) = std::fs::canonicalize(path) {
            return absolute.display().to_string();
        }
    }
    spec.to_string()
}

/// Missing samples are said even with `--quiet`: the keys are fitted across them, so the file
/// may not be what the hand did there.
fn warn_about_gaps(gaps: &record::SampleGaps, rate: f64) {
    let period = 1.0 / rate;
    if gaps.missing() == 0 && gaps.longest <= keypose::pacing::STALL_PERIODS * period {
        return;
    }
    eprintln!(
        "warning: {} sample(s) missing ({} failed read(s), {} deadline(s) skipped by {} stall(s)); the longest gap, {:.0} ms, ends at t = {:.3} s: the motion there is fitted across, not recorded",
        gaps.missing(),
        gaps.failed_reads,
        gaps.skipped_deadlines,
        gaps.stalls,
        gaps.longest * 1e3,
        gaps.longest_at
    );
}

/// A line on standard input (Enter) requests the stop. End of input (no terminal, a closed
/// pipe) is not a request: a script stops with --duration.
fn watch_stdin(stop: StopSignal, warn_on_eof: bool) {
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        let mut line = String::new();
        match stdin.lock().read_line(&mut line) {
            Ok(n) if n > 0 => stop.request(),
            _ => {
                if warn_on_eof {
                    eprintln!("standard input is closed: stop the recording with Ctrl-C");
                }
            }
        }
    });
}

pub(super) fn print_summary(result: &Keyframes, output: &Path, calibrated: bool) {
    println!("{}", escape_controls(&result.summary()));
    for c in &result.clamps {
        eprintln!(
            "warning: {} was pushed {} past its limit {} {} (worst at t = {:.3} s); the keys hold it at the limit",
            c.joint,
            format_amount(c.excess, c.unit),
            c.limit,
            c.unit,
            c.time
        );
    }
    for d in &result.drifts {
        eprintln!(
            "warning: {} was not recorded but moved {}; the file holds its starting value",
            d.joint,
            format_amount(d.moved, d.unit)
        );
    }
    if result.made_monotone > 0 {
        eprintln!(
            "{} cubic segment(s) overshot a limit and were made monotone",
            result.made_monotone
        );
    }
    if let Some(r) = &result.retimed {
        println!(
            "retimed to respect the velocity and acceleration limits: {} of {} segments stretched, last key {:.3} s → {:.3} s",
            r.stretched,
            r.segments,
            r.before(),
            r.after()
        );
        println!("key times: {}", key_time_changes(r));
    }
    if calibrated {
        eprintln!(
            "note: the file names the robot without the calibration; give the same --calibration (or --robot-id) to check and play it"
        );
    }
    println!("wrote {}", output.display());
}

/// "0.293 → 0.301 s, 0.811 → 0.840 s, …" for the keys whose time changed, at most
/// SHOWN_CHANGES of them.
fn key_time_changes(r: &Retimed) -> String {
    const SHOWN_CHANGES: usize = 12;
    let changes: Vec<String> = r
        .key_times_before
        .iter()
        .zip(&r.key_times_after)
        .filter(|(a, b)| (*b - *a).abs() > 1e-9)
        .map(|(a, b)| format!("{a:.3} → {b:.3} s"))
        .collect();
    let mut text = changes
        .iter()
        .take(SHOWN_CHANGES)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if changes.len() > SHOWN_CHANGES {
        text.push_str(&format!(", … ({} more)", changes.len() - SHOWN_CHANGES));
    }
    text
}

fn format_amount(value: f64, unit: &str) -> String {
    match unit {
        "deg" => format!("{value:.2}°"),
        unit => format!("{value:.4} {unit}"),
    }
}
