//! `keypose play`: stream a sequence to the servos.

use super::BusArgs;
use super::{option_values, parse_control_rate, CommandError, SequenceOptions, Verdict};
use keypose::error::Report;
use keypose::plan::Loops;
use keypose::plan::{check_at_speed, TimelineOptions, Trajectory};
use keypose::player::{self, Outcome, PlayError, PlayOptions};
use keypose::report;
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::terminal_text::escape_controls;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
// Only `play` simulates without a port: the other bus commands share the plain help.
#[command(mut_arg("episode", |a| a.requires("lerobot")))]
#[command(mut_arg("port", |port| port.help(
    "Serial port (e.g. /dev/ttyUSB0, /dev/ttyACM0), or \"virtual\" for emulated servos on a \
     pseudo-terminal; a sequence of several arms: ARM=PATH once per arm, or \"virtual\" for a \
     bus of emulated servos per arm; without a port, play in MuJoCo"
)))]
pub struct PlayArgs {
    /// Sequence file (keypose-sequence/1 JSON); a dataset episode (--lerobot) stands in for it.
    #[arg(required_unless_present = "lerobot", conflicts_with = "lerobot")]
    pub sequence: Option<PathBuf>,
    #[command(flatten)]
    pub options: SequenceOptions,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Play episode --episode of this LeRobotDataset v3.0 folder instead of a sequence file:
    /// imported in memory (as `keypose import lerobot`), then checked and ramped as any other.
    #[arg(long, value_name = "DIR", requires = "episode")]
    pub lerobot: Option<PathBuf>,
    #[command(flatten)]
    pub dataset: super::import::EpisodeArgs,
    /// Control rate, 10 to 1000 Hz [default: the robot's control_hz].
    #[arg(long, value_name = "HZ", value_parser = parse_control_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Time scale: 0.5 plays at half speed, 2 at double (limits are checked at this speed).
    #[arg(long, value_name = "F", default_value = "1", value_parser = option_values::parse_speed, allow_negative_numbers = true)]
    pub speed: f64,
    /// How many times to play: a number, or "forever".
    #[arg(long = "loop", value_name = "N|forever", default_value = "1", value_parser = parse_loops, allow_negative_numbers = true)]
    pub loops: Loops,
    /// Play forwards then backwards (each pass counts as one loop) instead of ramping back.
    #[arg(long)]
    pub ping_pong: bool,
    /// Play a sequence whose keys declare contacts ("contact" on a key: a pen on paper): the
    /// arm touches what they declare, down to the depth they give. Any other contact is
    /// refused all the same.
    #[arg(long)]
    pub allow_contact: bool,
    /// Start at this key: its index (0-based) or its name.
    #[arg(long, value_name = "KEY", allow_negative_numbers = true)]
    pub from: Option<String>,
    /// Do not ramp from the measured pose to the first pose: the arm JUMPS there at full servo
    /// speed. Needs --i-accept-the-jump.
    #[arg(long)]
    pub no_approach: bool,
    /// Confirms --no-approach.
    #[arg(long, requires = "no_approach")]
    pub i_accept_the_jump: bool,
    /// Release torque at the end, once the final pose is reached.
    #[arg(long)]
    pub release_at_end: bool,
    /// Do not watch the servos' loads: a joint pushing on something (the table, an object)
    /// is then not stopped by keypose, only by the servo's own overload protection, which
    /// lets go of the joint after seconds (the STS3215) or until a reboot (the X series).
    #[arg(long)]
    pub no_push_guard: bool,
    /// Read present positions every N cycles (0: never; the push guard then sees nothing).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = option_values::parse_readback, allow_negative_numbers = true)]
    pub readback: u32,
    /// Write commanded and measured positions and cycle lateness to a CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub log: Option<PathBuf>,
    /// No progress line.
    #[arg(long, short)]
    pub quiet: bool,
    /// A goal held this many milliseconds longer than one control period (the process did not
    /// run: a stall) is a fault: the arm brakes to rest along its path and keypose exits 3.
    #[arg(long, value_name = "MS", default_value = "250", value_parser = parse_max_stall, allow_negative_numbers = true)]
    pub max_stall: f64,
    #[command(flatten)]
    pub realtime: super::RealtimeArgs,
    /// Write each joint's acceleration limit into the servos' own motion profile (STS
    /// Acceleration, Dynamixel Profile_Acceleration) so they smooth between streamed goals;
    /// the previous values are restored afterwards, however playback ends.
    #[arg(long)]
    pub servo_profile: bool,
    /// Send goals that lead the path by each servo's droop under its load (gravity, the
    /// motion's inertia and the motor's back-EMF over the position loop's stiffness, from the
    /// robot's masses and its servos' build), so that the arm rather than the goal follows
    /// the path; clamped to the joints' limits and faded in along the approach ramp.
    #[arg(long)]
    pub compensate_droop: bool,
}

