use super::*;
use crate::pose::RigidTransform;
use crate::sequence::ToolKey;
use glam::{DQuat, DVec3};

fn so101() -> Robot {
    Robot::builtin("so101").unwrap()
}

fn one_key(values: &[(&str, f64)]) -> Sequence {
    let mut sequence = Sequence::new("so101");
    let values = values
        .iter()
        .map(|(n, v)| (n.to_string(), KeyValue::Joint(*v)))
        .collect();
    sequence.keyframes.push(Keyframe::new(values));
    sequence
}

fn joint(key: &Keyframe, name: &str) -> f64 {
    match key.value(name) {
        Some(KeyValue::Joint(v)) => *v,
        other => panic!("{name}: {other:?}"),
    }
}

#[test]
fn pan_and_roll_change_sign_the_rest_stays() {
    let robot = so101();
    let pose = [
        ("shoulder_pan", 30.0),
        ("shoulder_lift", -20.0),
        ("elbow_flex", 40.0),
        ("wrist_flex", 10.0),
        ("wrist_roll", 50.0),
        ("gripper", 20.0),
    ];
    let mirror = Mirror::new(&robot, Mapping::InPlace, "t.json").unwrap();
    let (mirrored, clips) = mirror.sequence(&one_key(&pose), &robot).unwrap();
    assert!(clips.is_empty());
    let key = &mirrored.keyframes[0];
    let expected = [-30.0, -20.0, 40.0, 10.0, -50.0, 20.0];
    for ((name, _), want) in pose.iter().zip(expected) {
        assert_eq!(joint(key, name), want, "{name}");
    }
    // The order of the file is kept.
    let names: Vec<&str> = key.values.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, pose.map(|(n, _)| n));
}

#[test]
fn a_value_past_an_unsymmetric_limit_is_clipped_and_reported() {
    // wrist_roll's limits are −157.21 … 162.79° (docs/robots.md §1.2): 160 mirrors to −160.
    let robot = so101();
    let mirror = Mirror::new(&robot, Mapping::InPlace, "t.json").unwrap();
    let (mirrored, clips) = mirror
        .sequence(&one_key(&[("wrist_roll", 160.0)]), &robot)
        .unwrap();
    assert_eq!(joint(&mirrored.keyframes[0], "wrist_roll"), -157.21);
    assert_eq!(
        clips,
        [Clip {
            key: 0,
            key_label: "#0".into(),
            joint: "wrist_roll".into(),
            value: -160.0,
            limit: -157.21,
            unit: "deg",
        }]
    );
}

#[test]
fn a_transform_mirrors_to_the_opposite_turn() {
    let robot = so101();
    let mut sequence = one_key(&[]);
    // 30° about shoulder_pan's own axis (z in its frame), as a transform.
    let turn = RigidTransform::new(DVec3::ZERO, DQuat::from_rotation_z(30f64.to_radians()));
    sequence.keyframes[0].values = vec![("shoulder_pan".into(), KeyValue::Transform(turn))];
    let mirror = Mirror::new(&robot, Mapping::InPlace, "t.json").unwrap();
    let (mirrored, _) = mirror.sequence(&sequence, &robot).unwrap();
    let value = mirrored.keyframes[0].value("shoulder_pan").unwrap();
    let degrees = plan::joint_value(&robot.joints[0], value, 0.0).unwrap();
    assert!((degrees + 30.0).abs() < 1e-9, "{degrees}");
}

#[test]
fn a_tool_key_is_reflected_across_the_plane() {
    let robot = so101();
    let r0 = robot.tcp_frame(&[0.0; 6]).r;
    // A turn of 30° about the vertical from the zero-pose orientation: its mirror image is the
    // turn of −30°, from the same orientation.
    let turned = DQuat::from_rotation_z(30f64.to_radians()) * r0;
    let mut sequence = one_key(&[]);
    sequence.keyframes[0].tool = Some(ToolKey {
        xyz: DVec3::new(0.25, 0.1, 0.2),
        orientation: Some(crate::sequence::ToolOrientation::Quaternion(turned)),
        approach: None,
    });
    let mirror = Mirror::new(&robot, Mapping::InPlace, "t.json").unwrap();
    let (mirrored, _) = mirror.sequence(&sequence, &robot).unwrap();
    let tool = mirrored.keyframes[0].tool.unwrap();
    // The SO-101's plane is x-z (within 3.2e-5 rad): y → −y.
    assert!((tool.xyz - DVec3::new(0.25, -0.1, 0.2)).length() < 2e-5);
    let want = DQuat::from_rotation_z(-30f64.to_radians()) * r0;
    let error = tool.orientation.unwrap().quaternion().angle_between(want);
    assert!(error < 1e-4, "{error}");
}

fn cell() -> Robot {
    let side = |y: f64| RigidTransform::new(DVec3::new(0.0, y, 0.0), DQuat::IDENTITY);
    Robot::cell(vec![
        ("left".into(), so101(), side(0.25)),
        ("right".into(), so101(), side(-0.25)),
    ])
    .unwrap()
}

