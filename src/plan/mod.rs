//! From a sequence and a robot to a timed joint trajectory, and the checks and retiming that
//! work on it.
//!
//! [`Trajectory::build`] turns a [`Sequence`] into one track per joint (solving tool keys and
//! straight tool lines on the way), over path time, which [`Timing`] maps sequence time to (the
//! identity unless a segment has a timing profile); [`check`] finds, exactly, where it exceeds
//! the robot's position, velocity and acceleration limits; [`retime`] stretches key times, each
//! segment as little as it needs, until it does not, and [`fastest`] gives every moving segment
//! the time-optimal profile along its curve; [`Timeline`] says what the arm should do at each
//! control cycle of playback (approach, loops, braking, stalls); [`Sampled`] samples it on an
//! even grid for plots and tables.

mod approach;
pub(crate) mod check;
mod clearance;
mod effort;
mod fastest;
mod lead;
mod limiter;
mod load;
mod retime;
mod sampled;
pub mod scurve;
mod states;
mod timeline;
mod timing;
mod tool_keys;

use crate::curve::{Cursor, CurveError, Track, TrackKey};
use crate::json::InputError;
use crate::pose::{self, RigidTransform};
use crate::robot::{Arm, Joint, JointKind, Robot};
use crate::sequence::{Ends, KeyValue, Sequence};
use std::f64::consts::TAU;

pub(crate) use approach::Approach;
pub use approach::{APPROACH_LIMIT_SHARE, MIN_APPROACH_SECONDS};
pub(crate) use check::{add_clearance, check_limits};
pub use check::{
    check, check_at_speed, radians_warning, Cause, CheckReport, JointSummary, LimitKind, Violation,
};
pub use clearance::{approach_refusal, ClearanceScope, Contact, ContactCause, ContactWindow};
pub use effort::{efforts_at, EffortLimit, FULL_EFFORT};
pub use fastest::{fastest, FastestOutcome, FastestRun};
pub(crate) use limiter::StepLimiter;
pub use load::{
    build_name, check_loads, torques, Droop, JointLoad, LoadReport, LoadScope, Overload, Sample,
    Samples, SETTLED_TOLERANCE_DEG, SETTLED_TOLERANCE_M,
};
pub use retime::{advice, retime, stretch_mends, RetimeOutcome, MAX_STRETCH};
pub use sampled::Sampled;
pub use states::{Side, State, States};
pub use timeline::{Loops, Phase, Timeline, TimelineOptions};
pub use timing::{Timing, TimingPiece};
pub use tool_keys::{KeyMargin, LineExcess, LineReport, LineSpeed, ToolKeyReport, ToolSolve};

/// Largest rotation off the joint axis (swing) accepted in a keyed transform, degrees. Hand-typed
/// quaternions carry rounding of this order; more than that is a rotation the joint cannot make.
pub const SWING_TOLERANCE_DEG: f64 = 0.5;
/// Largest translation a revolute joint's transform may carry, or a prismatic joint's may carry
/// off its axis, metres.
pub const OFF_AXIS_TOLERANCE_M: f64 = 1e-4;

/// The robot of a sequence that names built-in robots only (a program without robot files:
/// tests, fuzzing, a library user): the built-in it names, or the cell of the built-ins its arms
/// name, placed at their bases. None when it names anything else.
pub fn builtin_robot_of(sequence: &Sequence) -> Option<Robot> {
    if !sequence.is_cell() {
        return Robot::builtin(&sequence.robot);
    }
    let arms = sequence
        .arms
        .iter()
        .map(|arm| {
            let base = arm.base.map_or(RigidTransform::IDENTITY, |b| b.transform());
            Robot::builtin(&arm.robot).map(|robot| (arm.name.clone(), robot, base))
        })
        .collect::<Option<Vec<_>>>()?;
    Robot::cell(arms).ok()
}

