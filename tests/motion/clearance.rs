//! The check's clearance along the whole motion, through the binary: a key in the desk, a dip
//! between two clear keys (one lasting a millisecond), two arms on one base, a declared
//! contact; and `play` refusing what the check refuses, before any port is opened.
//!
//! The oracle for depths is the collision model `keypose pose` and the jog guard use (one model
//! for every surface; tests/simulation/collision.rs holds it against MuJoCo's contacts), and
//! for where a contact lies, the geometry of the moves (which keys are clear, when the wrist
//! passes the angle at which the gripper points at the desk).

use crate::common::{run, show, stdout};
use keypose::collision::CollisionModel;
use keypose::robot::Robot;
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// Runs keypose with `args`, asserting its exit code and that its standard error says each of
/// `words`.
fn refused(args: &[&str], code: i32, words: &[&str]) {
    let out = run(args);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {}", show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    for w in words {
        assert!(err.contains(w), "{args:?}: {w:?} missing: {}", show(&out));
    }
}

/// `play` of `file` on a port that does not exist: a refusal must come before it is opened.
fn play_args(file: &str) -> [&str; 5] {
    [
        "play",
        file,
        "--port",
        "/dev/keypose-no-such-port",
        "--quiet",
    ]
}

fn json_report(file: &str) -> serde_json::Value {
    let out = run(&["check", file, "--format", "json"]);
    serde_json::from_slice(&out.stdout).unwrap_or_else(|_| panic!("{}", show(&out)))
}

fn contacts(report: &serde_json::Value) -> Vec<serde_json::Value> {
    report["clearance"]["contacts"].as_array().unwrap().clone()
}

/// home → elbow 80° (the gripper in the desk) → home: `check` fails on the key, names it and
/// how far to raise it, and `play` refuses without opening its port.
#[test]
fn a_key_in_the_desk_fails_the_check_and_is_not_played() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "desk.json",
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{"name": "home", "time": 0, "joints": {"elbow_flex": 0}},
                          {"name": "into-desk", "time": 3, "joints": {"elbow_flex": 80}},
                          {"name": "back", "time": 6, "joints": {"elbow_flex": 0}}]}"#,
    );
    let out = run(&["check", &file]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert!(
        stdout(&out).contains("ok: no limit violations"),
        "{}",
        show(&out)
    );
    assert!(
        stdout(&out).contains("raise key 'into-desk' by"),
        "{}",
        show(&out)
    );
    let report = json_report(&file);
    let found = contacts(&report);
    let gripper = found
        .iter()
        .find(|c| c["bodies"][0] == "gripper")
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(gripper["kind"], "floor");
    assert_eq!(gripper["key"], 1);
    // The deepest point is the key itself, as deep as the model puts the arm there.
    assert!((gripper["deepest_time"].as_f64().unwrap() - 3.0).abs() < 2e-3);
    let robot = Robot::builtin("so101").unwrap();
    let model = CollisionModel::for_robot(&robot).unwrap();
    let at_key = model.touches(&[0.0, 0.0, 80.0, 0.0, 0.0, 0.0], 0.0);
    let depth = at_key
        .iter()
        .find(|t| t.bodies.0 == "gripper")
        .unwrap()
        .distance;
    let reported = gripper["distance_mm"].as_f64().unwrap() / 1000.0;
    assert!((reported - depth).abs() < 1e-4, "{reported} vs {depth}");

    // No timing mends it: `retime` says so, with the fix, and writes nothing.
    let retimed = dir.path().join("retimed.json");
    let fix = "raise key 'into-desk'";
    let retime = ["retime", &file, "-o", retimed.to_str().unwrap()];
    refused(&retime, 1, &["cannot be fixed by retiming", fix]);
    assert!(!retimed.exists());

    // Every export refuses it, and writes nothing.
    for (format, name) in [
        ("ros2", "t.yaml"),
        ("play_motion2", "m.yaml"),
        ("c", "t.h"),
        ("lerobot", "ds"),
    ] {
        let out_file = dir.path().join(name);
        let export = ["export", format, &file, "-o", out_file.to_str().unwrap()];
        refused(&export, 1, &["refusing to export", fix]);
        assert!(!out_file.exists(), "{format}: wrote {name}");
    }

    // Nothing is sent: the refusal comes before the port is opened (this one does not exist).
    refused(&play_args(&file), 1, &["refusing to play"]);
}

