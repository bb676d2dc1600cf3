//! The map from sequence time to path time: the one place where a segment's timing profile
//! (`"timing"`, `sequence::SegmentTiming`) acts.
//!
//! The tracks are built over path time (the key times the curves were shaped with,
//! `Sequence::path_times`), so a profile changes when each point of a curve is reached and
//! never the curve. Sequence time runs through path time piece by piece: at slope 1 in a hold
//! and in a segment without a profile (there the two differ by a constant), and in a profiled
//! segment with the path speed changing evenly between the profile's points, so path time is a
//! quadratic of sequence time on each piece; in a segment with an S-curve profile the path
//! acceleration changes evenly instead (constant path jerk), and path time is a cubic; so in a
//! hold with an S-curve (its timing's `"hold"`), which runs the hold's path time from rest to rest in
//! the hold's seconds. Everything that samples a trajectory (the player's timeline, `sample`,
//! `plot`, `sim`) goes through [`Trajectory::sample`](super::Trajectory), which goes through
//! here; the exact check composes each curve with these pieces.

use super::scurve::{advance, MotionState, SCurve};
use crate::sequence::{Sequence, TimeProfile};

/// One piece of the map: from sequence time `t0` to `t1`, path time
/// `u0 + v0·τ + a·τ²/2 + j·τ³/6` with τ = t − t0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimingPiece {
    /// Sequence time the piece starts, seconds.
    pub t0: f64,
    /// Sequence time it ends, seconds.
    pub t1: f64,
    /// Path time at `t0`, seconds.
    pub u0: f64,
    /// Path speed at `t0` (path seconds per second).
    pub v0: f64,
    /// Path acceleration at `t0` (per second).
    pub a: f64,
    /// Path jerk on the piece (per second squared): 0 but in an S-curve profile.
    pub j: f64,
}

impl TimingPiece {
    /// Path time at sequence time `t` (extrapolated outside the piece).
    pub fn path_time(&self, t: f64) -> f64 {
        let tau = t - self.t0;
        self.u0 + tau * (self.v0 + tau * (0.5 * self.a + tau * self.j / 6.0))
    }

    /// Path speed at sequence time `t`.
    pub fn speed(&self, t: f64) -> f64 {
        let tau = t - self.t0;
        self.v0 + tau * (self.a + 0.5 * self.j * tau)
    }

    /// Path acceleration at sequence time `t`.
    pub fn acceleration(&self, t: f64) -> f64 {
        self.a + self.j * (t - self.t0)
    }

    /// Path time as a cubic `[c0, c1, c2, c3]` of the seconds since `t`.
    pub fn cubic_from(&self, t: f64) -> [f64; 4] {
        [
            self.path_time(t),
            self.speed(t),
            0.5 * self.acceleration(t),
            self.j / 6.0,
        ]
    }

