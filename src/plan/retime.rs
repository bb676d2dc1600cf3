//! Stretching key times, segment by segment, just as much as the velocity and acceleration
//! limits need.
//!
//! Stretching a segment by a factor s divides its own velocities by s and its accelerations by
//! s² — but a key-time cubic's slope at a key depends on both neighbours, a linear corner's
//! acceleration (its velocity change turned within one control period) falls only as 1/s, and
//! a straight tool line is solved again at the control rate along its new time. So no formula
//! gives the stretch a segment needs; the exact check does. Each segment over a limit gets a
//! bracket of stretches, from none to one that mends it (the estimate from the ratios above,
//! doubled until the check passes it, up to [`MAX_STRETCH`]); bisection narrows every bracket
//! at once (each trial stretches all of them and checks once) until every bracket spans less
//! than half of a key time's millisecond, and the smallest stretch that mends each segment is
//! kept. Neighbours change each other's slopes, so the check is repeated and any segment still
//! over a limit gets another round. A trial costs one exact check of the whole trajectory,
//! about ten a round, so retiming scales as the check does: linearly in the keys. Only moving time is stretched: holds stay as written. Position violations
//! and the jumps of step segments cannot be fixed by time and are returned, as is a segment
//! that no stretch up to [`MAX_STRETCH`] mends (left as it was), each with advice that fits its
//! kind ([`advice`]).

use super::{add_clearance, check_limits, Cause, CheckReport, LimitKind, Trajectory, Violation};
use crate::curve::Interp;
use crate::json::InputError;
use crate::robot::Robot;
use crate::sequence::Sequence;

/// The largest stretch tried on one segment: beyond it what is over a limit is not a matter of
/// time (a line through a singularity, a step).
pub const MAX_STRETCH: f64 = 64.0;
const MAX_ROUNDS: usize = 20;
/// At most this many bisection steps: a factor bracket of 2 narrows to 2^(1/2¹⁴), far below a
/// millisecond of any segment a sequence can hold. Bisection stops sooner once every bracket
/// spans less than [`RESOLUTION_S`] of its segment's moving time.
const BISECTIONS: usize = 14;
/// Key times are written in milliseconds (rounded up): a bracket narrower than half of one
/// gives the same file.
const RESOLUTION_S: f64 = 0.5e-3;
/// The search for a segment's stretch starts at this share of its estimate, and climbs by
/// `FINE_STEP` for `FINE_STEPS` trials, then doubles.
const SCAN_START: f64 = 0.9;
const FINE_STEP: f64 = 1.03;
const FINE_STEPS: usize = 24;

/// What [`retime`] made of a sequence.
#[derive(Debug, Clone)]
pub struct RetimeOutcome {
    /// The retimed sequence, with absolute key times.
    pub sequence: Sequence,
    /// Bracket-and-bisect rounds it took.
    pub rounds: usize,
    /// Exact checks of the whole trajectory it ran (each costs about what `check` does, so
    /// retiming costs this many checks).
    pub checks: usize,
    /// (segment, old duration, new duration) of every segment that changed.
    pub stretched: Vec<(usize, f64, f64)>,
    /// The check of the retimed sequence; violations left here cannot be fixed by retiming.
    pub report: CheckReport,
}