/// Per-joint tracks in robot joint order and units, with the played time window.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// The robot's joint names, in its joint order (the tracks' order).
    pub joint_names: Vec<String>,
    tracks: Vec<Track<f64>>,
    /// First played time (the first key, or the second with control ends).
    pub start: f64,
    /// Last played time, including the last played key's hold.
    pub end: f64,
    /// Time of every keyframe, in order.
    pub key_times: Vec<f64>,
    /// Name (or "#index") of every keyframe.
    pub key_labels: Vec<String>,
    /// How long each key holds, seconds, in key order.
    pub key_holds: Vec<f64>,
    /// The contacts the keys declare (`"contact"`), with the time each is allowed in.
    pub declared: Vec<ContactWindow>,
    /// The effort limits the keys set (`"effort"`), in time order.
    pub efforts: Vec<EffortLimit>,
    /// The tool keys and straight tool lines solved on the way (empty without them).
    pub tools: ToolSolve,
    /// Sequence time to path time, over which the tracks are built (the identity unless a
    /// segment has a timing profile).
    timing: Timing,
}

impl Trajectory {
    /// Builds the joint tracks, rejecting with a path into the sequence file anything the robot
    /// cannot do: unknown joints, rotations off the joint axis, keys outside the joint limits.
    ///
    /// ```
    /// use keypose::plan::{check, Trajectory};
    /// use keypose::robot::Robot;
    /// use keypose::sequence::Sequence;
    ///
    /// let robot = Robot::builtin("so101").unwrap();
    /// let sequence = Sequence::from_json(
    ///     "nod.json",
    ///     r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "linear",
    ///         "keyframes": [{"time": 0, "joints": {"elbow_flex": 0}},
    ///                       {"time": 2, "joints": {"elbow_flex": 40}}]}"#,
    /// )
    /// .unwrap();
    /// let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    /// let elbow = trajectory.joint_names.iter().position(|j| j == "elbow_flex").unwrap();
    /// assert_eq!(trajectory.sample(0.5)[elbow], 10.0);
    /// // Joints no key names hold the robot's home pose.
    /// assert_eq!(trajectory.sample(0.5)[0], robot.home[0]);
    ///
    /// // A linear start from rest asks for 20 °/s within one 10 ms period: 2000 °/s², beyond
    /// // the SO-101's 344 °/s².
    /// assert!(!check(&trajectory, &robot, 100.0).passed());
    ///
    /// // A key outside the joint's limits is refused, naming where it is in the file.
    /// let outside = Sequence::from_json(
    ///     "far.json",
    ///     r#"{"format": "keypose-sequence/1", "robot": "so101",
    ///         "keyframes": [{"time": 0, "joints": {"elbow_flex": 170}}]}"#,
    /// )
    /// .unwrap();
    /// let error = Trajectory::build(&outside, &robot).unwrap_err().to_string();
    /// assert!(error.contains("far.json") && error.contains("elbow_flex"), "{error}");
    /// ```
    pub fn build(sequence: &Sequence, robot: &Robot) -> Result<Trajectory, InputError> {
        sequence.validate()?;
        let (solved, tools) = tool_keys::solve(sequence, robot)?;
        let sequence = solved.as_ref();
        let key_times = sequence.key_times();
        let path_times = sequence.path_times();
        refuse_unknown_joints(sequence, robot)?;
        // Under jerk limits a line's samples are joined with a continuous acceleration.
        let join = if robot.joints.iter().any(|j| j.limits.jerk.is_some()) {
            LineJoin::Smooth
        } else {
            LineJoin::KeyTimeCubic
        };
        let tracks = (0..robot.joints.len())
            .map(|j| joint_track(sequence, robot, j, &path_times, &tools, join))
            .collect::<Result<Vec<_>, _>>()?;

        let declared = clearance::declared_windows(sequence, robot, &key_times)?;
        let efforts = effort::effort_limits(sequence, robot, &key_times)?;
        let n = key_times.len();
        let (first, last) = match sequence.ends {
            Ends::Played => (0, n - 1),
            Ends::Control => (1, n - 2),
        };
        Ok(Trajectory {
            joint_names: robot.joints.iter().map(|j| j.name.clone()).collect(),
            tracks,
            start: key_times[first],
            end: key_times[last] + sequence.keyframes[last].hold,
            key_labels: sequence
                .keyframes
                .iter()
                .enumerate()
                .map(|(i, k)| k.label(i))
                .collect(),
            key_times,
            key_holds: sequence.keyframes.iter().map(|k| k.hold).collect(),
            declared,
            efforts,
            tools,
            timing: Timing::of(sequence),
        })
    }

