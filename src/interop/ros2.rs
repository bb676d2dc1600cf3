//! A trajectory as a ROS 2 `trajectory_msgs/msg/JointTrajectory` (docs/interop.md §2).
//!
//! ros2_control's joint_trajectory_controller, given positions and velocities but no
//! accelerations, joins each pair of consecutive points with the cubic Hermite through their
//! positions and velocities. keypose's cubic and monotone segments are such Hermites (values
//! and slopes at the keys, `curve`), and a cubic cut at any time is again the Hermite through
//! its value and slope there: so a point at every key (and at the end of every hold, the hold
//! being a segment at rest) with keypose's own slope makes the controller follow keypose's
//! curve exactly. A linear segment is a Hermite too (its secant at both ends). What no point can
//! carry is a corner, where the velocity changes at once (two linear segments meeting, a hold
//! next to a linear segment) or the value jumps (a step): each point carries the slope after
//! it, and one more point, a period of the corner rate earlier, confines the difference to that
//! last period before the corner (a step's jump falls in it too).
//!
//! A segment with a timing profile is a cubic of path time run at a changing path speed: on each
//! piece of the profile a polynomial of a higher degree in time, whose acceleration jumps where
//! pieces meet; a smooth segment is a quintic, which no one cubic follows either. Points stay positions and velocities (cubic joins may change their acceleration
//! at a point, as the curve does; a quintic join would force one acceleration there): one at
//! every end of every piece, and between two of them more, by halving, until the controller's
//! cubic follows the curve and keeps the limits, judged exactly (`hermite_fit`); a stretch that
//! still does not after `MAX_HALVINGS` (12) halvings is refused, naming its segment.

use super::{hermite_fit, yaml, SAME_TIME};
use crate::plan::check::spans::{JointCurve, Span};
use crate::plan::{LimitKind, Trajectory};
use crate::robot::{Joint, JointKind, Robot};

/// One point: seconds from the start, and per joint a position (rad or m) and velocity.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Seconds from the start.
    pub time: f64,
    /// Per joint: radians for a revolute joint, metres for a prismatic one.
    pub positions: Vec<f64>,
    /// Per joint: radians or metres per second.
    pub velocities: Vec<f64>,
}

/// The message's content.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// The joints, in the order of each point's values ([`joint_names`]).
    pub joint_names: Vec<String>,
    /// The points, in time order.
    pub points: Vec<Point>,
}

/// The joint names of the robot's official ROS 2 description: keypose's built-ins already use
/// them (SO-101 and SO-100 URDFs and LeRobot share one set; the OpenMANIPULATOR-X's are
/// ROBOTIS's ROS 2 names; docs/robots.md §1.2, §3.1, §11.2), and a robot file's own names are
/// the only ones known for it. A cell's joints are `ARM_JOINT` there (`left_shoulder_pan`):
/// in ROS a `/` separates namespaces, and a description of several arms prefixes each arm's
/// joint names with the arm and an underscore.
pub fn joint_names(robot: &Robot) -> Vec<String> {
    if robot.is_cell() {
        return robot
            .arms
            .iter()
            .flat_map(|arm| {
                arm.robot
                    .joints
                    .iter()
                    .map(move |j| format!("{}_{}", arm.name, j.name))
            })
            .collect();
    }
    robot.joint_names().iter().map(|n| n.to_string()).collect()
}

/// Halvings of a stretch between two points on a profiled segment before the export gives up:
/// points 2⁻¹² of a profile's piece apart.
const MAX_HALVINGS: u32 = 12;

/// A profiled segment the controller's cubics cannot follow within the limits.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "segment {segment} ({label}), t = {time:.3} s: even with points {spacing:.2e} s apart, the \
     controller's cubics through them {what} on joint {joint}; export play_motion2 (sampled) \
     or give the segment a gentler timing profile"
)]
pub struct Ros2ExportError {
    /// The segment (from key `segment` to the next).
    pub segment: usize,
    /// Its "from → to" label.
    pub label: String,
    /// Sequence time of the piece, seconds.
    pub time: f64,
    /// The points' spacing reached, seconds.
    pub spacing: f64,
    /// The joint.
    pub joint: String,
    /// What the cubic misses, in words.
    pub what: String,
}

/// The points of `trajectory`, each corner approached over one period of `corner_rate` Hz; on
/// a segment with a timing profile, dense enough that the controller's cubics follow the curve
/// and keep the limits (`hermite_fit`), else an error naming the segment.
pub fn joint_trajectory(
    trajectory: &Trajectory,
    robot: &Robot,
    corner_rate: f64,
) -> Result<JointTrajectory, Ros2ExportError> {
    let curves = super::joint_curves(trajectory);
    let played: Vec<Vec<Span>> = curves.iter().map(|c| c.played.clone()).collect();
    let corners = corner_times(&curves);
    let times = point_times(trajectory, &played, &corners, corner_rate);
    let times = Fit {
        trajectory,
        robot,
        played: &played,
        corners: &corners,
    }
    .refined(&times)?;
    let scale: Vec<f64> = robot
        .joints
        .iter()
        .map(|j| match j.kind {
            JointKind::Revolute => 1f64.to_radians(),
            JointKind::Prismatic => 1.0,
        })
        .collect();
    let points = times
        .iter()
        .map(|&t| {
            let states: Vec<(f64, f64)> = played
                .iter()
                .map(|spans| hermite_fit::state_at(spans, t))
                .collect();
            Point {
                time: t - trajectory.start,
                positions: states.iter().zip(&scale).map(|(s, k)| s.0 * k).collect(),
                velocities: states.iter().zip(&scale).map(|(s, k)| s.1 * k).collect(),
            }
        })
        .collect();
    Ok(JointTrajectory {
        joint_names: joint_names(robot),
        points,
    })
}