/// Stretches the moving segments of `sequence`, each as little as it needs, until its
/// trajectory for `robot` keeps the velocity and acceleration limits, steps and corners judged
/// at a control rate of `rate` Hz. What timing cannot mend (positions, steps, a segment no
/// stretch up to [`MAX_STRETCH`] mends) is left in the outcome's report.
pub fn retime(sequence: &Sequence, robot: &Robot, rate: f64) -> Result<RetimeOutcome, InputError> {
    let mut current = sequence.clone();
    current.make_times_absolute();
    let original = current.key_times();
    let segments = original.len().saturating_sub(1);
    let mut unfixable = vec![false; segments];
    // Timing changes the limits' verdict, not the path: the loop judges the limits alone,
    // and the clearance is checked once, on the result.
    let checks = std::cell::Cell::new(0);
    let judge = |s: &Sequence| -> Result<CheckReport, InputError> {
        checks.set(checks.get() + 1);
        Ok(check_limits(&Trajectory::build(s, robot)?, robot, rate))
    };
    let mut report = judge(&current)?;
    let mut rounds = 0;
    while rounds < MAX_ROUNDS {
        let needs: Vec<(usize, f64)> = estimates(&report, segments)
            .into_iter()
            .filter(|&(i, _)| !unfixable[i])
            .collect();
        if needs.is_empty() {
            break;
        }
        rounds += 1;
        let mut search = Search::new(&current, segments, &needs, &judge);
        search.bracket(&mut unfixable)?;
        search.bisect()?;
        let factors: Vec<(usize, f64)> = zip(&needs, &search.high)
            .into_iter()
            .filter(|&(i, _)| !unfixable[i])
            .collect();
        stretch(&mut current, &factors, segments);
        report = judge(&current)?;
    }
    // The loop's last report is of `current`: the path's clearance and the servos' loads are
    // added to it once, so that it is what `check` says of the result.
    let final_trajectory = Trajectory::build(&current, robot)?;
    add_clearance(&mut report, &final_trajectory, robot);
    report.loads = Some(super::check_loads(&final_trajectory, robot, 1.0));
    let times = current.key_times();
    let stretched = (0..times.len().saturating_sub(1))
        .filter_map(|i| {
            let before = original[i + 1] - original[i];
            let after = times[i + 1] - times[i];
            (after > before + 1e-9).then_some((i, before, after))
        })
        .collect();
    Ok(RetimeOutcome {
        sequence: current,
        rounds,
        checks: checks.get(),
        stretched,
        report,
    })
}

/// One round's search for the stretch of every segment over a limit, all at once: each trial
/// stretches every segment by its own factor and checks the whole trajectory once.
struct Search<'a> {
    base: &'a Sequence,
    segments: usize,
    /// (segment, estimate) of each segment searched.
    needs: &'a [(usize, f64)],
    judge: &'a dyn Fn(&Sequence) -> Result<CheckReport, InputError>,
    /// By search index: a stretch that does not mend the segment.
    low: Vec<f64>,
    /// By search index: a stretch that does.
    high: Vec<f64>,
}

impl<'a> Search<'a> {
    fn new(
        base: &'a Sequence,
        segments: usize,
        needs: &'a [(usize, f64)],
        judge: &'a dyn Fn(&Sequence) -> Result<CheckReport, InputError>,
    ) -> Self {
        Search {
            base,
            segments,
            needs,
            judge,
            low: vec![1.0; needs.len()],
            high: needs
                .iter()
                .map(|&(_, e)| (SCAN_START * e).clamp(1.0 + 1e-6, MAX_STRETCH))
                .collect(),
        }
    }

    /// The base stretched by `factors` (by search index): which segments are still over a
    /// limit.
    fn trial(&self, factors: &[f64]) -> Result<Vec<bool>, InputError> {
        let mut candidate = self.base.clone();
        stretch(&mut candidate, &zip(self.needs, factors), self.segments);
        Ok(segments_over(&(self.judge)(&candidate)?, self.segments))
    }

    /// Brackets: `low` does not mend the segment, `high` does. The search climbs from a
    /// little below the estimate in small steps, since what a stretch does is not always
    /// monotone (a straight tool line is solved again at the control rate along its new
    /// time, and its samples' interpolation changes with their count): the first stretch that
    /// mends a segment is taken, not one far past it. A segment not mended at
    /// [`MAX_STRETCH`] is marked in `unfixable`.
    fn bracket(&mut self, unfixable: &mut [bool]) -> Result<(), InputError> {
        for attempt in 0.. {
            let over = self.trial(&self.high)?;
            let mut widened = false;
            let step = if attempt < FINE_STEPS { FINE_STEP } else { 2.0 };
            for (k, &(i, _)) in self.needs.iter().enumerate() {
                if over[i] && !unfixable[i] {
                    if self.high[k] >= MAX_STRETCH {
                        unfixable[i] = true;
                    } else {
                        self.low[k] = self.high[k];
                        self.high[k] = (self.high[k] * step).min(MAX_STRETCH);
                        widened = true;
                    }
                }
            }
            if !widened {
                return Ok(());
            }
        }
        Ok(())
    }

