//! `keypose sim`: play a sequence in MuJoCo and judge it. Also `keypose play` without `--port`.

use super::{option_values, parse_rate, write_output, CommandError, SequenceOptions, Verdict};
use keypose::plan::{TimelineOptions, Trajectory};
use keypose::player::{print_progress_line, LogRow, PlayError, PlayOptions, PlaybackLog};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::sim::verdict::{self, KeyMark, Thresholds, Trace};
use keypose::sim::{self, CommandStream, Simulation, WarmSimulation};
use keypose::terminal_text::escape_controls;
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Clone, clap::Args)]
pub struct SimArgs {
    /// Sequence files (keypose-sequence/1 JSON). Several are simulated one after the other in
    /// one MuJoCo process, each judged on its own; --report, --log and --render take one.
    #[arg(required = true, value_name = "SEQUENCE")]
    pub sequences: Vec<PathBuf>,
    #[command(flatten)]
    pub options: SequenceOptions,
    /// Another MJCF model to run instead of the built-in one (its joint names must match the
    /// robot's), e.g. the arm maker's official mesh model. One arm only: a sequence of several
    /// arms is simulated with each arm's built-in model.
    #[arg(long, value_name = "FILE")]
    pub mjcf: Option<PathBuf>,
    /// With --mjcf: the model's names of the robot's joints, as ROBOT=MODEL pairs
    /// (shoulder_pan=base_rotation,…), a keypose-joint-map/1 file, or a shipped map:
    /// menagerie-koch (MuJoCo Menagerie's low_cost_robot_arm), robotis-omx (ROBOTIS's
    /// OpenMANIPULATOR-X model).
    #[arg(long, value_name = "NAME|FILE|A=B,…", requires = "mjcf")]
    pub joint_map: Option<String>,
    /// Write the player's log of the simulated playback (CSV, as `play --log`): per control
    /// cycle the commanded and the simulated position of every joint.
    #[arg(long, value_name = "FILE.csv")]
    pub log: Option<PathBuf>,
    /// Write the measurements and the verdict as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Render the robot at each key (.png contact sheet) or the whole motion (.gif, .mp4).
    #[arg(long, value_name = "FILE")]
    pub render: Option<PathBuf>,
    /// With --render to .png: a frame every this many seconds instead of one per key.
    #[arg(long, value_name = "SECONDS", value_parser = option_values::parse_every, allow_negative_numbers = true)]
    pub every: Option<f64>,
    /// Control rate [default: the robot's control_hz].
    #[arg(long, value_name = "HZ", value_parser = parse_rate)]
    pub rate: Option<f64>,
    /// Time scale, as for `play`.
    #[arg(long, value_name = "F", default_value = "1", value_parser = option_values::parse_speed, allow_negative_numbers = true)]
    pub speed: f64,
    /// Model the servos' own motion profile as `play --servo-profile` sets it (each servo
    /// follows its goal within the joint's acceleration limit, in the register's units).
    #[arg(long)]
    pub servo_profile: bool,
    /// Send goals that lead the path by each servo's droop under its load (gravity, the
    /// motion's inertia and the motor's back-EMF over the position loop's stiffness, from the
    /// robot's masses and its servos' build), so that the arm rather than the goal follows
    /// the path; clamped to the joints' limits and faded in along the approach ramp.
    #[arg(long)]
    pub compensate_droop: bool,
}

/// Simulated seconds per request when a progress line follows the run (`play` without a
/// port); without one the whole run is one request.
const CHUNK_SECONDS: f64 = 1.0;

/// The outcome of a simulated playback.
pub struct Simulated {
    pub verdict: verdict::Verdict,
    pub trace: Trace,
    pub model: String,
    pub wall_seconds: f64,
}

/// A log that cannot be written is the user's path to mend, as `play` on servos says.
fn log_error(e: PlayError) -> CommandError {
    CommandError::Usage(e.to_string())
}