    /// The part of a cell's trajectory that arm `arm` plays: its joints' tracks under the
    /// arm's own joint names, in its robot's joint order, on the same timeline.
    pub fn for_arm(&self, arm: &Arm) -> Trajectory {
        Trajectory {
            joint_names: arm
                .robot
                .joint_names()
                .iter()
                .map(|n| n.to_string())
                .collect(),
            tracks: self.tracks[arm.joints.clone()].to_vec(),
            start: self.start,
            end: self.end,
            key_times: self.key_times.clone(),
            key_labels: self.key_labels.clone(),
            key_holds: self.key_holds.clone(),
            declared: self
                .declared
                .iter()
                .filter_map(|w| arm_window(w, &arm.name))
                .collect(),
            efforts: self
                .efforts
                .iter()
                .filter(|e| arm.joints.contains(&e.joint))
                .map(|e| EffortLimit {
                    joint: e.joint - arm.joints.start,
                    ..e.clone()
                })
                .collect(),
            tools: ToolSolve::default(),
            timing: self.timing.clone(),
        }
    }

    /// Where playback starts: the time of key `from_key` inside the played window, or the
    /// window's start.
    pub fn play_from(&self, from_key: Option<usize>) -> f64 {
        from_key
            .and_then(|k| self.key_times.get(k).copied())
            .unwrap_or(self.start)
            .clamp(self.start, self.end)
    }

    /// The trajectory as played from key `from_key` (`play --from`): the window starts there,
    /// from rest, so the limit check sees the start the player makes.
    pub fn starting_at_key(&self, from_key: Option<usize>) -> Trajectory {
        Trajectory {
            start: self.play_from(from_key),
            ..self.clone()
        }
    }

    /// One track per joint, in joint order, over path time ([`Trajectory::path_time`]): the
    /// sequence's own time unless a segment has a timing profile.
    pub fn tracks(&self) -> &[Track<f64>] {
        &self.tracks
    }

    /// How sequence time maps to the tracks' path time.
    pub fn timing(&self) -> &Timing {
        &self.timing
    }

    /// The tracks' path time at sequence time `t` (`t` itself without timing profiles).
    pub fn path_time(&self, t: f64) -> f64 {
        self.timing.path_time(t)
    }

    /// Sequence time of the first key played.
    pub fn start(&self) -> f64 {
        self.start
    }

    /// Seconds of sequence time played, from [`Trajectory::start`] to the end.
    pub fn duration(&self) -> f64 {
        self.end - self.start
    }

    /// Joint values at `t`, clamped to the played window.
    pub fn sample_into(&self, t: f64, out: &mut [f64]) {
        let u = self.path_time(t.clamp(self.start, self.end));
        for (slot, track) in out.iter_mut().zip(&self.tracks) {
            *slot = track.sample(u);
        }
    }

    /// Joint values at `t` in joint order (degrees or metres), clamped to the played window.
    pub fn sample(&self, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; self.tracks.len()];
        self.sample_into(t, &mut out);
        out
    }

    /// A sampler for increasing times, O(1) amortised per joint-sample.
    pub fn sampler(&self) -> Sampler<'_> {
        Sampler {
            trajectory: self,
            cursors: self.tracks.iter().map(|t| t.cursor()).collect(),
        }
    }

    /// Index of the keyframe segment that `t` falls in (segment i runs from key i to key i+1).
    pub fn segment_at(&self, t: f64) -> usize {
        let last_segment = self.key_times.len().saturating_sub(2);
        self.key_times
            .partition_point(|&k| k <= t)
            .saturating_sub(1)
            .min(last_segment)
    }

    /// The last key at or before `t` (key 0 before the first): where playback has got to.
    /// Unlike [`Trajectory::segment_at`] it reaches the last key once `t` does.
    pub fn key_reached(&self, t: f64) -> usize {
        self.key_times
            .partition_point(|&k| k <= t)
            .saturating_sub(1)
    }

    /// "from → to" labels of segment `i`.
    pub fn segment_label(&self, i: usize) -> String {
        match self.key_labels.get(i + 1) {
            Some(next) => format!("{} → {}", self.key_labels[i], next),
            None => self.key_labels[i].clone(),
        }
    }

    /// Times `start + k/rate` from the start to the end inclusive, computed from k so that no
    /// rounding accumulates.
    pub fn grid(&self, rate: f64) -> impl Iterator<Item = f64> + '_ {
        let count = ((self.end - self.start) * rate + 1e-9).floor() as usize;
        (0..=count).map(move |k| self.start + k as f64 / rate)
    }
}