    /// Narrows every bracket by halving (geometrically) until each spans less than
    /// [`RESOLUTION_S`] of its segment's moving time, or [`BISECTIONS`] halvings.
    fn bisect(&mut self) -> Result<(), InputError> {
        let times = self.base.key_times();
        let moving: Vec<f64> = self
            .needs
            .iter()
            .map(|&(i, _)| times[i + 1] - times[i] - self.base.keyframes[i].hold)
            .collect();
        for _ in 0..BISECTIONS {
            let narrow = (0..self.needs.len())
                .all(|k| (self.high[k] - self.low[k]) * moving[k] < RESOLUTION_S);
            if narrow {
                break;
            }
            let middle: Vec<f64> = self
                .low
                .iter()
                .zip(&self.high)
                .map(|(l, h)| (l * h).sqrt())
                .collect();
            let over = self.trial(&middle)?;
            for (k, &(i, _)) in self.needs.iter().enumerate() {
                if over[i] {
                    self.low[k] = middle[k];
                } else {
                    self.high[k] = middle[k];
                }
            }
        }
        Ok(())
    }
}

fn zip(needs: &[(usize, f64)], factors: &[f64]) -> Vec<(usize, f64)> {
    needs
        .iter()
        .zip(factors)
        .map(|(&(i, _), &f)| (i, f))
        .collect()
}

/// Which of the `segments` have a violation timing can mend (a mask, so that thousands of
/// segments are looked up in constant time each).
fn segments_over(report: &CheckReport, segments: usize) -> Vec<bool> {
    let mut over = vec![false; segments];
    for v in report.violations.iter().filter(|v| v.mendable_by_timing()) {
        if let Some(flag) = over.get_mut(v.segment) {
            *flag = true;
        }
    }
    over
}

/// Each segment over a limit, with a first estimate of its stretch: a velocity falls as 1/s, a
/// curve's acceleration as 1/s², its jerk as 1/s³, a corner's acceleration as 1/s (its period
/// does not stretch).
fn estimates(report: &CheckReport, segments: usize) -> Vec<(usize, f64)> {
    let mut needed: Vec<Option<f64>> = vec![None; segments];
    for v in report.violations.iter().filter(|v| v.mendable_by_timing()) {
        let Some(entry) = needed.get_mut(v.segment) else {
            continue;
        };
        let ratio = v.peak.abs() / v.limit.abs();
        let this = match (v.kind, v.cause) {
            (LimitKind::Acceleration, Cause::Curve) => ratio.sqrt(),
            (LimitKind::Jerk, Cause::Curve) => ratio.cbrt(),
            _ => ratio,
        };
        *entry = Some(entry.map_or(this, |e: f64| e.max(this)));
    }
    needed
        .into_iter()
        .enumerate()
        .filter_map(|(s, e)| e.map(|e| (s, e)))
        .collect()
}

/// Multiplies the moving time of each segment in `factors` by its factor, shifting the keys
/// after it.
fn stretch(sequence: &mut Sequence, factors: &[(usize, f64)], segments: usize) {
    let mut all = vec![1.0; segments];
    for &(i, f) in factors {
        all[i] = f;
    }
    let times = sequence.key_times();
    let mut shift = 0.0;
    for i in 0..times.len() {
        let new_time = times[i] + shift;
        if let Some(&factor) = all.get(i) {
            let hold = sequence.keyframes[i].hold;
            let moving = times[i + 1] - times[i] - hold;
            shift += moving * (factor - 1.0);
        }
        // Millisecond key times read well in files; rounding up keeps every stretch at least
        // as long as computed.
        sequence.keyframes[i].time = Some((new_time * 1000.0 - 1e-6).ceil() / 1000.0 + 0.0);
    }
}

/// Whether stretching time (`keypose retime`, a lower `--speed`) can mend `v`: not a position
/// limit, a step, a corner, an acceleration jump or a straight tool line's need, which
/// [`advice`] says how to mend instead.
pub fn stretch_mends(sequence: &Sequence, v: &Violation) -> bool {
    let line = sequence.keyframes.get(v.segment).is_some_and(|k| k.line);
    v.kind != LimitKind::Position
        && !line
        && matches!(v.cause, Cause::Curve)
        && v.acceleration_jump.is_none()
}

