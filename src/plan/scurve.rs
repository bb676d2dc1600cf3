//! Jerk-limited motion from rest to rest: the S-curve, seven phases of constant jerk.
//!
//! A move of distance `d` that starts and ends at rest with zero acceleration, under limits on
//! velocity `v`, acceleration `a` and jerk `j`, is fastest when it raises its acceleration at
//! full jerk, holds it at `a` if it gets there, lowers it at full jerk to reach the peak speed,
//! cruises at that speed, and then brakes as the mirror image: jerk `+j, 0, −j, 0, −j, 0, +j`
//! over `tj, ta, tj, tv, tj, ta, tj` seconds. Its acceleration is continuous everywhere (no
//! jump, so no infinite jerk), and the three times are in closed form:
//!
//! - with a cruise (the peak speed reaches `v`): `tj = min(a/j, √(v/j))`, `ta = v/(j·tj) − tj`,
//!   `tv = d/v − (2·tj + ta)`;
//! - without one, reaching `a`: `tj = a/j`, `ta = (√(tj² + 4d/a) − 3·tj)/2`, `tv = 0`;
//! - reaching neither: `tj = ∛(d/(2j))`, `ta = tv = 0`.
//!
//! The distance it covers is `j·tj·(tj + ta)·(2·tj + ta + tv)` (the peak speed times the time
//! from the start to the middle of the cruise), which is how a shape of the three times is
//! given its jerk when it is scaled to another duration or distance ([`SCurve::shaped`]). This
//! is the time-optimal profile Ruckig finds for a rest-to-rest move of one axis; the benchmark
//! `benches/scurve.rs` and the tests compare the two.

use crate::curve::Track;
use crate::plan::check::poly::Poly;
use crate::robot::{Limits, Robot};

/// A path slope below this (degrees or metres per path second) is at rest.
const AT_REST: f64 = 1e-9;

/// Limits on one motion (or on a path parameter), each positive; the jerk may be infinite (no
/// jerk limit: the S-curve becomes the trapezoid of a plain acceleration limit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JerkLimits {
    /// Highest speed, per second.
    pub velocity: f64,
    /// Highest acceleration, per second squared.
    pub acceleration: f64,
    /// Highest jerk, per second cubed.
    pub jerk: f64,
}

impl JerkLimits {
    /// `share` of a joint's limits (its jerk infinite without a jerk limit).
    pub fn of(limits: &Limits, share: f64) -> JerkLimits {
        JerkLimits {
            velocity: limits.velocity * share,
            acceleration: limits.acceleration * share,
            jerk: limits.jerk.map_or(f64::INFINITY, |j| j * share),
        }
    }
}

/// A symmetric rest-to-rest S-curve: its phase times and its jerk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SCurve {
    /// Seconds of each of the four phases of constant jerk.
    pub jerk_time: f64,
    /// Seconds of each of the two phases of constant acceleration.
    pub acceleration_time: f64,
    /// Seconds of the cruise at the peak speed.
    pub cruise_time: f64,
    /// The jerk of the first phase, per second cubed (negative for a move backwards).
    pub jerk: f64,
}

/// Position, velocity and acceleration at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionState {
    /// Distance from the start.
    pub position: f64,
    /// Per second.
    pub velocity: f64,
    /// Per second squared.
    pub acceleration: f64,
}

impl SCurve {
    /// The fastest S-curve over `distance` (either sign) under `limits`.
    pub fn fastest(distance: f64, limits: JerkLimits) -> SCurve {
        let d = distance.abs();
        let JerkLimits {
            velocity: v,
            acceleration: a,
            jerk: j,
        } = limits;
        let shape = if d == 0.0 {
            [0.0; 3]
        } else if j.is_infinite() {
            // A trapezoid: the jerk phases last nothing.
            let ta = (v / a).min((d / a).sqrt());
            [0.0, ta, (d / (a * ta) - ta).max(0.0)]
        } else {
            let [tj, ta] = speed_change(v, a, j);
            if v * (2.0 * tj + ta) <= d {
                [tj, ta, (d / v - (2.0 * tj + ta)).max(0.0)]
            } else {
                let tj = a / j;
                let ta = 0.5 * ((tj * tj + 4.0 * d / a).sqrt() - 3.0 * tj);
                if ta >= 0.0 {
                    [tj, ta, 0.0]
                } else {
                    [(d / (2.0 * j)).cbrt(), 0.0, 0.0]
                }
            }
        };
        let jerk = if j.is_infinite() { f64::INFINITY } else { j };
        SCurve {
            jerk_time: shape[0],
            acceleration_time: shape[1],
            cruise_time: shape[2],
            jerk: jerk.copysign(distance),
        }
    }

