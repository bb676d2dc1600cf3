//! The torque check through the binary: each servo's load against its torque-speed line for the
//! build the robot names, `--payload`, `--robot-variant`, `sample --torque`, and the robot
//! file's drive fields refused with the field named. Loads are judged against hand-derived
//! numbers: a payload's weight times its lever from the robot file's own forward kinematics,
//! and the datasheet lines of docs/robots.md §4.

use crate::common::{run, show, stdout};
use keypose::robot::Robot;
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// The SO-101 held still at `lift`, `elbow` (degrees) for 2 s.
fn held(lift: f64, elbow: f64) -> String {
    format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{{"name": "a", "time": 0, "joints": {{"shoulder_lift": {lift}, "elbow_flex": {elbow}}}}},
                          {{"name": "b", "time": 2, "joints": {{"shoulder_lift": {lift}, "elbow_flex": {elbow}}}}}]}}"#
    )
}

/// shoulder_lift from 0 to 90° in `seconds`, the elbow at −90°: the arm swings out until it
/// reaches forward (within the velocity and acceleration limits from 1.2 s).
fn swing(seconds: f64) -> String {
    format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{{"name": "low", "time": 0, "joints": {{"shoulder_lift": 0, "elbow_flex": -90}}}},
                          {{"name": "high", "time": {seconds}, "joints": {{"shoulder_lift": 90, "elbow_flex": -90}}}}]}}"#
    )
}

/// What the tests' arm carries, kilograms: the 5 V shoulder (1.35 N·m stall) holds it reaching
/// forward, with little to spare for braking the swing.
const PAYLOAD: &str = "0.05";

/// The `JOINT.torque` column of `sample --torque` output, first row.
fn first_torque(csv: &str, joint: &str) -> f64 {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    let column = header
        .iter()
        .position(|h| *h == format!("{joint}.torque"))
        .unwrap_or_else(|| panic!("a {joint}.torque column in {header:?}"));
    row[column]
}

#[test]
fn a_payload_adds_its_weight_times_its_lever_to_the_sampled_shoulder_torque() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "held.json", &held(60.0, -60.0));
    let bare = run(&["sample", &file, "--torque", "--rate", "10"]);
    assert_eq!(bare.status.code(), Some(0), "{}", show(&bare));
    let loaded = run(&[
        "sample",
        &file,
        "--torque",
        "--rate",
        "10",
        "--payload",
        "0.25",
    ]);
    assert_eq!(loaded.status.code(), Some(0), "{}", show(&loaded));
    let added = first_torque(&stdout(&loaded), "shoulder_lift")
        - first_torque(&stdout(&bare), "shoulder_lift");
    // The TCP's reach from the shoulder_lift axis, across gravity, by the robot file's chain.
    let robot = Robot::builtin("so101").unwrap();
    let values = [0.0, 60.0, -60.0, 0.0, 0.0, 0.0];
    let (anchor, axis) = robot.joint_axes(&values)[1];
    let weight = glam::DVec3::new(0.0, 0.0, -0.25 * 9.81);
    let lever = (robot.tcp_position(&values) - anchor)
        .cross(weight)
        .dot(axis);
    assert!(
        (added.abs() - lever.abs()).abs() < 1e-6,
        "{added} N·m added, the lever gives {lever}"
    );
}

