//! One joint's played curve as spans of polynomials, and where it jumps.
//!
//! A track is a polynomial between any two of its key times and hold ends (a step's is its first
//! value, a hold's the key's); the trajectory plays it over its window and holds it still before
//! and after. Splitting the curve there, and at every key time of the sequence (so that each span
//! lies in one keyframe segment), gives spans on which position, velocity and acceleration are
//! polynomials. Where two spans meet, the value may jump (the end of a step) and the slope may
//! jump (a linear corner, a start in motion): those are the curve's discontinuities.
//!
//! A track runs over path time; where a segment has a timing profile, path time is a quadratic
//! of sequence time on each piece of the profile (`plan::timing`), so the curve's polynomial
//! there is the track's cubic of that quadratic (of a cubic in an S-curve profile, whose path
//! jerk is constant on each piece), split at the pieces' ends too.

use super::poly::Poly;
use crate::curve::Track;
use crate::plan::{Timing, TimingPiece};

/// A polynomial in the seconds since `start`, on [start, end].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    pub start: f64,
    pub end: f64,
    pub poly: Poly,
}

impl Span {
    pub fn len(&self) -> f64 {
        self.end - self.start
    }

    pub fn at_start(&self) -> f64 {
        self.poly.eval(0.0)
    }

    pub fn at_end(&self) -> f64 {
        self.poly.eval(self.len())
    }

    /// The span's derivative (per second).
    pub fn derivative(&self) -> Span {
        Span {
            poly: self.poly.derivative(),
            ..*self
        }
    }

    /// The polynomial with its origin at time `t`.
    pub fn origin_at(&self, t: f64) -> Poly {
        self.poly.shifted(t - self.start)
    }
}

/// Where the curve jumps at `time`: in value (`jump`) and in slope (`kink`, per second); 0 for
/// what does not jump. `moving` says whether the curve moves just before and just after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discontinuity {
    pub time: f64,
    pub jump: f64,
    pub kink: f64,
    pub moving: [bool; 2],
}

/// A joint's curve over the played window, with `margin` seconds of rest on either side.
#[derive(Debug, Clone)]
pub struct JointCurve {
    /// The played window [start, end] in spans; empty when it lasts no time.
    pub played: Vec<Span>,
    /// The same with the rest before and after, each `margin` long.
    pub extended: Vec<Span>,
}

impl JointCurve {
    /// Every joint's curve over `trajectory`'s played window, split at its key times, with no
    /// rest around it: what the check, the exports and the states of motion read.
    pub fn of_trajectory(trajectory: &crate::plan::Trajectory) -> Vec<JointCurve> {
        trajectory
            .tracks()
            .iter()
            .map(|track| {
                JointCurve::new(
                    track,
                    trajectory.timing(),
                    trajectory.start,
                    trajectory.end,
                    &trajectory.key_times,
                    0.0,
                )
            })
            .collect()
    }

    /// `track` played from `start` to `end` (sequence time, mapped to the track's path time
    /// by `timing`), split at `splits` (the sequence's key times).
    pub fn new(
        track: &Track<f64>,
        timing: &Timing,
        start: f64,
        end: f64,
        splits: &[f64],
        margin: f64,
    ) -> Self {
        let mut played = Vec::new();
        let pieces = track_pieces(track);
        for window in timing_windows(timing, start, end) {
            for (a, b, poly) in composed(&pieces, &window) {
                push_split(&mut played, a, b, poly, splits);
            }
        }
        // The player holds the window's end values, which a track gives at those times.
        let before = Span {
            start: start - margin,
            end: start,
            poly: Poly::constant(track.sample(timing.path_time(start))),
        };
        let after = Span {
            start: end,
            end: end + margin,
            poly: Poly::constant(track.sample(timing.path_time(end))),
        };
        let mut extended = Vec::with_capacity(played.len() + 2);
        extended.push(before);
        extended.extend_from_slice(&played);
        extended.push(after);
        JointCurve { played, extended }
    }

    /// The values the player holds before and after the window.
    pub fn rest_values(&self) -> [f64; 2] {
        let last = self.extended.len() - 1;
        [self.extended[0].at_start(), self.extended[last].at_start()]
    }