    /// The S-curve whose phase times have the proportions of `shape` (`[tj, ta, tv]`, seconds,
    /// `tj` > 0), scaled to last `seconds`, with the jerk that makes it cover `distance`.
    pub fn shaped(shape: [f64; 3], seconds: f64, distance: f64) -> SCurve {
        let [tj, ta, tv] = shape;
        let scale = seconds / (4.0 * tj + 2.0 * ta + tv);
        let (tj, ta, tv) = (tj * scale, ta * scale, tv * scale);
        SCurve {
            jerk_time: tj,
            acceleration_time: ta,
            cruise_time: tv,
            jerk: distance / (tj * (tj + ta) * (2.0 * tj + ta + tv)),
        }
    }

    /// `[tj, ta, tv]`.
    pub fn shape(&self) -> [f64; 3] {
        [self.jerk_time, self.acceleration_time, self.cruise_time]
    }

    /// Seconds from start to rest.
    pub fn duration(&self) -> f64 {
        4.0 * self.jerk_time + 2.0 * self.acceleration_time + self.cruise_time
    }

    /// The seven phases as `(seconds, jerk)`, some of them lasting no time.
    pub fn phases(&self) -> [(f64, f64); 7] {
        let (tj, ta, tv, j) = (
            self.jerk_time,
            self.acceleration_time,
            self.cruise_time,
            self.jerk,
        );
        [
            (tj, j),
            (ta, 0.0),
            (tj, -j),
            (tv, 0.0),
            (tj, -j),
            (ta, 0.0),
            (tj, j),
        ]
    }

    /// Where the motion is `t` seconds after its start (at rest before it and after its end).
    pub fn state_at(&self, t: f64) -> MotionState {
        let mut state = MotionState {
            position: 0.0,
            velocity: 0.0,
            acceleration: 0.0,
        };
        if t <= 0.0 {
            return state;
        }
        let mut left = t.min(self.duration());
        for (seconds, jerk) in self.phases() {
            if seconds <= 0.0 {
                continue;
            }
            let tau = left.min(seconds);
            state = advance(state, jerk, tau);
            left -= tau;
            if left <= 0.0 {
                break;
            }
        }
        if t >= self.duration() {
            // The end is rest, exactly: no rounding left over from the phases.
            state.velocity = 0.0;
            state.acceleration = 0.0;
        }
        state
    }
}

/// The fastest change of speed by `change` from rest (zero acceleration at both ends) under the
/// acceleration and jerk limits: `[tj, ta]`, jerk phases of `tj` on either side of `ta` at the
/// full acceleration (none when the jerk phases meet first). A jerk phase lasts no time with
/// an infinite jerk limit; with both limits infinite the change is instant.
pub fn speed_change(change: f64, acceleration: f64, jerk: f64) -> [f64; 2] {
    if acceleration.is_infinite() {
        return [0.0, 0.0];
    }
    if jerk.is_infinite() {
        return [0.0, change / acceleration];
    }
    let tj = (acceleration / jerk).min((change / jerk).sqrt());
    if tj == 0.0 {
        return [0.0, 0.0];
    }
    // Where the jerk phases meet (tj = √(change/j)) the difference is zero but for rounding,
    // which may leave it a few 1e-17 below: no phase lasts a negative time.
    [tj, (change / (jerk * tj) - tj).max(0.0)]
}

/// One joint along a stretch of path: the largest magnitudes of its first three derivatives
/// with respect to the path parameter there, and its limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlongPath {
    /// Largest |dq/du|.
    pub slope: f64,
    /// Largest |d²q/du²|.
    pub curvature: f64,
    /// Largest |d³q/du³|.
    pub third: f64,
    /// The joint's limits (the jerk infinite without one).
    pub limits: JerkLimits,
}

/// Steps in which [`along_path`] tries shares of the path speed and acceleration.
const SPLITS: u32 = 20;
/// Without a jerk limit on any joint that moves, the S-curve still needs a finite path jerk:
/// one that reaches the path acceleration in this many seconds.
const UNLIMITED_JERK_SECONDS: f64 = 1e-3;

