//! Recording by hand and turning a recording into keyframes.
//!
//! [`record`] limps the chosen joints (torque off) and samples the present pose of the whole arm
//! at the control rate until a stop request or a duration, then makes the limp joints hold where
//! they were left. [`keyframes`] turns the [`Recording`] into a keyframe list: the fewest keys
//! whose curve stays within a tolerance of the recording ([`extract`]), as a [`Sequence`] that
//! passes `plan::check` — retimed where a hand moved faster than the limits allow, clamped where
//! it pushed a joint past a software limit.

pub mod extract;

use crate::bus::{faulty_joint, joint_prefix, BusError, ReadStreak, ServoBus};
use crate::curve::Interp;
use crate::json::InputError;
use crate::pacing::{Clock, Pacer, WallClock};
use crate::plan::{check, retime, CheckReport, LimitKind, Trajectory};
use crate::robot::{JointKind, Robot};
use crate::sequence::{Ends, KeyValue, Keyframe, Sequence};
use crate::stop::StopSignal;
use extract::ExtractError;
use std::io::Write;
use std::time::Instant;

/// Highest sampling rate: key times are whole milliseconds, so faster samples would share them
/// (it is also the top of the player's control rates).
pub const MAX_RATE_HZ: f64 = 1000.0;
/// Longest recording, seconds: an hour of teaching by hand is far beyond any sequence, and the
/// bound keeps memory and extraction time (about linear in length) in reason.
pub const MAX_SECONDS: f64 = 3600.0;
/// Rounds of "extract, check, make overshooting cubic segments monotone" at most; each round
/// only ever makes more segments monotone, and all-monotone cannot overshoot.
const MAX_LIMIT_ROUNDS: usize = 20;
/// Calls of `plan::retime` at most, each continuing from the last one's result.
const MAX_RETIME_CALLS: usize = 10;

#[derive(Debug, Clone)]
pub struct RecordOptions {
    pub rate_hz: f64,
    /// Indices (robot joint order) of the joints to record: their torque goes off. The others
    /// are read too but left as they are.
    pub joints: Vec<usize>,
    /// Stop after this many seconds (else only a stop request ends the recording).
    pub duration: Option<f64>,
    /// A progress line on standard error.
    pub progress: bool,
}

/// Why a recording ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    Requested,
    Duration,
    /// [`MAX_SECONDS`] reached.
    Longest,
}

/// The present pose of the whole arm over time.
#[derive(Debug)]
pub struct Recording {
    /// Seconds since the first sample, increasing (as measured: the middle of each read).
    pub times: Vec<f64>,
    /// `values[joint][sample]` for every joint of the robot, in its unit (degrees or metres).
    pub values: Vec<Vec<f64>>,
    /// Which joints were recorded (limp); the others kept their torque.
    pub recorded: Vec<bool>,
    pub rate_hz: f64,
    pub stopped: StopReason,
    /// Samples missing from the recording, and the longest gap between two.
    pub gaps: SampleGaps,
    /// Set when the recording is complete but the limp joints could not all be made to hold
    /// again: some may still be limp.
    pub hold_error: Option<HoldError>,
}

