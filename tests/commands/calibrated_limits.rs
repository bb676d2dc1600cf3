//! A LeRobot calibration moves each joint's zero to the middle of its recorded range and its
//! limits with it: the recorded range is the joint's range, and a whole-turn joint keeps the
//! robot's limits at the same servo ticks. The real binary (`check`, `sample`, `torque`,
//! `play`) with the calibration LeRobot writes for an SO-101 follower
//! (tests/data/lerobot_so101_follower.json, laid out as `draccus.dump(..., indent=4)` writes
//! it), and every built-in robot, Feetech and Dynamixel, through the library.
//!
//! Every expected tick comes from LeRobot's formulas (`motors_bus.py`): `RANGE_0_100` goes to
//! tick `int(p / 100 · (range_max − range_min) + range_min)` (`_unnormalize`, drive_mode 0 as
//! the SO follower's `calibrate()` writes it); `DEGREES` is centred on `mid = (range_min +
//! range_max) / 2`, which keypose counts at 360/4096° a tick (docs/formats.md "keypose's degrees and
//! LeRobot's").

use crate::common::{keypose, repo, run, show, stderr, stdout, VirtualBusProcess, SO101_JOINTS};
use keypose::robot::{import_lerobot_calibration, LimitsOrigin, Robot, BUILTIN_NAMES};
use std::path::Path;

/// The calibration file as LeRobot wrote it for an SO-101 follower.
const CALIBRATION: &str = "tests/data/lerobot_so101_follower.json";

/// Its gripper's recorded range, ticks.
const GRIPPER_MIN: i64 = 1956;
const GRIPPER_MAX: i64 = 3128;
/// Its elbow_flex's recorded range, ticks: mid 2007.5, half-width 1117.5 ticks.
const ELBOW_MIN: i64 = 890;
const ELBOW_MAX: i64 = 3125;
/// elbow_flex's ends in keypose's degrees: ±1117.5 · 360/4096. Beyond the built-in ±96.83°.
const ELBOW_END_DEG: f64 = 98.217_773_437_5;

/// LeRobot's `RANGE_0_100` unnormalisation of `percent` onto `min … max` (drive_mode 0).
fn lerobot_percent_tick(percent: f64, min: i64, max: i64) -> i64 {
    (percent / 100.0 * (max - min) as f64 + min as f64) as i64
}

fn calibration() -> String {
    repo(CALIBRATION)
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// The gripper at 0 %, 10 % and 100 %, elbow_flex at both ends of its recorded range as
/// percents and as degrees; monotone, so that no curve passes a key.
const ENDS: &str = r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"monotone",
  "keyframes":[
    {"time":0,"joints":{"gripper":"0%","elbow_flex":"0%","shoulder_lift":-90}},
    {"time":4,"joints":{"gripper":"10%","elbow_flex":"100%"}},
    {"time":8,"joints":{"gripper":"100%","elbow_flex":-98.2177734375}},
    {"time":12,"joints":{"elbow_flex":98.2177734375}}]}"#;

/// The rows of a `sample --units ticks` CSV at whole seconds: (time, ticks by joint).
fn rows_at_whole_seconds(csv: &str) -> Vec<(f64, Vec<i64>)> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[1..], SO101_JOINTS, "{csv}");
    lines
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            let ticks = fields[1..].iter().map(|f| f.parse().unwrap()).collect();
            (fields[0].parse().unwrap(), ticks)
        })
        .filter(|(t, _): &(f64, Vec<i64>)| t.fract() == 0.0)
        .collect()
}