/// The player's log of the simulated playback: the rows the player would have sent (not the
/// hold after them that judges settling), each with the simulated position as its measurement.
/// The simulation keeps the control rate exactly: no lateness, no stalls.
fn write_log(
    log: &mut PlaybackLog,
    stream: &CommandStream,
    trace: &Trace,
) -> Result<(), PlayError> {
    let rows = stream.played.min(trace.position.len());
    for row in 0..rows {
        log.row(&LogRow {
            time: row as f64 / stream.rate,
            phase: stream.phase[row],
            sequence_time: stream.timeline_time[row],
            commanded: &stream.rows[row],
            measured: Some(&trace.position[row]),
            lateness: 0.0,
            stall: None,
            // The simulation plays through MuJoCo's own actuators, not the servos' firmware:
            // no servo telemetry (`--port virtual --physics` gives it).
            loads: &[],
            health: &[],
            needed: &[],
        })?;
    }
    log.finish()
}

/// Runs `trajectory` in MuJoCo as the player would play it with `options`, in the session's
/// harness `warm` (started if none runs yet).
pub fn simulate(
    warm: &mut WarmSimulation,
    sequence: &Sequence,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
    mjcf: Option<&sim::MjcfModel>,
) -> Result<Simulated, CommandError> {
    let started = Instant::now();
    let thresholds = Thresholds::default();
    let mut stream = sim::command_stream(robot, trajectory, &options.timeline, options.rate_hz);
    stream.hold_at_end(thresholds.settle_time, options.timeline.speed);
    // Created before MuJoCo starts: a log that cannot be written is refused first.
    let mut log = match &options.log {
        Some(path) => Some(PlaybackLog::create(path, robot).map_err(log_error)?),
        None => None,
    };
    let (trace, model) = warm.with_simulation(robot, mjcf, |simulation| {
        if options.servo_profile {
            simulation.model_servo_profile(robot)?;
        }
        let trace = run_stream(simulation, robot, &stream, trajectory, options.progress)?;
        // The verdict names the build it judged (keypose's own model made the robot's servos)
        // and how the goals reach the servos between control ticks.
        let actuators = match simulation.build() {
            Some(build) => format!("built {build}"),
            None => "its own actuators".to_string(),
        };
        let model = format!(
            "{}, {actuators}, {}",
            simulation.model(),
            goal_shaping(options)
        );
        Ok((trace, model))
    })?;
    if let Some(log) = &mut log {
        write_log(log, &stream, &trace).map_err(log_error)?;
    }
    let keys: Vec<KeyMark> = sequence
        .keyframes
        .iter()
        .zip(&trajectory.key_times)
        .zip(&trajectory.key_labels)
        .filter(|((_, t), _)| **t >= trajectory.start && **t <= trajectory.end)
        .map(|((key, t), label)| KeyMark {
            label: label.clone(),
            time: *t,
            hold: key.hold,
        })
        .collect();
    let verdict = verdict::judge(robot, &trace, &keys, &thresholds);
    Ok(Simulated {
        verdict,
        trace,
        model,
        wall_seconds: started.elapsed().as_secs_f64(),
    })
}

/// How the simulated servos take their goals between control ticks, as the verdict names it:
/// held as the goal register holds them (a servo with no motion profile steps to each new goal)
/// or through the profile `--servo-profile` writes; leading the path with
/// `--compensate-droop`.
fn goal_shaping(options: &PlayOptions) -> String {
    let held = match options.servo_profile {
        true => "goals through the servos' profile",
        false => "goals held between ticks",
    };
    match options.timeline.compensation {
        Some(_) => format!("{held}, leading for droop"),
        None => held.to_string(),
    }
}