#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{0}")]
    Invalid(String),
    /// The bus failed while recording; the limp joints were asked to hold where they were.
    #[error("{}{error} (at {at:.3} s)", joint_prefix(joint))]
    Fault {
        joint: Option<String>,
        error: BusError,
        at: f64,
    },
    #[error("keyframes: {0}")]
    Extract(#[from] ExtractError),
    /// The keyframes do not make a valid sequence for the robot (a bug if it happens).
    #[error(transparent)]
    Sequence(#[from] InputError),
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
pub fn record_with_clock(
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
    let (times, values, stopped, gaps) = match sampled {
        Ok(s) => s,
        Err((error, at)) => return Err(fault(error, at)),
    };
    let mut recorded = vec![false; robot.joints.len()];
    for &j in &options.joints {
        recorded[j] = true;
    }
    Ok(Recording {
        times,
        values,
        recorded,
        rate_hz: options.rate_hz,
        stopped,
        gaps,
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

type Samples = (Vec<f64>, Vec<Vec<f64>>, StopReason, SampleGaps);

/// Where a recording has no samples for longer than one period: what the hand did there is
/// not known, and the keys are fitted across it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SampleGaps {
    /// Reads that failed (each one a sample missing).
    pub failed_reads: u64,
    /// Cycles that began late after a stall of the process, and the deadlines passed over.
    pub stalls: u64,
    pub skipped_deadlines: u64,
    /// The longest time between two samples, seconds, and where it ended (recording time).
    pub longest: f64,
    pub longest_at: f64,
}

impl SampleGaps {
    fn sampled(&mut self, times: &[f64], t: f64) {
        if let Some(&previous) = times.last() {
            if t - previous > self.longest {
                self.longest = t - previous;
                self.longest_at = t;
            }
        }
    }

    /// Samples the recording should have and does not.
    pub fn missing(&self) -> u64 {
        self.failed_reads + self.skipped_deadlines
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
) -> Result<Samples, (BusError, f64)> {
    let period = 1.0 / options.rate_hz;
    let limit = options.duration.unwrap_or(MAX_SECONDS).min(MAX_SECONDS);
    let mut times = Vec::new();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); robot.joints.len()];
    let mut reads = ReadStreak::default();
    let mut gaps = SampleGaps::default();
    let mut last_progress: Option<Instant> = None;
    // Absolute deadlines, and a stall skips the deadlines it missed rather than bunching
    // samples after it; the pacer counts both.
    let mut pacer = Pacer::new(clock, period);
    let t0 = clock.now().as_secs_f64();
    let stopped = loop {
        let start = pacer.wait(clock, stop, 0);
        let before = start.now - t0;
        match bus.read_positions(ids) {
            Ok(ticks) => {
                // The servos answered some time during the read: its middle is the best guess.
                let t = (before + clock.now().as_secs_f64() - t0) / 2.0;
                gaps.sampled(&times, t);
                times.push(t);
                for ((series, joint), &tick) in values.iter_mut().zip(&robot.joints).zip(&ticks) {
                    series.push(joint.servo.value(tick));
                }
                *last_ticks = ticks;
                reads.succeeded();
            }
            Err(e) => {
                gaps.failed_reads += 1;
                if let Some(error) = reads.failed(e) {
                    return Err((error, before));
                }
            }
        }
        if options.progress && last_progress.is_none_or(|p| p.elapsed().as_secs_f64() >= 0.1) {
            last_progress = Some(Instant::now());
            print_progress(before, times.len());
        }
        if !times.is_empty() {
            if stop.count() > 0 {
                break StopReason::Requested;
            }
            if before + period > limit + 1e-9 {
                break match options.duration {
                    Some(_) => StopReason::Duration,
                    None => StopReason::Longest,
                };
            }
        }
    };
    if options.progress {
        print_progress(clock.now().as_secs_f64() - t0, times.len());
        eprintln!();
    }
    gaps.stalls = pacer.summary.stalls;
    gaps.skipped_deadlines = pacer.summary.skipped_deadlines;
    // Times from the first sample.
    let first = times.first().copied().unwrap_or(0.0);
    for t in &mut times {
        *t -= first;
    }
    gaps.longest_at -= first;
    Ok((times, values, stopped, gaps))
}

fn print_progress(seconds: f64, samples: usize) {
    let mut err = std::io::stderr().lock();
    let _ = write!(err, "\rrecording {seconds:>7.2} s  {samples:>6} samples   ");
    let _ = err.flush();
}

/// Why the limp joints could not all be made to hold again.
#[derive(Debug, thiserror::Error)]
pub enum HoldError {
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

#[derive(Debug, Clone, Copy)]
pub struct KeyframeOptions {
    /// Mode of the sequence. Step is refused: its jumps never pass the limit check.
    pub interpolation: Interp,
    /// Largest deviation from the recording, degrees, for revolute joints.
    pub tolerance_deg: f64,
    /// Largest deviation from the recording, metres, for prismatic joints.
    pub tolerance_m: f64,
    /// Rate at which the result is checked against the limits (the control rate).
    pub check_rate_hz: f64,
}

/// The largest deviation of one joint's curve from its recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Deviation {
    pub joint: String,
    /// In the joint's unit ("deg" or "m").
    pub unit: &'static str,
    pub value: f64,
    /// Sample time (seconds from the first key) where it occurs.
    pub time: f64,
    /// `value` over the joint's tolerance.
    pub share: f64,
}

/// A joint pushed past a software limit while recording: its samples there were clamped.
#[derive(Debug, Clone, PartialEq)]
pub struct Clamp {
    pub joint: String,
    pub unit: &'static str,
    /// The limit crossed.
    pub limit: f64,
    /// How far past it at the worst, and when.
    pub excess: f64,
    pub time: f64,
}

/// A joint that was not recorded but moved while recording (the file holds its first value).
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    pub joint: String,
    pub unit: &'static str,
    pub moved: f64,
}

/// How retiming changed the key times.
#[derive(Debug, Clone, PartialEq)]
pub struct Retimed {
    /// Every key's time as recorded, and after retiming.
    pub key_times_before: Vec<f64>,
    pub key_times_after: Vec<f64>,
    /// Segments stretched, of all.
    pub stretched: usize,
    pub segments: usize,
}

impl Retimed {
    /// Time of the last key as recorded.
    pub fn before(&self) -> f64 {
        self.key_times_before.last().copied().unwrap_or(0.0)
    }

    /// Time of the last key after retiming.
    pub fn after(&self) -> f64 {
        self.key_times_after.last().copied().unwrap_or(0.0)
    }
}

/// A recording turned into keyframes.
#[derive(Debug, Clone)]
pub struct Keyframes {
    pub sequence: Sequence,
    /// Samples used (after snapping their times to milliseconds).
    pub samples: usize,
    /// Every recorded joint's largest deviation, in robot joint order.
    pub deviations: Vec<Deviation>,
    /// The recorded joint whose largest deviation is the largest share of its tolerance.
    pub worst: usize,
    pub clamps: Vec<Clamp>,
    pub drifts: Vec<Drift>,
    pub retimed: Option<Retimed>,
    /// Cubic segments made monotone because they overshot a limit.
    pub made_monotone: usize,
    /// The limit check of the sequence as saved.
    pub check: CheckReport,
}

impl Keyframes {
    pub fn keys(&self) -> usize {
        self.sequence.keyframes.len()
    }

    /// "N samples → K keys, largest deviation X° (joint, t = T s)".
    pub fn summary(&self) -> String {
        let mut line = format!("{} samples → {} keys", self.samples, self.keys());
        if let Some(d) = self.deviations.get(self.worst).filter(|d| d.value > 0.0) {
            let value = match d.unit {
                "deg" => format!("{:.3}°", d.value),
                unit => format!("{:.5} {unit}", d.value),
            };
            line.push_str(&format!(
                ", largest deviation {value} ({}, t = {:.3} s)",
                d.joint, d.time
            ));
        } else {
            line.push_str(", exact (no deviation)");
        }
        line
    }
}

/// The fewest keys whose curve stays within tolerance of `recording` (see [`extract`]), as a
/// sequence with absolute key times (the recorded times, in whole milliseconds, from 0) that
/// passes the limit check:
/// - samples past a position limit are clamped to it first (with a [`Clamp`] to warn about);
/// - a cubic segment that overshoots a limit between keys is made monotone, and the keys are
///   extracted again with it;
/// - if velocity or acceleration limits fail (a hand moves faster than the servos may), the
///   sequence is retimed, which stretches the segments that need it ([`Retimed`]); the
///   deviations are those of the curve at the recorded times. If retiming cannot mend them (a
///   linear corner changes velocity within one control period), the recorded timing is kept
///   and [`Keyframes::check`] says what fails.
///
/// Joints that were not recorded appear in the first key only, with their first value.
pub fn keyframes(
    recording: &Recording,
    robot: &Robot,
    options: &KeyframeOptions,
) -> Result<Keyframes, RecordError> {
    if options.interpolation == Interp::Step {
        return Err(RecordError::Invalid(
            "step interpolation jumps between keys, which no limit check passes; use linear, cubic or monotone".into(),
        ));
    }
    for (name, tolerance) in [
        ("degrees", options.tolerance_deg),
        ("metres", options.tolerance_m),
    ] {
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(RecordError::Invalid(format!(
                "the tolerance in {name} must be a number above 0, found {tolerance}"
            )));
        }
    }
    let joints = robot.joints.len();
    if recording.values.len() != joints || recording.recorded.len() != joints {
        return Err(RecordError::Invalid(format!(
            "the recording has {} joints, the robot {} has {joints}",
            recording.values.len(),
            robot.name
        )));
    }
    let recorded: Vec<usize> = (0..joints).filter(|&j| recording.recorded[j]).collect();
    if recorded.is_empty() {
        return Err(RecordError::Invalid("no joint was recorded".into()));
    }
    let (times, kept) = snap_times(&recording.times);
    if times.is_empty() {
        return Err(RecordError::Invalid("the recording has no samples".into()));
    }

    let mut clamps = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::with_capacity(joints);
    for (j, joint) in robot.joints.iter().enumerate() {
        let series = &recording.values[j];
        let mut out = Vec::with_capacity(kept.len());
        let mut worst: Option<Clamp> = None;
        for (&k, &t) in kept.iter().zip(&times) {
            let v = *series.get(k).ok_or_else(|| {
                RecordError::Invalid(format!("joint {}: fewer values than times", joint.name))
            })?;
            let clamped = v.clamp(joint.limits.min, joint.limits.max);
            let excess = (v - clamped).abs();
            if excess > 0.0 && worst.as_ref().is_none_or(|w| excess > w.excess) {
                worst = Some(Clamp {
                    joint: joint.name.clone(),
                    unit: joint.kind.unit(),
                    limit: if v > joint.limits.max {
                        joint.limits.max
                    } else {
                        joint.limits.min
                    },
                    excess,
                    time: t,
                });
            }
            out.push(clamped);
        }
        // A joint that was not recorded is clamped too: its one value, its first sample, must
        // be inside the limits as well.
        clamps.extend(worst);
        values.push(out);
    }
    let drifts: Vec<Drift> = (0..joints)
        .filter(|&j| !recording.recorded[j])
        .filter_map(|j| {
            let joint = &robot.joints[j];
            let first = values[j][0];
            let moved = values[j]
                .iter()
                .fold(0.0f64, |m, v| m.max((v - first).abs()));
            (moved > tolerance_of(joint.kind, options)).then(|| Drift {
                joint: joint.name.clone(),
                unit: joint.kind.unit(),
                moved,
            })
        })
        .collect();

    let series: Vec<Vec<f64>> = recorded.iter().map(|&j| values[j].clone()).collect();
    let tolerances: Vec<f64> = recorded
        .iter()
        .map(|&j| tolerance_of(robot.joints[j].kind, options))
        .collect();
    let mut modes = vec![options.interpolation; times.len()];
    let mut made_monotone = 0;
    let mut round = 0;
    let (fit, sequence, report, retimed) = loop {
        round += 1;
        let fit = extract::extract_with_modes(&times, &series, &tolerances, &modes)?;
        let sequence = build_sequence(
            robot, &times, &values, &recorded, &fit.keys, &modes, options,
        );
        let trajectory = Trajectory::build(&sequence, robot)?;
        let mut report = check(&trajectory, robot, options.check_rate_hz);
        let mut retimed = None;
        let mut final_sequence = sequence;
        if !report.passed() {
            let original = final_sequence.key_times();
            let mut candidate = final_sequence.clone();
            let mut candidate_report = report.clone();
            // `retime` gives up on a segment whose need did not fall after a stretch, which also
            // happens when a neighbour's stretch changed its slopes; a fresh call starts over.
            for _ in 0..MAX_RETIME_CALLS {
                let outcome = retime(&candidate, robot, options.check_rate_hz)?;
                let stretched = !outcome.stretched.is_empty();
                candidate = outcome.sequence;
                candidate_report = outcome.report;
                if candidate_report.passed() || !stretched {
                    break;
                }
            }
            // Retiming that leaves velocity or acceleration broken is no better than the
            // recorded timing, which at least is what the hand did: keep that one then.
            let speeds_fixed = candidate_report
                .violations
                .iter()
                .all(|v| v.kind == LimitKind::Position);
            let times = candidate.key_times();
            let stretched = (0..times.len().saturating_sub(1))
                .filter(|&i| times[i + 1] - times[i] > original[i + 1] - original[i] + 1e-9)
                .count();
            if speeds_fixed && stretched > 0 {
                retimed = Some(Retimed {
                    segments: times.len().saturating_sub(1),
                    key_times_before: original,
                    key_times_after: times,
                    stretched,
                });
                final_sequence = candidate;
                report = candidate_report;
            }
        }
        // A cubic can overshoot a limit between keys that are inside it; monotone cannot.
        let overshoots: Vec<usize> = report
            .violations
            .iter()
            .filter(|v| v.kind == LimitKind::Position)
            .map(|v| v.segment)
            .collect();
        let mut changed = false;
        for segment in overshoots {
            let (Some(&a), Some(&b)) = (fit.keys.get(segment), fit.keys.get(segment + 1)) else {
                continue;
            };
            if modes[a] != Interp::Monotone {
                made_monotone += 1;
                changed = true;
            }
            for mode in &mut modes[a..b] {
                *mode = Interp::Monotone;
            }
        }
        if !changed || round >= MAX_LIMIT_ROUNDS {
            break (fit, final_sequence, report, retimed);
        }
    };

    let deviations: Vec<Deviation> = recorded
        .iter()
        .zip(&fit.deviations)
        .zip(&tolerances)
        .map(|((&j, d), &tolerance)| Deviation {
            joint: robot.joints[j].name.clone(),
            unit: robot.joints[j].kind.unit(),
            value: d.max,
            time: times[d.sample],
            share: d.max / tolerance,
        })
        .collect();
    Ok(Keyframes {
        sequence,
        samples: times.len(),
        deviations,
        worst: fit.worst_joint,
        clamps,
        drifts,
        retimed,
        made_monotone,
        check: report,
    })
}

fn tolerance_of(kind: JointKind, options: &KeyframeOptions) -> f64 {
    match kind {
        JointKind::Revolute => options.tolerance_deg,
        JointKind::Prismatic => options.tolerance_m,
    }
}

/// Sample times in whole milliseconds (what the file will say, so that the deviations are those
/// of the saved curve), dropping a sample that would share a millisecond with the one before
/// (possible only after a stall). Returns the times and the indices of the samples kept.
fn snap_times(times: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut out = Vec::with_capacity(times.len());
    let mut kept = Vec::with_capacity(times.len());
    let mut previous: Option<i64> = None;
    for (k, &t) in times.iter().enumerate() {
        if !t.is_finite() {
            continue;
        }
        let ms = (t * 1000.0).round() as i64;
        if previous.is_some_and(|p| ms <= p) {
            continue;
        }
        previous = Some(ms);
        out.push(ms as f64 / 1000.0);
        kept.push(k);
    }
    (out, kept)
}

fn build_sequence(
    robot: &Robot,
    times: &[f64],
    values: &[Vec<f64>],
    recorded: &[usize],
    keys: &[usize],
    modes: &[Interp],
    options: &KeyframeOptions,
) -> Sequence {
    let keyframes = keys
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            let joints: Vec<(String, KeyValue)> = (0..robot.joints.len())
                // The first key names every joint, so the file is complete on its own.
                .filter(|j| i == 0 || recorded.contains(j))
                .map(|j| (robot.joints[j].name.clone(), KeyValue::Joint(values[j][s])))
                .collect();
            let mut key = Keyframe::new(joints);
            key.time = Some(times[s]);
            if modes[s] != options.interpolation {
                key.interp = Some(modes[s]);
            }
            key
        })
        .collect();
    Sequence {
        file: "<recording>".into(),
        robot: robot.name.clone(),
        description: Some(format!(
            "recorded by hand: {} samples, {} keys within {}° / {} m",
            times.len(),
            keys.len(),
            options.tolerance_deg,
            options.tolerance_m
        )),
        interpolation: options.interpolation,
        ends: Ends::Played,
        key_interval: None,
        keyframes,
    }
}
