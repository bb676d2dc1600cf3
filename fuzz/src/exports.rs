//! What the export targets share: a trajectory of a built-in robot built from the fuzzer's
//! choices (2 to 5 keys within the limits, any interpolation, holds), and names of any content
//! from the fuzzer's bytes for its joints, the motion and the source file.

use crate::{builtin_robot, Choices};
use keypose::curve::Interp;
use keypose::plan::Trajectory;
use keypose::robot::Robot;
use keypose::sequence::{KeyValue, Keyframe, Sequence};

const MODES: [Option<Interp>; 6] = [
    None,
    Some(Interp::Step),
    Some(Interp::Linear),
    Some(Interp::Cubic),
    Some(Interp::Monotone),
    Some(Interp::Smooth),
];

/// A fraction 0 … 1 from the next byte.
fn share(choices: &mut Choices) -> f64 {
    f64::from(choices.byte()) / 255.0
}

/// A built-in robot and a trajectory of 2 to 5 keys for it: every joint at the first key, a
/// chosen few at the others, each value inside the joint's limits; keys 0.05 to 3 s apart,
/// some held, each segment's mode chosen. `None` when it does not build.
pub fn trajectory(choices: &mut Choices) -> Option<(&'static Robot, Trajectory)> {
    let robot = builtin_robot(choices.byte());
    let mut sequence = Sequence::new(&robot.name);
    sequence.key_interval = None;
    let keys = 2 + usize::from(choices.byte() % 4);
    let mut time = 0.0;
    for k in 0..keys {
        let mask = if k == 0 { u8::MAX } else { choices.byte() };
        let values = robot
            .joints
            .iter()
            .enumerate()
            .filter(|(j, _)| mask & (1 << (j % 8)) != 0)
            .map(|(_, joint)| {
                let (min, max) = (joint.limits.min, joint.limits.max);
                (
                    joint.name.clone(),
                    KeyValue::Joint(min + (max - min) * share(choices)),
                )
            })
            .collect();
        let mut key = Keyframe::new(values);
        let gap = 0.05 + 2.95 * share(choices);
        key.time = Some(time);
        key.interp = choices.pick(&MODES);
        if k + 1 < keys && choices.byte().is_multiple_of(4) {
            key.hold = (gap * 0.5 * 1000.0).round() / 1000.0;
        }
        sequence.keyframes.push(key);
        time += (gap * 1000.0).round() / 1000.0;
    }
    let trajectory = Trajectory::build(&sequence, robot).ok()?;
    Some((robot, trajectory))
}

/// `count` names from the fuzzer's bytes: each a length byte (0 … 63) and that many bytes,
/// read as UTF-8 (invalid sequences as U+FFFD). Every character can occur.
pub fn names(choices: &mut Choices, count: usize) -> Vec<String> {
    (0..count)
        .map(|_| {
            let length = usize::from(choices.byte() % 64);
            String::from_utf8_lossy(choices.take(length)).into_owned()
        })
        .collect()
}

/// A longer name: whatever is left of the input, as UTF-8.
pub fn rest_as_name(choices: &mut Choices) -> String {
    String::from_utf8_lossy(choices.rest()).into_owned()
}

/// `robot` with its joints renamed.
pub fn renamed(robot: &Robot, names: &[String]) -> Robot {
    let mut robot = robot.clone();
    for (joint, name) in robot.joints.iter_mut().zip(names) {
        joint.name.clone_from(name);
    }
    robot
}
