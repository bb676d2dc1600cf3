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
//! at once (each trial stretches all of them and checks once) until its ends are a key-time
//! millisecond apart, and the smallest stretch that mends each segment is kept. Neighbours
//! change each other's slopes, so the check is repeated and any segment still over a limit gets
//! another round. Only moving time is stretched: holds stay as written. Position violations
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
/// Bisection steps: a factor bracket of 2 narrows to 2^(1/2¹⁴), far below a millisecond of any
/// segment a sequence can hold.
const BISECTIONS: usize = 14;
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
    let judge = |s: &Sequence| -> Result<CheckReport, InputError> {
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
        let base = current.clone();
        let trial = |factors: &[(usize, f64)]| -> Result<Vec<usize>, InputError> {
            let mut candidate = base.clone();
            stretch(&mut candidate, factors, segments);
            Ok(segments_over(&judge(&candidate)?))
        };
        // Brackets: `low` does not mend the segment, `high` does. The search climbs from a
        // little below the estimate in small steps, since what a stretch does is not always
        // monotone (a straight tool line is solved again at the control rate along its new
        // time, and its samples' interpolation changes with their count): the first stretch
        // that mends a segment is taken, not one far past it.
        let mut low: Vec<f64> = vec![1.0; needs.len()];
        let mut high: Vec<f64> = needs
            .iter()
            .map(|&(_, e)| (SCAN_START * e).clamp(1.0 + 1e-6, MAX_STRETCH))
            .collect();
        for attempt in 0.. {
            let over = trial(&zip(&needs, &high))?;
            let mut widened = false;
            let step = if attempt < FINE_STEPS { FINE_STEP } else { 2.0 };
            for (k, &(i, _)) in needs.iter().enumerate() {
                if over.contains(&i) && !unfixable[i] {
                    if high[k] >= MAX_STRETCH {
                        unfixable[i] = true;
                    } else {
                        low[k] = high[k];
                        high[k] = (high[k] * step).min(MAX_STRETCH);
                        widened = true;
                    }
                }
            }
            if !widened {
                break;
            }
        }
        for _ in 0..BISECTIONS {
            let middle: Vec<f64> = low.iter().zip(&high).map(|(l, h)| (l * h).sqrt()).collect();
            let over = trial(&zip(&needs, &middle))?;
            for (k, &(i, _)) in needs.iter().enumerate() {
                if over.contains(&i) {
                    low[k] = middle[k];
                } else {
                    high[k] = middle[k];
                }
            }
        }
        let factors: Vec<(usize, f64)> = zip(&needs, &high)
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
        stretched,
        report,
    })
}

fn zip(needs: &[(usize, f64)], factors: &[f64]) -> Vec<(usize, f64)> {
    needs
        .iter()
        .zip(factors)
        .map(|(&(i, _), &f)| (i, f))
        .collect()
}

/// The segments with a violation timing can mend, in order, each once.
fn segments_over(report: &CheckReport) -> Vec<usize> {
    let mut out: Vec<usize> = report
        .violations
        .iter()
        .filter(|v| v.mendable_by_timing())
        .map(|v| v.segment)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Each segment over a limit, with a first estimate of its stretch: a velocity falls as 1/s, a
/// curve's acceleration as 1/s², its jerk as 1/s³, a corner's acceleration as 1/s (its period
/// does not stretch).
fn estimates(report: &CheckReport, segments: usize) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    for v in report.violations.iter().filter(|v| v.mendable_by_timing()) {
        if v.segment >= segments {
            continue;
        }
        let ratio = v.peak.abs() / v.limit.abs();
        let needed = match (v.kind, v.cause) {
            (LimitKind::Acceleration, Cause::Curve) => ratio.sqrt(),
            (LimitKind::Jerk, Cause::Curve) => ratio.cbrt(),
            _ => ratio,
        };
        match out.iter_mut().find(|(s, _)| *s == v.segment) {
            Some(entry) => entry.1 = entry.1.max(needed),
            None => out.push((v.segment, needed)),
        }
    }
    out.sort_by_key(|&(s, _)| s);
    out
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
        (LimitKind::Position, _) if mode == Interp::Cubic && !line => {
            "the cubic overshoots its keys here: use monotone for this segment (it never leaves \
             the range of its keys), or move the keys away from the limit"
        }
        (LimitKind::Position, _) => "move the keys inside the limits",
        (LimitKind::Jerk, _) if v.acceleration_jump.is_some() => {
            "the acceleration jumps here (at a key of a key-time curve, where it starts or ends \
             moving, or at a step or corner), an infinite jerk no stretch mends: use retime \
             --fastest, which runs each segment from rest to rest along an S-curve when the \
             robot has jerk limits"
        }
        (_, Cause::Step) => {
            "a step jumps within one control period, whatever its time: give this segment \
             linear, cubic or monotone interpolation"
        }
        _ if line => {
            "the straight tool line needs joint speed no timing gives (it passes near a \
             singularity or changes branch): move its end keys, or drop \"line\" so the segment \
             moves in joint space"
        }
        (_, Cause::Corner) if mode == Interp::Linear => {
            "the linear segments meet at a corner the servos turn within one control period: \
             use cubic or monotone for this segment so the velocity changes smoothly"
        }
        _ => "no stretch up to 64× mends it: check the keys of this segment",
    }
}
