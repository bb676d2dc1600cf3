//! Keyframes from a recording, without the bus: clamp the samples into the limits, find the
//! fewest keys within tolerance ([`super::extract`]), and make the result pass the limit check
//! (monotone where a cubic overshoots, retimed where the hand was too fast).

use super::extract::{self, Fit};
use super::{RecordError, Recording};
use crate::curve::Interp;
use crate::plan::{check, retime, CheckReport, LimitKind, Trajectory};
use crate::robot::{JointKind, Robot};
use crate::sequence::{Ends, KeyValue, Keyframe, Sequence};

/// Rounds of "extract, check, make overshooting cubic segments monotone" at most; each round
/// only ever makes more segments monotone, and all-monotone cannot overshoot.
const MAX_LIMIT_ROUNDS: usize = 20;
/// Calls of `plan::retime` at most, each continuing from the last one's result.
const MAX_RETIME_CALLS: usize = 10;

/// How keyframes are fitted to a recording.
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

impl KeyframeOptions {
    /// The largest deviation allowed for a joint of `kind`, in its unit.
    pub fn tolerance(&self, kind: JointKind) -> f64 {
        match kind {
            JointKind::Revolute => self.tolerance_deg,
            JointKind::Prismatic => self.tolerance_m,
        }
    }
}

/// The largest deviation of one joint's curve from its recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Deviation {
    /// The joint's name.
    pub joint: String,
    /// The joint's unit, `"deg"` or `"m"`.
    pub unit: &'static str,
    /// The largest |curve − recording|, in `unit`.
    pub value: f64,
    /// Sample time (seconds from the first key) where it occurs.
    pub time: f64,
    /// `value` over the joint's tolerance.
    pub share: f64,
}

/// A joint pushed past a software limit while recording: its samples there were clamped.
#[derive(Debug, Clone, PartialEq)]
pub struct Clamp {
    /// The joint's name.
    pub joint: String,
    /// The joint's unit, `"deg"` or `"m"`.
    pub unit: &'static str,
    /// The limit crossed, in `unit`.
    pub limit: f64,
    /// How far past it at the worst, in `unit`.
    pub excess: f64,
    /// When the worst excess was, seconds from the first sample.
    pub time: f64,
}

/// A joint that was not recorded but moved while recording (the file holds its first value).
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    /// The joint's name.
    pub joint: String,
    /// The joint's unit, `"deg"` or `"m"`.
    pub unit: &'static str,
    /// How far it moved from its first value at the most, in `unit`.
    pub moved: f64,
}

/// How retiming changed the key times.
#[derive(Debug, Clone, PartialEq)]
pub struct Retimed {
    /// Every key's time as recorded, seconds.
    pub key_times_before: Vec<f64>,
    /// Every key's time after retiming, seconds.
    pub key_times_after: Vec<f64>,
    /// Segments stretched.
    pub stretched: usize,
    /// Segments in all.
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
    /// The keyframes, with absolute times.
    pub sequence: Sequence,
    /// Samples used (after snapping their times to milliseconds).
    pub samples: usize,
    /// Every recorded joint's largest deviation, in robot joint order.
    pub deviations: Vec<Deviation>,
    /// The recorded joint whose largest deviation is the largest share of its tolerance.
    pub worst: usize,
    /// Joints pushed past a limit, whose samples were clamped to it.
    pub clamps: Vec<Clamp>,
    /// Joints not recorded that moved while recording.
    pub drifts: Vec<Drift>,
    /// How retiming changed the key times; `None` when the recorded timing passed the check.
    pub retimed: Option<Retimed>,
    /// Cubic segments made monotone because they overshot a limit.
    pub made_monotone: usize,
    /// The limit check of the sequence as saved.
    pub check: CheckReport,
}

impl Keyframes {
    /// Number of keys.
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

/// The fewest keys whose curve stays within tolerance of `recording` (see [`extract()`](fn@crate::record::extract)), as a
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
    let recorded = validate(recording, robot, options)?;
    let (times, kept) = snap_times(&recording.times);
    if times.is_empty() {
        return Err(RecordError::Invalid("the recording has no samples".into()));
    }
    let (values, clamps) = clamp_to_limits(recording, robot, &times, &kept)?;
    let drifts = drifts(recording, robot, &values, options);
    let samples = Fitting {
        robot,
        options,
        tolerances: recorded
            .iter()
            .map(|&j| options.tolerance(robot.joints[j].kind))
            .collect(),
        series: recorded.iter().map(|&j| values[j].clone()).collect(),
        times,
        values,
        recorded,
    };
    let fitted = samples.fit_within_limits()?;
    Ok(Keyframes {
        deviations: samples.deviations(&fitted.fit),
        samples: samples.times.len(),
        worst: fitted.fit.worst_joint,
        sequence: fitted.sequence,
        clamps,
        drifts,
        retimed: fitted.retimed,
        made_monotone: fitted.made_monotone,
        check: fitted.report,
    })
}

