//! The `keypose` binary as a user runs it: exit codes, messages, and outputs.

use crate::common::{repo, run as keypose};
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `check` on `text` and returns stderr, asserting exit code 2 and no panic.
fn bad_input(text: &str) -> String {
    let (_dir, path) = temp_sequence("bad.json", text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.stdout.is_empty(), "printed a report for bad input");
    assert!(
        stderr.contains("bad.json"),
        "message does not name the file: {stderr}"
    );
    stderr
}

/// Asserts that `text` is refused as bad input with a message containing `expected`.
fn refused(text: &str, expected: &str) {
    let err = bad_input(text);
    assert!(err.contains(expected), "expected {expected:?} in: {err}");
}

fn sequence(keyframes: &str) -> String {
    sequence_in("cubic", keyframes)
}

fn sequence_in(interpolation: &str, keyframes: &str) -> String {
    format!(
        r#"{{"format":"keypose-sequence/1","robot":"so101","interpolation":"{interpolation}","keyframes":[{keyframes}]}}"#
    )
}

/// A sequence file in a fresh temporary directory (kept alive by the returned guard).
fn temp_sequence(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), name, text);
    (dir, path)
}

#[test]
fn malformed_json_names_line_and_column() {
    refused(
        "{\n  \"format\": \"keypose-sequence/1\",\n  \"robot\": so101\n}",
        "bad.json:3:12: invalid JSON",
    );
}

#[test]
fn wrong_format_is_refused() {
    refused(
        r#"{"format":"keypose-sequence/9","robot":"so101","keyframes":[]}"#,
        r#"$.format: expected "keypose-sequence/1", found "keypose-sequence/9""#,
    );
}

#[test]
fn unknown_joint_names_the_key_and_the_choices() {
    refused(
        &sequence(
            r#"{"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":1,"joints":{"elbw":10}}"#,
        ),
        r#"$.keyframes[1].joints.elbw: unknown joint "elbw" for robot so101; expected one of: shoulder_pan, shoulder_lift, elbow_flex"#,
    );
}