/// The fastest S-curve of the path parameter over `length` that keeps every joint within its
/// limits wherever it is on the path. Along the path `q(u(t))`:
///
/// - velocity `q'·u̇`, bounded by `slope·V`;
/// - acceleration `q''·u̇² + q'·ü`, bounded by `curvature·V² + slope·A`;
/// - jerk `q'''·u̇³ + 3·q''·u̇·ü + q'·u⃛`, bounded by `third·V³ + 3·curvature·V·A + slope·J`,
///
/// for a path speed up to `V`, path acceleration up to `A` and path jerk up to `J`. Each
/// bound within each joint's limit is sufficient; the split of the acceleration and jerk
/// budgets between the terms is chosen among `SPLITS`² shares of `V` and `A` ([`candidates`])
/// as the one that takes the least time. On a straight line (`curvature` and `third` 0) the
/// best is the whole budget, and the result is the time-optimal straight-line move. None when
/// no joint moves.
pub fn along_path(length: f64, joints: &[AlongPath]) -> Option<SCurve> {
    if let Some(straight) = straight_line(length, joints) {
        return Some(straight);
    }
    candidates(length, joints)
        .into_iter()
        .min_by(|a, b| a.duration().total_cmp(&b.duration()))
}

/// On a straight line (no moving joint curves: `curvature` and `third` 0) the bounds of
/// [`along_path`] do not couple, and a time-optimal S-curve is never slower for higher limits:
/// the best split is the whole budget, the last of the [`candidates`], found in one solve
/// (a point-to-point move is this). None off a straight line, or when nothing moves.
fn straight_line(length: f64, joints: &[AlongPath]) -> Option<SCurve> {
    let mut moving = joints.iter().filter(|j| j.slope > 0.0).peekable();
    moving.peek()?;
    let mut limits = JerkLimits {
        velocity: f64::INFINITY,
        acceleration: f64::INFINITY,
        jerk: f64::INFINITY,
    };
    for j in moving {
        if j.curvature != 0.0 || j.third != 0.0 {
            return None;
        }
        limits.velocity = limits.velocity.min(j.limits.velocity / j.slope);
        limits.acceleration = limits.acceleration.min(j.limits.acceleration / j.slope);
        limits.jerk = limits.jerk.min(j.limits.jerk / j.slope);
    }
    if !(limits.acceleration > 0.0 && limits.acceleration.is_finite()) || limits.jerk <= 0.0 {
        return None;
    }
    limits.jerk = limits
        .jerk
        .min(limits.acceleration / UNLIMITED_JERK_SECONDS);
    Some(SCurve::fastest(length, limits))
}

/// The S-curves over `length` for every split of the budgets [`along_path`] tries, each within
/// the limits by the bounds there.
pub fn candidates(length: f64, joints: &[AlongPath]) -> Vec<SCurve> {
    let moving: Vec<&AlongPath> = joints.iter().filter(|j| j.slope > 0.0).collect();
    let least =
        |f: &dyn Fn(&AlongPath) -> f64| moving.iter().map(|j| f(j)).fold(f64::INFINITY, f64::min);
    let top_speed = least(&|j| j.limits.velocity / j.slope);
    let mut out = Vec::new();
    for kv in 1..=SPLITS {
        let v = top_speed * f64::from(kv) / f64::from(SPLITS);
        let room = least(&|j| (j.limits.acceleration - j.curvature * v * v) / j.slope);
        if room <= 0.0 || !room.is_finite() {
            continue;
        }
        for ka in 1..=SPLITS {
            let a = room * f64::from(ka) / f64::from(SPLITS);
            let jerk = least(&|j| {
                (j.limits.jerk - j.third * v * v * v - 3.0 * j.curvature * v * a) / j.slope
            });
            if jerk <= 0.0 {
                continue;
            }
            let limits = JerkLimits {
                velocity: v,
                acceleration: a,
                jerk: jerk.min(a / UNLIMITED_JERK_SECONDS),
            };
            out.push(SCurve::fastest(length, limits));
        }
    }
    out
}

/// How `track` moves between path times `from` and `to`: the largest magnitudes of its first
/// three derivatives there (exact: each piece is a cubic, or a smooth segment's quintic), with
/// `limits` times `share`.
pub fn along_track(
    track: &Track<f64>,
    from: f64,
    to: f64,
    limits: &Limits,
    share: f64,
) -> AlongPath {
    let mut out = AlongPath {
        slope: 0.0,
        curvature: 0.0,
        third: 0.0,
        limits: JerkLimits::of(limits, share),
    };
    let times = track.times();
    for k in 0..times.len().saturating_sub(1) {
        let start = track.move_start(k);
        let (lo, hi) = (start.max(from), times[k + 1].min(to));
        if hi <= lo {
            continue;
        }
        // Exact peaks of each derivative: a cubic's or a smooth segment's quintic.
        let (a, b) = (lo - start, hi - start);
        let velocity = Poly::new(&track.segment_polynomial(k))
            .shifted(a)
            .derivative();
        let acceleration = velocity.derivative();
        let jerk = acceleration.derivative();
        out.slope = out.slope.max(velocity.peak_magnitude(b - a));
        out.curvature = out.curvature.max(acceleration.peak_magnitude(b - a));
        out.third = out.third.max(jerk.peak_magnitude(b - a));
    }
    // Rounding of a joint that does not move is no slope.
    if out.slope <= AT_REST {
        out.slope = 0.0;
    }
    out
}