/// Two clear keys (the wrist at −85.5° and +85.5° with the elbow at 30°) whose path points the
/// gripper at the desk on the way: found between them, no key to move, and the advice says
/// timing does not help. The same swing in 2 ms — a dip of about a millisecond, shorter than
/// any control period — is found as surely.
#[test]
fn a_dip_between_two_clear_keys_fails_however_short() {
    let dir = tempfile::tempdir().unwrap();
    for (name, seconds) in [("slow.json", 3.0), ("dip.json", 0.002)] {
        let file = write(
            dir.path(),
            name,
            &format!(
                r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
                    "keyframes": [{{"name": "a", "time": 0, "joints": {{"elbow_flex": 30, "wrist_flex": -85.5}}}},
                                  {{"name": "b", "time": {seconds}, "joints": {{"wrist_flex": 85.5}}}}]}}"#
            ),
        );
        let report = json_report(&file);
        let found = contacts(&report);
        assert!(!found.is_empty(), "{name}: {report}");
        for c in &found {
            assert_eq!(c["kind"], "floor", "{name}: {c}");
            // Both keys are clear: no key is to move, the path itself is.
            assert_eq!(c["key"], serde_json::Value::Null, "{name}: {c}");
            let at = c["deepest_time"].as_f64().unwrap();
            assert!(at > 0.0 && at < seconds, "{name}: {c}");
            let advice = c["advice"].as_str().unwrap();
            assert!(advice.contains("retime does not help"), "{name}: {c}");
        }
        assert_eq!(report["passed"], false);
    }
}

/// Two arms 2 cm apart are in each other; 0.4 m apart the same motion is clear; on one base
/// (both without "base": at the cell's origin) the file is refused before anything is checked.
#[test]
fn two_arms_on_one_base_fail_and_apart_they_pass() {
    let dir = tempfile::tempdir().unwrap();
    let cell = |bases: &str| {
        format!(
            r#"{{"format": "keypose-sequence/1", "robots": {bases}, "interpolation": "cubic",
                "keyframes": [{{"time": 0, "joints": {{"left/elbow_flex": 0, "right/elbow_flex": 0}}}},
                              {{"time": 2, "joints": {{"left/elbow_flex": -30, "right/elbow_flex": -30}}}}]}}"#
        )
    };
    let one_base = write(
        dir.path(),
        "one_base.json",
        &cell(r#"{"left": "so101", "right": "so101"}"#),
    );
    let out = run(&["check", &one_base]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        crate::common::stderr(&out).contains("arms \"left\" and \"right\" stand on one base"),
        "{}",
        show(&out)
    );
    let together = write(
        dir.path(),
        "together.json",
        &cell(
            r#"{"left": {"robot": "so101", "base": {"xyz": [0, 0.01, 0]}},
                "right": {"robot": "so101", "base": {"xyz": [0, -0.01, 0]}}}"#,
        ),
    );
    let report = json_report(&together);
    assert!(
        contacts(&report)
            .iter()
            .any(|c| c["kind"] == "between_arms"),
        "{report}"
    );
    let apart = write(
        dir.path(),
        "apart.json",
        &cell(
            r#"{"left": {"robot": "so101", "base": {"xyz": [0, 0.2, 0]}},
                "right": {"robot": "so101", "base": {"xyz": [0, -0.2, 0]}}}"#,
        ),
    );
    let out = run(&["check", &apart]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

/// A key that means to touch the desk says so: within its depth it passes the check (shown as
/// declared), `play` asks for --allow-contact, and deeper than declared it fails again.
#[test]
fn a_declared_contact_passes_within_its_depth_and_play_asks_for_it() {
    let dir = tempfile::tempdir().unwrap();
    // The gripper 5.6 mm into the desk at "press" (the model's depth there).
    let sequence = |depth: f64| {
        format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
                "keyframes": [{{"name": "home", "time": 0, "joints": {{"shoulder_lift": 0, "elbow_flex": 0, "wrist_flex": 0}}}},
                              {{"name": "press", "time": 3, "hold": 0.5,
                                "joints": {{"shoulder_lift": 40, "elbow_flex": -30, "wrist_flex": 75}},
                                "contact": [{{"link": "gripper", "with": "floor", "depth_mm": {depth}}}]}},
                              {{"name": "back", "time": 6, "joints": {{"shoulder_lift": 0, "elbow_flex": 0, "wrist_flex": 0}}}}]}}"#
        )
    };
    let deep_enough = write(dir.path(), "press.json", &sequence(8.0));
    let out = run(&["check", &deep_enough]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        stdout(&out).contains("declared by key #1"),
        "{}",
        show(&out)
    );
    refused(&play_args(&deep_enough), 1, &["--allow-contact"]);
    let too_shallow = write(dir.path(), "shallow.json", &sequence(2.0));
    let out = run(&["check", &too_shallow]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    // A link the robot does not have is bad input, naming where.
    let unknown = write(
        dir.path(),
        "unknown.json",
        &sequence(8.0).replace(r#""link": "gripper""#, r#""link": "tentacle""#),
    );
    refused(&["check", &unknown], 2, &["$.keyframes[1].contact[0].link"]);
}