/// The rows of `stream` run from a reset: in one request, or with a progress line in requests
/// of [`CHUNK_SECONDS`] of simulated time each. A run that diverged ends there.
fn run_stream(
    simulation: &mut Simulation,
    robot: &Robot,
    stream: &CommandStream,
    trajectory: &Trajectory,
    progress: bool,
) -> Result<Trace, sim::SimError> {
    let total = stream.rows.len();
    if !progress {
        return simulation.run(robot, stream, 0..total, true);
    }
    let chunk = ((CHUNK_SECONDS * stream.rate).round() as usize).max(1);
    let mut trace = Trace::default();
    let mut start = 0;
    while start < total {
        let end = (start + chunk).min(total);
        let part = simulation.run(robot, stream, start..end, start == 0)?;
        let diverged = !part.divergence.is_empty();
        trace.extend(part);
        // The hold after the last cycle is the verdict's, not the playback's.
        let row = end.min(stream.played).max(1) - 1;
        print_progress_line(
            stream.phase[row].name(),
            stream.timeline_time[row],
            &stream.loop_label[row],
            trajectory,
        );
        if diverged {
            break;
        }
        start = end;
    }
    eprintln!();
    Ok(trace)
}

/// One sequence ready to simulate: everything about it that can be refused has been.
struct Prepared {
    sequence: Sequence,
    robot: Robot,
    trajectory: Trajectory,
    render_times: Option<Vec<(f64, String)>>,
    model: Option<sim::MjcfModel>,
    options: PlayOptions,
}

pub fn run(args: &SimArgs) -> Result<Verdict, CommandError> {
    if let [_, _, ..] = args.sequences[..] {
        one_sequence_options(args)?;
    }
    // Every file is read and checked before MuJoCo starts: a bad one is refused before any
    // is simulated.
    let prepared = args
        .sequences
        .iter()
        .map(|path| prepare(args, path))
        .collect::<Result<Vec<_>, _>>()?;
    let mut warm = WarmSimulation::new();
    let mut failed = Vec::new();
    for (index, one) in prepared.iter().enumerate() {
        if index > 0 {
            println!();
        }
        let result = simulate(
            &mut warm,
            &one.sequence,
            &one.robot,
            &one.trajectory,
            &one.options,
            one.model.as_ref(),
        )?;
        print!("{}", escape_controls(&table(&one.sequence.file, &result)));
        if let Some(path) = &args.report {
            let report = report_json(&one.sequence.file, &one.robot, &result);
            write_output(Some(path), &format!("{report:#}\n"))?;
        }
        if let (Some(path), Some(times)) = (&args.render, &one.render_times) {
            render(one, times.clone(), path)?;
        }
        if !result.verdict.passed() {
            failed.push(one.sequence.file.as_str());
        }
    }
    if prepared.len() > 1 {
        let passed = prepared.len() - failed.len();
        let failures = if failed.is_empty() {
            String::new()
        } else {
            format!("; FAILED: {}", failed.join(", "))
        };
        println!(
            "\n{passed} of {} sequences passed in one MuJoCo process{failures}",
            prepared.len()
        );
    }
    Ok(if failed.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

/// The options that write one file refused with several sequences: each sequence's would
/// overwrite the last's.
fn one_sequence_options(args: &SimArgs) -> Result<(), CommandError> {
    let given: Vec<&str> = [
        ("--report", args.report.is_some()),
        ("--log", args.log.is_some()),
        ("--render", args.render.is_some()),
        ("--every", args.every.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, given)| given.then_some(name))
    .collect();
    if given.is_empty() {
        return Ok(());
    }
    Err(CommandError::Usage(format!(
        "{}: with one sequence only ({} given); simulate the others in a call of their own",
        given.join(", "),
        args.sequences.len()
    )))
}

/// The sequence at `path` loaded, planned and checked against every option, before MuJoCo
/// starts.
fn prepare(args: &SimArgs, path: &Path) -> Result<Prepared, CommandError> {
    let (sequence, robot) = args.options.load(path)?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    let rate = args.rate.unwrap_or(robot.control_hz);
    let render_times = match &args.render {
        Some(path) => Some(render_times(
            render_kind(path, args.every)?,
            args.every,
            &trajectory,
        )?),
        None if args.every.is_some() => {
            return Err(CommandError::Usage(
                "--every: only with --render FILE.png (a frame every so many seconds)".into(),
            ))
        }
        None => None,
    };
    let model = match &args.mjcf {
        Some(path) if robot.is_cell() => {
            return Err(CommandError::Usage(format!(
                "--mjcf {}: {} is {}, each simulated with its built-in model at its base; --mjcf and --joint-map are for a sequence of one arm",
                path.display(),
                sequence.file,
                robot.description
            )))
        }
        Some(path) => {
            sim::check_mjcf_file(path)?;
            let joint_map = match &args.joint_map {
                Some(spec) => sim::JointMap::parse(spec, &robot)?,
                None => sim::JointMap::default(),
            };
            Some(sim::MjcfModel {
                path: path.clone(),
                joint_map,
            })
        }
        None => None,
    };
    super::check_sample_budget(&sequence.file, &trajectory, rate / args.speed)?;
    let options = PlayOptions {
        timeline: TimelineOptions {
            speed: args.speed,
            compensation: super::droop_compensation(args.compensate_droop, &robot)?,
            ..TimelineOptions::default()
        },
        servo_profile: args.servo_profile,
        log: args.log.clone(),
        ..PlayOptions::new(rate)
    };
    Ok(Prepared {
        sequence,
        robot,
        trajectory,
        render_times,
        model,
        options,
    })
}

/// What `--render` draws, from the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RenderKind {
    /// A .png contact sheet: a frame at each key, or every `--every` seconds.
    Sheet,
    /// A .gif or .mp4 of the whole motion.
    Motion,
}

fn render_kind(path: &Path, every: Option<f64>) -> Result<RenderKind, CommandError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match (extension.as_str(), every) {
        ("png", _) => Ok(RenderKind::Sheet),
        ("gif" | "mp4", None) => Ok(RenderKind::Motion),
        ("gif" | "mp4", Some(_)) => Err(CommandError::Usage(format!(
            "--every: only with a .png contact sheet; {} is drawn at 25 frames per second",
            path.display()
        ))),
        _ => Err(CommandError::Usage(format!(
            "--render {}: expected a .png, .gif or .mp4 file",
            path.display()
        ))),
    }
}