/// A cell's declared contact as one arm's trajectory has it (its own link names), if both
/// links are that arm's.
fn arm_window(window: &ContactWindow, arm: &str) -> Option<ContactWindow> {
    let own = |link: &str| {
        link.strip_prefix(arm)?
            .strip_prefix('/')
            .map(str::to_string)
    };
    let with = match &window.with {
        None => None,
        Some(other) => Some(own(other)?),
    };
    Some(ContactWindow {
        link: own(&window.link)?,
        with,
        ..window.clone()
    })
}

/// Samples all joints at increasing times through one cursor per track.
pub struct Sampler<'a> {
    trajectory: &'a Trajectory,
    cursors: Vec<Cursor<'a, f64>>,
}

impl Sampler<'_> {
    /// Joint values at `t` into `out`, clamped to the played window; `t` must not go back.
    pub fn sample_into(&mut self, t: f64, out: &mut [f64]) {
        let t = t.clamp(self.trajectory.start, self.trajectory.end);
        let u = self.trajectory.path_time(t);
        for (slot, cursor) in out.iter_mut().zip(&mut self.cursors) {
            *slot = cursor.sample(u);
        }
    }
}

fn format_value(v: f64, kind: JointKind) -> String {
    match kind {
        JointKind::Revolute => format!("{v:.3} deg"),
        JointKind::Prismatic => format!("{v:.5} m"),
    }
}

fn value_path(sequence: &Sequence, index: usize, joint: &str, value: &KeyValue) -> String {
    key_value_path(&sequence.key_path(index), joint, value)
}

/// The JSON path of what the key at `key_path` says about `joint`.
pub(crate) fn key_value_path(key_path: &str, joint: &str, value: &KeyValue) -> String {
    let field = match value {
        KeyValue::Joint(_) | KeyValue::Percent(_) => "joints",
        KeyValue::Transform(_) => "transforms",
    };
    let simple = joint
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && !joint.is_empty();
    if simple {
        format!("{key_path}.{field}.{joint}")
    } else {
        format!("{key_path}.{field}[{joint:?}]")
    }
}

/// How a straight tool line's samples are joined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LineJoin {
    /// A key-time cubic: continuous in velocity, its acceleration jumping a little at each
    /// sample.
    KeyTimeCubic,
    /// Smooth interpolation (`curve::Interp::Smooth`): continuous in acceleration too, and
    /// zero acceleration at the line's ends, for a robot with jerk limits, where every jump of
    /// the acceleration is a violation.
    Smooth,
}

/// The solved samples of a straight tool line starting at key `index`, as keys of joint
/// `joint`'s track, joined as `join` says; whether there were any (none when the line could
/// not be followed).
///
/// The line is timed to start and stop at rest (minimum jerk), so its first key is at rest and
/// the key it runs into must be too (the caller marks it). Between them the samples are a
/// key-time cubic: dense samples of a smooth path, whose central-difference slopes follow the
/// path's own. A monotone cubic would stop at every sample where a joint turns back (its slope
/// is zero at a local extreme), and how hard it stops depends on where the control-rate
/// samples fall: a line that passed the check at one duration failed it 40 ms later. Smooth
/// interpolation's slopes follow the path's too (inside, it is the cubic spline through the
/// samples, which through a cubic's samples is that cubic), its second derivative does not jump
/// at the samples, and at the line's ends, at rest, its acceleration is zero, as the
/// minimum-jerk timing's is.
fn push_line_samples(
    keys: &mut Vec<TrackKey<f64>>,
    tools: &ToolSolve,
    index: usize,
    joint: usize,
    join: LineJoin,
) -> bool {
    let Some(line) = tools
        .lines
        .iter()
        .find(|l| l.key == index && l.joints.contains(&joint))
    else {
        return false;
    };
    let mode = match join {
        LineJoin::Smooth => crate::curve::Interp::Smooth,
        LineJoin::KeyTimeCubic => crate::curve::Interp::Cubic,
    };
    if let Some(start) = keys.last_mut() {
        start.rest = true;
        if join == LineJoin::Smooth {
            // The line's first piece is smooth too, whatever the key's own mode.
            start.interp = mode;
        }
    }
    let before = keys.len();
    for (k, time) in line.times.iter().enumerate() {
        if let Some(value) = line.value(k, joint) {
            keys.push(TrackKey::new(*time, value, mode));
        }
    }
    keys.len() > before
}

