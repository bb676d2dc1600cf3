//! Sequences for several arms (`"robots"`): the format, the cell robot, per-arm tool keys, and
//! the commands' bad-input answers.

use crate::common::{run, show};
use glam::{DQuat, DVec3};
use keypose::plan::{check, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;

const TWO_ARMS: &str = r#"{"format": "keypose-sequence/1",
    "robots": {"left": {"robot": "so101", "base": {"xyz": [0, 0.3, 0], "rpy": [0, 0, 0.5]}},
               "right": "so101"},
    "interpolation": "linear",
    "keyframes": [
        {"time": 0, "joints": {"left/elbow_flex": 0}},
        {"time": 2, "joints": {"left/elbow_flex": 40}, "tool": {"right": {"xyz": [0.22, 0.05, 0.12]}}},
        {"time": 4, "joints": {"left/elbow_flex": 0, "right/elbow_flex": 0}}]}"#;

fn cell_of(sequence: &Sequence) -> Robot {
    keypose::plan::builtin_robot_of(sequence).unwrap()
}

#[test]
fn a_cell_sequence_loads_with_its_arms_and_bases_and_saves_back_as_loaded() {
    let sequence = Sequence::from_json("two.json", TWO_ARMS).unwrap();
    assert!(sequence.is_cell());
    let names: Vec<&str> = sequence.arms.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["left", "right"]);
    let base = sequence.arms[0].base.unwrap().transform();
    assert!((base.t - DVec3::new(0.0, 0.3, 0.0)).length() < 1e-15);
    // rpy (0, 0, 0.5) is a yaw of 0.5 rad about z.
    assert!(base.r.angle_between(DQuat::from_rotation_z(0.5)) < 1e-12);
    assert_eq!(sequence.arms[1].base, None);
    assert_eq!(sequence.keyframes[1].arm_tools[0].0, "right");
    let again = Sequence::from_json("two.json", &sequence.to_json()).unwrap();
    assert_eq!(again.arms, sequence.arms);
    assert_eq!(again.keyframes, sequence.keyframes);
    assert!(
        sequence.to_json().contains(r#""rpy":[0.0,0.0,0.5]"#),
        "{}",
        sequence.to_json()
    );
}

