//! Live capture on the bus: limp the joints to be moved by hand, sample the whole arm at the
//! control rate, then hold the limp joints where they were left.

use super::{RecordError, Recording, SampleGaps, StopReason};
use crate::bus::{faulty_joint, ReadStreak};
use crate::bus::{BusError, ServoBus};
use crate::pacing::{Clock, Pacer, WallClock};
use crate::robot::Robot;
use crate::stop::StopSignal;
use std::io::Write;
use std::time::Instant;

/// Highest sampling rate: key times are whole milliseconds, so faster samples would share them
/// (it is also the top of the player's control rates).
pub const MAX_RATE_HZ: f64 = 1000.0;
/// Longest recording, seconds: an hour of teaching by hand is far beyond any sequence, and the
/// bound keeps memory and extraction time (about linear in length) in reason.
pub const MAX_SECONDS: f64 = 3600.0;

/// What to record, how fast and for how long.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// Sampling rate, hertz (at most [`MAX_RATE_HZ`]).
    pub rate_hz: f64,
    /// Indices (robot joint order) of the joints to record: their torque goes off. The others
    /// are read too but left as they are.
    pub joints: Vec<usize>,
    /// Stop after this many seconds (else only a stop request ends the recording).
    pub duration: Option<f64>,
    /// A progress line on standard error.
    pub progress: bool,
}

/// Limps `options.joints` and samples every joint's present position at `options.rate_hz`,
/// paced by absolute deadlines, until `stop` is requested or the duration has passed; then
/// writes each limp joint's present position as its goal and turns its torque back on, so the
/// arm holds where it was left without a jump. The first sample is always taken.
pub fn record(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    options: &RecordOptions,
    stop: &StopSignal,
) -> Result<Recording, RecordError> {
    record_with_clock(bus, robot, options, stop, &WallClock::new())
}

/// [`record`] on a given clock (tests make it stall).
pub(crate) fn record_with_clock(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    options: &RecordOptions,
    stop: &StopSignal,
    clock: &dyn Clock,
) -> Result<Recording, RecordError> {
    validate_options(robot, options)?;
    let all: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let limp: Vec<u8> = options
        .joints
        .iter()
        .map(|&j| robot.joints[j].servo.id)
        .collect();
    let fault = |error: BusError, at: f64| RecordError::Fault {
        joint: faulty_joint(robot, &error),
        error,
        at,
    };
    // Read first: a bus that does not answer is reported before anything goes limp.
    let mut last_ticks = bus.read_positions(&all).map_err(|e| fault(e, 0.0))?;
    if let Err(e) = bus.set_torque(&limp, false) {
        // Some servos may have gone limp before the failure: make them hold again.
        let _ = hold_where_they_are(bus, robot, &options.joints, &last_ticks);
        return Err(fault(e, 0.0));
    }
    let sampled = sample(bus, robot, options, stop, clock, &all, &mut last_ticks);
    let hold = hold_where_they_are(bus, robot, &options.joints, &last_ticks);
    let (samples, stopped) = match sampled {
        Ok(s) => s,
        Err((error, at)) => return Err(fault(error, at)),
    };
    let mut recorded = vec![false; robot.joints.len()];
    for &j in &options.joints {
        recorded[j] = true;
    }
    Ok(Recording {
        times: samples.times,
        values: samples.values,
        recorded,
        rate_hz: options.rate_hz,
        stopped,
        gaps: samples.gaps,
        hold_error: hold.err(),
    })
}

fn validate_options(robot: &Robot, options: &RecordOptions) -> Result<(), RecordError> {
    let rate = options.rate_hz;
    let lowest = *crate::pacing::RATE_RANGE_HZ.start();
    if !(rate.is_finite() && (lowest..=MAX_RATE_HZ).contains(&rate)) {
        return Err(RecordError::Invalid(format!(
            "the rate must be from {lowest} to {MAX_RATE_HZ} Hz (key times are whole milliseconds), found {rate}"
        )));
    }
    if let Some(d) = options.duration {
        if !(d.is_finite() && d > 0.0 && d <= MAX_SECONDS) {
            return Err(RecordError::Invalid(format!(
                "the duration must be above 0 and at most {MAX_SECONDS} s, found {d}"
            )));
        }
    }
    if options.joints.is_empty() {
        return Err(RecordError::Invalid("no joint to record".into()));
    }
    for (i, &j) in options.joints.iter().enumerate() {
        if j >= robot.joints.len() {
            return Err(RecordError::Invalid(format!(
                "joint index {j} is out of range: {} has {} joints",
                robot.name,
                robot.joints.len()
            )));
        }
        if options.joints[..i].contains(&j) {
            return Err(RecordError::Invalid(format!(
                "joint {} is listed twice",
                robot.joints[j].name
            )));
        }
    }
    Ok(())
}

/// What the sampling loop gathers.
struct Samples {
    times: Vec<f64>,
    values: Vec<Vec<f64>>,
    gaps: SampleGaps,
}

impl Samples {
    fn new(joints: usize) -> Samples {
        Samples {
            times: Vec::new(),
            values: vec![Vec::new(); joints],
            gaps: SampleGaps::default(),
        }
    }

    /// One reading of every joint, taken at `t` (recording time).
    fn push(&mut self, robot: &Robot, ticks: &[i64], t: f64) {
        self.gaps.sampled(&self.times, t);
        self.times.push(t);
        for ((series, joint), &tick) in self.values.iter_mut().zip(&robot.joints).zip(ticks) {
            series.push(joint.servo.value(tick));
        }
    }