/// `--max-stall` in milliseconds, returned in seconds.
pub(super) fn parse_max_stall(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(ms) if ms.is_finite() && (1.0..=10_000.0).contains(&ms) => Ok(ms / 1000.0),
        _ => Err(format!(
            "expected a stall bound from 1 to 10000 ms, found {s:?}"
        )),
    }
}

fn parse_loops(s: &str) -> Result<Loops, String> {
    if s == "forever" {
        return Ok(Loops::Forever);
    }
    match s.parse::<u32>() {
        Ok(n) if n >= 1 => Ok(Loops::Count(n)),
        _ => Err(format!(
            "expected a number of loops (1 or more) or \"forever\", found {s:?}"
        )),
    }
}

pub fn run(args: &PlayArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = load(args)?;
    let trajectory = Trajectory::build(&sequence, &robot)?;
    if args.no_approach && !args.i_accept_the_jump {
        return Err(CommandError::Usage(
            "--no-approach makes the arm jump to the first pose at full speed; add --i-accept-the-jump to confirm".into(),
        ));
    }
    if args.servo_profile && args.bus.driver == keypose::bus::Driver::Sdk {
        return Err(CommandError::Usage(
            "--servo-profile needs --driver native: the vendor-SDK bridge does not reach the profile registers".into(),
        ));
    }
    let from_key = from_key(args, &trajectory)?;
    let rate = super::control_rate(args.rate, &robot)?;
    super::check_sample_budget(&sequence.file, &trajectory, rate)?;

    // Refuse what the servos would be asked to do beyond their limits at this speed and rate,
    // from where playback starts.
    let report = check_at_speed(
        &trajectory.starting_at_key(from_key),
        &robot,
        rate,
        args.speed,
    );
    if !report.passed() {
        let text = report::check_text(&report, &sequence.file, &robot);
        eprint!("{}", escape_controls(&text));
        let from = match &args.from {
            Some(key) => format!(" from key {key:?} (the arm starts there from rest)"),
            None => String::new(),
        };
        let why = if report.violations.is_empty() {
            "the arm would touch what the clearance above lists (no timing mends that: move the keys)".to_string()
        } else {
            let hint = super::limits_hint(
                &sequence,
                &report,
                "try `keypose retime`, or a lower --speed",
            );
            format!(
                "the sequence breaks the limits above at speed {}{from} ({hint})",
                args.speed
            )
        };
        eprintln!("{}", escape_controls(&format!("refusing to play: {why}")));
        return Ok(Verdict::Fail);
    }
    if report.declared_contacts().next().is_some() && !args.allow_contact {
        eprint!(
            "{}",
            escape_controls(&report::check_text(&report, &sequence.file, &robot))
        );
        eprintln!(
            "refusing to play: the sequence declares the contacts above; --allow-contact plays \
             it (the arm will touch what its keys declare, and nothing else)"
        );
        return Ok(Verdict::Fail);
    }

    let options = PlayOptions {
        timeline: TimelineOptions {
            speed: args.speed,
            loops: args.loops,
            ping_pong: args.ping_pong,
            from_key,
            approach: !args.no_approach,
            compensation: super::droop_compensation(args.compensate_droop, &robot)?,
            ..TimelineOptions::default()
        },
        release_at_end: args.release_at_end,
        readback_every: (args.readback > 0).then_some(args.readback),
        log: args.log.clone(),
        progress: !args.quiet,
        max_stall: args.max_stall,
        servo_profile: args.servo_profile,
        push_guard: !args.no_push_guard,
        ..PlayOptions::new(rate)
    };
    if options.push_guard && options.readback_every.is_none() {
        eprintln!("note: --readback 0 reads nothing back: the push guard is off");
    }
    if args.bus.given() {
        play_on_servos(args, &sequence, &robot, &trajectory, &options)
    } else {
        play_in_simulation(args, &sequence, &robot, &trajectory, &options)
    }
}