/// Instants per phase at which [`time_scale`] measures the joints.
const SAMPLES_PER_PHASE: usize = 48;

/// The factor by which `curve`, run along the tracks from path time `from`, must be stretched in
/// time (below 1: may be shrunk) for its peaks to be `share` of the joints' limits at most.
/// Stretching by k divides velocities by k, accelerations by k² and jerks by k³, so the
/// factor is the largest of the peak ratios, their square and cube roots. The peaks are
/// measured at evenly spaced instants of each phase, both ends included (the jerk changes only
/// there), from the exact derivatives; the exact check confirms the result.
pub fn time_scale(
    curve: &SCurve,
    tracks: &[Track<f64>],
    limits: &[&Limits],
    from: f64,
    share: f64,
) -> f64 {
    let mut factor: f64 = 0.0;
    let mut state = MotionState {
        position: 0.0,
        velocity: 0.0,
        acceleration: 0.0,
    };
    for (seconds, jerk) in curve.phases() {
        if seconds <= 0.0 {
            continue;
        }
        for k in 0..=SAMPLES_PER_PHASE {
            let at = advance(state, jerk, seconds * k as f64 / SAMPLES_PER_PHASE as f64);
            let (ud, udd) = (at.velocity, at.acceleration);
            for (track, limits) in tracks.iter().zip(limits) {
                let [d1, d2, d3] = derivatives(track, from + at.position);
                let v = d1 * ud;
                let a = d2 * ud * ud + d1 * udd;
                let j = d3 * ud * ud * ud + 3.0 * d2 * ud * udd + d1 * jerk;
                factor = factor
                    .max(v.abs() / (share * limits.velocity))
                    .max((a.abs() / (share * limits.acceleration)).sqrt());
                if let Some(limit) = limits.jerk {
                    factor = factor.max((j.abs() / (share * limit)).cbrt());
                }
            }
        }
        state = advance(state, jerk, seconds);
    }
    factor
}

/// The first three derivatives of `track` at path time `u`, from the polynomial it moves on there
/// (0 in a hold and outside its keys).
fn derivatives(track: &Track<f64>, u: f64) -> [f64; 3] {
    let times = track.times();
    if times.len() < 2 || u < times[0] || u > times[times.len() - 1] {
        return [0.0; 3];
    }
    let k = times
        .partition_point(|&t| t <= u)
        .saturating_sub(1)
        .min(times.len() - 2);
    let s = u - track.move_start(k);
    if s < 0.0 {
        return [0.0; 3];
    }
    let velocity = Poly::new(&track.segment_polynomial(k)).derivative();
    let acceleration = velocity.derivative();
    [
        velocity.eval(s),
        acceleration.eval(s),
        acceleration.derivative().eval(s),
    ]
}

/// A point-to-point move of `robot` from `from` to `to` (joint values in robot order) from
/// rest to rest along the straight line between them, as fast as `share` of every joint's
/// limits allow: the S-curve of the line's parameter from 0 to 1 (a joint without a jerk limit
/// adds none). None when nothing moves.
pub fn point_to_point(robot: &Robot, from: &[f64], to: &[f64], share: f64) -> Option<SCurve> {
    let joints: Vec<AlongPath> = robot
        .joints
        .iter()
        .zip(from.iter().zip(to))
        .map(|(joint, (a, b))| AlongPath {
            slope: (b - a).abs(),
            curvature: 0.0,
            third: 0.0,
            limits: JerkLimits::of(&joint.limits, share),
        })
        .collect();
    along_path(1.0, &joints)
}

