//! The motions `space`, `y` and the jogs ask for, planned from the list and the goals alone:
//! pure functions, so what the arm would be sent is tested without servos or a session.
//!
//! Every motion runs on the player (its ramp, limiter, guard, stop braking along the path and
//! fault handling), on the session's motion thread, so that a stop request is acted on within
//! one control period whatever the motion is — a jog included.

use super::format;
use crate::json::InputError;
use crate::plan::{self, CheckReport, TimelineOptions, Trajectory};
use crate::player::PlayOptions;
use crate::robot::Robot;
use crate::sequence::{KeyValue, Keyframe, Sequence};

/// What a motion on the player's thread is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    /// `space`: to key `index`, with the approach ramp.
    ToKey(usize),
    /// `y`: the sequence from key `from`.
    Play {
        /// The key playback starts from.
        from: usize,
    },
    /// An arrow key, a tool jog or the studio's tool handle: these joints (robot order) to
    /// these values, the others left as they are.
    Jog,
}

/// A motion for the player: the approach ramp from the present pose, then `trajectory`.
#[derive(Debug, Clone)]
pub struct MotionPlan {
    /// What the motion is for.
    pub kind: MotionKind,
    /// What the player drives: the session's robot, or for a jog its jogged joints alone
    /// ([`Robot::only`]), so that the others (limp ones too) are neither written nor switched on.
    pub robot: Robot,
    /// The driven joints' indices in the session's robot, in the order of `robot`'s joints.
    pub joints: Vec<usize>,
    /// The trajectory played after the approach ramp, for `robot`.
    pub trajectory: Trajectory,
    /// How the player plays it (rate, speed, first key).
    pub options: PlayOptions,
    /// Where the arm is commanded at the end when the motion finishes.
    pub end_pose: Vec<f64>,
}

/// Why `y` does not play.
#[derive(Debug)]
pub(crate) enum PlayRefusal {
    /// The list does not build into a trajectory on this robot.
    Unplayable(InputError),
    /// At this speed the trajectory breaks the robot's limits, or it makes a contact, as
    /// `keypose play` would refuse.
    Limits(Box<CheckReport>),
}

/// `space`: to key `index` of `sequence` by the player's approach ramp alone.
///
/// The target is the pose playback passes through at that key (joints the key does not name
/// follow their own tracks), evaluated on the tracks so that control keys are reached too.
pub(crate) fn to_key(
    robot: &Robot,
    sequence: &Sequence,
    index: usize,
) -> Result<MotionPlan, InputError> {
    let trajectory = Trajectory::build(sequence, robot)?;
    let pose = pose_at(&trajectory, robot, sequence.key_time(index));
    let mut target = Sequence::new(&robot.name);
    target.file = format!("<{}>", format::key_label(sequence, index));
    target.keyframes.push(Keyframe::new(
        robot
            .joints
            .iter()
            .zip(&pose)
            .map(|(j, &v)| (j.name.clone(), KeyValue::Joint(v)))
            .collect(),
    ));
    // One key: the player's approach ramp is the whole motion.
    Ok(MotionPlan {
        kind: MotionKind::ToKey(index),
        robot: robot.clone(),
        joints: (0..robot.joints.len()).collect(),
        trajectory: Trajectory::build(&target, robot)?,
        options: PlayOptions {
            progress: false,
            ..PlayOptions::new(robot.control_hz)
        },
        end_pose: pose,
    })
}

/// Every key's pose as playback passes through it — the pose [`to_key`] moves the arm to:
/// joints a key leaves out on their own tracks, tool keys as solved. The studio draws these
/// as the keys' ghosts, so that what the screen shows is where `space` goes.
pub(crate) fn key_poses(robot: &Robot, sequence: &Sequence) -> Result<Vec<Vec<f64>>, InputError> {
    let trajectory = Trajectory::build(sequence, robot)?;
    Ok(sequence
        .key_times()
        .into_iter()
        .map(|time| pose_at(&trajectory, robot, time))
        .collect())
}

/// What each of `poses` (a robot's, robot order) touches closer than the robot's clearance, in
/// words — the first contact, `None` where it is clear (and for a robot with no collision
/// model): what the studio draws a key's ghost red for, as `space` would refuse to go there.
pub(crate) fn pose_contacts(robot: &Robot, poses: &[Vec<f64>]) -> Vec<Option<String>> {
    let Some(model) = crate::collision::CollisionModel::for_robot(robot) else {
        return vec![None; poses.len()];
    };
    poses
        .iter()
        .map(|pose| {
            let touches = model.touches(pose, robot.clearance);
            touches.first().map(|t| t.describe())
        })
        .collect()
}