#[test]
fn the_whole_recorded_range_is_reachable_in_check_and_sample() {
    let dir = tempfile::tempdir().unwrap();
    let seq = write(dir.path(), "ends.json", ENDS);
    let cal = calibration();
    // Within the limits everywhere; at the ends of the recorded range the elbow folds its
    // lower arm into the shoulder (0.1 mm on the built-in model) and its wrist within the
    // clearance of the upper arm, which the check reports as the contacts they are, and
    // nothing else.
    let out = run(&["check", &seq, "--calibration", &cal, "--format", "json"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("a JSON report");
    assert_eq!(
        report["violations"],
        serde_json::json!([]),
        "{}",
        show(&out)
    );
    let contacts = report["clearance"]["contacts"].as_array().unwrap();
    assert!(
        !contacts.is_empty() && contacts.iter().all(|c| c["kind"] == "self"),
        "{}",
        show(&out)
    );
    let out = run(&[
        "sample",
        &seq,
        "--calibration",
        &cal,
        "--units",
        "ticks",
        "--rate",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let rows = rows_at_whole_seconds(&stdout(&out));
    let (elbow, gripper) = (2, 5);
    let at = |t: f64| &rows.iter().find(|(time, _)| *time == t).unwrap().1;
    let grip = |p| lerobot_percent_tick(p, GRIPPER_MIN, GRIPPER_MAX);
    // 0 %: range_min; 10 %: int(117.2 + 1956) = 2073; 100 %: range_max.
    assert_eq!((grip(0.0), grip(10.0), grip(100.0)), (1956, 2073, 3128));
    assert_eq!(at(0.0)[gripper], grip(0.0));
    assert_eq!(at(4.0)[gripper], grip(10.0));
    assert_eq!(at(8.0)[gripper], grip(100.0));
    // elbow_flex: 0 % and 100 % are its recorded ends; ∓98.2177734375° is mid ∓ 1117.5 ticks,
    // the same ends.
    assert_eq!(at(0.0)[elbow], ELBOW_MIN);
    assert_eq!(at(4.0)[elbow], ELBOW_MAX);
    assert_eq!(at(8.0)[elbow], ELBOW_MIN);
    assert_eq!(at(12.0)[elbow], ELBOW_MAX);
    assert_eq!(
        ELBOW_END_DEG,
        (ELBOW_MAX - ELBOW_MIN) as f64 / 2.0 * 360.0 / 4096.0
    );
}

#[test]
fn a_key_past_the_recorded_range_is_refused_naming_the_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let cal = calibration();
    // One tick past the top of elbow_flex's recorded range: 1118.5 ticks above its middle,
    // 1118.5 · 360/4096 = 98.3056640625°.
    let seq = write(
        dir.path(),
        "past.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"elbow_flex":0}},{"time":10,"joints":{"elbow_flex":98.3056640625}}]}"#,
    );
    let out = run(&["check", &seq, "--calibration", &cal]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    assert!(
        err.contains("expected -98.2177734375 … 98.2177734375 deg"),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "the range recorded for it in the calibration {cal}"
        )),
        "{err}"
    );
}

#[test]
fn a_whole_turn_joint_keeps_the_robots_limits_at_the_same_ticks() {
    // wrist_roll: LeRobot gives it 0 … 4095 (no recorded range), so its middle is 2047.5; the
    // built-in SO-101's zero is tick 2047 and its upper limit 162.79°, tick
    // 2047 + 162.79 · 4096/360 = 3899.18. From the calibrated zero that tick is half a tick
    // less: 162.79 − 0.5 · 360/4096 = 162.7460546875°.
    let dir = tempfile::tempdir().unwrap();
    let cal = calibration();
    let key = |deg: &str| {
        let text = format!(
            r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[
              {{"time":0,"joints":{{"wrist_roll":0}}}},{{"time":10,"joints":{{"wrist_roll":{deg}}}}}]}}"#
        );
        write(dir.path(), &format!("roll_{deg}.json"), &text)
    };
    let out = run(&["check", &key("162.74"), "--calibration", &cal]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let out = run(&["check", &key("162.75"), "--calibration", &cal]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        stderr(&out).contains("the robot's limits, moved to the zero of the calibration"),
        "{}",
        show(&out)
    );
}

/// A copy of the built-in SO-101 as a robot file whose servos hold the calibration's homing
/// offsets and rest with the gripper at `gripper_tick` (the others at their zero tick): the arm
/// after LeRobot calibrated it, for `keypose virtual-bus`.
fn calibrated_arm_at(dir: &Path, gripper_tick: i64) -> String {
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    let cal: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(calibration()).unwrap()).unwrap();
    for joint in robot["joints"].as_array_mut().unwrap() {
        let name = joint["name"].as_str().unwrap().to_string();
        joint["servo"]["homing_offset"] = cal[&name]["homing_offset"].clone();
    }
    // The built-in's zero is tick 2047, at 360/4096° a tick.
    robot["home"]["gripper"] = ((gripper_tick - 2047) as f64 * 360.0 / 4096.0).into();
    write(dir, "arm.json", &robot.to_string())
}

