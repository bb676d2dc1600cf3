//! How `--robot` and a sequence's "robot" resolve, through the real binary: a built-in name
//! always means the built-in; a file is read only when the value is a path.

use crate::common::{keypose, repo, show, stderr};
use serde_json::Value;
use std::path::Path;

/// The built-in SO-101 (its limit on shoulder_pan is ±110°, docs/robots.md) with that joint widened
/// to ±170°: what a planted copy could carry.
fn wide_so101() -> String {
    let text = std::fs::read_to_string(repo("robots/so101.json")).unwrap();
    let mut robot: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(robot["joints"][0]["name"], "shoulder_pan");
    let limits = &mut robot["joints"][0]["limits"];
    limits["min"] = (-170.0).into();
    limits["max"] = 170.0.into();
    robot.to_string()
}

/// A slow move of shoulder_pan to `degrees`, written as `name` in `dir`; `robot` is what the
/// sequence's "robot" field says.
fn pan_sequence(dir: &Path, name: &str, robot: &str, degrees: f64) -> String {
    let path = dir.join(name);
    std::fs::write(
        &path,
        format!(
            r#"{{"format":"keypose-sequence/1","robot":"{robot}","keyframes":[
              {{"time":0,"joints":{{"shoulder_pan":0}}}},{{"time":10,"joints":{{"shoulder_pan":{degrees}}}}}]}}"#
        ),
    )
    .unwrap();
    path.display().to_string()
}

/// A move of shoulder_pan to 150°: inside the planted copy's limits, 40° past the built-in's
/// (a key outside the limits is bad input, exit 2).
fn sequence_to_150(dir: &Path, robot: &str) -> String {
    pan_sequence(dir, "pan.json", robot, 150.0)
}

/// A move of shoulder_pan to 20°, inside every SO-101 and Koch limit.
fn sequence_to_20(dir: &Path, robot: &str) -> String {
    pan_sequence(dir, &format!("pan_{robot}.json"), robot, 20.0)
}

fn check_json(cwd: &Path, args: &[&str]) -> (Option<i32>, Value, String) {
    let out = keypose()
        .current_dir(cwd)
        .args(["-v", "check", "--format", "json"])
        .args(args)
        .output()
        .unwrap();
    let report = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
    (out.status.code(), report, show(&out))
}

#[test]
fn a_planted_file_named_like_a_built_in_is_ignored() {
    // A built-in's name and a LeRobot type's name alike.
    for name in ["so101", "so101_follower"] {
        let cwd = tempfile::tempdir().unwrap();
        let beside = tempfile::tempdir().unwrap();
        std::fs::write(cwd.path().join(name), wide_so101()).unwrap();
        std::fs::write(beside.path().join(name), wide_so101()).unwrap();
        let sequence = sequence_to_150(beside.path(), name);
        for args in [vec![sequence.as_str()], vec![&sequence, "--robot", name]] {
            let (code, _, shown) = check_json(cwd.path(), &args);
            // The built-in's ±110° limit applies: the 150° key is refused as bad input.
            assert_eq!(code, Some(2), "{args:?}: {shown}");
            assert!(shown.contains("robot so101: built-in"), "{shown}");
            assert!(shown.contains("expected -110 … 110 deg"), "{shown}");
        }
    }
}

#[test]
fn a_path_reads_the_file() {
    let cwd = tempfile::tempdir().unwrap();
    let beside = tempfile::tempdir().unwrap();
    std::fs::write(cwd.path().join("so101"), wide_so101()).unwrap();
    std::fs::write(beside.path().join("wide.json"), wide_so101()).unwrap();
    // --robot ./so101: relative to the working directory.
    let sequence = sequence_to_150(beside.path(), "so101");
    let (code, report, shown) = check_json(cwd.path(), &[&sequence, "--robot", "./so101"]);
    assert_eq!(code, Some(0), "{shown}");
    assert_eq!(
        report["robot_source"],
        serde_json::json!({ "file": "./so101" })
    );
    // "robot": "wide.json" in the sequence: relative to the sequence.
    let sequence = sequence_to_150(beside.path(), "wide.json");
    let (code, report, shown) = check_json(cwd.path(), &[&sequence]);
    assert_eq!(code, Some(0), "{shown}");
    let file = beside.path().join("wide.json").display().to_string();
    assert_eq!(report["robot_source"], serde_json::json!({ "file": file }));
}