/// The tracks at sequence time `time`, inside the limits; not clamped to the played window, so
/// that control keys (outside it) are reached too.
fn pose_at(trajectory: &Trajectory, robot: &Robot, time: f64) -> Vec<f64> {
    trajectory
        .tracks()
        .iter()
        .zip(&robot.joints)
        .map(|(track, joint)| {
            let value = track.sample(trajectory.path_time(time));
            value.clamp(joint.limits.min, joint.limits.max)
        })
        .collect()
}

/// `y`: `sequence` from key `from` at `speed`, at the robot's control rate, refused (as
/// `keypose play --from` refuses) when anything played goes beyond the limits at that speed —
/// the start at that key from rest included.
pub(crate) fn play(
    robot: &Robot,
    sequence: &Sequence,
    from: usize,
    speed: f64,
) -> Result<MotionPlan, PlayRefusal> {
    let trajectory = Trajectory::build(sequence, robot).map_err(PlayRefusal::Unplayable)?;
    let rate = robot.control_hz;
    let played = trajectory.starting_at_key(Some(from));
    let report = plan::check_at_speed(&played, robot, rate, speed);
    if !report.passed() {
        return Err(PlayRefusal::Limits(Box::new(report)));
    }
    let end_pose = trajectory.sample(trajectory.end);
    Ok(MotionPlan {
        kind: MotionKind::Play { from },
        robot: robot.clone(),
        joints: (0..robot.joints.len()).collect(),
        trajectory,
        options: PlayOptions {
            timeline: TimelineOptions {
                speed,
                from_key: Some(from),
                ..TimelineOptions::default()
            },
            progress: false,
            ..PlayOptions::new(rate)
        },
        end_pose,
    })
}

/// A jog: `jogged` joints (robot order, values already inside their limits) from the goals
/// they hold, `goals`, to their new values, by the player's approach ramp alone on those
/// joints — within half their velocity and acceleration limits and timed by them (no
/// deliberate half second: the start is a held goal, known to a tick), brakeable along its
/// path like any playback.
pub(crate) fn jog(
    robot: &Robot,
    goals: &[f64],
    jogged: &[(usize, f64)],
) -> Result<MotionPlan, InputError> {
    let joints: Vec<usize> = jogged.iter().map(|&(j, _)| j).collect();
    let driven = robot.only(&joints);
    let mut target = Sequence::new(&robot.name);
    target.file = "<jog>".into();
    target.keyframes.push(Keyframe::new(
        jogged
            .iter()
            .map(|&(j, v)| (robot.joints[j].name.clone(), KeyValue::Joint(v)))
            .collect(),
    ));
    let mut end_pose = goals.to_vec();
    for &(j, v) in jogged {
        end_pose[j] = v;
    }
    Ok(MotionPlan {
        kind: MotionKind::Jog,
        trajectory: Trajectory::build(&target, &driven)?,
        robot: driven,
        joints,
        options: PlayOptions {
            progress: false,
            timeline: TimelineOptions {
                shortest_approach: 0.0,
                ..TimelineOptions::default()
            },
            // A jog has no timing to keep: after a long stall it resumes along its ramp (the
            // limiter bounding every step) rather than stopping with a fault, which on a busy
            // machine would leave the arm short of where the key asked. Stalls too frequent to
            // keep up with still stop it.
            max_stall: JOG_MAX_STALL,
            ..PlayOptions::new(robot.control_hz)
        },
        end_pose,
    })
}