#[test]
fn torque_on_holds_a_gripper_resting_low_in_its_range() {
    let dir = tempfile::tempdir().unwrap();
    // 100 ticks above range_min: (2056 − 1956) / 1172 = 8.53 % of the recorded range.
    let rest = 2056;
    let arm = calibrated_arm_at(dir.path(), rest);
    let server = VirtualBusProcess::start(&["--robot", &arm]);
    let cal = calibration();
    let with_arm = |verb: &[&str]| {
        let mut args = verb.to_vec();
        args.extend([
            "--robot",
            "so101",
            "--calibration",
            &cal,
            "--port",
            &server.path,
        ]);
        run(&args)
    };
    let out = with_arm(&["torque", "on"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let out = with_arm(&["read"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let pose: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(pose["ticks"][5], rest, "{pose}");
    let percent = pose["percent"]["gripper"].as_f64().unwrap();
    let expected = (rest - GRIPPER_MIN) as f64 / (GRIPPER_MAX - GRIPPER_MIN) as f64 * 100.0;
    assert!((percent - expected).abs() < 1e-9, "{pose}");
    assert!((8.5..8.6).contains(&percent), "{pose}");
}

#[test]
fn play_takes_a_gripper_resting_low_in_its_range_through_0_10_and_100_percent() {
    let dir = tempfile::tempdir().unwrap();
    let arm = calibrated_arm_at(dir.path(), 2056);
    let server = VirtualBusProcess::start(&["--robot", &arm]);
    // Each percent held for half a second (a monotone curve is flat between equal keys), so
    // that whichever cycles fall there command exactly that value.
    let seq = write(
        dir.path(),
        "grip.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"monotone",
          "keyframes":[
            {"time":0,"joints":{"gripper":"0%"}},
            {"time":0.5,"joints":{"gripper":"0%"}},
            {"time":1.5,"joints":{"gripper":"10%"}},
            {"time":2,"joints":{"gripper":"10%"}},
            {"time":4,"joints":{"gripper":"100%"}},
            {"time":4.5,"joints":{"gripper":"100%"}}]}"#,
    );
    let log = dir.path().join("grip.csv");
    let out = keypose()
        .args(["play", &seq, "--calibration", &calibration()])
        .args(crate::common::TOLERATED_STALL)
        .args(["--port", &server.path, "--quiet", "--log"])
        .arg(&log)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // The commanded gripper in keypose's degrees from the calibrated middle
    // (1956 + 3128) / 2 = 2542, at 360/4096° a tick: 0 % is −586 ticks, 10 % (unrounded
    // 2073.2) −468.8, 100 % +586.
    let deg = |tick: f64| (tick - 2542.0) * 360.0 / 4096.0;
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (phase, time, cmd) = (
        column("phase"),
        column("sequence_time"),
        column("gripper_cmd"),
    );
    let played: Vec<(f64, f64)> = lines
        .map(|line| line.split(',').collect::<Vec<_>>())
        .filter(|f| f[phase] == "play")
        .map(|f| (f[time].parse().unwrap(), f[cmd].parse().unwrap()))
        .collect();
    // The log gives six decimals.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6;
    for (from, to, tick) in [(0.0, 0.5, 1956.0), (1.5, 2.0, 2073.2), (4.0, 4.5, 3128.0)] {
        let held: Vec<f64> = played
            .iter()
            .filter(|(t, _)| (from..=to).contains(t))
            .map(|&(_, value)| value)
            .collect();
        assert!(!held.is_empty(), "no cycle within {from} … {to} s");
        assert!(
            held.iter().all(|&value| close(value, deg(tick))),
            "{from} … {to} s: {held:?}, expected {}",
            deg(tick)
        );
    }
    let (low, high) = (deg(1956.0), deg(3128.0));
    assert!(
        played
            .iter()
            .all(|&(_, value)| value >= low - 1e-6 && value <= high + 1e-6),
        "a goal outside {low} … {high}"
    );
}

/// A calibration of `robot` as LeRobot writes it, with `recorded` given that range and every
/// other joint the whole turn, as LeRobot gives its full-turn motors.
fn calibrate(robot: &str, recorded: &str, range: (i64, i64)) -> Robot {
    let mut robot = Robot::builtin(robot).unwrap();
    let entries: Vec<String> = robot
        .joints
        .iter()
        .map(|j| {
            let (min, max) = if j.name == recorded { range } else { (0, 4095) };
            format!(
                r#""{}": {{"id": {}, "drive_mode": 0, "homing_offset": 0, "range_min": {min}, "range_max": {max}}}"#,
                j.name, j.servo.id
            )
        })
        .collect();
    import_lerobot_calibration(
        &mut robot,
        "cal.json",
        &format!("{{{}}}", entries.join(",")),
    )
    .unwrap();
    robot
}

#[test]
fn every_builtin_robots_limits_follow_the_calibrated_zero() {
    // The oracle is each robot file as written: tick = zero_tick + direction · value / unit, with
    // unit 360/4096° a tick or the file's metres_per_tick. The calibrated unit is the same and the
    // zero the middle of the recorded range.
    for name in BUILTIN_NAMES {
        let file: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(repo(&format!("robots/{name}.json"))).unwrap(),
        )
        .unwrap();
        let joints = file["joints"].as_array().unwrap();
        for recorded in joints.iter().map(|j| j["name"].as_str().unwrap()) {
            let robot = calibrate(name, recorded, (1000, 3000));
            for (joint, spec) in robot.joints.iter().zip(joints) {
                let servo = &spec["servo"];
                let unit = servo["metres_per_tick"].as_f64().unwrap_or(360.0 / 4096.0);
                let (zero, direction) = (
                    servo["zero_tick"].as_f64().unwrap(),
                    servo["direction"].as_f64().unwrap(),
                );
                let ticks = ["min", "max"]
                    .map(|end| zero + direction * spec["limits"][end].as_f64().unwrap() / unit);
                let (low, high) = (ticks[0].min(ticks[1]), ticks[0].max(ticks[1]));
                let (expected_min, expected_max, origin) = if joint.name == recorded {
                    // The recorded range, ±1000 ticks around 2000.
                    (-1000.0 * unit, 1000.0 * unit, "recorded")
                } else {
                    // The robot's ticks, within the turn 0 … 4095, from the middle 2047.5.
                    (
                        (low.max(0.0) - 2047.5) * unit,
                        (high.min(4095.0) - 2047.5) * unit,
                        "rebased",
                    )
                };
                let what = format!("{name} {} ({recorded} recorded)", joint.name);
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * unit.max(b.abs());
                assert!(
                    close(joint.limits.min, expected_min) && close(joint.limits.max, expected_max),
                    "{what}: {} … {}, expected {expected_min} … {expected_max}",
                    joint.limits.min,
                    joint.limits.max
                );
                let found = match joint.limits_origin {
                    LimitsOrigin::RecordedRange { .. } => "recorded",
                    LimitsOrigin::Rebased { .. } => "rebased",
                    LimitsOrigin::Robot => "robot",
                };
                assert_eq!(found, origin, "{what}");
            }
        }
    }
}

#[test]
fn a_whole_turn_joint_whose_robot_limits_lie_outside_the_turn_is_bad_input() {
    // A robot file whose wrist_roll zero is tick 10000: its limits −157.21 … 162.79° are ticks
    // 8211 … 11852, none of them in the 0 … 4095 the calibration gives that joint.
    let dir = tempfile::tempdir().unwrap();
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot["joints"][4]["servo"]["zero_tick"] = 10000.into();
    let robot = write(dir.path(), "far.json", &robot.to_string());
    let cal = calibration();
    let out = run(&[
        "check",
        &repo("sequences/so101_nod.json"),
        "--robot",
        &robot,
        "--calibration",
        &cal,
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    for part in [
        format!("{cal}: $.wrist_roll"),
        "outside the whole turn 0 … 4095".to_string(),
        "zero_tick".to_string(),
    ] {
        assert!(err.contains(&part), "{part:?} in {err}");
    }
}
