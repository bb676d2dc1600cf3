//! Stretching key times until velocity and acceleration limits hold.
//!
//! Stretching a segment by a factor s divides its velocities by s and its accelerations by s²,
//! so a segment whose worst velocity is r_v times its limit and worst acceleration r_a times its
//! limit needs s = max(r_v, √r_a); a linear corner's acceleration is its velocity change turned
//! within one control period, so it falls only as 1/s and needs s = r_a. Segments are not
//! independent — a key's slope depends on both neighbours — so the stretch is applied and the
//! check repeated until it passes. Only moving time is stretched: holds stay as written. The
//! check's peaks are exact, so a stretch lands on the limit, not short of it. Position
//! violations and the jumps of step segments cannot be fixed by time and are returned.

use super::{check, Cause, CheckReport, LimitKind, Trajectory};
use crate::json::InputError;
use crate::robot::Robot;
use crate::sequence::Sequence;

/// Margin added to each stretch: the peaks are exact, so this only keeps a round from landing
/// on the limit by rounding.
const MARGIN: f64 = 1.0 + 1e-6;
const MAX_ROUNDS: usize = 100;

/// What [`retime`] made of a sequence.
#[derive(Debug, Clone)]
pub struct RetimeOutcome {
    /// The retimed sequence, with absolute key times.
    pub sequence: Sequence,
    /// Stretch-and-check rounds it took.
    pub rounds: usize,
    /// (segment, old duration, new duration) of every segment that changed.
    pub stretched: Vec<(usize, f64, f64)>,
    /// The check of the retimed sequence; violations left here cannot be fixed by retiming.
    pub report: CheckReport,
}

/// Stretches the moving segments of `sequence` until its trajectory for `robot` keeps the
/// velocity and acceleration limits, steps and corners judged at a control rate of `rate` Hz.
/// What timing cannot mend (positions, steps) is left in the outcome's report.
pub fn retime(sequence: &Sequence, robot: &Robot, rate: f64) -> Result<RetimeOutcome, InputError> {
    let mut current = sequence.clone();
    current.make_times_absolute();
    let original = current.key_times();
    let segments = original.len().saturating_sub(1);
    let mut previous_need = vec![1.0f64; segments];
    // A segment whose need does not fall after a stretch (by a tenth of what it exceeds 1 by)
    // is left alone; a step's is never stretched at all.
    let mut unfixable = vec![false; segments];
    let mut rounds = 0;
    let report = loop {
        let trajectory = Trajectory::build(&current, robot)?;
        let report = check(&trajectory, robot, rate);
        let mut factors = stretch_factors(&report, current.keyframes.len());
        for i in 0..segments {
            if previous_need[i] > 1.0 && factors[i] - 1.0 > 0.9 * (previous_need[i] - 1.0) {
                unfixable[i] = true;
            }
            previous_need[i] = factors[i];
            if unfixable[i] {
                factors[i] = 1.0;
            }
        }
        if rounds == MAX_ROUNDS || factors.iter().all(|&f| f <= 1.0) {
            break report;
        }
        stretch(&mut current, &factors);
        rounds += 1;
    };
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

/// The stretch each segment needs, 1 where none.
fn stretch_factors(report: &CheckReport, keys: usize) -> Vec<f64> {
    let mut factors = vec![1.0f64; keys.saturating_sub(1)];
    for v in &report.violations {
        let ratio = v.peak.abs() / v.limit.abs();
        let needed = match (v.kind, v.cause) {
            (LimitKind::Position, _) | (_, Cause::Step) => continue,
            (LimitKind::Velocity, _) | (LimitKind::Acceleration, Cause::Corner) => ratio,
            (LimitKind::Acceleration, Cause::Curve) => ratio.sqrt(),
        };
        if let Some(f) = factors.get_mut(v.segment) {
            *f = f.max(needed * MARGIN);
        }
    }
    factors
}

/// Multiplies each segment's moving time by its factor, shifting the keys after it.
fn stretch(sequence: &mut Sequence, factors: &[f64]) {
    let times = sequence.key_times();
    let mut shift = 0.0;
    for i in 0..times.len() {
        let new_time = times[i] + shift;
        if let Some(&factor) = factors.get(i) {
            let hold = sequence.keyframes[i].hold;
            let moving = times[i + 1] - times[i] - hold;
            shift += moving * (factor - 1.0);
        }
        // Millisecond key times read well in files; rounding up keeps every stretch at least
        // as long as computed.
        sequence.keyframes[i].time = Some((new_time * 1000.0).ceil() / 1000.0);
    }
}