fn curve_error(sequence: &Sequence, error: CurveError) -> InputError {
    // Sequence validation already enforces these rules on keyframe times; a track is a subset
    // of those keys, so this is reached only through an inconsistent in-memory sequence.
    InputError::at_path(&sequence.file, "$.keyframes", error.to_string())
}

/// Why what a key says about a joint is no value of that joint.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KeyValueError {
    /// A percent of the calibrated range on a joint without a LeRobot calibration.
    #[error(
        "{percent}% of {joint}'s calibrated range, but {joint} has no calibration: a percent \
         needs the arm's LeRobot calibration (--calibration FILE or --robot-id NAME); without \
         one give a number ({unit})"
    )]
    Uncalibrated {
        /// The joint keyed.
        joint: String,
        /// The percent keyed.
        percent: f64,
        /// The joint's unit, "deg" or "m", for the advice.
        unit: &'static str,
    },
    /// A revolute joint's transform with a translation.
    #[error("a revolute joint's transform cannot translate; expected \"t\" to be zero, found {length_m:.5} m")]
    Translates {
        /// Length of the translation, metres.
        length_m: f64,
    },
    /// A revolute joint's rotation not about its axis (more than [`SWING_TOLERANCE_DEG`] off).
    #[error("the rotation is {swing_deg:.2}° off the joint axis {axis:?}; expected a rotation about that axis (at most {SWING_TOLERANCE_DEG}° off)")]
    OffAxisRotation {
        /// The rotation's part off the axis, degrees.
        swing_deg: f64,
        /// The joint's axis, in its parent's frame.
        axis: [f64; 3],
    },
    /// A revolute joint's rotation none of whose turns (±360°) is inside the joint's limits.
    #[error("the rotation ({twist_deg:.3}°) has no representative inside the limits of {joint}: expected {min} … {max} deg")]
    NoTurnInside {
        /// The joint keyed.
        joint: String,
        /// The rotation about the axis, degrees.
        twist_deg: f64,
        /// The joint's lower limit, degrees.
        min: f64,
        /// The joint's upper limit, degrees.
        max: f64,
    },
    /// A prismatic joint's translation not along its axis (more than
    /// [`OFF_AXIS_TOLERANCE_M`] off).
    #[error("the translation is {off_m:.5} m off the joint axis {axis:?}; expected a translation along it")]
    OffAxisTranslation {
        /// The translation's part off the axis, metres.
        off_m: f64,
        /// The joint's axis, in its parent's frame.
        axis: [f64; 3],
    },
    /// A prismatic joint's transform with a rotation.
    #[error("a prismatic joint cannot rotate; expected \"r\" to be the identity, found a {angle_deg:.2}° rotation")]
    Rotates {
        /// Angle of the rotation, degrees.
        angle_deg: f64,
    },
}

/// A joint value (degrees or metres) from what a key says about the joint. `reference` is the
/// previous key's value on this joint (or home): a revolute angle is unwrapped to the turn inside
/// the limits nearest to it. (The mirror reads keys the same way.)
pub fn joint_value(joint: &Joint, value: &KeyValue, reference: f64) -> Result<f64, KeyValueError> {
    match *value {
        KeyValue::Joint(v) => Ok(v),
        KeyValue::Percent(p) => percent_value(joint, p),
        KeyValue::Transform(tf) => match joint.kind {
            JointKind::Revolute => revolute_angle(joint, &tf, reference),
            JointKind::Prismatic => prismatic_offset(joint, &tf),
        },
    }
}

/// The joint value at `percent` of the range its LeRobot calibration recorded: only a
/// calibration says where 0 % and 100 % are, so without one a percent means nothing.
fn percent_value(joint: &Joint, percent: f64) -> Result<f64, KeyValueError> {
    joint
        .calibrated_range
        .map(|range| range.value(percent))
        .ok_or_else(|| KeyValueError::Uncalibrated {
            joint: joint.name.clone(),
            percent,
            unit: joint.kind.unit(),
        })
}