/// The longest stall a jog plays on through, seconds.
const JOG_MAX_STALL: f64 = 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::Ends;

    fn pans(degrees: &[f64]) -> Sequence {
        let mut sequence = Sequence::new("so101");
        for &deg in degrees {
            sequence.keyframes.push(Keyframe::new(vec![(
                "shoulder_pan".into(),
                KeyValue::Joint(deg),
            )]));
        }
        sequence
    }

    #[test]
    fn a_move_to_a_key_is_one_key_reached_by_the_approach_ramp() {
        let robot = Robot::builtin("so101").unwrap();
        let plan = to_key(&robot, &pans(&[0.0, 20.0, 40.0]), 1).unwrap();
        assert_eq!(plan.kind, MotionKind::ToKey(1));
        assert!(plan.options.timeline.approach && !plan.options.progress);
        assert_eq!(plan.trajectory.key_times.len(), 1);
        assert!(
            (plan.end_pose[0] - 20.0).abs() < 1e-9,
            "{:?}",
            plan.end_pose
        );
        // Joints the key does not name stay where playback has them: home.
        assert_eq!(&plan.end_pose[1..], &robot.home[1..]);
    }

    #[test]
    fn a_control_key_is_reached_at_its_own_pose() {
        let robot = Robot::builtin("so101").unwrap();
        let mut sequence = pans(&[-20.0, 0.0, 10.0, 40.0]);
        sequence.ends = Ends::Control;
        let plan = to_key(&robot, &sequence, 0).unwrap();
        assert!(
            (plan.end_pose[0] + 20.0).abs() < 1e-9,
            "{:?}",
            plan.end_pose
        );
    }

    #[test]
    fn playback_starts_at_the_key_and_ends_at_the_last_pose() {
        let robot = Robot::builtin("so101").unwrap();
        let plan = play(&robot, &pans(&[0.0, 20.0]), 1, 1.5).unwrap();
        assert_eq!(plan.kind, MotionKind::Play { from: 1 });
        assert_eq!(plan.options.timeline.from_key, Some(1));
        assert_eq!(plan.options.timeline.speed, 1.5);
        assert_eq!(plan.options.rate_hz, robot.control_hz);
        assert!((plan.end_pose[0] - 20.0).abs() < 1e-9);
    }

    #[test]
    fn a_jog_drives_the_jogged_joints_alone_within_half_their_limits() {
        let robot = Robot::builtin("so101").unwrap();
        let goals = [0.0, 5.0, 0.0, 0.0, 0.0, 0.0];
        let plan = jog(&robot, &goals, &[(3, 10.0)]).unwrap();
        assert_eq!(plan.kind, MotionKind::Jog);
        assert_eq!(plan.joints, [3]);
        let names: Vec<&str> = plan.robot.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["wrist_flex"]);
        assert_eq!(plan.end_pose, [0.0, 5.0, 0.0, 10.0, 0.0, 0.0]);
        assert!(plan.options.timeline.approach && plan.options.timeline.shortest_approach == 0.0);
        // From 0 to 10°, the minimum-jerk ramp at half the wrist's limits: its time is the
        // larger of 15/8 · 10 / (v/2) and √(10/√3 · 10 / (a/2)).
        let wrist = &robot.joints[3].limits;
        let by_velocity = 15.0 / 8.0 * 10.0 / (wrist.velocity / 2.0);
        let by_acceleration = (10.0 / 3f64.sqrt() * 10.0 / (wrist.acceleration / 2.0)).sqrt();
        let timeline = crate::plan::Timeline::new(
            &plan.robot,
            &plan.trajectory,
            &plan.options.timeline,
            &[0.0],
        );
        assert!(
            (timeline.approach_seconds() - by_velocity.max(by_acceleration)).abs() < 1e-12,
            "{} vs {by_velocity} / {by_acceleration}",
            timeline.approach_seconds()
        );
    }

    #[test]
    fn playback_from_a_key_the_arm_passes_at_speed_is_refused_as_play_from_refuses_it() {
        let robot = Robot::builtin("so101").unwrap();
        // 0 → 40 → 80° a second apart, from rest to rest: within the pan's limits from key 0,
        // but it passes key 1 at some 60 °/s, which a start from rest there would have to
        // reach within one 10 ms period (6000 °/s², far beyond its acceleration limit).
        let mut sequence = pans(&[0.0, 40.0, 80.0]);
        sequence.key_interval = Some(1.0);
        assert!(play(&robot, &sequence, 0, 1.0).is_ok());
        assert!(matches!(
            play(&robot, &sequence, 1, 1.0),
            Err(PlayRefusal::Limits(report)) if !report.violations.is_empty()
        ));
    }

    #[test]
    fn playback_beyond_the_limits_or_off_the_robot_is_refused() {
        let robot = Robot::builtin("so101").unwrap();
        let mut fast = pans(&[0.0, 90.0]);
        // 90° in 0.1 s is far beyond 115°/s.
        fast.key_interval = Some(0.1);
        assert!(matches!(
            play(&robot, &fast, 0, 1.0),
            Err(PlayRefusal::Limits(report)) if !report.violations.is_empty()
        ));
        let mut unknown = Sequence::new("so101");
        unknown
            .keyframes
            .push(Keyframe::new(vec![("joint9".into(), KeyValue::Joint(0.0))]));
        assert!(matches!(
            play(&robot, &unknown, 0, 1.0),
            Err(PlayRefusal::Unplayable(_))
        ));
        assert!(to_key(&robot, &unknown, 0).is_err());
    }
}