/// The sequence file, or the dataset episode imported in memory (clap makes sure it is one of
/// the two).
fn load(args: &PlayArgs) -> Result<(Sequence, Robot), CommandError> {
    let (Some(dir), None) = (&args.lerobot, &args.sequence) else {
        let path = args.sequence.as_deref().ok_or_else(|| {
            CommandError::Usage("a sequence file is required (or --lerobot DIR --episode N)".into())
        })?;
        return args.options.load(path);
    };
    let interpolation = match args.options.interpolation {
        Some(mode) => super::record::parse_mode(mode.name()).map_err(CommandError::Usage)?,
        None => keypose::curve::Interp::Monotone,
    };
    let choice = super::import::RobotChoice {
        robot: args.options.robot.as_deref(),
        calibration: &args.options.calibration,
        interpolation,
    };
    let (imported, robot, _) = super::import::import_episode(dir, &args.dataset, choice)?;
    for notice in &imported.notices {
        eprintln!("{}", escape_controls(notice));
    }
    eprintln!("{}", escape_controls(&imported.keyframes.summary()));
    let mut sequence = imported.keyframes.sequence;
    sequence.file = format!(
        "{} episode {}",
        dir.display(),
        args.dataset.episode.unwrap_or_default()
    );
    Ok((sequence, robot))
}

/// `--from`: a key by index or name.
fn from_key(args: &PlayArgs, trajectory: &Trajectory) -> Result<Option<usize>, CommandError> {
    match &args.from {
        None => Ok(None),
        Some(key) => resolve_key(trajectory, key).map(Some),
    }
}