/// Most frames a render draws.
const MAX_FRAMES: usize = 2000;

/// The times (and labels) of the frames to draw, counted before any is made: a tiny `--every`
/// must be refused, not allocated.
fn render_times(
    kind: RenderKind,
    every: Option<f64>,
    trajectory: &Trajectory,
) -> Result<Vec<(f64, String)>, CommandError> {
    let fps = 25.0;
    let count = match (kind, every) {
        (RenderKind::Sheet, None) => trajectory
            .key_times
            .iter()
            .filter(|t| (trajectory.start..=trajectory.end).contains(*t))
            .count() as f64,
        (RenderKind::Sheet, Some(every)) => (trajectory.duration() / every).floor() + 1.0,
        (RenderKind::Motion, _) => (trajectory.duration() * fps).ceil() + 1.0,
    };
    if count > MAX_FRAMES as f64 {
        return Err(CommandError::Usage(format!(
            "--render: {count:.0} frames is too many (at most {MAX_FRAMES}); use a larger --every or a shorter sequence"
        )));
    }
    let frames = count as usize;
    Ok(match (kind, every) {
        (RenderKind::Sheet, None) => trajectory
            .key_times
            .iter()
            .zip(&trajectory.key_labels)
            .filter(|(t, _)| **t >= trajectory.start && **t <= trajectory.end)
            .map(|(t, l)| (*t, format!("{l} · {t:.2} s")))
            .collect(),
        (RenderKind::Sheet, Some(every)) => (0..frames)
            .map(|k| {
                let t = trajectory.start + k as f64 * every;
                (t, format!("{t:.2} s"))
            })
            .collect(),
        (RenderKind::Motion, _) => (0..frames)
            .map(|k| {
                let t = (trajectory.start + k as f64 / fps).min(trajectory.end);
                (t, format!("{t:.2} s"))
            })
            .collect(),
    })
}

fn render(one: &Prepared, times: Vec<(f64, String)>, path: &Path) -> Result<(), CommandError> {
    let frames: Vec<Vec<f64>> = times
        .iter()
        .map(|(t, _)| one.trajectory.sample(*t))
        .collect();
    let labels: Vec<String> = times.into_iter().map(|(_, l)| l).collect();
    let gl = sim::render(
        &one.robot,
        one.model.as_ref(),
        &frames,
        &labels,
        path,
        &sim::Camera::default(),
    )?;
    eprintln!(
        "{}: rendered {} frame(s) of {} to {} ({gl})",
        one.sequence.file,
        frames.len(),
        one.robot.name,
        path.display()
    );
    Ok(())
}