#[test]
fn onto_another_arm_replaces_its_keys_and_leaves_the_source() {
    let robot = cell();
    let mut sequence = one_key(&[
        ("left/shoulder_pan", 20.0),
        ("left/elbow_flex", -45.0),
        ("right/shoulder_pan", 5.0),
        ("right/wrist_flex", 7.0),
    ]);
    sequence.keyframes[0].arm_tools = vec![(
        "left".into(),
        ToolKey {
            xyz: DVec3::new(0.2, 0.05, 0.1),
            orientation: None,
            approach: None,
        },
    )];
    let mapping = Mapping::Onto {
        from: "left",
        to: "right",
    };
    let mirror = Mirror::new(&robot, mapping, "t.json").unwrap();
    let (mirrored, _) = mirror.sequence(&sequence, &robot).unwrap();
    let key = &mirrored.keyframes[0];
    assert_eq!(joint(key, "left/shoulder_pan"), 20.0);
    assert_eq!(joint(key, "right/shoulder_pan"), -20.0);
    assert_eq!(joint(key, "right/elbow_flex"), -45.0);
    // right's own wrist_flex key is gone: right does what left does, mirrored.
    assert!(key.value("right/wrist_flex").is_none());
    let tools: Vec<&str> = key.arm_tools.iter().map(|(a, _)| a.as_str()).collect();
    assert_eq!(tools, ["left", "right"]);
    assert!((key.arm_tools[1].1.xyz - DVec3::new(0.2, -0.05, 0.1)).length() < 2e-5);
}

#[test]
fn bad_arms_are_named() {
    let robot = cell();
    let onto = |from, to| Mirror::new(&robot, Mapping::Onto { from, to }, "c.json").unwrap_err();
    let error = onto("left", "middle");
    assert!(matches!(&error, MirrorError::UnknownArm { name, .. } if name == "middle"));
    assert!(error.to_string().contains("left, right"), "{error}");
    assert_eq!(
        onto("left", "left"),
        MirrorError::SameArm {
            name: "left".into()
        }
    );
    let one = Mirror::new(&so101(), Mapping::Onto { from: "a", to: "b" }, "o.json").unwrap_err();
    assert_eq!(
        one,
        MirrorError::NotACell {
            file: "o.json".into()
        }
    );
}

#[test]
fn teach_mirrors_the_selected_arm_onto_the_other_of_two() {
    let robot = cell();
    assert_eq!(
        Mirror::for_selected_joint(&robot, 8),
        Mapping::Onto {
            from: "right",
            to: "left"
        }
    );
    assert_eq!(Mirror::for_selected_joint(&so101(), 0), Mapping::InPlace);
}

#[test]
fn a_key_left_with_nothing_is_refused_naming_it() {
    let robot = cell();
    let mut sequence = one_key(&[("left/shoulder_pan", 10.0)]);
    let mut solo = Keyframe::new(vec![("right/elbow_flex".into(), KeyValue::Joint(20.0))]);
    solo.name = Some("solo".into());
    sequence.keyframes.push(solo);
    let mapping = Mapping::Onto {
        from: "left",
        to: "right",
    };
    let error = Mirror::new(&robot, mapping, "t.json")
        .unwrap()
        .sequence(&sequence, &robot)
        .unwrap_err();
    assert!(
        matches!(&error, MirrorError::EmptyKey { label, .. } if label == "solo"),
        "{error}"
    );
    assert!(error.to_string().contains("$.keyframes[1]"), "{error}");
}

#[test]
fn a_percent_mirrors_through_the_calibrated_range() {
    use crate::robot::CalibratedRange;
    let mut robot = so101();
    // A recorded pan range of −100° … 120°: 50 % is 10°, its mirror −10° is 90/220 = 40.909 %.
    robot.joints[0].calibrated_range = Some(CalibratedRange {
        at_0: -100.0,
        at_100: 120.0,
    });
    let mut sequence = one_key(&[]);
    sequence.keyframes[0].values = vec![
        ("shoulder_pan".into(), KeyValue::Percent(50.0)),
        ("shoulder_lift".into(), KeyValue::Joint(12.0)),
    ];
    let mirror = Mirror::new(&robot, Mapping::InPlace, "t.json").unwrap();
    let (mirrored, clips) = mirror.sequence(&sequence, &robot).unwrap();
    assert!(clips.is_empty());
    match mirrored.keyframes[0].value("shoulder_pan") {
        Some(KeyValue::Percent(p)) => assert!((p - 9000.0 / 220.0).abs() < 1e-9, "{p}"),
        other => panic!("{other:?}"),
    }
    // Without a calibration a percent names no angle: refused with the key's path.
    let error = Mirror::new(&so101(), Mapping::InPlace, "t.json")
        .unwrap()
        .sequence(&sequence, &so101())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("$.keyframes[0].joints.shoulder_pan") && error.contains("calibration"),
        "{error}"
    );
}