/// No hardware: play in MuJoCo, with the same commands the servos would get.
fn play_in_simulation(
    args: &PlayArgs,
    sequence: &Sequence,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
) -> Result<Verdict, CommandError> {
    if args.loops == Loops::Forever {
        return Err(CommandError::Usage(
            "--loop forever needs servos (--port); in simulation give a number of loops".into(),
        ));
    }
    if !args.quiet {
        eprintln!(
            "playing {} in MuJoCo (no --port) at {} Hz, speed {}",
            sequence.file, options.rate_hz, args.speed
        );
    }
    let mut warm = keypose::sim::WarmSimulation::new();
    let result = super::sim::simulate(&mut warm, sequence, robot, trajectory, options, None)?;
    print!(
        "{}",
        escape_controls(&super::sim::table(&sequence.file, &result))
    );
    Ok(if result.verdict.passed() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

fn play_on_servos(
    args: &PlayArgs,
    sequence: &Sequence,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
) -> Result<Verdict, CommandError> {
    let mut connection = args.bus.open(robot)?;
    let stop = keypose::stop::stop_on_signal();
    args.realtime.enter();

    if !args.quiet {
        eprintln!(
            "playing {} on {} at {} Hz, speed {}",
            sequence.file,
            connection.bus.describe(),
            options.rate_hz,
            args.speed
        );
    }
    let played = player::play(connection.bus.as_mut(), robot, trajectory, options, &stop);
    conclude(args, robot, played)
}

/// What the player's outcome means for the command line: only a finished playback passes.
fn conclude(
    args: &PlayArgs,
    robot: &Robot,
    played: Result<(Outcome, player::Stats), PlayError>,
) -> Result<Verdict, CommandError> {
    match played {
        Ok((Outcome::Finished, stats)) => {
            if !args.quiet {
                eprintln!(
                    "done: {} cycles, approach {:.2} s, {}",
                    stats.cycles,
                    stats.approach_seconds,
                    tracking_summary(robot, &stats)
                );
            }
            report_offsets(args, &stats);
            report_pacing(&stats);
            Ok(Verdict::Pass)
        }
        Ok((Outcome::Stopped, stats)) => {
            report_offsets(args, &stats);
            report_pacing(&stats);
            Err(CommandError::Interrupted(
                "stopped on request: the arm decelerated along its path and holds there, torque on"
                    .into(),
            ))
        }
        Ok((Outcome::Held, stats)) => {
            report_offsets(args, &stats);
            report_pacing(&stats);
            Err(CommandError::Interrupted(
                "held at once on a second request: torque on".into(),
            ))
        }
        Err(e @ PlayError::Log { .. }) => Err(CommandError::Usage(Report(&e).to_string())),
        // The same words as any playback fault, and the options that cure it.
        Err(e @ PlayError::CannotKeepUp { .. }) => Err(CommandError::Hardware(format!(
            "{}\nhint: --realtime runs the control loop under SCHED_FIFO where permitted (see `keypose doctor`); --rate sets a lower rate; --readback N reads back every Nth cycle only",
            Report(&CommandError::Play(e))
        ))),
        Err(
            e @ PlayError::ServoProfile(
                player::ServoProfileError::Units(_) | player::ServoProfileError::TimeBased { .. },
            ),
        ) => Err(CommandError::Usage(e.to_string())),
        Err(e) => Err(CommandError::Play(e)),
    }
}

/// The largest tracking error with its unit and joint, or why there is none.
fn tracking_summary(robot: &Robot, stats: &player::Stats) -> String {
    match stats.tracking_error_joint {
        Some(j) => {
            let joint = &robot.joints[j];
            format!(
                "largest tracking error {:.2} {} ({})",
                stats.max_tracking_error,
                joint.kind.unit(),
                escape_controls(&joint.name)
            )
        }
        None => "no tracking error measured (no read-back)".into(),
    }
}

/// A cell: how far apart the arms' buses started each cycle's goal write.
fn report_offsets(args: &PlayArgs, stats: &player::Stats) {
    let Some(offsets) = stats.write_offsets.filter(|o| o.cycles > 0) else {
        return;
    };
    if !args.quiet {
        // Microseconds: the resolution the offsets are kept at.
        let us = |d: std::time::Duration| d.as_micros();
        eprintln!(
            "goal writes of the arms' buses apart by: median {} µs, p99 {} µs, max {} µs over {} cycles",
            us(offsets.median),
            us(offsets.p99),
            us(offsets.max),
            offsets.cycles
        );
    }
}

/// Stalls and limiter interventions are reported even with `--quiet`: they change what the arm
/// did.
fn report_pacing(stats: &player::Stats) {
    for warning in stats.warnings() {
        eprintln!("warning: {warning}");
    }
}

/// A key by index or by name. A name two keys share is refused: starting at either one would
/// be a guess, and the two can be far apart in the sequence.
fn resolve_key(trajectory: &Trajectory, key: &str) -> Result<usize, CommandError> {
    let count = trajectory.key_times.len();
    let named: Vec<usize> = match key.parse::<usize>() {
        Ok(i) => (i < count).then_some(i).into_iter().collect(),
        Err(_) => (0..count)
            .filter(|&i| trajectory.key_labels[i] == key)
            .collect(),
    };
    match named[..] {
        [index] => Ok(index),
        [] => Err(CommandError::Usage(format!(
            "--from {key:?}: no such key; expected an index 0…{} or one of: {}",
            count - 1,
            trajectory.key_labels.join(", ")
        ))),
        _ => Err(CommandError::Usage(format!(
            "--from {key:?}: {} keys have this name, at indices {}: give the index of the one to start at",
            named.len(),
            named
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}
