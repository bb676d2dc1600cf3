//! `export ros2` and `export play_motion2` for a trajectory of a built-in robot whose joints,
//! motion and description are renamed with any text at all (the motion name of any length).
//! Property: no panic; both documents parse with libyaml (serde_norway, the parser ROS 2's
//! parameter files and PyYAML go through) to the same names and texts, character for
//! character, and the same numbers: the JointTrajectory's every position, velocity and time,
//! play_motion2's times on the sampling grid and its positions the trajectory's samples there.
#![no_main]

use keypose::interop::{play_motion2, ros2};
use keypose::plan::Trajectory;
use keypose::robot::{JointKind, Robot};
use keypose_fuzz::exports::{names, renamed, rest_as_name, trajectory};
use keypose_fuzz::Choices;
use libfuzzer_sys::fuzz_target;
use serde_norway::Value;

/// The writers keep 12 decimals: half of the last is the rounding, the rest is f64's.
fn same_number(written: f64, read: &Value) -> bool {
    let read = read.as_f64().expect("a number");
    (read - written).abs() <= 0.5e-12 + 1e-15 * written.abs().max(1.0)
}

fn strings(value: &Value) -> Vec<&str> {
    let items = value.as_sequence().expect("a list");
    items
        .iter()
        .map(|v| v.as_str().expect("a string"))
        .collect()
}

fn parse(text: &str) -> Value {
    serde_norway::from_str(text).unwrap_or_else(|e| panic!("not YAML: {e}\n{text}"))
}

fn check_ros2(trajectory: &Trajectory, robot: &Robot, corner_rate: f64) {
    // A profile the controller's cubics cannot follow within the limits is refused: no message.
    let Ok(message) = ros2::joint_trajectory(trajectory, robot, corner_rate) else {
        return;
    };
    let document = parse(&ros2::to_yaml(&message));
    assert_eq!(strings(&document["joint_names"]), message.joint_names);
    let points = document["points"].as_sequence().expect("points");
    assert_eq!(points.len(), message.points.len());
    for (read, point) in points.iter().zip(&message.points) {
        for (field, values) in [
            ("positions", &point.positions),
            ("velocities", &point.velocities),
        ] {
            let list = read[field].as_sequence().expect("a list");
            assert_eq!(list.len(), values.len());
            assert!(
                values.iter().zip(list).all(|(&x, r)| same_number(x, r)),
                "{field}"
            );
        }
        let time = &read["time_from_start"];
        let (sec, nanosec) = (
            time["sec"].as_i64().unwrap(),
            time["nanosec"].as_u64().unwrap(),
        );
        assert!(nanosec < 1_000_000_000);
        let read_time = sec as f64 + nanosec as f64 * 1e-9;
        assert!((read_time - point.time).abs() <= 0.5e-9 + 1e-15 * point.time.abs());
    }
}

fn check_play_motion2(
    trajectory: &Trajectory,
    robot: &Robot,
    rate: f64,
    name: &str,
    description: &str,
) {
    let document = parse(&play_motion2::motion_yaml(
        trajectory,
        robot,
        rate,
        name,
        description,
    ));
    let motions = document["/play_motion2"]["ros__parameters"]["motions"]
        .as_mapping()
        .expect("motions");
    assert_eq!(motions.len(), 1);
    let (key, motion) = motions.iter().next().unwrap();
    assert_eq!(key.as_str(), Some(name), "the motion's key");
    assert_eq!(motion["meta"]["name"].as_str(), Some(name));
    assert_eq!(motion["meta"]["description"].as_str(), Some(description));
    assert_eq!(strings(&motion["joints"]), ros2::joint_names(robot));
    let times = motion["times_from_start"].as_sequence().expect("times");
    let positions = motion["positions"].as_sequence().expect("positions");
    let joints = robot.joints.len();
    assert_eq!(positions.len(), times.len() * joints);
    // The grid start + k/rate from the played start (`Trajectory::grid`), the end added when
    // it falls off it.
    let grid: Vec<f64> = trajectory.grid(rate).collect();
    assert!(times.len() == grid.len() || times.len() == grid.len() + 1);
    for (k, time) in times.iter().enumerate() {
        let t = grid.get(k).copied().unwrap_or(trajectory.end);
        assert!(same_number(t - trajectory.start, time), "time {k}");
        let pose = trajectory.sample(t);
        for (j, joint) in robot.joints.iter().enumerate() {
            let value = match joint.kind {
                JointKind::Revolute => pose[j].to_radians(),
                JointKind::Prismatic => pose[j],
            };
            assert!(
                same_number(value, &positions[k * joints + j]),
                "sample {k}, joint {j}: {:?} against {value}",
                positions[k * joints + j]
            );
        }
    }
    let last = times.last().and_then(Value::as_f64).expect("a time");
    assert!(
        (last - trajectory.duration()).abs() <= 1e-9,
        "the last sample is the end"
    );
}

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let Some((robot, trajectory)) = trajectory(&mut choices) else {
        return;
    };
    let corner_rate = 10.0 + f64::from(choices.byte()) * 4.0;
    let rate = 1.0 + f64::from(choices.byte() % 50);
    let names = names(&mut choices, robot.joints.len());
    let description = names_one(&mut choices);
    let motion = rest_as_name(&mut choices);
    let robot = renamed(robot, &names);
    check_ros2(&trajectory, &robot, corner_rate);
    check_play_motion2(&trajectory, &robot, rate, &motion, &description);
});

fn names_one(choices: &mut Choices) -> String {
    names(choices, 1).pop().unwrap_or_default()
}