/// The verdict as a table a person can read.
pub fn table(file: &str, result: &Simulated) -> String {
    let mut out = String::new();
    let simulated = result.trace.time.last().copied().unwrap_or(0.0);
    let _ = writeln!(
        out,
        "{file} in MuJoCo ({}): {simulated:.2} s simulated in {:.2} s",
        result.model, result.wall_seconds
    );
    // A cell's joints are ARM/JOINT: the column is as wide as the longest.
    let width = result
        .verdict
        .tracking
        .iter()
        .map(|t| t.joint.chars().count())
        .fold(18, usize::max);
    let _ = writeln!(
        out,
        "  {:<width$} {:>22} {:>10} {:>22} {:>18}",
        "joint", "max tracking error", "rms", "worst after settling", "servo speed °/s"
    );
    for t in &result.verdict.tracking {
        let show = |value| verdict::shown(t.kind, value);
        let worst = t
            .settled
            .iter()
            .max_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(label, _, e)| format!("{} ({label})", show(*e).number()))
            .unwrap_or_else(|| "-".into());
        let max = show(t.max_error);
        let _ = writeln!(
            out,
            "  {:<width$} {:>9} {:<3} @ {:>6.2} s {:>10} {:>22} {:>8.0} / {:<6.0}",
            t.joint,
            max.number(),
            max.unit,
            t.max_error_time,
            show(t.rms_error).number(),
            worst,
            t.peak_speed_servo_deg_s,
            t.servo_speed_limit_deg_s
        );
    }
    if result.verdict.passed() {
        let _ = writeln!(out, "PASSED: no collisions, limit hits, saturation, overspeed or divergence; tracking within bounds");
    } else {
        let _ = writeln!(out, "FAILED: {} finding(s)", result.verdict.findings.len());
        for f in &result.verdict.findings {
            let joint = f
                .joint
                .as_deref()
                .map(|j| format!(" {j}:"))
                .unwrap_or_default();
            let _ = writeln!(
                out,
                "  t = {:>6.2} s  {:<16}{joint} {}",
                f.time, f.kind, f.message
            );
        }
    }
    out
}

pub fn report_json(file: &str, robot: &Robot, result: &Simulated) -> serde_json::Value {
    json!({
        "sequence": file,
        "robot": robot.name,
        "model": result.model,
        "passed": result.verdict.passed(),
        "simulated_seconds": result.trace.time.last().copied().unwrap_or(0.0),
        "wall_seconds": result.wall_seconds,
        // Each base as the sequence gives it: metres, and roll-pitch-yaw in radians.
        "arms": robot.arms.iter().map(|a| {
            let (roll, pitch, yaw) = keypose::pose::rpy_from_quat(a.base.r);
            json!({
                "name": a.name, "robot": a.robot.name,
                "base": {"xyz": a.base.t.to_array(), "rpy": [roll, pitch, yaw]},
            })
        }).collect::<Vec<_>>(),
        "findings": result.verdict.findings.iter().map(|f| json!({
            "kind": f.kind, "joint": f.joint, "arms": f.arms, "time": f.time, "message": f.message,
        })).collect::<Vec<_>>(),
        "tracking": result.verdict.tracking.iter().map(|t| json!({
            "joint": t.joint,
            "arm": t.arm,
            "unit": t.unit,
            "max_error": t.max_error,
            "max_error_time": t.max_error_time,
            "rms_error": t.rms_error,
            "settled": t.settled.iter().map(|(label, time, e)| json!({"key": label, "time": time, "error": e})).collect::<Vec<_>>(),
            "peak_servo_speed_deg_s": t.peak_speed_servo_deg_s,
            "servo_speed_limit_deg_s": t.servo_speed_limit_deg_s,
        })).collect::<Vec<_>>(),
    })
}