    /// Every place where the curve (with its rest) jumps in value or in slope, beyond rounding.
    pub fn discontinuities(&self) -> Vec<Discontinuity> {
        self.extended
            .windows(2)
            .filter_map(|w| {
                let (left, right) = (&w[0], &w[1]);
                let (a, b) = (left.at_end(), right.at_start());
                let (va, vb) = (left.derivative().at_end(), right.derivative().at_start());
                // A jump within rounding of the values on either side is no jump.
                let real = |x: f64, y: f64| {
                    let d = y - x;
                    if d.abs() > 1e-9 * (1.0 + x.abs() + y.abs()) {
                        d
                    } else {
                        0.0
                    }
                };
                let (jump, kink) = (real(a, b), real(va, vb));
                (jump != 0.0 || kink != 0.0).then_some(Discontinuity {
                    time: right.start,
                    jump,
                    kink,
                    moving: [real(0.0, va) != 0.0, real(0.0, vb) != 0.0],
                })
            })
            .collect()
    }

    /// The span of the extended curve that plays at `t` (the later one where two meet).
    pub fn span_at(&self, t: f64) -> &Span {
        let i = self.extended.partition_point(|s| s.start <= t);
        &self.extended[i.saturating_sub(1)]
    }
}

/// The track's pieces over all time, as (from, to, polynomial from `from`): the first value
/// before the first key, each key's hold, each segment's motion, the last value after the last
/// key.
fn track_pieces(track: &Track<f64>) -> Vec<(f64, f64, Poly)> {
    let times = track.times();
    let values = track.values();
    let n = times.len();
    let mut pieces = vec![(f64::NEG_INFINITY, times[0], Poly::constant(values[0]))];
    for i in 0..n - 1 {
        let moving = track.move_start(i);
        if moving > times[i] {
            pieces.push((times[i], moving, Poly::constant(values[i])));
        }
        let poly = Poly::new(&track.segment_polynomial(i));
        pieces.push((moving, times[i + 1], poly));
    }
    pieces.push((times[n - 1], f64::INFINITY, Poly::constant(values[n - 1])));
    pieces
}

/// The pieces of `timing` over [start, end], cut to it: one piece of slope 1 for the identity.
fn timing_windows(timing: &Timing, start: f64, end: f64) -> Vec<TimingPiece> {
    let mut cuts = vec![start, end];
    cuts.extend(
        timing
            .pieces()
            .iter()
            .flat_map(|p| [p.t0, p.t1])
            .filter(|&t| t > start && t < end),
    );
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts.windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let middle = timing.piece_at(0.5 * (w[0] + w[1]));
            TimingPiece {
                t0: w[0],
                t1: w[1],
                u0: middle.path_time(w[0]),
                v0: middle.speed(w[0]),
                a: middle.acceleration(w[0]),
                j: middle.j,
            }
        })
        .collect()
}

/// The track's pieces (over path time) that `window` runs through, each as (from, to,
/// polynomial from `from`) in sequence time: the piece's cubic (or quintic) of the window's
/// quadratic (or cubic).
fn composed(pieces: &[(f64, f64, Poly)], window: &TimingPiece) -> Vec<(f64, f64, Poly)> {
    let (u_a, u_b) = (window.u0, window.path_time(window.t1));
    // A window's ends land on a key's path time only to rounding; a sliver of the piece
    // beyond, a few rounding errors long in path time, is no piece of its own. Where the path
    // comes to rest at a key (an S-curve), that sliver would last microseconds of sequence
    // time and start the held value while the path still creeps: a false corner.
    let sliver = 1e-12 * (1.0 + u_a.abs().max(u_b.abs()));
    let first = pieces.partition_point(|p| p.1 <= u_a + sliver);
    let mut out = Vec::new();
    for &(from, to, poly) in pieces[first.min(pieces.len())..]
        .iter()
        .take_while(|p| p.0 < u_b - sliver)
    {
        let (lo, hi) = (from.max(u_a), to.min(u_b));
        let a = if lo <= u_a + sliver {
            window.t0
        } else {
            window.time_at(lo)
        };
        let b = if hi >= u_b - sliver {
            window.t1
        } else {
            window.time_at(hi)
        };
        if b <= a {
            continue;
        }
        let mut q = window.cubic_from(a);
        // A piece reaching to ±∞ is constant: no origin to move.
        if from.is_finite() {
            q[0] -= from;
        }
        out.push((a, b, poly.of_cubic(q)));
    }
    out
}

/// Pushes [a, b] of `poly` (from a) as spans split at the `splits` inside it.
fn push_split(spans: &mut Vec<Span>, a: f64, b: f64, poly: Poly, splits: &[f64]) {
    let first = splits.partition_point(|&s| s <= a);
    let mut from = a;
    for &s in splits[first..].iter().take_while(|&&s| s < b) {
        spans.push(Span {
            start: from,
            end: s,
            poly: poly.shifted(from - a),
        });
        from = s;
    }
    spans.push(Span {
        start: from,
        end: b,
        poly: poly.shifted(from - a),
    });
}