#[test]
fn an_arm_no_key_names_holds_its_home_while_the_other_moves() {
    let text = TWO_ARMS.replace(
        r#"{"time": 2, "joints": {"left/elbow_flex": 40}, "tool": {"right": {"xyz": [0.22, 0.05, 0.12]}}}"#,
        r#"{"time": 2, "joints": {"left/elbow_flex": 40}}"#,
    );
    let text = text.replace(r#", "right/elbow_flex": 0"#, "");
    let sequence = Sequence::from_json("two.json", &text).unwrap();
    let cell = cell_of(&sequence);
    let trajectory = Trajectory::build(&sequence, &cell).unwrap();
    let middle = trajectory.sample(1.0);
    let elbow = cell.joint_index("left/elbow_flex").unwrap();
    // Linear from 0° at 0 s to 40° at 2 s: 20° at 1 s.
    assert!((middle[elbow] - 20.0).abs() < 1e-9);
    let right = cell.arm("right").unwrap();
    assert_eq!(right.values(&middle), Robot::builtin("so101").unwrap().home);
}

#[test]
fn a_tool_target_of_one_arm_is_solved_in_that_arms_base_frame() {
    // The right arm stands 0.3 m along −y and turned a quarter turn about z.
    let text = TWO_ARMS.replace(
        r#""right": "so101""#,
        r#""right": {"robot": "so101", "base": {"xyz": [0, -0.3, 0], "rpy": [0, 0, 1.5707963267948966]}}"#,
    );
    let sequence = Sequence::from_json("two.json", &text).unwrap();
    let cell = cell_of(&sequence);
    let trajectory = Trajectory::build(&sequence, &cell).unwrap();
    let at_key = trajectory.sample(2.0);
    let right = cell.arm("right").unwrap();
    let target = DVec3::new(0.22, 0.05, 0.12);
    let in_base = right.robot.tcp_position(right.values(&at_key));
    assert!((in_base - target).length() < 1e-4, "{in_base:?}");
    // The cell's own chain puts that tool at the base's image of the target: a quarter turn
    // takes (x, y) to (−y, x), then the base is 0.3 m along −y.
    let tcp = right.robot.tcp.as_ref().unwrap();
    let frames = cell.joint_frames(&at_key);
    let world = frames[right.joints.start + tcp.parent]
        .compose(&tcp.origin)
        .t;
    let expected = DVec3::new(-0.05, 0.22 - 0.3, 0.12);
    assert!((world - expected).length() < 1e-4, "{world:?}");
    // The left arm was left alone by the right arm's solve: linear 0° → 40° over 2 s.
    assert!((at_key[cell.joint_index("left/elbow_flex").unwrap()] - 40.0).abs() < 1e-9);
    assert_eq!(trajectory.tools.keys[0].arm.as_deref(), Some("right"));
}

#[test]
fn the_limit_check_of_a_cell_names_the_arm_of_each_joint() {
    // A linear start from rest on one arm's elbow: 20 °/s reached in one 10 ms period, far
    // beyond the SO-101's acceleration limit.
    let sequence = Sequence::from_json("two.json", TWO_ARMS).unwrap();
    let cell = cell_of(&sequence);
    let trajectory = Trajectory::build(&sequence, &cell).unwrap();
    let report = check(&trajectory, &cell, 100.0);
    assert!(!report.passed());
    assert!(report
        .violations
        .iter()
        .any(|v| v.joint.starts_with("left/")));
}

#[test]
fn bad_cell_input_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            TWO_ARMS.replace(r#""robots""#, r#""robot": "so101", "robots""#),
            "$.robots",
            "both \"robot\" and \"robots\"",
        ),
        (
            TWO_ARMS.replace(r#""right": "so101""#, r#""ri/ght": "so101""#),
            "$.robots",
            "arm name",
        ),
        (
            TWO_ARMS.replace(r#"{"right": {"xyz""#, r#"{"middle": {"xyz""#),
            "tool.middle",
            "unknown arm \"middle\"",
        ),
        (
            TWO_ARMS.replace("left/elbow_flex\": 40", "middle/elbow_flex\": 40"),
            "middle/elbow_flex",
            "left/shoulder_pan",
        ),
        (
            TWO_ARMS.replace(r#""right": "so101""#, r#""right": "so999""#),
            "$.robots.right",
            "unknown robot",
        ),
        (
            TWO_ARMS.replace(r#"[0.22, 0.05, 0.12]"#, r#"[2.0, 0.05, 0.12]"#),
            "tool.right.xyz",
            "arm right",
        ),
    ];
    for (index, (text, field, words)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{index}.json"));
        std::fs::write(&path, text).unwrap();
        let out = run(&["check", path.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "case {index}: {}", show(&out));
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(
            message.contains(field) && message.contains(words),
            "case {index}: {message}"
        );
        assert!(!message.contains("panicked"), "{message}");
    }
}

#[test]
fn one_arm_options_on_a_cell_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.json");
    std::fs::write(&path, TWO_ARMS).unwrap();
    let path = path.to_str().unwrap();
    for (args, words) in [
        (
            vec!["check", path, "--robot", "koch"],
            "expected no --robot",
        ),
        (
            vec!["check", path, "--calibration", "cal.json"],
            "expected ARM=VALUE with ARM one of left, right",
        ),
        (
            vec!["check", path, "--robot-id", "middle=arm1"],
            "expected ARM=VALUE with ARM one of left, right",
        ),
    ] {
        let out = run(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", show(&out));
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(words),
            "{args:?}: {}",
            show(&out)
        );
    }
}

#[test]
fn sample_gives_each_arms_tool_in_its_own_base_frame() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.json");
    std::fs::write(&path, TWO_ARMS).unwrap();
    let out = run(&["sample", path.to_str().unwrap(), "--tool", "--rate", "10"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let row: Vec<f64> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap())
                .collect::<Vec<f64>>()
        })
        .find(|r| (r[0] - 2.0).abs() < 1e-9)
        .unwrap();
    // The right arm's tool key at 2 s, in the right arm's base frame.
    let right: Vec<f64> = ["right/tool_x", "right/tool_y", "right/tool_z"]
        .iter()
        .map(|c| row[column(c)])
        .collect();
    for (got, want) in right.iter().zip([0.22, 0.05, 0.12]) {
        assert!((got - want).abs() < 1e-4, "{right:?}");
    }
    // Without its tool key the right arm stays at home, the zero pose, as the left is at 0 s.
    let home_only = TWO_ARMS.replace(r#", "tool": {"right": {"xyz": [0.22, 0.05, 0.12]}}"#, "");
    std::fs::write(&path, home_only).unwrap();
    let out = run(&["sample", path.to_str().unwrap(), "--tool", "--rate", "10"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    // At 0 s both arms stand at the zero pose. The left base is moved 0.3 m and turned 0.5 rad,
    // the right one is not: in each arm's own base frame their tools are at the same point, in
    // the arm's own vertical plane (y = 0, to the 0.17 mm the SO-101's roll axis passes beside
    // it); in the cell frame the left one would be 0.3 m and a turn away.
    let first: Vec<f64> = lines_at(&text, 0.0);
    for axis in ["tool_x", "tool_y", "tool_z"] {
        let (l, r) = (
            first[column(&format!("left/{axis}"))],
            first[column(&format!("right/{axis}"))],
        );
        assert!((l - r).abs() < 1e-12, "{axis}: left {l}, right {r}");
    }
    assert!(first[column("left/tool_y")].abs() < 1e-3, "{first:?}");
    assert!(first[column("left/tool_x")] > 0.3, "{first:?}");
}

/// The CSV row of `text` at time `t`.
fn lines_at(text: &str, t: f64) -> Vec<f64> {
    text.lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap())
                .collect::<Vec<f64>>()
        })
        .find(|r| (r[0] - t).abs() < 1e-9)
        .unwrap()
}

#[test]
fn ros_exports_of_a_cell_name_joints_as_ros_descriptions_of_two_arms_do() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = crate::common::repo("sequences/bimanual_wave.json");
    for format in ["ros2", "play_motion2"] {
        let output = dir.path().join(format!("{format}.yaml"));
        let out = run(&["export", format, &sequence, "-o", output.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(0), "{}", show(&out));
        let text = std::fs::read_to_string(&output).unwrap();
        assert!(
            text.contains(r#"["left_shoulder_pan", "left_shoulder_lift""#)
                && text.contains(r#""right_wrist_roll", "right_gripper"]"#),
            "{format}: {text}"
        );
        assert!(!text.contains("left/"), "{format}: {text}");
    }
}