/// Where any joint's curve jumps in value or slope (a step's end, a linear corner, a hold
/// beside a linear segment, a profile ending in motion beside a segment that does not start
/// so), in sequence time, sorted.
fn corner_times(curves: &[JointCurve]) -> Vec<f64> {
    let mut times: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.discontinuities())
        .map(|d| d.time)
        .collect();
    super::sorted_once(&mut times);
    times
}

/// Where any joint's polynomial changes (key times, hold ends, the pieces of timing profiles),
/// a point one period before every corner, and the played window's ends; sorted, each once,
/// within the window.
fn point_times(
    trajectory: &Trajectory,
    played: &[Vec<Span>],
    corners: &[f64],
    corner_rate: f64,
) -> Vec<f64> {
    let period = 1.0 / corner_rate;
    let mut times = super::span_boundaries(played);
    times.extend([trajectory.start, trajectory.end]);
    times.extend(corners.iter().map(|t| t - period));
    times.retain(|t| (trajectory.start..=trajectory.end).contains(t));
    for t in &mut times {
        *t = on_nanoseconds(*t, trajectory.start);
    }
    super::sorted_once(&mut times);
    times
}

/// `t` on the whole nanosecond (from `start`) its point's `time_from_start` will say: each
/// point's position and velocity are the curve's at the time written, which the controller
/// reads. Off by up to half a nanosecond, a point 0.1 ms from the next moves its cubic's
/// acceleration by degrees per second squared (the distance a joint at 80 °/s covers in that
/// time, over h²).
fn on_nanoseconds(t: f64, start: f64) -> f64 {
    start + ((t - start) * 1e9).round() / 1e9
}

/// The curves the points stand for, and what judges the cubics between them.
struct Fit<'a> {
    trajectory: &'a Trajectory,
    robot: &'a Robot,
    played: &'a [Vec<Span>],
    corners: &'a [f64],
}

impl Fit<'_> {
    /// `times` with points added, by halving, where a profiled stretch needs them.
    fn refined(&self, times: &[f64]) -> Result<Vec<f64>, Ros2ExportError> {
        let mut out = times[..times.len().min(1)].to_vec();
        for w in times.windows(2) {
            self.refine(w[0], w[1], 0, &mut out)?;
        }
        Ok(out)
    }

    /// Pushes the points after `a` up to `b` that the stretch [a, b] needs.
    fn refine(
        &self,
        a: f64,
        b: f64,
        halvings: u32,
        out: &mut Vec<f64>,
    ) -> Result<(), Ros2ExportError> {
        if let Some((joint, shortfall)) = self.shortfall(a, b) {
            if halvings == MAX_HALVINGS {
                let segment = self.trajectory.segment_at(0.5 * (a + b));
                return Err(Ros2ExportError {
                    segment,
                    label: self.trajectory.segment_label(segment),
                    time: a,
                    spacing: b - a,
                    joint: joint.name.clone(),
                    what: describe(shortfall, joint),
                });
            }
            let middle = on_nanoseconds(0.5 * (a + b), self.trajectory.start);
            self.refine(a, middle, halvings + 1, out)?;
            return self.refine(middle, b, halvings + 1, out);
        }
        out.push(b);
        Ok(())
    }

    /// The first joint whose cubic on [a, b] misses, on a profiled stretch or a smooth
    /// segment's quintic (elsewhere the cubic through the points is keypose's own cubic); a
    /// stretch ending at a corner is the corner's last period, which the limit check judged as
    /// the player turns it.
    fn shortfall(&self, a: f64, b: f64) -> Option<(&Joint, hermite_fit::Shortfall)> {
        let middle = 0.5 * (a + b);
        let piece = self.trajectory.timing().piece_at(middle);
        // [a, b] lies inside one span of each joint (the points include every span's ends,
        // to the nanosecond): the one at its middle.
        let beyond_cubic = self.played.iter().any(|spans| {
            let i = spans.partition_point(|s| s.end <= middle);
            spans
                .get(i)
                .is_some_and(|s| s.poly.coefficients().len() > 4)
        });
        let profiled = piece.v0 != 1.0 || piece.a != 0.0 || beyond_cubic;
        let at_corner = |t: f64| {
            let i = self.corners.partition_point(|&c| c < t - SAME_TIME);
            self.corners.get(i).is_some_and(|&c| c - t < SAME_TIME)
        };
        if !profiled || at_corner(b) {
            return None;
        }
        self.played
            .iter()
            .zip(&self.robot.joints)
            .find_map(|(spans, joint)| hermite_fit::judge(spans, joint, a, b).map(|s| (joint, s)))
    }
}

