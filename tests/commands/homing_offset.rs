//! The homing offsets a calibration gives are checked against the servos' Homing_Offset
//! registers when a bus opens, before anything can move: the real serial and protocol code
//! against emulated servos on a pseudo-terminal, and the real binary.

use crate::common::{repo, run, show, stderr, VirtualBusProcess};
use keypose::bus::{self, BusError, BusOptions, Driver};
use keypose::robot::{import_lerobot_calibration, Robot};
use keypose::testing::PtyServer;

/// A full LeRobot calibration of `robot` (whole turn recorded on every joint) with these
/// homing offsets, one per joint in joint order.
fn calibration(robot: &Robot, offsets: &[i64]) -> String {
    let entries: Vec<String> = robot
        .joints
        .iter()
        .zip(offsets)
        .map(|(j, offset)| {
            format!(
                r#""{}": {{"id": {}, "drive_mode": 0, "homing_offset": {offset}, "range_min": 0, "range_max": 4095}}"#,
                j.name, j.servo.id
            )
        })
        .collect();
    format!("{{{}}}", entries.join(","))
}

/// Offsets as a LeRobot calibration of an SO-101 (STS: ±2047) or a Koch (Dynamixel: 32 bit)
/// might leave them, negative ones included.
const OFFSETS: [i64; 6] = [-1470, 1024, 1200, -2047, 0, 12];

fn calibrated(name: &str, offsets: &[i64]) -> Robot {
    let mut robot = Robot::builtin(name).unwrap();
    let text = calibration(&robot, offsets);
    import_lerobot_calibration(&mut robot, "cal.json", &text).unwrap();
    robot
}

fn open(robot: &Robot, port: &str) -> Result<bus::Connection, BusError> {
    let options = BusOptions {
        driver: Driver::Native,
        baud: None,
        fast_sync_read: false,
        ..BusOptions::default()
    };
    bus::connect_with(robot, port, &options)
}

#[test]
fn servos_holding_the_calibrations_offsets_open() {
    for name in ["so101", "koch"] {
        let robot = calibrated(name, &OFFSETS);
        // The emulated arm is the calibrated one: its servos hold these offsets.
        let server = PtyServer::start(&robot).unwrap();
        assert!(open(&robot, server.path()).is_ok(), "{name}");
    }
}

#[test]
fn a_servo_holding_another_offset_is_refused_before_anything_is_written() {
    for name in ["so101", "koch"] {
        let robot = calibrated(name, &OFFSETS);
        let server = PtyServer::start(&robot).unwrap();
        // Servo 3 (elbow_flex on both arms) was recalibrated: it now holds -300.
        server
            .bus()
            .lock()
            .servo_mut(3)
            .unwrap()
            .set_homing_offset(-300)
            .unwrap();
        let error = match open(&robot, server.path()) {
            Err(e) => e,
            Ok(_) => panic!("{name}: opened despite the mismatch"),
        };
        let message = error.to_string();
        assert!(
            matches!(error, BusError::HomingOffset(_)),
            "{name}: {message}"
        );
        assert!(
            message
                .contains("joint elbow_flex (servo 3): the file says 1200, the servo holds -300"),
            "{name}: {message}"
        );
        // Only the other joints matched: no other joint is named.
        assert!(!message.contains("shoulder_pan"), "{name}: {message}");
        let received = server.bus().lock().received.clone();
        assert!(!received.is_empty(), "{name}: the registers were not read");
        // PING 0x01 (opening a bus checks that its first servo answers), READ 0x02 and SYNC
        // READ 0x82 in both protocols: nothing that writes reached a servo.
        for packet in &received {
            let code = packet.instruction_code();
            assert!(
                matches!(code, Some(0x01 | 0x02 | 0x82)),
                "{name}: sent {packet:?}"
            );
        }
    }
}

#[test]
fn play_with_the_arms_calibration_plays() {
    let dir = tempfile::tempdir().unwrap();
    let robot = Robot::builtin("so101").unwrap();
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, calibration(&robot, &OFFSETS)).unwrap();
    let out = crate::common::play_patiently(&[
        &repo("sequences/so101_nod.json"),
        "--port",
        "virtual",
        "--calibration",
        cal.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

#[test]
fn play_on_an_arm_holding_another_offset_exits_2_naming_joint_servo_and_values() {
    let dir = tempfile::tempdir().unwrap();
    let robot = Robot::builtin("so101").unwrap();
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, calibration(&robot, &OFFSETS)).unwrap();
    // The arm on the port: the calibration's offsets on every servo but servo 2.
    let mut args: Vec<String> = vec!["--robot".into(), "so101".into()];
    for (joint, offset) in robot.joints.iter().zip(OFFSETS) {
        let offset = if joint.servo.id == 2 { 0 } else { offset };
        args.push("--homing-offset".into());
        args.push(format!("{}:{offset}", joint.servo.id));
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let server = VirtualBusProcess::start(&args);
    for command in [
        vec!["play", &repo("sequences/so101_nod.json"), "--quiet"],
        vec!["torque", "on", "--robot", "so101"],
    ] {
        let mut full = command.clone();
        full.extend([
            "--port",
            &server.path,
            "--calibration",
            cal.to_str().unwrap(),
        ]);
        let out = run(&full);
        assert_eq!(out.status.code(), Some(2), "{command:?}: {}", show(&out));
        assert!(
            stderr(&out)
                .contains("joint shoulder_lift (servo 2): the file says 1024, the servo holds 0"),
            "{}",
            show(&out)
        );
    }
    // Without the calibration the robot file says nothing about offsets: it opens.
    let out = run(&["read", "--robot", "so101", "--port", &server.path]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}