#[test]
fn a_fast_swing_is_over_the_5_v_line_and_within_the_12_v_one() {
    // Braking the swing at its end asks the 5 V shoulder for more than its 1.35 N·m; the 12 V
    // servo (2.94 N·m) carries it, and the 5 V one carries a slower swing.
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "swing.json", &swing(1.3));
    let five = run(&["check", &file, "--payload", PAYLOAD]);
    assert_eq!(five.status.code(), Some(1), "{}", show(&five));
    let text = stdout(&five);
    assert!(text.contains("build sts3215 c001 @ 5 V"), "{text}");
    assert!(
        text.contains("FAILED: ") && text.contains("where the line gives"),
        "{text}"
    );
    let twelve = run(&[
        "check",
        &file,
        "--robot-variant",
        "12v",
        "--payload",
        PAYLOAD,
    ]);
    assert_eq!(twelve.status.code(), Some(0), "{}", show(&twelve));
    assert!(stdout(&twelve).contains("build sts3215 c047 @ 12 V"));
    // Slower, the 5 V build carries it too.
    let slow = write(dir.path(), "slow.json", &swing(4.0));
    let out = run(&["check", &slow, "--payload", PAYLOAD]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

#[test]
fn the_json_report_names_the_build_and_each_overload() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "swing.json", &swing(1.3));
    let out = run(&["check", &file, "--format", "json", "--payload", PAYLOAD]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let torque = &report["torque"];
    assert_eq!(torque["build"], "sts3215 c001 @ 5 V; 0.050 kg payload");
    let overload = &torque["overloads"][0];
    assert!(overload["torque"].as_f64().unwrap().abs() > overload["available"].as_f64().unwrap());
    let lift = torque["joints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["joint"] == "shoulder_lift")
        .unwrap();
    assert_eq!(lift["stall_torque"], 1.35);
    assert_eq!(lift["drive"], "sts3215 c001 @ 5 V");
    assert_eq!(lift["no_load_speed"], 3.5);
    assert!(lift["peak_share_of_line"].as_f64().unwrap() > 1.0);
}

#[test]
fn the_fastest_timing_keeps_every_servo_within_its_line() {
    // The swing's keys with the payload, retimed: the result passes the torque check on the
    // 5 V build.
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "swing.json", &swing(1.3));
    let fast = dir.path().join("fast.json");
    let fast = fast.to_str().unwrap();
    let out = run(&[
        "retime",
        &file,
        "--fastest",
        "--payload",
        PAYLOAD,
        "-o",
        fast,
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let out = run(&["check", fast, "--format", "json", "--payload", PAYLOAD]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let share = report["torque"]["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["peak_share_of_line"].as_f64().unwrap_or(0.0))
        .fold(0.0, f64::max);
    // The line, not the velocity limit, binds: some servo runs close to it.
    assert!(
        (0.9..=1.0).contains(&share),
        "peak share of the line {share}"
    );
}

/// A change to a robot file.
type Edit = Box<dyn Fn(&mut serde_json::Value)>;

#[test]
fn bad_drive_fields_name_the_file_the_field_and_what_was_expected() {
    let dir = tempfile::tempdir().unwrap();
    let robot: serde_json::Value =
        serde_json::from_str(keypose::robot::BUILTINS[0].description).unwrap();
    let cases: [(&str, Edit, &str); 4] = [
        (
            "variant",
            Box::new(|r| r["joints"][1]["servo"]["variant"] = "c999".into()),
            "$.joints[1].servo.variant: expected one of c001, c018, c047, c044, c046",
        ),
        (
            "supply",
            Box::new(|r| r["joints"][2]["servo"]["supply_v"] = 9.0.into()),
            "$.joints[2].servo.supply_v: expected a supply c001 is rated for: 5, 6, 7.4 V",
        ),
        (
            "payload",
            Box::new(|r| r["payload"] = serde_json::json!({"mass": 25})),
            "$.payload.mass: expected a mass from 0 to 10 kg",
        ),
        (
            "robot supply",
            Box::new(|r| r["supply_v"] = 0.into()),
            "$.supply_v: expected a supply above 0 and at most 48 V",
        ),
    ];
    for (what, edit, expected) in cases {
        let mut bad = robot.clone();
        edit(&mut bad);
        let path = write(dir.path(), "arm.json", &bad.to_string());
        let out = run(&[
            "check",
            "--robot",
            &path,
            &write(dir.path(), "s.json", &swing(3.0)),
        ]);
        assert_eq!(out.status.code(), Some(2), "{what}: {}", show(&out));
        let err = crate::common::stderr(&out);
        assert!(
            err.contains("arm.json") && err.contains(expected),
            "{what}: {err}"
        );
    }
    let out = run(&[
        "check",
        &write(dir.path(), "s.json", &swing(3.0)),
        "--payload",
        "-1",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
}
