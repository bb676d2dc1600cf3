//! `keypose record` on two arms at once (`--robot ARM=ROBOT`, `--port ARM=PATH` per arm): the
//! real binary against two buses of emulated servos on their own pseudo-terminals, served by
//! this test, while two "hands" push one limp joint of each arm along known paths (an emulated
//! servo lets itself be pushed only while its torque is off). Nothing is mocked.

use crate::common::{keypose, run, show};
use keypose::plan::{builtin_robot_of, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::testing::PtyServer;
use std::time::{Duration, Instant};

fn smoothstep(t: f64, from: f64, to: f64) -> f64 {
    let x = ((t - from) / (to - from)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A hand on servo `id` of `bus` (an SO-101 joint `joint`): waits for it to go limp, then pushes
/// it from 0 to `to` degrees over a second, and holds it there.
fn hand(bus: &PtyServer, id: u8, joint: usize, to: f64) -> std::thread::JoinHandle<()> {
    let servos = bus.bus().clone();
    let servo = Robot::builtin("so101").unwrap().joints[joint].servo.clone();
    std::thread::spawn(move || {
        let give_up = Instant::now() + Duration::from_secs(60);
        while servos.lock().servo_mut(id).unwrap().motion.torque {
            assert!(Instant::now() < give_up, "servo {id} never went limp");
            std::thread::sleep(Duration::from_millis(1));
        }
        let start = Instant::now();
        loop {
            let t = start.elapsed().as_secs_f64();
            let value = to * smoothstep(t, 0.1, 1.1);
            servos
                .lock()
                .servo_mut(id)
                .unwrap()
                .motion
                .push_to(servo.tick_exact(value));
            if t > 1.2 {
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    })
}

#[test]
fn two_arms_moved_by_hand_are_recorded_into_one_sequence_of_both() {
    let (left, right) = (
        PtyServer::start(&Robot::builtin("so101").unwrap()).unwrap(),
        PtyServer::start(&Robot::builtin("so101").unwrap()).unwrap(),
    );
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("both.json");
    // The left elbow (servo 3, joint 2) to 20°, the right wrist (servo 4, joint 3) to −15°.
    let hands = [hand(&left, 3, 2, 20.0), hand(&right, 4, 3, -15.0)];
    let out = keypose()
        .args(["record", "-o", output.to_str().unwrap(), "--quiet"])
        .args(["--robot", "left=so101", "--robot", "right=so101"])
        .args(["--port", &format!("left={}", left.path())])
        .args(["--port", &format!("right={}", right.path())])
        .args(["--joints", "left/elbow_flex,right/wrist_flex"])
        .args(["--duration", "3"])
        .output()
        .unwrap();
    for hand in hands {
        hand.join().unwrap();
    }
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("default bases"),
        "{}",
        show(&out)
    );

    let sequence = Sequence::load(&output).unwrap();
    let arms: Vec<&str> = sequence.arms.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(arms, ["left", "right"]);
    // Left on +y, right on −y: the default placement, written out for the user to edit.
    assert_eq!(sequence.arms[0].base.unwrap().xyz.y, 0.2);
    assert_eq!(sequence.arms[1].base.unwrap().xyz.y, -0.2);
    let cell = builtin_robot_of(&sequence).unwrap();
    let trajectory = Trajectory::build(&sequence, &cell).unwrap();
    let end = trajectory.sample(trajectory.end);
    let value = |name: &str| end[cell.joint_index(name).unwrap()];
    // Where the hands left the joints, within the 1° tolerance and a tick.
    assert!((value("left/elbow_flex") - 20.0).abs() <= 1.1, "{end:?}");
    assert!((value("right/wrist_flex") + 15.0).abs() <= 1.1, "{end:?}");
    // The joints no hand moved stay at home on both arms.
    for name in ["left/wrist_flex", "right/elbow_flex", "left/shoulder_pan"] {
        assert!(value(name).abs() <= 0.1, "{name}: {end:?}");
    }
    // The file is a sequence like any other: it passes the limit check.
    let checked = run(&["check", output.to_str().unwrap()]);
    assert_eq!(checked.status.code(), Some(0), "{}", show(&checked));
}

#[test]
fn several_robots_without_arm_names_are_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("x.json");
    let out = run(&[
        "record",
        "-o",
        output.to_str().unwrap(),
        "--robot",
        "so101",
        "--robot",
        "koch",
        "--port",
        "virtual",
        "--duration",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("ARM=ROBOT once per arm"),
        "{}",
        show(&out)
    );
    assert!(!output.exists());
}
