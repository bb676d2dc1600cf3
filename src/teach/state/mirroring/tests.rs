//! The teach keys `m` and `M` on the state machine alone.

use super::*;
use crate::sequence::Keyframe;

fn so101() -> Robot {
    Robot::builtin("so101").expect("built-in so101")
}

fn with_keys(robot: Robot, sequence: Sequence) -> TeachState {
    let present = robot.home.clone();
    TeachState::new(
        robot,
        KeyframeList::new(sequence),
        "mirrored.json".into(),
        None,
        present,
    )
}

fn key_of(values: &[(&str, f64)]) -> Keyframe {
    Keyframe::new(
        values
            .iter()
            .map(|(n, v)| (n.to_string(), KeyValue::Joint(*v)))
            .collect(),
    )
}

fn values_of(key: &Keyframe) -> Vec<(String, f64)> {
    key.values
        .iter()
        .map(|(n, v)| match v {
            KeyValue::Joint(x) => (n.clone(), *x),
            other => panic!("{n}: {other:?}"),
        })
        .collect()
}

fn named(values: &[(&str, f64)]) -> Vec<(String, f64)> {
    values.iter().map(|(n, v)| (n.to_string(), *v)).collect()
}

#[test]
fn m_mirrors_the_current_key_and_again_gives_it_back() {
    let mut sequence = Sequence::new("so101");
    let pose = [
        ("shoulder_pan", 30.0),
        ("shoulder_lift", -20.0),
        ("wrist_roll", 50.0),
        ("gripper", 20.0),
    ];
    sequence.keyframes = vec![key_of(&[("shoulder_pan", 5.0)]), key_of(&pose)];
    let mut state = with_keys(so101(), sequence);
    state.handle_key(Key::SelectKey(1));
    let commands = state.handle_key(Key::Char('m'));
    assert!(commands.is_empty(), "no journal, no bus: {commands:?}");
    let key = state.list().show().unwrap();
    // By hand: pan and roll turn about axes in the arm's plane, so they change sign; the lift
    // is square to it and the gripper's opening is not mirrored.
    assert_eq!(
        values_of(key),
        named(&[
            ("shoulder_pan", -30.0),
            ("shoulder_lift", -20.0),
            ("wrist_roll", -50.0),
            ("gripper", 20.0)
        ])
    );
    assert!(
        state.status().text.starts_with("mirrored key 1"),
        "{:?}",
        state.status()
    );
    assert!(state.is_dirty());
    // The other key is untouched.
    assert_eq!(
        values_of(&state.list().sequence().keyframes[0]),
        named(&[("shoulder_pan", 5.0)])
    );
    state.handle_key(Key::Char('m'));
    assert_eq!(values_of(state.list().show().unwrap()), named(&pose));
}

#[test]
fn shift_m_mirrors_every_key_and_warns_of_a_clip() {
    let mut sequence = Sequence::new("so101");
    sequence.keyframes = vec![
        key_of(&[("shoulder_pan", 10.0)]),
        key_of(&[("wrist_roll", 160.0)]),
    ];
    let mut state = with_keys(so101(), sequence);
    state.handle_key(Key::Char('M'));
    let keys = &state.list().sequence().keyframes;
    assert_eq!(values_of(&keys[0]), named(&[("shoulder_pan", -10.0)]));
    // −160° is past wrist_roll's −157.21° limit: clipped there, and said in red.
    assert_eq!(values_of(&keys[1]), named(&[("wrist_roll", -157.21)]));
    let status = state.status();
    assert!(status.error, "{status:?}");
    assert!(
        status.text.contains("mirrored all 2 keys")
            && status.text.contains("wrist_roll -160.00 → -157.21 deg"),
        "{status:?}"
    );
}

#[test]
fn on_two_arms_m_mirrors_the_selected_joints_arm_onto_the_other() {
    use crate::pose::RigidTransform;
    use crate::sequence::ArmSpec;
    let side = |y: f64| RigidTransform::new(glam::DVec3::new(0.0, y, 0.0), glam::DQuat::IDENTITY);
    let robot = Robot::cell(vec![
        ("left".into(), so101(), side(0.25)),
        ("right".into(), so101(), side(-0.25)),
    ])
    .unwrap();
    let arms = ["left", "right"].map(|name| ArmSpec {
        name: name.into(),
        robot: "so101".into(),
        base: None,
    });
    let mut sequence = Sequence::new_cell(arms.to_vec());
    sequence.keyframes = vec![key_of(&[
        ("left/shoulder_pan", 3.0),
        ("right/shoulder_pan", 25.0),
        ("right/elbow_flex", -40.0),
    ])];
    let mut state = with_keys(robot, sequence);
    // right/shoulder_pan is joint 6: right's motion goes onto left.
    state.handle_key(Key::SelectJoint(6));
    state.handle_key(Key::Char('m'));
    let key = state.list().show().unwrap();
    assert_eq!(
        values_of(key),
        named(&[
            ("right/shoulder_pan", 25.0),
            ("right/elbow_flex", -40.0),
            ("left/shoulder_pan", -25.0),
            ("left/elbow_flex", -40.0)
        ])
    );
    assert!(
        state
            .status()
            .text
            .contains("mirrored right onto left in key 0"),
        "{:?}",
        state.status()
    );
}

#[test]
fn m_without_keys_says_so() {
    let mut state = with_keys(so101(), Sequence::new("so101"));
    state.handle_key(Key::Char('m'));
    assert!(state.status().error && state.status().text.contains("no key to mirror"));
    state.handle_key(Key::Char('M'));
    assert!(state.status().text.contains("no keys to mirror"));
}