#[test]
fn an_unknown_bare_name_lists_the_built_ins() {
    let cwd = tempfile::tempdir().unwrap();
    // Even with a file of that name present.
    std::fs::write(cwd.path().join("so102"), wide_so101()).unwrap();
    let sequence = sequence_to_150(cwd.path(), "so102");
    for args in [vec![sequence.as_str()], vec![&sequence, "--robot", "so102"]] {
        let (code, _, shown) = check_json(cwd.path(), &args);
        assert_eq!(code, Some(2), "{shown}");
        for expected in [
            "unknown robot \"so102\"",
            "so101, so100, koch, omx",
            "./so102",
        ] {
            assert!(shown.contains(expected), "{expected:?} in {shown}");
        }
        assert!(!shown.contains("panicked"), "{shown}");
    }
    // In the sequence: the message points at the field.
    let (_, _, shown) = check_json(cwd.path(), &[&sequence]);
    assert!(
        shown.contains("pan.json") && shown.contains("$.robot"),
        "{shown}"
    );
}

#[test]
fn verbose_says_which_robot_is_used() {
    let cwd = tempfile::tempdir().unwrap();
    std::fs::write(cwd.path().join("wide.json"), wide_so101()).unwrap();
    let out = keypose()
        .current_dir(cwd.path())
        .args(["-v", "read", "--robot", "so101", "--port", "virtual"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        stderr(&out).contains("robot so101: built-in"),
        "{}",
        show(&out)
    );
    let out = keypose()
        .current_dir(cwd.path())
        .args([
            "torque",
            "off",
            "--robot",
            "wide.json",
            "--port",
            "virtual",
            "--verbose",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        stderr(&out).contains("robot so101: file wide.json"),
        "{}",
        show(&out)
    );
}

#[test]
fn lerobot_type_names_mean_the_built_ins() {
    let cwd = tempfile::tempdir().unwrap();
    for (lerobot, builtin, leader) in [
        ("so101_follower", "so101", false),
        ("so101_leader", "so101", true),
        ("so100_follower", "so100", false),
        ("so100_leader", "so100", true),
        ("koch_follower", "koch", false),
        ("koch_leader", "koch", true),
    ] {
        let in_sequence = sequence_to_20(cwd.path(), lerobot);
        let on_command_line = sequence_to_20(cwd.path(), builtin);
        for args in [
            vec![in_sequence.as_str()],
            vec![&on_command_line, "--robot", lerobot],
        ] {
            let (code, report, shown) = check_json(cwd.path(), &args);
            assert_eq!(code, Some(0), "{lerobot}: {shown}");
            assert_eq!(report["robot"], builtin, "{shown}");
            assert_eq!(
                report["robot_source"],
                serde_json::json!({ "builtin": builtin })
            );
            assert!(shown.contains(&format!("(LeRobot {lerobot})")), "{shown}");
            // A leader is read with its follower's description, and the user is told.
            let note = format!("{lerobot} is LeRobot's leader arm, read as the built-in {builtin}");
            assert_eq!(shown.contains(&note), leader, "{shown}");
        }
    }
    // A leader can be read where a robot is given without a sequence.
    let out = keypose()
        .args(["read", "--robot", "so101_leader", "--port", "virtual"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

#[test]
fn lerobot_types_keypose_has_not_built_in_are_refused_with_the_reason() {
    let cwd = tempfile::tempdir().unwrap();
    let cases = [
        ("omx_follower", "not the OpenMANIPULATOR-X"),
        ("omx_leader", "not the OpenMANIPULATOR-X"),
    ];
    for (name, reason) in cases {
        let sequence = sequence_to_20(cwd.path(), name);
        let plain = sequence_to_20(cwd.path(), "so101");
        for args in [vec![sequence.as_str()], vec![&plain, "--robot", name]] {
            let (code, report, shown) = check_json(cwd.path(), &args);
            assert_eq!(code, Some(2), "{name}: {shown}");
            assert_eq!(report, Value::Null, "nothing checked: {shown}");
            for expected in [reason, "robot file", name] {
                assert!(shown.contains(expected), "{expected:?} in {shown}");
            }
        }
    }
}