#[test]
fn non_numbers_and_out_of_range_numbers_are_refused() {
    refused(
        &sequence(r#"{"time":"NaN","joints":{"elbow_flex":0}}"#),
        "$.keyframes[0].time: expected a finite number",
    );
    refused(
        &sequence(r#"{"time":0,"joints":{"elbow_flex":1e999}}"#),
        "bad.json:1:",
    );
    refused(
        &sequence(r#"{"time":0,"joints":{"elbow_flex":null}}"#),
        "$.keyframes[0].joints.elbow_flex: expected a finite number",
    );
}

#[test]
fn non_unit_and_zero_quaternions_are_refused() {
    refused(
        &sequence(r#"{"time":0,"transforms":{"wrist_roll":{"r":{"w":1,"x":0,"y":0,"z":0.5}}}}"#),
        "$.keyframes[0].transforms.wrist_roll.r: expected a unit quaternion",
    );
    refused(
        &sequence(r#"{"time":0,"transforms":{"wrist_roll":{"r":{"w":0,"x":0,"y":0,"z":0}}}}"#),
        "found norm 0.000000",
    );
}

#[test]
fn a_rotation_off_the_joint_axis_is_refused_not_projected() {
    // wrist_roll turns about its own z axis; this is 90° about x.
    refused(
        &sequence(
            r#"{"time":0,"transforms":{"wrist_roll":{"r":{"w":0.7071068,"x":0.7071068,"y":0,"z":0}}}}"#,
        ),
        "$.keyframes[0].transforms.wrist_roll: the rotation is 90.00° off the joint axis",
    );
}

#[test]
fn duplicate_times_are_refused_at_the_second_key() {
    // Sorted by time the keys are [1] (t=0), [0] (t=1), [2] (t=1); the later duplicate is named.
    refused(
        &sequence(
            r#"{"time":1,"joints":{"elbow_flex":0}},{"time":0,"joints":{"elbow_flex":5}},{"time":1,"joints":{"elbow_flex":9}}"#,
        ),
        "$.keyframes[2].time: duplicate key time 1 s (also at $.keyframes[0])",
    );
}

#[test]
fn a_hold_that_overruns_the_next_key_is_refused() {
    refused(
        &sequence(
            r#"{"time":0,"hold":1.5,"joints":{"elbow_flex":0}},{"time":1,"joints":{"elbow_flex":5}}"#,
        ),
        "$.keyframes[0].hold: hold of 1.5 s overruns the next key, 1 s later",
    );
}

#[test]
fn mixing_timed_and_untimed_keys_is_refused() {
    refused(
        &sequence(
            r#"{"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"joints":{"elbow_flex":5}}"#,
        ),
        "$.keyframes[1]: this key has no \"time\" but 1 of 2 keys do",
    );
}

#[test]
fn keys_outside_joint_limits_are_refused() {
    refused(&sequence(r#"{"time":0,"joints":{"elbow_flex":120}}"#), "$.keyframes[0].joints.elbow_flex: 120.000 deg is outside the limits of elbow_flex: expected -96.83 … 96.83 deg");
}

#[test]
fn an_empty_keyframe_list_is_refused() {
    refused(&sequence(""), "$.keyframes: expected at least one keyframe");
}

#[test]
fn unknown_robots_are_refused() {
    refused(
        r#"{"format":"keypose-sequence/1","robot":"so999","keyframes":[{"time":0,"joints":{"a":1}}]}"#,
        r#"$.robot: unknown robot "so999": expected a built-in robot (so101, so100, koch, omx)"#,
    );
    let out = keypose(&[
        "check",
        &repo("sequences/so101_wave.json"),
        "--robot",
        "nope",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--robot: unknown robot \"nope\""));
}

#[test]
fn misspelt_fields_are_refused_rather_than_ignored() {
    refused(
        &sequence(r#"{"tiem":0,"joints":{"elbow_flex":0}}"#),
        r#"$.keyframes[0]: unknown field "tiem""#,
    );
}

#[test]
fn missing_files_and_bad_arguments_exit_2() {
    let out = keypose(&["check", "/nonexistent/seq.json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/seq.json: cannot read"));
    let out = keypose(&["sample", &repo("sequences/so101_wave.json"), "--rate", "-5"]);
    assert_eq!(out.status.code(), Some(2));
    let out = keypose(&[
        "sample",
        &repo("sequences/so101_wave.json"),
        "--units",
        "furlongs",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn every_example_sequence_passes_check() {
    for entry in std::fs::read_dir(repo("sequences")).unwrap() {
        let path = entry.unwrap().path();
        let out = keypose(&["check", path.to_str().unwrap()]);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stdout)
        );
    }
}

#[test]
fn check_catches_a_cubic_overshoot_between_keys_inside_the_limit() {
    // elbow_flex limit 96.83°. Keys 0 → 90 → 95 → 0 at t = 0, 2, 3, 5 are all inside it, but
    // the slope at the 90° key, (95 − 0)/(3 − 0) = 95/3 °/s, carries the curve past 96.83°
    // between t = 2 and t = 3.
    let keys = r#"{"name":"a","time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"name":"b","time":2,"joints":{"elbow_flex":90}},
               {"name":"c","time":3,"joints":{"elbow_flex":95}},{"name":"d","time":5,"joints":{"elbow_flex":0}}"#;
    let (dir, path) = temp_sequence("overshoot.json", &sequence(keys));
    let out = keypose(&["check", path.to_str().unwrap(), "--format", "json"]);
    assert_eq!(out.status.code(), Some(1));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let violations = report["violations"].as_array().unwrap();
    let position: Vec<_> = violations
        .iter()
        .filter(|v| v["kind"] == "position")
        .collect();
    assert_eq!(position.len(), 1, "{violations:?}");
    let v = position[0];
    assert_eq!(v["joint"], "elbow_flex");
    assert_eq!(v["segment"], 1);
    assert_eq!(v["segment_label"], "b → c");
    let peak = v["peak"].as_f64().unwrap();
    // Hermite on [2, 3] (h = 1): a = 90, b = 95, slopes 95/3 and (0 − 90)/(5 − 2) = −30:
    //   c2 = 3·5 − 2·95/3 + 30 = −55/3,  c3 = −2·5 + 95/3 − 30 = −25/3,
    //   v(f) = 90 + (95/3) f − (55/3) f² − (25/3) f³,
    //   v'(f) = 0 ⇔ 75 f² + 110 f − 95 = 0 ⇔ f = (−110 + √40600)/150 ≈ 0.610, v ≈ 100.60°.
    let f: f64 = (-110.0 + 40600f64.sqrt()) / 150.0;
    let expected = 90.0 + 95.0 / 3.0 * f - 55.0 / 3.0 * f * f - 25.0 / 3.0 * f * f * f;
    assert!((peak - expected).abs() < 1e-9, "peak {peak} vs {expected}");
    assert!((v["peak_time"].as_f64().unwrap() - (2.0 + f)).abs() < 1e-9);
    assert!((v["excess"].as_f64().unwrap() - (expected - 96.83)).abs() < 1e-9);

    // Monotone on the same keys stays inside.
    let path = write(dir.path(), "monotone.json", &sequence_in("monotone", keys));
    assert_eq!(
        keypose(&["check", path.to_str().unwrap()]).status.code(),
        Some(0)
    );
}

#[test]
fn sample_rows_are_at_k_over_rate_without_drift() {
    let (_dir, path) = temp_sequence(
        "lin.json",
        &sequence_in(
            "linear",
            r#"{"time":0.5,"joints":{"elbow_flex":0}},{"time":3.5,"joints":{"elbow_flex":30}}"#,
        ),
    );
    let out = keypose(&["sample", path.to_str().unwrap(), "--rate", "30"]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time,shoulder_pan,shoulder_lift,elbow_flex,wrist_flex,wrist_roll,gripper"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    // 3 s at 30 Hz: rows k = 0 … 90, first and last key inclusive.
    assert_eq!(rows.len(), 91);
    for (k, row) in rows.iter().enumerate() {
        let t = 0.5 + k as f64 / 30.0;
        assert!((row[0] - t).abs() < 1e-9, "row {k}: {}", row[0]);
        // Linear 0 → 30° over 3 s: 10°/s.
        assert!((row[3] - 10.0 * (t - 0.5)).abs() < 1e-6, "row {k}");
    }

    let out = keypose(&[
        "sample",
        path.to_str().unwrap(),
        "--rate",
        "1",
        "--units",
        "ticks",
    ]);
    let text = String::from_utf8(out.stdout).unwrap();
    // 30° = 341.33 ticks past the zero tick 2047 at the end: 2388.
    assert_eq!(
        text.lines().last().unwrap(),
        "3.5,2047,2047,2388,2047,2047,2047"
    );
    let out = keypose(&[
        "sample",
        path.to_str().unwrap(),
        "--rate",
        "1",
        "--units",
        "rad",
        "--format",
        "json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let last = json["rows"].as_array().unwrap().last().unwrap();
    assert!((last[3].as_f64().unwrap() - 30f64.to_radians()).abs() < 1e-12);
}

#[test]
fn plot_writes_an_svg_with_every_joint() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("wave.svg");
    let out = keypose(&[
        "plot",
        &repo("sequences/so101_wave.json"),
        "-o",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") || text.starts_with("<?xml"));
    for joint in ["shoulder_pan", "elbow_flex", "wrist_roll", "gripper"] {
        assert!(text.contains(joint), "{joint} missing");
    }
    // Two curves (position, velocity) per joint.
    assert_eq!(text.matches("<polyline").count(), 12);
}

/// `keypose retime PATH -o fixed.json` beside it: the output path and the run.
fn retime_beside(path: &Path) -> (PathBuf, std::process::Output) {
    let fixed = path.with_file_name("fixed.json");
    let out = keypose(&[
        "retime",
        path.to_str().unwrap(),
        "-o",
        fixed.to_str().unwrap(),
    ]);
    (fixed, out)
}

#[test]
fn retime_fixes_a_too_fast_sequence_and_leaves_a_sequence_that_checks() {
    // 90° in 0.5 s: a cubic peaks at 1.5·90/0.5 = 270°/s against so101's 115°/s.
    let (_dir, path) = temp_sequence(
        "fast.json",
        &sequence(
            r#"{"time":0,"hold":0.2,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":0.7,"joints":{"elbow_flex":90}},{"time":1.5,"joints":{"elbow_flex":80}}"#,
        ),
    );
    assert_eq!(
        keypose(&["check", path.to_str().unwrap()]).status.code(),
        Some(1)
    );
    let (fixed, out) = retime_beside(&path);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        keypose(&["check", fixed.to_str().unwrap()]).status.code(),
        Some(0)
    );
    let text = std::fs::read_to_string(&fixed).unwrap();
    let seq: serde_json::Value = serde_json::from_str(&text).unwrap();
    let keys = seq["keyframes"].as_array().unwrap();
    // The hold is kept; the moving time grows, but only until a limit is reached: the key-time
    // cubic's slope at the middle key changes with the stretch too, so no ratio gives the time,
    // but the stretched curve touches a limit (here elbow_flex's 344 deg/s², to 1 %). (On main
    // at bb14c46, which stretched by the velocity ratio, it peaked at 93 %.)
    assert_eq!(keys[0]["hold"], 0.2);
    let moving = keys[1]["time"].as_f64().unwrap() - 0.2;
    assert!(moving > 0.5, "moving time {moving}");
    let out = keypose(&["check", fixed.to_str().unwrap()]);
    let printed = String::from_utf8_lossy(&out.stdout).into_owned();
    let elbow = printed
        .lines()
        .find(|l| l.trim_start().starts_with("elbow_flex"))
        .unwrap();
    let percent: Vec<f64> = elbow
        .split('(')
        .skip(1)
        .filter_map(|p| p.split('%').next()?.trim().parse().ok())
        .collect();
    assert!(percent.iter().any(|&p| p >= 99.0), "{elbow}");
}

#[test]
fn retime_cannot_fix_a_step_jump_and_says_so() {
    let (_dir, path) = temp_sequence(
        "step.json",
        &sequence(
            r#"{"time":0,"interp":"step","joints":{"elbow_flex":0}},{"time":1,"joints":{"elbow_flex":60}}"#,
        ),
    );
    let out = keypose(&["retime", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("cannot be fixed by retiming"), "{stderr}");
    assert!(out.stdout.is_empty());
}

#[test]
fn every_command_has_help() {
    for command in ["check", "sample", "plot", "retime"] {
        let out = keypose(&[command, "--help"]);
        assert_eq!(out.status.code(), Some(0));
        assert!(String::from_utf8_lossy(&out.stdout).contains("Usage: keypose"));
    }
}

/// The top-level help says what each command does as it does it: the check is exact, not
/// sampled, and covers clearance and torque; export names every format it writes.
#[test]
fn the_command_list_says_what_check_and_export_do() {
    let out = keypose(&["--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    let line = |name: &str| {
        help.lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no {name} in {help}"))
            .to_string()
    };
    let check = line("check ");
    assert!(
        check.contains("exact") && !check.contains("sampled"),
        "{check}"
    );
    let export = line("export ");
    for format in ["ROS 2", "play_motion2", "C header", "LeRobot"] {
        assert!(export.contains(format), "{format}: {export}");
    }
}

#[test]
fn absurd_durations_are_refused_before_sampling() {
    refused(
        &sequence(
            r#"{"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":1e9,"joints":{"elbow_flex":5}}"#,
        ),
        "$.keyframes[1].time: key time 1000000000 s is out of range",
    );
    // Within a day but 8 million samples at 100 Hz: refused, not allocated.
    refused(
        &sequence(
            r#"{"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":80000,"joints":{"elbow_flex":5}}"#,
        ),
        "lower --rate",
    );
}

/// A linear 0 → 80° pan in 1 s from rest: at the 100 Hz control rate its first step asks for
/// 80 °/s within one 10 ms period, 8000 °/s² against the 344 °/s² limit. Sampled once a second,
/// the same start looks like 80 °/s² and would pass.
const SUDDEN_START: &str =
    r#"{"time":0,"joints":{"shoulder_pan":0}},{"time":1,"joints":{"shoulder_pan":80}}"#;

#[test]
fn a_rate_below_the_control_rate_does_not_hide_a_violation() {
    let (_dir, path) = temp_sequence("sudden.json", &sequence_in("linear", SUDDEN_START));
    let path = path.to_str().unwrap();
    // A rate too coarse to mean anything is refused outright.
    for rate in ["0.001", "1", "-5"] {
        let out = keypose(&["check", path, "--rate", rate]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "--rate {rate}: {err}");
        assert!(
            err.contains("expected a rate from 10 to 100000 Hz"),
            "{err}"
        );
    }
    // At any rate the corner is judged as the player turns it, at the robot's control rate:
    // 80 °/s within 10 ms, 8000 °/s².
    for rate in ["10", "50", "100", "1000"] {
        let out = keypose(&["check", path, "--rate", rate]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "--rate {rate}: {text}");
        assert!(
            text.contains("acceleration segment 0 (#0 → #1), t = 0.000 s (from -0.010 to 0.010 s): 8000.000 deg/s² > limit 344.000 deg/s²"),
            "--rate {rate}: {text}"
        );
        assert!(
            text.contains("at the 100 Hz control rate"),
            "--rate {rate}: {text}"
        );
    }
    // retime stretches the segment at the control rate even when asked for 10 Hz.
    let out = keypose(&["retime", path, "--rate", "10"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("segment 0"), "{err}");
    // plot draws the curves at least at the control rate: 1 s at 100 Hz is 101 points.
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("sudden.svg");
    let out = keypose(&["plot", path, "--rate", "10", "-o", svg.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    let text = std::fs::read_to_string(&svg).unwrap();
    let points = text
        .split("<polyline")
        .nth(1)
        .and_then(|p| p.split("points=\"").nth(1))
        .and_then(|p| p.split('"').next())
        .unwrap();
    assert!(points.split_whitespace().count() >= 101, "{points}");
}

#[test]
fn a_robot_whose_control_rate_the_player_cannot_keep_is_refused_before_teach_opens_a_port() {
    let dir = tempfile::tempdir().unwrap();
    let robot = std::fs::read_to_string(repo("robots/so101.json"))
        .unwrap()
        .replace("\"control_hz\": 100", "\"control_hz\": 2000");
    assert!(robot.contains("\"control_hz\": 2000"));
    let robot_path = write(dir.path(), "fast.json", &robot);
    let out = keypose(&[
        "teach",
        "--robot",
        robot_path.to_str().unwrap(),
        "--port",
        "/dev/keypose-no-such-port",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("control_hz 2000 is outside the 10 … 1000 Hz"),
        "{err}"
    );
}

#[test]
fn retime_writes_key_times_in_seconds() {
    // docs/commands.md: elbow_flex 0 → 90° in 0.5 s; a cubic over T peaks at 6·Δ/T², so 344 °/s² allows
    // T ≥ √(6·90/344) = 1.2529 s, written as a time in seconds (not 1252.9 ms).
    let (_dir, path) = temp_sequence("fast.json", README_FIXTURES[0].1);
    let (fixed, out) = retime_beside(&path);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::show(&out));
    let seq: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fixed).unwrap()).unwrap();
    let time = seq["keyframes"][1]["time"].as_f64().unwrap();
    let expected = (6.0 * 90.0 / 344.0f64).sqrt();
    assert!((time - expected).abs() < 1e-3, "{time} s vs {expected} s");
}

/// The help text of `--port` in `keypose COMMAND --help`.
fn port_help(command: &[&str]) -> String {
    let mut args = command.to_vec();
    args.push("--help");
    let out = keypose(&args);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::show(&out));
    let help = crate::common::stdout(&out);
    let start = help.find("--port <").unwrap_or_else(|| panic!("{help}"));
    let rest = &help[start..];
    // The option's paragraph ends at the next option.
    let end = rest[1..].find("\n      -").map_or(rest.len(), |e| e + 1);
    rest[..end].to_string()
}

#[test]
fn only_play_says_it_simulates_without_a_port() {
    for command in [&["read"][..], &["torque", "on"], &["record"], &["teach"]] {
        let help = port_help(command);
        assert!(
            !help.contains("MuJoCo") && !help.to_lowercase().contains("simulat"),
            "{command:?}: {help}"
        );
    }
    assert!(port_help(&["play"]).contains("without a port, play in MuJoCo"));
}

#[test]
fn scan_shows_its_default_baud_once() {
    let out = keypose(&["scan", "--help"]);
    let help = crate::common::stdout(&out);
    let baud = &help[help.find("--baud").unwrap()..];
    let baud = &baud[..baud[1..].find("\n      -").unwrap()];
    assert_eq!(baud.matches("default").count(), 1, "{baud}");
    assert_eq!(baud.matches("[default: 1000000]").count(), 1, "{baud}");
}

#[test]
fn read_and_torque_default_to_so101_and_say_so() {
    let out = keypose(&["read", "--port", "virtual"]);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::show(&out));
    assert!(crate::common::stderr(&out).contains("robot so101 (built-in)"));
    let pose: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(pose["robot"], "so101");
    let out = keypose(&["torque", "off", "--port", "virtual"]);
    assert_eq!(out.status.code(), Some(0), "{}", crate::common::show(&out));
    let err = crate::common::stderr(&out);
    assert!(err.contains("robot so101 (built-in)"), "{err}");
    // SO-101's six servos, ids 1–6.
    assert!(
        err.contains("torque off on servo(s) [1, 2, 3, 4, 5, 6]"),
        "{err}"
    );
}

#[test]
fn example_descriptions_say_what_their_keys_do() {
    let read = |name: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(repo(&format!("sequences/{name}.json"))).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    // A description may mention step segments only where a key has one.
    for name in [
        "so101_pick_place",
        "so101_wave",
        "so101_nod",
        "koch_wave",
        "omx_reach",
    ] {
        let seq = read(name);
        let says_step = seq["description"]
            .as_str()
            .unwrap()
            .contains("step segment");
        let has_step = seq["keyframes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|k| k["interp"] == "step");
        assert!(!says_step || has_step, "{name}: {}", seq["description"]);
    }
    // omx_reach's "turn" key is a rotation of 90° about z, (w, z) = (cos 45°, sin 45°): a
    // quarter turn, not half a turn.
    let seq = read("omx_reach");
    let description = seq["description"].as_str().unwrap();
    assert!(description.contains("quarter turn") && description.contains("90 deg"));
    assert!(!description.contains("half a turn"), "{description}");
}

/// The files docs/commands.md's examples name that are not in the repository, as it describes
/// them.
const README_FIXTURES: [(&str, &str); 4] = [
    // "elbow_flex 0 → 90° in 0.5 s"
    (
        "fast.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic","keyframes":[
          {"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":0.5,"joints":{"elbow_flex":90}}]}"#,
    ),
    // Keys a, b, c, d at 0, 90, 95, 0° (t = 0, 2, 3, 5 s), all inside elbow_flex's 96.83°.
    (
        "overshoot.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic","keyframes":[
          {"name":"a","time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"name":"b","time":2,"joints":{"elbow_flex":90}},
          {"name":"c","time":3,"joints":{"elbow_flex":95}},{"name":"d","time":5,"joints":{"elbow_flex":0}}]}"#,
    ),
    // wrist_flex 0 → 60 → 0° over 4 ms, cubic.
    (
        "spike.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic","keyframes":[
          {"time":0,"joints":{"wrist_flex":0}},{"time":0.002,"joints":{"wrist_flex":60}},{"time":0.004,"joints":{"wrist_flex":0}}]}"#,
    ),
    // A 0.4 s line from (0.25, −0.05, 0.12) to (0.15, 0.1, 0.06).
    (
        "pick.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"monotone","keyframes":[
          {"name":"start","time":0,"joints":{"shoulder_pan":0,"shoulder_lift":0,"elbow_flex":0,"wrist_flex":0,"wrist_roll":0,"gripper":0}},
          {"name":"above","time":2.0,"interp":"line","tool":{"xyz":[0.25,-0.05,0.12]}},
          {"name":"grasp","time":2.4,"tool":{"xyz":[0.15,0.1,0.06]},"joints":{"gripper":30}},
          {"name":"lift","time":4,"tool":{"xyz":[0.25,0.05,0.12]}}]}"#,
    ),
];

/// The documents whose `console` examples are run: the README's first sequence, then the
/// command reference.
const DOCUMENTS: [&str; 2] = ["README.md", "docs/commands.md"];

/// Pairs of text: a command and what it prints, or a file's name and its text.
type Pairs = Vec<(String, String)>;

/// Every `$ command` of the documents' `console` blocks with the lines printed under it, and
/// the files their `sh` blocks write with `cat > NAME <<'EOF'`.
fn readme_console_examples() -> (Pairs, Pairs) {
    let mut examples: Pairs = Vec::new();
    let mut files: Pairs = Vec::new();
    for document in DOCUMENTS {
        let text = std::fs::read_to_string(repo(document)).unwrap();
        let mut block = "";
        let mut writing: Option<(String, String)> = None;
        for line in text.lines() {
            if let Some((name, body)) = writing.as_mut() {
                if line == "EOF" {
                    files.push((std::mem::take(name), std::mem::take(body)));
                    writing = None;
                } else {
                    body.push_str(line);
                    body.push('\n');
                }
                continue;
            }
            match line {
                "```console" => block = "console",
                "```sh" => block = "sh",
                "```" => block = "",
                _ if block == "sh" => {
                    if let Some(name) = line
                        .strip_prefix("cat > ")
                        .and_then(|rest| rest.strip_suffix(" <<'EOF'"))
                    {
                        writing = Some((name.to_string(), String::new()));
                    }
                }
                _ if block != "console" => {}
                _ => match line.strip_prefix("$ ") {
                    Some(command) => examples.push((command.to_string(), String::new())),
                    None => {
                        let (_, output) = examples.last_mut().expect("output before a command");
                        output.push_str(line);
                        output.push('\n');
                    }
                },
            }
        }
    }
    (examples, files)
}

/// Runs a README command line in `dir`: `keypose ARGS [| head -N | sed -n 'Np;A,Bp']
/// # comment`. What it printed: standard output (the lines the filter keeps), then standard
/// error.
fn run_readme_command(command: &str, dir: &Path) -> String {
    let command = command.split(" #").next().unwrap();
    let (command, filter) = match command.split_once(" | ") {
        Some((command, filter)) => (command, Some(filter.trim())),
        None => (command, None),
    };
    let args: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(args[0], "keypose", "{command}");
    let out = crate::common::keypose()
        .args(&args[1..])
        .current_dir(dir)
        .output()
        .unwrap();
    let stdout = crate::common::stdout(&out);
    let kept: String = stdout
        .lines()
        .enumerate()
        .filter(|(i, _)| filter.is_none_or(|f| line_kept(f, i + 1)))
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    kept + &crate::common::stderr(&out)
}

/// Whether the README's filter (`head -N`, or `sed -n` with `Np` and `A,Bp` parts) prints
/// line `n` (from 1).
fn line_kept(filter: &str, n: usize) -> bool {
    if let Some(count) = filter.strip_prefix("head -") {
        return n <= count.parse::<usize>().unwrap();
    }
    let spec = filter
        .strip_prefix("sed -n '")
        .and_then(|s| s.strip_suffix('\''))
        .unwrap_or_else(|| panic!("a filter the README runner knows: {filter}"));
    spec.split(';').any(|part| {
        let range = part.strip_suffix('p').expect("sed -n parts end in p");
        let (first, last) = range.split_once(',').unwrap_or((range, range));
        (first.parse().unwrap()..=last.parse().unwrap()).contains(&n)
    })
}

#[test]
fn the_readme_console_examples_print_what_the_commands_print() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in README_FIXTURES {
        write(dir.path(), name, text);
    }
    std::os::unix::fs::symlink(repo("sequences"), dir.path().join("sequences")).unwrap();
    let (examples, files) = readme_console_examples();
    assert_eq!(files.len(), 1, "the README writes its first sequence");
    for (name, text) in &files {
        write(dir.path(), name, text);
    }
    let mut compared = Vec::new();
    for (command, expected) in examples {
        let verb = command.split_whitespace().nth(1).unwrap_or_default();
        // Those need servos, MuJoCo, a playback log, a browser or a dataset: not run here
        // (tests/commands/pose.rs compares the `pose` sample; tests/teaching/studio.rs, lerobot_import.rs
        // and export_cli.rs run the others).
        if ["play", "plot", "sim", "pose", "studio", "import", "export"].contains(&verb) {
            continue;
        }
        let printed = run_readme_command(&command, dir.path());
        let trimmed = |text: &str| -> Vec<String> {
            text.lines().map(|l| l.trim_end().to_string()).collect()
        };
        assert_eq!(
            trimmed(&printed),
            trimmed(&expected),
            "README example `{command}` printed:\n{printed}"
        );
        compared.push(verb.to_string());
    }
    assert_eq!(
        compared,
        [
            "check", "check", "check", "check", "check", "sample", "sample", "retime", "retime",
            "mirror"
        ]
    );
}

#[test]
fn the_check_report_shows_a_prismatic_gripper_in_millimetres() {
    // omx_reach opens the gripper by a translation of 0.015 m along its axis.
    let out = keypose(&["check", &repo("sequences/omx_reach.json")]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    let row = text
        .lines()
        .find(|l| l.trim_start().starts_with("gripper_left_joint"))
        .unwrap_or_else(|| panic!("{text}"));
    assert!(row.contains("0.00 …   15.00 mm"), "{row}");
    assert!(row.contains(" mm/s ") && row.contains(" mm/s²"), "{row}");
}

/// A "see "X" below" (or above) in a document points at a heading of that document, in the
/// direction it says.
#[test]
fn every_see_below_and_above_points_at_a_heading_there() {
    for doc in [
        "README.md",
        "docs/formats.md",
        "docs/commands.md",
        "docs/python.md",
    ] {
        let text = std::fs::read_to_string(repo(doc)).unwrap();
        let headings: Vec<(usize, String)> = text
            .lines()
            .enumerate()
            .filter(|(_, l)| l.starts_with('#'))
            .map(|(i, l)| (i, l.trim_start_matches('#').trim().to_string()))
            .collect();
        for (at, line) in text.lines().enumerate() {
            for (start, _) in line.match_indices("see \"") {
                let rest = &line[start + 5..];
                let Some(end) = rest.find('"') else { continue };
                let (name, after) = (&rest[..end], rest[end + 1..].trim_start());
                let below = after.starts_with("below");
                if !below && !after.starts_with("above") {
                    continue;
                }
                let found = headings
                    .iter()
                    .any(|(i, h)| h.contains(name) && if below { *i > at } else { *i < at });
                assert!(
                    found,
                    "{doc}:{}: see {name:?} {after:.5}: no such heading",
                    at + 1
                );
            }
        }
    }
}

/// The README's first sequence says how `keypose` gets on the PATH before it calls it.
#[test]
fn the_first_sequence_says_where_keypose_comes_from() {
    let readme = std::fs::read_to_string(repo("README.md")).unwrap();
    let section = &readme[readme.find("## A first sequence").unwrap()..];
    let before_first_call = &section[..section.find("$ keypose").unwrap()];
    assert!(
        before_first_call.contains("cargo install --path .")
            && before_first_call.contains("cargo run --release --"),
        "{before_first_call}"
    );
}