/// What to do about a violation `retime` leaves, for the kind of segment it is in.
pub fn advice(sequence: &Sequence, v: &Violation) -> &'static str {
    let key = sequence.keyframes.get(v.segment);
    let line = key.is_some_and(|k| k.line);
    let mode = key.and_then(|k| k.interp).unwrap_or(sequence.interpolation);
    match (v.kind, v.cause) {
        (LimitKind::Position, _) if matches!(mode, Interp::Cubic | Interp::Smooth) && !line => {
            "the curve overshoots its keys here: use monotone for this segment (it never leaves \
             the range of its keys), or move the keys away from the limit"
        }
        (LimitKind::Position, _) => "move the keys inside the limits",
        (LimitKind::Jerk, _) if v.acceleration_jump.is_some() => {
            "the acceleration jumps here (at a key of a key-time curve, where it starts or ends \
             moving, or at a step or corner), an infinite jerk no stretch mends: use smooth \
             interpolation (its acceleration is continuous through every key and zero at rest), \
             or retime --fastest, which runs each segment from rest to rest along an S-curve \
             when the robot has jerk limits"
        }
        (_, Cause::Step) => {
            "a step jumps within one control period, whatever its time: give this segment \
             linear, smooth, cubic or monotone interpolation"
        }
        _ if line => {
            "the straight tool line needs joint speed no timing gives (it passes near a \
             singularity or changes branch): move its end keys, or drop \"line\" so the segment \
             moves in joint space"
        }
        (_, Cause::Corner) if mode == Interp::Linear => {
            "the linear segments meet at a corner the servos turn within one control period: \
             use smooth, cubic or monotone for this segment so the velocity changes smoothly"
        }
        _ => "no stretch up to 64× mends it: check the keys of this segment",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An SO-101 sequence of `keys` keys 0.12 s apart, each joint swinging by tens of degrees
    /// at incommensurate rates: every segment is over a limit.
    fn dense(keys: usize) -> Sequence {
        let keyframes: Vec<String> = (0..keys)
            .map(|i| {
                let x = i as f64;
                format!(
                    r#"{{"time": {:.3}, "joints": {{"shoulder_pan": {:.3}, "shoulder_lift": {:.3}, "elbow_flex": {:.3}, "wrist_flex": {:.3}}}}}"#,
                    x * 0.12,
                    10.0 * (x * 0.7).sin(),
                    -20.0 + 8.0 * (x * 0.3).sin(),
                    -30.0 + 10.0 * (x * 0.5).cos(),
                    20.0 * (x * 1.1).sin(),
                )
            })
            .collect();
        let text = format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic", "keyframes": [{}]}}"#,
            keyframes.join(", ")
        );
        Sequence::from_json("dense.json", &text).unwrap()
    }

    #[test]
    fn every_segment_mended_in_a_few_checks_a_round_however_many_there_are() {
        let robot = Robot::builtin("so101").unwrap();
        let sequence = dense(300);
        let outcome = retime(&sequence, &robot, 100.0).unwrap();
        assert!(
            outcome.report.violations.is_empty(),
            "{:?}",
            outcome.report.violations
        );
        assert_eq!(
            outcome.stretched.len(),
            299,
            "every segment was over a limit"
        );
        // By hand: the search starts at 0.9 of each estimate and climbs by 3 % (four trials to
        // pass an estimate that was right), then halves brackets 3 % of a ≥ 0.12 s segment wide
        // (3.6 ms) until they are under half a millisecond: three halvings. With the check
        // that ends the round, about eight a round; bisecting to a fixed 14 halvings whatever
        // the bracket took at least 16.
        let per_round = (outcome.checks - 1) as f64 / outcome.rounds as f64;
        assert!(
            per_round <= 12.0,
            "{} checks in {} rounds",
            outcome.checks,
            outcome.rounds
        );
        // Each stretch is the smallest that mends its segment, to the millisecond the file
        // keeps: a millisecond less on any one segment breaks a limit again.
        let times = outcome.sequence.key_times();
        for &(i, _, _) in outcome.stretched.iter().step_by(37) {
            let mut shorter = outcome.sequence.clone();
            for key in &mut shorter.keyframes[i + 1..] {
                key.time = key.time.map(|t| t - 0.002);
            }
            let report = check_limits(&Trajectory::build(&shorter, &robot).unwrap(), &robot, 100.0);
            assert!(
                report.violations.iter().any(|v| v.segment.abs_diff(i) <= 1),
                "segment {i} ({:.3} s) holds 2 ms shorter",
                times[i + 1] - times[i]
            );
        }
    }
}