    /// The sequence time inside the piece at which path time reaches `u` (clamped to it).
    pub fn time_at(&self, u: f64) -> f64 {
        let du = u - self.u0;
        if du <= 0.0 {
            return self.t0;
        }
        if self.j != 0.0 {
            // Path time never falls along a piece: bisect to the last bit.
            let (mut lo, mut hi) = (self.t0, self.t1);
            for _ in 0..200 {
                let m = 0.5 * (lo + hi);
                if m <= lo || m >= hi {
                    break;
                }
                if self.path_time(m) < u {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            return 0.5 * (lo + hi);
        }
        // v0·τ + a·τ²/2 = du, in the form that does not cancel when a is small.
        let root = (self.v0 * self.v0 + 2.0 * self.a * du).max(0.0).sqrt();
        let tau = 2.0 * du / (self.v0 + root);
        (self.t0 + tau).min(self.t1)
    }
}

/// Sequence time to path time over a whole sequence: slope 1 before its first key and after
/// its last, the pieces in between. No pieces: the identity (a sequence without profiles).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timing {
    pieces: Vec<TimingPiece>,
    /// (sequence time, path time) of the last key: the map's slope-1 tail starts there.
    tail: (f64, f64),
}

impl Timing {
    /// The map of `sequence`, whose keys must be valid (`Sequence::validate`).
    pub fn of(sequence: &Sequence) -> Timing {
        if !sequence.has_timing() {
            return Timing::default();
        }
        let times = sequence.key_times();
        let paths = sequence.path_times();
        let mut pieces = Vec::new();
        for i in 0..times.len() - 1 {
            let key = &sequence.keyframes[i];
            let moving_from = times[i] + key.hold;
            match key.timing.as_ref().and_then(|t| t.hold) {
                // Through the hold on an S-curve: its path time in its seconds.
                Some(hold) if key.hold > 0.0 => {
                    let curve = SCurve::shaped(hold.scurve, key.hold, hold.path_time);
                    s_curve_pieces(&mut pieces, &curve, times[i], moving_from, paths[i]);
                }
                _ if key.hold > 0.0 => pieces.push(TimingPiece {
                    t0: times[i],
                    t1: moving_from,
                    u0: paths[i],
                    v0: 1.0,
                    a: 0.0,
                    j: 0.0,
                }),
                _ => {}
            }
            let u_from = paths[i] + key.hold_path_time();
            match &key.timing {
                None => pieces.push(TimingPiece {
                    t0: moving_from,
                    t1: times[i + 1],
                    u0: u_from,
                    v0: 1.0,
                    a: 0.0,
                    j: 0.0,
                }),
                Some(timing) => match &timing.profile {
                    TimeProfile::Speeds(speeds) => {
                        let seconds = timing.stretch_seconds();
                        // The speeds are a shape: one factor makes them last the key times' span.
                        let scale = (times[i + 1] - moving_from) / seconds.iter().sum::<f64>();
                        let step = timing.path_time / seconds.len() as f64;
                        let mut t = moving_from;
                        for (k, &dt) in seconds.iter().enumerate() {
                            let dt = dt * scale;
                            let (v0, v1) = (speeds[k] / scale, speeds[k + 1] / scale);
                            let last = k + 1 == seconds.len();
                            let t1 = if last { times[i + 1] } else { t + dt };
                            pieces.push(TimingPiece {
                                t0: t,
                                t1,
                                u0: u_from + k as f64 * step,
                                v0,
                                a: (v1 - v0) / dt,
                                j: 0.0,
                            });
                            t = t1;
                        }
                    }
                    TimeProfile::SCurve(shape) => {
                        let curve =
                            SCurve::shaped(*shape, times[i + 1] - moving_from, timing.path_time);
                        s_curve_pieces(&mut pieces, &curve, moving_from, times[i + 1], u_from);
                    }
                },
            }
        }
        let last = times.len() - 1;
        Timing {
            pieces,
            tail: (times[last], paths[last]),
        }
    }

    /// Whether sequence time is path time everywhere.
    pub fn is_identity(&self) -> bool {
        self.pieces.is_empty()
    }

    /// The pieces in time order (none for the identity).
    pub fn pieces(&self) -> &[TimingPiece] {
        &self.pieces
    }

    /// The piece sequence time `t` falls in, as a piece of slope 1 before the first and after
    /// the last (the identity is one such piece).
    pub fn piece_at(&self, t: f64) -> TimingPiece {
        let Some(first) = self.pieces.first() else {
            return TimingPiece {
                t0: t,
                t1: t,
                u0: t,
                v0: 1.0,
                a: 0.0,
                j: 0.0,
            };
        };
        if t < first.t0 {
            return TimingPiece {
                t0: first.t0,
                t1: first.t0,
                u0: first.u0,
                v0: 1.0,
                a: 0.0,
                j: 0.0,
            };
        }
        if t >= self.tail.0 {
            return TimingPiece {
                t0: self.tail.0,
                t1: f64::INFINITY,
                u0: self.tail.1,
                v0: 1.0,
                a: 0.0,
                j: 0.0,
            };
        }
        let i = self.pieces.partition_point(|p| p.t0 <= t).saturating_sub(1);
        self.pieces[i]
    }