fn revolute_angle(
    joint: &Joint,
    tf: &RigidTransform,
    reference: f64,
) -> Result<f64, KeyValueError> {
    if tf.t.length() > OFF_AXIS_TOLERANCE_M {
        return Err(KeyValueError::Translates {
            length_m: tf.t.length(),
        });
    }
    let (twist, swing) = pose::twist_swing(tf.r, joint.axis);
    if swing.to_degrees() > SWING_TOLERANCE_DEG {
        return Err(KeyValueError::OffAxisRotation {
            swing_deg: swing.to_degrees(),
            axis: joint.axis.to_array(),
        });
    }
    let (min, max) = (joint.limits.min.to_radians(), joint.limits.max.to_radians());
    pose::unwrap_within(twist, reference.to_radians(), min, max, TAU)
        .map(f64::to_degrees)
        .ok_or_else(|| KeyValueError::NoTurnInside {
            joint: joint.name.clone(),
            twist_deg: twist.to_degrees(),
            min: joint.limits.min,
            max: joint.limits.max,
        })
}

fn prismatic_offset(joint: &Joint, tf: &RigidTransform) -> Result<f64, KeyValueError> {
    let along = tf.t.dot(joint.axis);
    let off = (tf.t - joint.axis * along).length();
    if off > OFF_AXIS_TOLERANCE_M {
        return Err(KeyValueError::OffAxisTranslation {
            off_m: off,
            axis: joint.axis.to_array(),
        });
    }
    let angle = pose::rotation_vector(pose::same_hemisphere(glam::DQuat::IDENTITY, tf.r)).length();
    if angle.to_degrees() > SWING_TOLERANCE_DEG {
        return Err(KeyValueError::Rotates {
            angle_deg: angle.to_degrees(),
        });
    }
    Ok(along)
}

/// Refuses a key value of a joint `robot` does not have, naming it and the joints it has.
fn refuse_unknown_joints(sequence: &Sequence, robot: &Robot) -> Result<(), InputError> {
    for (index, key) in sequence.keyframes.iter().enumerate() {
        for (name, value) in &key.values {
            if robot.joint_index(name).is_none() {
                return Err(InputError::at_path(
                    &sequence.file,
                    &value_path(sequence, index, name, value),
                    format!(
                        "unknown joint {name:?} for robot {}; expected one of: {}",
                        robot.name,
                        robot.joint_names().join(", ")
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Joint `joint_index`'s track through the keys that give it a value (its home where none
/// does), each value within its limits, with a straight tool line's samples between its keys.
fn joint_track(
    sequence: &Sequence,
    robot: &Robot,
    joint_index: usize,
    path_times: &[f64],
    tools: &ToolSolve,
    join: LineJoin,
) -> Result<Track<f64>, InputError> {
    let joint = &robot.joints[joint_index];
    let file = sequence.file.as_str();
    let mut keys = Vec::new();
    let mut previous: Option<f64> = None;
    // The key a straight tool line runs into: the line stops there.
    let mut line_ends_here = false;
    for (index, key) in sequence.keyframes.iter().enumerate() {
        let Some(value) = key.value(&joint.name) else {
            continue;
        };
        let path = value_path(sequence, index, &joint.name, value);
        let reference = previous.unwrap_or(robot.home[joint_index]);
        let v = joint_value(joint, value, reference)
            .map_err(|error| InputError::at_path(file, &path, error.to_string()))?;
        if !joint.limits.contains(v) {
            return Err(InputError::at_path(
                file,
                &path,
                format!(
                    "{} is outside the limits of {}: expected {} … {} {}{}",
                    format_value(v, joint.kind),
                    joint.name,
                    joint.limits.min,
                    joint.limits.max,
                    joint.kind.unit(),
                    joint.limits_origin.note()
                ),
            ));
        }
        previous = Some(v);
        let interp = key.interp.unwrap_or(sequence.interpolation);
        let mut track_key =
            TrackKey::new(path_times[index], v, interp).with_hold(key.hold_path_time());
        if line_ends_here {
            track_key = track_key.at_rest();
        }
        keys.push(track_key);
        line_ends_here = push_line_samples(&mut keys, tools, index, joint_index, join);
    }
    if keys.is_empty() {
        keys.push(TrackKey::new(
            path_times[0],
            robot.home[joint_index],
            sequence.interpolation,
        ));
    }
    Track::new(&keys).map_err(|e| curve_error(sequence, e))
}