/// Why keys in `mode` cannot be fitted to a recording, if they cannot.
pub fn unfittable(mode: Interp) -> Option<&'static str> {
    match mode {
        Interp::Step => Some("jumps between keys, which no limit check passes"),
        // The fit judges each segment from its own keys and their neighbours' slopes; a
        // spline's every key moves every segment of its run.
        Interp::Smooth => Some(
            "shapes each segment from every key of its run, and keys are fitted to a \
             recording a few segments at a time",
        ),
        Interp::Linear | Interp::Cubic | Interp::Monotone => None,
    }
}

/// Refuses options and recordings no keyframes can come from; returns the recorded joints.
fn validate(
    recording: &Recording,
    robot: &Robot,
    options: &KeyframeOptions,
) -> Result<Vec<usize>, RecordError> {
    if let Some(why) = unfittable(options.interpolation) {
        return Err(RecordError::Invalid(format!(
            "{} interpolation {why}; use linear, cubic or monotone",
            options.interpolation
        )));
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
    Ok(recorded)
}

/// Every joint's samples at the `kept` indices (taken at `times`), clamped into its position
/// limits, with the worst clamp of each joint that needed one. A joint that was not recorded
/// is clamped too: its one value, its first sample, must be inside the limits as well.
fn clamp_to_limits(
    recording: &Recording,
    robot: &Robot,
    times: &[f64],
    kept: &[usize],
) -> Result<(Vec<Vec<f64>>, Vec<Clamp>), RecordError> {
    let mut clamps = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::with_capacity(robot.joints.len());
    for (joint, series) in robot.joints.iter().zip(&recording.values) {
        let mut out = Vec::with_capacity(kept.len());
        let mut worst: Option<Clamp> = None;
        for (&k, &t) in kept.iter().zip(times) {
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
        clamps.extend(worst);
        values.push(out);
    }
    Ok((values, clamps))
}

/// The joints that were not recorded but moved by more than their tolerance anyway.
fn drifts(
    recording: &Recording,
    robot: &Robot,
    values: &[Vec<f64>],
    options: &KeyframeOptions,
) -> Vec<Drift> {
    (0..robot.joints.len())
        .filter(|&j| !recording.recorded[j])
        .filter_map(|j| {
            let joint = &robot.joints[j];
            let first = values[j][0];
            let moved = values[j]
                .iter()
                .fold(0.0f64, |m, v| m.max((v - first).abs()));
            (moved > options.tolerance(joint.kind)).then(|| Drift {
                joint: joint.name.clone(),
                unit: joint.kind.unit(),
                moved,
            })
        })
        .collect()
}

/// The clamped samples being fitted, and what fitting them needs.
struct Fitting<'a> {
    robot: &'a Robot,
    options: &'a KeyframeOptions,
    /// Sample times, whole milliseconds.
    times: Vec<f64>,
    /// `values[joint][sample]` for every joint of the robot.
    values: Vec<Vec<f64>>,
    /// The recorded joints, and their samples and tolerances in that order.
    recorded: Vec<usize>,
    series: Vec<Vec<f64>>,
    tolerances: Vec<f64>,
}

/// The keys found, as the sequence that will be saved.
struct Fitted {
    fit: Fit,
    sequence: Sequence,
    report: CheckReport,
    retimed: Option<Retimed>,
    made_monotone: usize,
}

impl Fitting<'_> {
    /// Extract, check and retime, then make the cubic segments that overshoot a limit monotone
    /// and go again, until nothing overshoots (or [`MAX_LIMIT_ROUNDS`]).
    fn fit_within_limits(&self) -> Result<Fitted, RecordError> {
        let mut modes = vec![self.options.interpolation; self.times.len()];
        let mut made_monotone = 0;
        let mut round = 0;
        loop {
            round += 1;
            let fit =
                extract::extract_with_modes(&self.times, &self.series, &self.tolerances, &modes)?;
            let sequence = self.build_sequence(&fit.keys, &modes);
            let trajectory = Trajectory::build(&sequence, self.robot)?;
            let report = check(&trajectory, self.robot, self.options.check_rate_hz);
            let (sequence, report, retimed) = self.retime_if_needed(sequence, report)?;
            let changed = make_overshoots_monotone(&report, &fit.keys, &mut modes);
            made_monotone += changed;
            if changed == 0 || round >= MAX_LIMIT_ROUNDS {
                return Ok(Fitted {
                    fit,
                    sequence,
                    report,
                    retimed,
                    made_monotone,
                });
            }
        }
    }

    /// When velocity or acceleration limits fail (a hand moves faster than the servos may),
    /// the retimed sequence, if retiming mends them; else `sequence` as it is.
    fn retime_if_needed(
        &self,
        sequence: Sequence,
        report: CheckReport,
    ) -> Result<(Sequence, CheckReport, Option<Retimed>), RecordError> {
        // Timing mends the limits, not a contact: only a limit violation is retimed.
        if report.violations.is_empty() {
            return Ok((sequence, report, None));
        }
        let rate = self.options.check_rate_hz;
        let original = sequence.key_times();
        let mut candidate = sequence.clone();
        let mut candidate_report = report.clone();
        // `retime` gives up on a segment whose need did not fall after a stretch, which also
        // happens when a neighbour's stretch changed its slopes; a fresh call starts over.
        for _ in 0..MAX_RETIME_CALLS {
            let outcome = retime(&candidate, self.robot, rate)?;
            let stretched = !outcome.stretched.is_empty();
            candidate = outcome.sequence;
            candidate_report = outcome.report;
            if candidate_report.violations.is_empty() || !stretched {
                break;
            }
        }
        // Retiming that leaves velocity or acceleration broken is no better than the recorded
        // timing, which at least is what the hand did: keep that one then.
        let speeds_fixed = candidate_report
            .violations
            .iter()
            .all(|v| v.kind == LimitKind::Position);
        let times = candidate.key_times();
        let stretched = (0..times.len().saturating_sub(1))
            .filter(|&i| times[i + 1] - times[i] > original[i + 1] - original[i] + 1e-9)
            .count();
        if !(speeds_fixed && stretched > 0) {
            return Ok((sequence, report, None));
        }
        let retimed = Retimed {
            segments: times.len().saturating_sub(1),
            key_times_before: original,
            key_times_after: times,
            stretched,
        };
        Ok((candidate, candidate_report, Some(retimed)))
    }

    /// Every recorded joint's largest deviation, at the recorded times.
    fn deviations(&self, fit: &Fit) -> Vec<Deviation> {
        self.recorded
            .iter()
            .zip(&fit.deviations)
            .zip(&self.tolerances)
            .map(|((&j, d), &tolerance)| Deviation {
                joint: self.robot.joints[j].name.clone(),
                unit: self.robot.joints[j].kind.unit(),
                value: d.max,
                time: self.times[d.sample],
                share: d.max / tolerance,
            })
            .collect()
    }

    /// The keys at sample indices `keys` as a sequence with absolute times; a key whose mode
    /// differs from the sequence's says so.
    fn build_sequence(&self, keys: &[usize], modes: &[Interp]) -> Sequence {
        let (robot, options) = (self.robot, self.options);
        let keyframes = keys
            .iter()
            .enumerate()
            .map(|(i, &s)| {
                let joints: Vec<(String, KeyValue)> = (0..robot.joints.len())
                    // The first key names every joint, so the file is complete on its own.
                    .filter(|j| i == 0 || self.recorded.contains(j))
                    .map(|j| {
                        (
                            robot.joints[j].name.clone(),
                            KeyValue::Joint(self.values[j][s]),
                        )
                    })
                    .collect();
                let mut key = Keyframe::new(joints);
                key.time = Some(self.times[s]);
                if modes[s] != options.interpolation {
                    key.interp = Some(modes[s]);
                }
                key
            })
            .collect();
        Sequence {
            file: "<recording>".into(),
            robot: robot.name.clone(),
            arms: Vec::new(),
            description: Some(format!(
                "recorded by hand: {} samples, {} keys within {}° / {} m",
                self.times.len(),
                keys.len(),
                options.tolerance_deg,
                options.tolerance_m
            )),
            interpolation: options.interpolation,
            ends: Ends::Played,
            key_interval: None,
            keyframes,
            source: Default::default(),
        }
    }
}

/// A cubic can overshoot a limit between keys that are inside it; monotone cannot. Makes the
/// segments of `report`'s position violations monotone; returns how many were not already.
fn make_overshoots_monotone(report: &CheckReport, keys: &[usize], modes: &mut [Interp]) -> usize {
    let mut changed = 0;
    let overshoots = report
        .violations
        .iter()
        .filter(|v| v.kind == LimitKind::Position)
        .map(|v| v.segment);
    for segment in overshoots {
        let (Some(&a), Some(&b)) = (keys.get(segment), keys.get(segment + 1)) else {
            continue;
        };
        if modes[a] != Interp::Monotone {
            changed += 1;
        }
        for mode in &mut modes[a..b] {
            *mode = Interp::Monotone;
        }
    }
    changed
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