    /// Times from the first sample.
    fn start_at_zero(&mut self) {
        let first = self.times.first().copied().unwrap_or(0.0);
        for t in &mut self.times {
            *t -= first;
        }
        self.gaps.longest_at -= first;
    }
}

/// The sampling loop. On a fault returns the error and the time it happened.
fn sample(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    options: &RecordOptions,
    stop: &StopSignal,
    clock: &dyn Clock,
    ids: &[u8],
    last_ticks: &mut Vec<i64>,
) -> Result<(Samples, StopReason), (BusError, f64)> {
    let period = 1.0 / options.rate_hz;
    let mut samples = Samples::new(robot.joints.len());
    let mut reads = ReadStreak::default();
    let mut last_progress: Option<Instant> = None;
    // Absolute deadlines, and a stall skips the deadlines it missed rather than bunching
    // samples after it; the pacer counts both.
    let mut pacer = Pacer::new(clock, period);
    let t0 = clock.now().as_secs_f64();
    let stopped = loop {
        let before = pacer.wait(clock, stop, 0).now - t0;
        match bus.read_positions(ids) {
            Ok(ticks) => {
                // The servos answered some time during the read: its middle is the best guess.
                let t = (before + clock.now().as_secs_f64() - t0) / 2.0;
                samples.push(robot, &ticks, t);
                *last_ticks = ticks;
                reads.succeeded();
            }
            Err(e) => {
                samples.gaps.failed_reads += 1;
                if let Some(error) = reads.failed(e) {
                    return Err((error, before));
                }
            }
        }
        if options.progress && last_progress.is_none_or(|p| p.elapsed().as_secs_f64() >= 0.1) {
            last_progress = Some(Instant::now());
            print_progress(before, samples.times.len());
        }
        if let Some(reason) = stop_reason(options, stop, !samples.times.is_empty(), before + period)
        {
            break reason;
        }
    };
    if options.progress {
        print_progress(clock.now().as_secs_f64() - t0, samples.times.len());
        eprintln!();
    }
    samples.gaps.stalls = pacer.summary.stalls;
    samples.gaps.skipped_deadlines = pacer.summary.skipped_deadlines;
    samples.start_at_zero();
    Ok((samples, stopped))
}

/// Why the recording ends after this cycle, if it does: a stop request, or a next deadline
/// (`next`, recording time) past the duration. Never before the first sample, so a recording
/// is never empty.
fn stop_reason(
    options: &RecordOptions,
    stop: &StopSignal,
    sampled: bool,
    next: f64,
) -> Option<StopReason> {
    if !sampled {
        return None;
    }
    if stop.count() > 0 {
        return Some(StopReason::Requested);
    }
    let limit = options.duration.unwrap_or(MAX_SECONDS).min(MAX_SECONDS);
    (next > limit + 1e-9).then_some(match options.duration {
        Some(_) => StopReason::Duration,
        None => StopReason::Longest,
    })
}

fn print_progress(seconds: f64, samples: usize) {
    let mut err = std::io::stderr().lock();
    let _ = write!(err, "\rrecording {seconds:>7.2} s  {samples:>6} samples   ");
    let _ = err.flush();
}

/// Why the limp joints could not all be made to hold again.
#[derive(Debug, thiserror::Error)]
pub enum HoldError {
    /// The bus failed while reading the present positions or writing the goals.
    #[error(transparent)]
    Bus(#[from] BusError),
    /// Holding these where they are would need a goal outside their limits, and pulling them
    /// inside at once would be a jump: they stay limp.
    #[error("{} left limp: pushed past {} limits, where no goal may go; move {} inside by hand, then `keypose torque on`", .0.join(", "), if .0.len() == 1 { "its" } else { "their" }, if .0.len() == 1 { "it" } else { "them" })]
    OutsideLimits(Vec<String>),
}

/// Goal = present position for each limp joint, then torque on: the arm neither drops nor
/// jumps. A joint a little past a limit (within the player's start slack) is held at the limit;
/// one further past stays limp, since no goal may go outside the limits. Falls back to the last
/// sampled positions if the present ones cannot be read, and carries on past a servo that
/// fails, so that one does not leave the others limp. Returns the first problem.
fn hold_where_they_are(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    limp: &[usize],
    last_ticks: &[i64],
) -> Result<(), HoldError> {
    let ids: Vec<u8> = limp.iter().map(|&j| robot.joints[j].servo.id).collect();
    let ticks: Vec<Option<i64>> = match bus.read_positions(&ids) {
        Ok(ticks) => ticks.into_iter().map(Some).collect(),
        Err(_) => limp.iter().map(|&j| last_ticks.get(j).copied()).collect(),
    };
    let mut goals = Vec::with_capacity(limp.len());
    let mut outside = Vec::new();
    for (&j, tick) in limp.iter().zip(ticks) {
        let joint = &robot.joints[j];
        let goal = tick.and_then(|tick| joint.hold_tick(tick));
        match goal {
            Some(goal) => goals.push((joint.servo.id, goal)),
            None => outside.push(joint.name.clone()),
        }
    }
    // Without this write, torque on would drive each servo to its stale goal: limp is safer
    // than a jump, so a failure here leaves the torque off.
    bus.write_goals(&goals)?;
    let mut first_error = None;
    for &(id, _) in &goals {
        if let Err(e) = bus.set_torque(&[id], true) {
            first_error.get_or_insert(e);
        }
    }
    match (first_error, outside.is_empty()) {
        (Some(e), _) => Err(e.into()),
        (None, false) => Err(HoldError::OutsideLimits(outside)),
        (None, true) => Ok(()),
    }
}
