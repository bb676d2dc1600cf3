//! Robot file text, loaded; when it loads, the kinematics and the tick conversions of every
//! joint at and around its limits and home, and emulated servos built for it.
//! Property: no panic; every goal tick the joint gives (`goal_tick`, `hold_tick`) maps back to a
//! value inside its limits; the forward kinematics at home are finite.
#![no_main]

use keypose::robot::{Joint, Robot};
use keypose::testing::VirtualServos;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(robot) = Robot::from_json("fuzz.json", text) else {
        return;
    };
    let frames = robot.joint_frames(&robot.home);
    assert_eq!(frames.len(), robot.joints.len());
    assert!(
        robot.tcp_position(&robot.home).is_finite(),
        "home FK not finite"
    );
    for (joint, &home) in robot.joints.iter().zip(&robot.home) {
        check_goals(joint, home);
    }
    let servos = VirtualServos::for_robot(&robot);
    assert_eq!(servos.servos.len(), robot.joints.len());
});

/// Values at, just past and between the limits: each goal tick lands inside them.
fn check_goals(joint: &Joint, home: f64) {
    let (min, max) = (joint.limits.min, joint.limits.max);
    let span = max - min;
    let values = [
        min,
        max,
        home,
        (min + max) / 2.0,
        min - span * 0.01,
        max + span * 0.01,
        min + span * 1e-9,
        max - span * 1e-9,
    ];
    for value in values {
        if let Ok(tick) = joint.goal_tick(value) {
            let back = joint.servo.value(tick);
            assert!(
                joint.limits.contains(back),
                "{}: goal for {value} is tick {tick} = {back}, outside {min}..{max}",
                joint.name
            );
        }
        if let Ok(tick) = joint.servo.tick(value) {
            if let Some(goal) = joint.hold_tick(tick) {
                let back = joint.servo.value(goal);
                assert!(
                    joint.limits.contains(back),
                    "{}: hold at tick {tick} is tick {goal} = {back}, outside {min}..{max}",
                    joint.name
                );
            }
        }
    }
}