    /// Path time at sequence time `t`.
    pub fn path_time(&self, t: f64) -> f64 {
        if self.is_identity() {
            return t;
        }
        self.piece_at(t).path_time(t)
    }

    /// Path speed at sequence time `t` (path seconds per second; 1 without a profile).
    pub fn speed(&self, t: f64) -> f64 {
        if self.is_identity() {
            return 1.0;
        }
        self.piece_at(t).speed(t)
    }
}

/// The pieces of an S-curve profile from sequence time `from` and path time `u_from`, its last
/// piece ending at `to` (the next key).
fn s_curve_pieces(pieces: &mut Vec<TimingPiece>, curve: &SCurve, from: f64, to: f64, u_from: f64) {
    let mut state = MotionState {
        position: u_from,
        velocity: 0.0,
        acceleration: 0.0,
    };
    let mut t = from;
    let phases: Vec<(f64, f64)> = curve
        .phases()
        .into_iter()
        .filter(|&(seconds, _)| seconds > 0.0)
        .collect();
    for (k, &(seconds, jerk)) in phases.iter().enumerate() {
        let t1 = if k + 1 == phases.len() {
            to
        } else {
            t + seconds
        };
        pieces.push(TimingPiece {
            t0: t,
            t1,
            u0: state.position,
            v0: state.velocity,
            a: state.acceleration,
            j: jerk,
        });
        state = advance(state, jerk, seconds);
        t = t1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sequence(text: &str) -> Sequence {
        Sequence::from_json("t.json", text).unwrap()
    }

    #[test]
    fn a_profile_runs_its_path_time_in_its_keys_time() {
        // Path time 2 s in two stretches of 1; speeds 0, 1, 1 as written last 2 + 1 = 3 s,
        // and the keys give 1.5 s after the hold: every speed doubles. The first stretch, from
        // rest to 2, lasts 1 s at 2 /s²; the second 0.5 s at 2.
        let s = sequence(
            r#"{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
                {"time": 0, "hold": 0.5, "timing": {"path_time": 2, "speeds": [0, 1, 1]},
                 "joints": {"elbow_flex": 0}},
                {"time": 2, "joints": {"elbow_flex": 10}},
                {"time": 3, "joints": {"elbow_flex": 0}}]}"#,
        );
        assert_eq!(s.path_times(), vec![0.0, 2.5, 3.5]);
        let timing = Timing::of(&s);
        // In the hold, path time is sequence time.
        assert_eq!(timing.path_time(0.25), 0.25);
        // 0.25 s into the first stretch: u = 0.5 + ½·2·0.25².
        assert!((timing.path_time(0.75) - 0.5625).abs() < 1e-12);
        assert!((timing.path_time(1.0) - 0.75).abs() < 1e-12);
        assert!((timing.speed(1.0) - 1.0).abs() < 1e-12);
        assert!((timing.path_time(1.5) - 1.5).abs() < 1e-12);
        // Second stretch at 2 /s: 1.5 + 2·0.25.
        assert!((timing.path_time(1.75) - 2.0).abs() < 1e-12);
        assert!((timing.path_time(2.0) - 2.5).abs() < 1e-12);
        // The next segment has no profile: slope 1, and after the last key too.
        assert!((timing.path_time(2.5) - 3.0).abs() < 1e-12);
        assert!((timing.path_time(4.0) - 4.5).abs() < 1e-12);
        assert_eq!(timing.path_time(-1.0), -1.0);
        // And back: path time 0.5625 is reached 0.25 s into the stretch.
        let piece = timing.piece_at(0.75);
        assert!((piece.time_at(0.5625) - 0.75).abs() < 1e-12);
    }

    #[test]
    fn a_sequence_without_profiles_is_the_identity() {
        let s = sequence(
            r#"{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
                {"time": 0, "joints": {"elbow_flex": 0}}, {"time": 2, "joints": {"elbow_flex": 10}}]}"#,
        );
        assert_eq!(s.path_times(), s.key_times());
        assert!(Timing::of(&s).is_identity());
    }
}