/// `state` after `tau` seconds at constant `jerk`.
pub fn advance(state: MotionState, jerk: f64, tau: f64) -> MotionState {
    let MotionState {
        position: p,
        velocity: v,
        acceleration: a,
    } = state;
    MotionState {
        position: p + tau * (v + tau * (a / 2.0 + tau * jerk / 6.0)),
        velocity: v + tau * (a + tau * jerk / 2.0),
        acceleration: a + tau * jerk,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(velocity: f64, acceleration: f64, jerk: f64) -> JerkLimits {
        JerkLimits {
            velocity,
            acceleration,
            jerk,
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    }

    #[test]
    fn each_case_covers_its_distance_and_ends_at_rest_within_its_limits() {
        // Long (cruise at v), middle (reaches a, not v), short (reaches neither).
        let l = limits(100.0, 400.0, 4000.0);
        for (d, cruise, full_acceleration) in [
            (200.0, true, true),
            (30.0, false, true),
            (1.0, false, false),
        ] {
            let s = SCurve::fastest(d, l);
            let end = s.state_at(s.duration());
            assert!(close(end.position, d), "{d}: {s:?} {end:?}");
            let mid = s.state_at(2.0 * s.jerk_time + s.acceleration_time);
            assert_eq!(s.cruise_time > 0.0, cruise, "{d}: {s:?}");
            assert!(mid.velocity <= 100.0 * (1.0 + 1e-12), "{mid:?}");
            assert!(!cruise || close(mid.velocity, 100.0), "{mid:?}");
            let peak_a = s.state_at(s.jerk_time).acceleration;
            assert_eq!(close(peak_a, 400.0), full_acceleration, "{d}: {peak_a}");
            assert!(peak_a <= 400.0 * (1.0 + 1e-12));
        }
    }

    #[test]
    fn a_long_move_takes_the_textbook_time() {
        // v = 100, a = 400, j = 4000: tj = 0.1, ta = 100/400 − 0.1 = 0.15; accelerating takes
        // 2·0.1 + 0.15 = 0.35 s and covers 100·0.35/2 = 17.5, twice 35; the other 165 at 100
        // take 1.65 s: 0.7 + 1.65 = 2.35 s.
        let s = SCurve::fastest(200.0, limits(100.0, 400.0, 4000.0));
        assert!(close(s.duration(), 2.35), "{s:?}");
        // Backwards: the same times, the jerk negated.
        let back = SCurve::fastest(-200.0, limits(100.0, 400.0, 4000.0));
        assert_eq!(back.shape(), s.shape());
        assert!(close(back.state_at(10.0).position, -200.0));
    }

    #[test]
    fn a_shape_scaled_keeps_its_proportions_and_covers_the_distance() {
        let s = SCurve::fastest(50.0, limits(100.0, 400.0, 4000.0));
        let slower = SCurve::shaped(s.shape(), 2.0 * s.duration(), 50.0);
        assert!(close(slower.duration(), 2.0 * s.duration()));
        assert!(close(slower.jerk, s.jerk / 8.0), "{slower:?}");
        assert!(close(slower.state_at(slower.duration()).position, 50.0));
    }

    #[test]
    fn a_straight_line_takes_the_best_of_every_split_in_one_solve() {
        // The oracle is the search over every split of the budgets, which a straight line
        // skips: its one solve must be as fast as the best split, and within the limits.
        let joint = |slope: f64, l: JerkLimits| AlongPath {
            slope,
            curvature: 0.0,
            third: 0.0,
            limits: l,
        };
        let cases = [
            vec![joint(90.0, limits(200.0, 800.0, 8000.0))],
            vec![
                joint(30.0, limits(200.0, 800.0, 8000.0)),
                joint(120.0, limits(150.0, 300.0, 1e4)),
                joint(0.0, limits(1.0, 1.0, 1.0)),
            ],
            // One joint without a jerk limit, one whose jerk binds.
            vec![
                joint(5.0, limits(100.0, 400.0, f64::INFINITY)),
                joint(60.0, limits(300.0, 2000.0, 900.0)),
            ],
        ];
        for joints in cases {
            for length in [1e-3, 0.3, 1.0, 40.0] {
                let straight = along_path(length, &joints).unwrap();
                let best = candidates(length, &joints)
                    .into_iter()
                    .map(|c| c.duration())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    straight.duration() <= best * (1.0 + 1e-12),
                    "{joints:?} {length}"
                );
                assert!(
                    straight.duration() >= best * (1.0 - 1e-9),
                    "{joints:?} {length}"
                );
                assert!(close(
                    straight.state_at(straight.duration()).position,
                    length
                ));
            }
        }
        // Off a straight line it is not taken.
        let curved = [AlongPath {
            curvature: 10.0,
            ..joint(90.0, limits(200.0, 800.0, 8000.0))
        }];
        assert!(straight_line(1.0, &curved).is_none());
    }
}
