//! Every joint's position, velocity and acceleration at any instant of the played window,
//! from the same polynomial spans the check reads (`check::spans`): exact, and on either side
//! of an instant where a joint's acceleration jumps (a key of a cubic, a timing piece's end).

use super::check::spans::{JointCurve, Span};
use super::Trajectory;

/// Which side of an instant to read, where a derivative jumps there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The limit from before.
    Before,
    /// The limit from after.
    After,
}

/// The joints' state of motion at one instant, joint units (degrees or metres), per second
/// and per second squared, robot order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct State {
    /// Sequence time, seconds.
    pub time: f64,
    /// Positions.
    pub values: Vec<f64>,
    /// Velocities.
    pub velocities: Vec<f64>,
    /// Accelerations.
    pub accelerations: Vec<f64>,
}

/// One joint's spans and their first two derivatives.
#[derive(Debug, Clone)]
struct Joint {
    spans: Vec<[Span; 3]>,
    /// Where the window does not move the joint: its value.
    rest: f64,
}

/// A trajectory's states of motion, per joint.
#[derive(Debug, Clone)]
pub struct States {
    joints: Vec<Joint>,
    start: f64,
    end: f64,
}

impl States {
    /// The states of `trajectory` over its played window.
    pub fn of(trajectory: &Trajectory) -> States {
        let joints = JointCurve::of_trajectory(trajectory)
            .into_iter()
            .map(|curve| {
                let rest = curve.rest_values()[0];
                let spans = curve
                    .played
                    .iter()
                    .map(|s| {
                        let v = s.derivative();
                        [*s, v, v.derivative()]
                    })
                    .collect();
                Joint { spans, rest }
            })
            .collect();
        States {
            joints,
            start: trajectory.start,
            end: trajectory.end,
        }
    }

    /// Every instant where some joint's span ends, in order, the window's ends included: the
    /// places where an acceleration may jump, to be read from both sides.
    pub fn breaks(&self) -> Vec<f64> {
        let mut times: Vec<f64> = vec![self.start, self.end];
        for joint in &self.joints {
            times.extend(joint.spans.iter().map(|s| s[0].start));
        }
        times.sort_by(f64::total_cmp);
        times.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        times
    }

    /// The state at sequence time `t` (clamped to the window), read from `side` where a
    /// derivative jumps at `t`.
    pub fn at(&self, t: f64, side: Side) -> State {
        let mut state = State {
            time: t,
            ..State::default()
        };
        self.fill(t, side, &mut state);
        state
    }

    /// [`States::at`] into `state`, reusing its buffers.
    pub fn fill(&self, t: f64, side: Side, state: &mut State) {
        let t = t.clamp(self.start, self.end);
        state.time = t;
        state.values.clear();
        state.velocities.clear();
        state.accelerations.clear();
        for joint in &self.joints {
            let [p, v, a] = match joint.span_at(t, side) {
                Some(spans) => spans.map(|s| s.poly.eval(t - s.start)),
                None => [joint.rest, 0.0, 0.0],
            };
            state.values.push(p);
            state.velocities.push(v);
            state.accelerations.push(a);
        }
    }
}

impl Joint {
    /// The span that holds `t`, the one ending there when read from before.
    fn span_at(&self, t: f64, side: Side) -> Option<&[Span; 3]> {
        if self.spans.is_empty() {
            return None;
        }
        // First span starting after t (Side::After) or at/after t (Side::Before).
        let next = self.spans.partition_point(|s| match side {
            Side::After => s[0].start <= t,
            Side::Before => s[0].start < t,
        });
        Some(&self.spans[next.saturating_sub(1)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use crate::sequence::Sequence;

    #[test]
    fn a_cubic_through_three_keys_reads_its_own_derivatives_and_both_sides_of_a_key() {
        let robot = Robot::builtin("so101").unwrap();
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{"time": 0, "joints": {"elbow_flex": 0}},
                          {"time": 1, "joints": {"elbow_flex": 30}},
                          {"time": 3, "joints": {"elbow_flex": 0}}]}"#;
        let sequence = Sequence::from_json("t.json", text).unwrap();
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let states = States::of(&trajectory);
        let elbow = robot.joint_index("elbow_flex").unwrap();
        // Central differences of the sampled positions are the velocity and acceleration.
        let h = 1e-4;
        for t in [0.3, 0.7, 1.6, 2.4] {
            let s = states.at(t, Side::After);
            let p = |t: f64| trajectory.sample(t)[elbow];
            assert!((s.values[elbow] - p(t)).abs() < 1e-9);
            let v = (p(t + h) - p(t - h)) / (2.0 * h);
            let a = (p(t + h) - 2.0 * p(t) + p(t - h)) / (h * h);
            assert!((s.velocities[elbow] - v).abs() < 1e-5, "{t}");
            assert!((s.accelerations[elbow] - a).abs() < 1e-2, "{t}");
        }
        // At the middle key the velocity is continuous and the acceleration may jump.
        let before = states.at(1.0, Side::Before);
        let after = states.at(1.0, Side::After);
        assert!((before.velocities[elbow] - after.velocities[elbow]).abs() < 1e-9);
        assert!(states.breaks().contains(&1.0));
        // A joint that no key moves rests.
        let pan = robot.joint_index("shoulder_pan").unwrap();
        assert_eq!(after.velocities[pan], 0.0);
    }
}
