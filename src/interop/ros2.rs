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

use super::yaml;
use crate::curve::{Interp, Track};
use crate::plan::Trajectory;
use crate::robot::{JointKind, Robot};

/// Times closer than this are one point (seconds; a nanosecond stamp's resolution).
const SAME_TIME: f64 = 1e-9;
/// A slope change above this (degrees or metres per second) is a corner: smooth joins agree
/// to rounding, far below it.
const CORNER_SLOPE: f64 = 1e-9;

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

/// The points of `trajectory`, each corner approached over one period of `corner_rate` Hz.
/// The points follow the tracks' cubics in time: a trajectory with a timing profile is refused
/// before (`interop::refuse_timing`), as `export ros2` does.
pub fn joint_trajectory(
    trajectory: &Trajectory,
    robot: &Robot,
    corner_rate: f64,
) -> JointTrajectory {
    let times = point_times(trajectory, corner_rate);
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
            let tracks = trajectory.tracks();
            Point {
                time: t - trajectory.start,
                positions: tracks
                    .iter()
                    .zip(&scale)
                    .map(|(k, s)| k.sample(t) * s)
                    .collect(),
                velocities: tracks
                    .iter()
                    .zip(&scale)
                    .map(|(k, s)| k.rate_at(t) * s)
                    .collect(),
            }
        })
        .collect();
    JointTrajectory {
        joint_names: joint_names(robot),
        points,
    }
}

/// Every joint's key times and hold ends, a point one period before every corner, and the
/// played window's ends; sorted, each once, within the window.
fn point_times(trajectory: &Trajectory, corner_rate: f64) -> Vec<f64> {
    let period = 1.0 / corner_rate;
    let mut times = breakpoints(trajectory);
    let corners: Vec<f64> = times
        .iter()
        .copied()
        .filter(|&t| trajectory.tracks().iter().any(|track| is_corner(track, t)))
        .map(|t| t - period)
        .collect();
    times.extend(corners);
    sorted_within(trajectory, times)
}

/// Every joint's key times and hold ends and the played window's ends, sorted, each once,
/// within the window: between two of them every joint's curve is one polynomial.
pub(crate) fn breakpoints(trajectory: &Trajectory) -> Vec<f64> {
    let mut times = vec![trajectory.start, trajectory.end];
    for track in trajectory.tracks() {
        for (i, &t) in track.times().iter().enumerate() {
            times.push(t);
            times.push(track.move_start(i));
        }
    }
    sorted_within(trajectory, times)
}

fn sorted_within(trajectory: &Trajectory, mut times: Vec<f64>) -> Vec<f64> {
    let (start, end) = (trajectory.start, trajectory.end);
    times.retain(|t| (start..=end).contains(t));
    times.sort_by(f64::total_cmp);
    times.dedup_by(|later, earlier| *later - *earlier < SAME_TIME);
    times
}

/// Whether the curve's slope or value changes at once at `t`: the slope just before differs
/// from the slope after, or a step segment ends there with another value.
fn is_corner(track: &Track<f64>, t: f64) -> bool {
    if (track.rate_before(t) - track.rate_at(t)).abs() > CORNER_SLOPE {
        return true;
    }
    let (times, values) = (track.times(), track.values());
    (1..times.len()).any(|k| {
        times[k] == t && track.modes()[k - 1] == Interp::Step && values[k] != values[k - 1]
    })
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
}