/// A shortfall in words, in the joint's units.
fn describe(shortfall: hermite_fit::Shortfall, joint: &Joint) -> String {
    let unit = joint.kind.unit();
    match shortfall {
        hermite_fit::Shortfall::Strays(by) => {
            format!("stray {by:.2e} {unit} from keypose's curve")
        }
        hermite_fit::Shortfall::Exceeds(kind, peak) => {
            let (limit, per) = match kind {
                LimitKind::Position => (
                    if peak < joint.limits.min {
                        joint.limits.min
                    } else {
                        joint.limits.max
                    },
                    "",
                ),
                LimitKind::Velocity => (joint.limits.velocity, "/s"),
                LimitKind::Acceleration => (joint.limits.acceleration, "/s²"),
                LimitKind::Jerk => (joint.limits.jerk.unwrap_or(f64::INFINITY), "/s³"),
            };
            format!(
                "reach {peak:.4} {unit}{per}, past the {} limit of {limit} {unit}{per}",
                kind.name()
            )
        }
    }
}

/// The message as YAML, the form `ros2 topic pub` and `ros2 action send_goal` take and
/// `ros2 topic echo` prints (header stamp 0: start at once).
pub fn to_yaml(message: &JointTrajectory) -> String {
    let mut out = String::new();
    yaml::open(&mut out, 0, "header");
    yaml::open(&mut out, 2, "stamp");
    yaml::line(&mut out, 4, "sec", "0");
    yaml::line(&mut out, 4, "nanosec", "0");
    yaml::line(&mut out, 2, "frame_id", "''");
    yaml::line(
        &mut out,
        0,
        "joint_names",
        &yaml::name_list(message.joint_names.iter().map(String::as_str)),
    );
    yaml::open(&mut out, 0, "points");
    for point in &message.points {
        let (sec, nanosec) = sec_nanosec(point.time);
        out.push_str(&format!(
            "- positions: {}\n",
            yaml::float_list(point.positions.iter().copied())
        ));
        yaml::line(
            &mut out,
            2,
            "velocities",
            &yaml::float_list(point.velocities.iter().copied()),
        );
        yaml::line(&mut out, 2, "accelerations", "[]");
        yaml::line(&mut out, 2, "effort", "[]");
        yaml::open(&mut out, 2, "time_from_start");
        yaml::line(&mut out, 4, "sec", &sec.to_string());
        yaml::line(&mut out, 4, "nanosec", &nanosec.to_string());
    }
    out
}

/// `builtin_interfaces/Duration`: whole seconds and nanoseconds 0 … 999 999 999.
fn sec_nanosec(t: f64) -> (i64, u32) {
    let total = (t * 1e9).round() as i64;
    (
        total.div_euclid(1_000_000_000),
        total.rem_euclid(1_000_000_000) as u32,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_split_into_whole_seconds_and_nanoseconds() {
        assert_eq!(sec_nanosec(0.0), (0, 0));
        assert_eq!(sec_nanosec(1.2), (1, 200_000_000));
        assert_eq!(sec_nanosec(2.999_999_999_6), (3, 0));
    }

    /// A cubic run by a profile of three long pieces (tests/commands/export.rs follows it on
    /// the SO-101), from rest to rest: the elbow's 40° in 2 s.
    fn curved() -> (Trajectory, Robot) {
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [
              {"time": 0, "timing": {"path_time": 2, "speeds": [0, 1, 1.5, 0]},
               "joints": {"elbow_flex": 0, "wrist_flex": 0}},
              {"time": 2, "joints": {"elbow_flex": 40, "wrist_flex": -20}},
              {"time": 3.5, "joints": {"elbow_flex": 0, "wrist_flex": 10}}]}"#;
        let sequence = crate::sequence::Sequence::from_json("curved.json", text).unwrap();
        let robot = Robot::builtin("so101").unwrap();
        (Trajectory::build(&sequence, &robot).unwrap(), robot)
    }

    #[test]
    fn a_profile_no_cubics_can_follow_within_the_limits_is_refused_naming_it() {
        let (trajectory, mut robot) = curved();
        assert!(joint_trajectory(&trajectory, &robot, 100.0).is_ok());
        // 40° from rest to rest in 2 s needs 4·40/2² = 40 °/s² at least (bang-bang): below
        // that the curve itself exceeds the limit, and halving brings the cubics to the curve,
        // never under it.
        let elbow = robot.joint_index("elbow_flex").unwrap();
        robot.joints[elbow].limits.acceleration = 30.0;
        let error = joint_trajectory(&trajectory, &robot, 100.0).unwrap_err();
        assert_eq!((error.segment, error.joint.as_str()), (0, "elbow_flex"));
        assert!(error.spacing < 2.0 / 4096.0, "{error}");
        let text = error.to_string();
        assert!(
            text.contains("past the acceleration limit of 30 deg/s²"),
            "{text}"
        );
    }
}
