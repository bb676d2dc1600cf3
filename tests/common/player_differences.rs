//! The brute-force side of the exact limit check's differential tests (tests/motion/check_exact.rs and
//! the `check_exact` fuzz target): what the player asks of each joint, found by sampling the
//! trajectory (`Trajectory::sample`, which evaluates the tracks and knows nothing of the check's
//! spans) at many phases of every control period, and how it compares with a check report.

use keypose::plan::{CheckReport, Trajectory};
use keypose::robot::Robot;

/// Control rates a differential case is checked at, Hz: the range's ends, the usual 100 Hz and
/// odd ones.
pub const RATES: [f64; 7] = [10.0, 37.0, 50.0, 100.0, 250.0, 500.0, 1000.0];
/// Phases sampled per control period.
pub const PHASES: usize = 16;

/// A differential case from bytes (the `check_exact` fuzz target's input and seeds): a rate
/// byte (an index into [`RATES`], modulo its length), a phase byte (the offset of the sampled
/// phases, in 256ths of their spacing), then sequence file text. None when the text is not
/// UTF-8.
pub fn decode(data: &[u8]) -> Option<(f64, f64, &str)> {
    let rate = RATES[usize::from(*data.first().unwrap_or(&0)) % RATES.len()];
    let offset = f64::from(*data.get(1).unwrap_or(&0)) / 256.0;
    let text = std::str::from_utf8(data.get(2..).unwrap_or_default()).ok()?;
    Some((rate, offset, text))
}

/// The extremes one joint reaches in the samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    pub min_position: f64,
    pub max_position: f64,
    /// Largest |goal velocity|, `(p(t + T/2) − p(t − T/2)) / T`.
    pub velocity: f64,
    /// Largest |goal acceleration|, `(p(t + T) − 2·p(t) + p(t − T)) / T²`.
    pub acceleration: f64,
}

/// Each joint's extremes over the phases `start − T + k·T/phases` up to `end + T` (the arm
/// held still outside the window, as `Trajectory::sample` holds it), `T = 1/rate`, shifted by
/// `offset` (a fraction of T/phases) so that the phases need not fall on key times.
pub fn player_extremes(
    trajectory: &Trajectory,
    rate: f64,
    phases: usize,
    offset: f64,
) -> Vec<Extremes> {
    let period = 1.0 / rate;
    let h = period / phases as f64;
    let first = trajectory.start - period + offset * h;
    let count = ((trajectory.duration() + 2.0 * period) / h).ceil() as usize;
    let joints = trajectory.joint_names.len();
    let mut out = vec![
        Extremes {
            min_position: f64::INFINITY,
            max_position: f64::NEG_INFINITY,
            velocity: 0.0,
            acceleration: 0.0,
        };
        joints
    ];
    for k in 0..=count {
        let t = first + k as f64 * h;
        let (before, at, after) = (
            trajectory.sample(t - period),
            trajectory.sample(t),
            trajectory.sample(t + period),
        );
        let (half_before, half_after) = (
            trajectory.sample(t - period / 2.0),
            trajectory.sample(t + period / 2.0),
        );
        for (j, e) in out.iter_mut().enumerate() {
            e.min_position = e.min_position.min(at[j]);
            e.max_position = e.max_position.max(at[j]);
            let velocity = (half_after[j] - half_before[j]) / period;
            let acceleration = (after[j] - 2.0 * at[j] + before[j]) / (period * period);
            e.velocity = e.velocity.max(velocity.abs());
            e.acceleration = e.acceleration.max(acceleration.abs());
        }
    }
    out
}

/// Panics naming the joint where a sampled extreme goes past what `report` says the peak is
/// (beyond rounding), or where `report` passes but a sample is outside the robot's limits.
pub fn assert_within_report(report: &CheckReport, robot: &Robot, sampled: &[Extremes]) {
    let beyond = |sampled: f64, bound: f64| sampled - bound > 1e-7 * (1.0 + bound.abs());
    for ((summary, joint), s) in report.joints.iter().zip(&robot.joints).zip(sampled) {
        let name = &summary.joint;
        assert!(
            !beyond(summary.min_position, s.min_position)
                && !beyond(s.max_position, summary.max_position),
            "{name}: sampled {} … {}, reported {} … {}",
            s.min_position,
            s.max_position,
            summary.min_position,
            summary.max_position
        );
        assert!(
            !beyond(s.velocity, summary.peak_velocity),
            "{name}: sampled velocity {} beyond the reported peak {}",
            s.velocity,
            summary.peak_velocity
        );
        assert!(
            !beyond(s.acceleration, summary.peak_acceleration),
            "{name}: sampled acceleration {} beyond the reported peak {}",
            s.acceleration,
            summary.peak_acceleration
        );
        if report.passed() {
            let limits = joint.limits;
            assert!(
                !beyond(s.max_position, limits.max)
                    && !beyond(limits.min, s.min_position)
                    && !beyond(s.velocity, limits.velocity)
                    && !beyond(s.acceleration, limits.acceleration),
                "{name}: the check says ok, sampling finds {s:?} against {limits:?}"
            );
        }
    }
}
