//! Hostile and huge input through the binary: duplicate keys, files that are not files, files
//! too big, too many keys, control characters in names, absurd option values. Each is bad input:
//! exit 2, a message naming the file or option and what was expected, no panic.

use crate::common::{repo, run as keypose, show, stderr};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    fs::write(&path, text).unwrap();
    path
}

/// Asserts exit code 2, no panic, and `expected` in the message; returns stderr.
fn bad_input(out: &Output, expected: &str) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{}", show(out));
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(expected), "expected {expected:?} in: {err}");
    err
}

#[test]
fn a_duplicate_key_names_the_key_and_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    // The second "joints" of key 1 would silently replace the first.
    let text = "{\"format\":\"keypose-sequence/1\",\"robot\":\"so101\",\"keyframes\":[\n\
                {\"time\":0,\"joints\":{\"elbow_flex\":0}},\n\
                {\"time\":1,\"joints\":{\"elbow_flex\":30},\"joints\":{\"elbow_flex\":5}}]}";
    let path = write(dir.path(), "dup.json", text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    // Line 3; the second "joints" ends at column 45.
    bad_input(
        &out,
        "dup.json:3:45: invalid JSON: duplicate key \"joints\"; expected each key once in an object",
    );
}

#[test]
fn a_sequence_in_yaml_is_refused_saying_keyposes_files_are_json() {
    let dir = tempfile::tempdir().unwrap();
    let text = "format: keypose-sequence/1\nrobot: so101\nkeyframes:\n  - time: 0\n    joints: {elbow_flex: 0}\n";
    let path = write(dir.path(), "wave.yaml", text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    let err = bad_input(&out, "looks like YAML, and keypose's files are JSON");
    assert!(
        err.contains("keypose-sequence/1") && err.contains("wave.yaml:1:"),
        "{err}"
    );
}

#[cfg(unix)]
#[test]
fn a_device_a_fifo_or_a_directory_is_refused_at_once() {
    let out = keypose(&["check", "/dev/zero"]);
    bad_input(
        &out,
        "/dev/zero: is a character device; expected a regular file",
    );
    let dir = tempfile::tempdir().unwrap();
    let out = keypose(&["check", dir.path().to_str().unwrap()]);
    bad_input(&out, "is a directory; expected a regular file");
    let fifo = dir.path().join("seq.json");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.unwrap().success());
    // Nothing ever writes to the FIFO: reading it would wait forever.
    let out = keypose(&["check", fifo.to_str().unwrap()]);
    bad_input(
        &out,
        "seq.json: is a FIFO (named pipe); expected a regular file",
    );
    // A calibration file too.
    let out = keypose(&[
        "check",
        &repo("sequences/so101_nod.json"),
        "--calibration",
        "/dev/zero",
    ]);
    bad_input(&out, "/dev/zero: is a character device");
}

#[test]
fn a_file_over_16_mib_is_refused_with_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.json");
    let size: usize = 16 * 1024 * 1024 + 1;
    fs::write(&path, vec![b' '; size]).unwrap();
    let out = keypose(&["check", path.to_str().unwrap()]);
    bad_input(
        &out,
        "huge.json: is 16777217 bytes; expected at most 16 MiB (16777216 bytes)",
    );
}

#[test]
fn more_than_100000_keyframes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let keys = vec![r#"{"joints":{"elbow_flex":0}}"#; 100_001].join(",");
    let text = format!(r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[{keys}]}}"#);
    let path = write(dir.path(), "many.json", &text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    bad_input(
        &out,
        "many.json: $.keyframes: 100001 keyframes; expected at most 100000",
    );
}

/// ESC [ 2 J (clear screen) and ESC ] 0 ; … BEL (set the window title) inside key names.
const CRAFTED: &str = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
  {"name":"a\u001b[2J","time":0,"joints":{"elbow_flex":0}},
  {"name":"b\u001b]0;owned\u0007","time":0.5,"joints":{"elbow_flex":90}}]}"#;

/// Asserts no control byte but the line break that ends the last line.
fn assert_no_control_bytes(text: &[u8]) {
    let body = text.strip_suffix(b"\n").unwrap_or(text);
    let bad: Vec<u8> = body.iter().copied().filter(|&b| b < 0x20).collect();
    assert!(
        bad.is_empty(),
        "control bytes {bad:?} in {:?}",
        String::from_utf8_lossy(text)
    );
}

/// The SO-101's robot file with joint 0 renamed to `name` (and its home entry with it).
fn robot_with_joint_named(dir: &Path, file: &str, name: &str) -> PathBuf {
    let mut robot: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    let old = robot["joints"][0]["name"].as_str().unwrap().to_string();
    robot["joints"][0]["name"] = name.into();
    if let Some(home) = robot["home"].as_object_mut() {
        if let Some(value) = home.remove(&old) {
            home.insert(name.to_string(), value);
        }
    }
    write(dir, file, &robot.to_string())
}

/// A two-key sequence for `robot` (a file or a built-in name) moving shoulder_lift.
fn sequence_for(dir: &Path, file: &str, robot: &str) -> PathBuf {
    let sequence = serde_json::json!({"format": "keypose-sequence/1", "robot": robot,
        "keyframes": [{"time": 0, "joints": {"shoulder_lift": 0}},
                      {"time": 2, "joints": {"shoulder_lift": 20}}]});
    write(dir, file, &sequence.to_string())
}

/// Every command that reads the file refuses it the same way: exit 2, on one line, the file,
/// the JSON path and what was expected; nothing written.
fn refused_by_every_command(dir: &Path, sequence: &Path, expected: &str) {
    let seq = sequence.to_str().unwrap();
    let out_file = dir.join("out");
    let o = out_file.to_str().unwrap();
    let svg_file = dir.join("out.svg");
    let svg = svg_file.to_str().unwrap();
    let keys = write(dir, "quit.keys", "q\n");
    let commands: Vec<Vec<&str>> = vec![
        vec!["check", seq],
        vec!["sample", seq, "-o", o],
        vec!["plot", seq, "-o", svg],
        vec!["retime", seq, "-o", o],
        vec!["mirror", seq, "-o", o],
        vec!["export", "ros2", seq, "-o", o],
        vec!["export", "play_motion2", seq, "-o", o],
        vec!["export", "c", seq, "-o", o],
        vec!["sim", seq],
        vec!["play", seq, "--port", "virtual"],
        vec![
            "teach",
            seq,
            "--port",
            "virtual",
            "-o",
            o,
            "--keys",
            keys.to_str().unwrap(),
        ],
    ];
    for args in commands {
        let out = keypose(&args);
        let err = bad_input(&out, expected);
        assert_no_control_bytes(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(
            !out_file.exists() && !svg_file.exists(),
            "{args:?} wrote its output"
        );
    }
}

#[test]
fn control_characters_in_names_are_refused_at_load_by_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Key names (escape sequences), from the sequence file.
    let crafted = write(d, "crafted.json", CRAFTED);
    refused_by_every_command(
        d,
        &crafted,
        r#"crafted.json: $.keyframes[0].name: expected a key name without control characters (line breaks, tabs, escapes, bidirectional overrides), found "a\u{1b}[2J""#,
    );
    // A joint name with a line break, from the robot file the sequence names: the issue's
    // injection into the C header's comment.
    let robot = robot_with_joint_named(d, "two_lines.json", "pan */\n#include \"/etc/passwd\"\n/*");
    let sequence = sequence_for(d, "seq.json", robot.to_str().unwrap());
    refused_by_every_command(
        d,
        &sequence,
        r#"two_lines.json: $.joints[0].name: expected a name without control characters"#,
    );
    // A right-to-left override in a joint named in a key.
    let text = CRAFTED
        .replace("a\\u001b[2J", "a")
        .replace("b\\u001b]0;owned\\u0007", "b")
        .replace("\"elbow_flex\":90", "\"elbow\\u202eflex\":90");
    let path = write(d, "rtl.json", &text);
    refused_by_every_command(
        d,
        &path,
        r#"rtl.json: $.keyframes[1].joints["elbow\u{202e}flex"]: expected joint names without control characters"#,
    );
    // A tab in the robot's name; an escape in a description (a description may hold line
    // breaks and tabs, nothing else).
    let mut robot: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot["name"] = "so\t101".into();
    let tabbed = write(d, "tabbed.json", &robot.to_string());
    let sequence = sequence_for(d, "seq.json", tabbed.to_str().unwrap());
    refused_by_every_command(
        d,
        &sequence,
        r#"tabbed.json: $.name: expected a name without"#,
    );
    let text = CRAFTED
        .replace("a\\u001b[2J", "a")
        .replace("b\\u001b]0;owned\\u0007", "b")
        .replace(
            "\"robot\":\"so101\"",
            "\"robot\":\"so101\",\"description\":\"two\\nlines\\u001b[2J\"",
        );
    let path = write(d, "described.json", &text);
    refused_by_every_command(
        d,
        &path,
        r#"described.json: $.description: expected a text without control characters other than line breaks and tabs, found "two\nlines\u{1b}[2J""#,
    );
}

#[test]
fn control_characters_in_a_calibration_or_a_robot_given_alone_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // A LeRobot calibration whose motor name holds an escape.
    let mut calibration: serde_json::Value = serde_json::from_str(
        &fs::read_to_string(repo("tests/data/lerobot_so101_follower.json")).unwrap(),
    )
    .unwrap();
    let motors = calibration.as_object_mut().unwrap();
    let wrist = motors.remove("wrist_flex").unwrap();
    motors.insert("wrist\u{1b}[2J".into(), wrist);
    let path = write(dir.path(), "cal.json", &calibration.to_string());
    let out = keypose(&[
        "check",
        &repo("sequences/so101_nod.json"),
        "--calibration",
        path.to_str().unwrap(),
    ]);
    bad_input(
        &out,
        r#"cal.json: $["wrist\u{1b}[2J"]: expected motor names without control characters"#,
    );
    assert_no_control_bytes(&out.stderr);
    // A robot file given to the commands that take no sequence.
    let robot = robot_with_joint_named(dir.path(), "bell.json", "pan\u{7}");
    let r = robot.to_str().unwrap();
    for args in [
        vec!["pose", "--robot", r],
        vec!["virtual-bus", "--robot", r],
    ] {
        let out = keypose(&args);
        bad_input(
            &out,
            r#"bell.json: $.joints[0].name: expected a name without control characters"#,
        );
        assert_no_control_bytes(&out.stderr);
    }
}

#[test]
fn a_line_break_in_an_error_message_is_escaped_like_an_escape() {
    // A file name can hold anything: it is quoted in the message, on its one line.
    let dir = tempfile::tempdir().unwrap();
    let name = dir.path().join("x\nerror: all is well\u{1b}[2J.json");
    let out = keypose(&["check", name.to_str().unwrap()]);
    let err = bad_input(&out, r"x\x0aerror: all is well\x1b[2J.json");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_no_control_bytes(&out.stderr);
}

/// Asserts a refused option value: exit 2, the option named, `expected` in the message, and
/// not clap's tip about `-- -1` for a negative number.
fn refused_option(args: &[&str], option: &str, expected: &str) {
    let out = keypose(args);
    let err = bad_input(&out, expected);
    assert!(err.contains(option), "{option} not named in: {err}");
    assert!(
        !err.contains("-- -"),
        "clap's tip instead of a message: {err}"
    );
}

#[test]
fn absurd_and_negative_option_values_are_refused_with_what_was_expected() {
    let wave = repo("sequences/so101_wave.json");
    let w = wave.as_str();
    // 1e300 seconds used to reach Duration::from_secs_f64 (a panic).
    refused_option(
        &["virtual-bus", "--robot", "so101", "--fault-after", "1e300"],
        "--fault-after",
        "expected seconds from 0 to 86400, found \"1e300\"",
    );
    refused_option(
        &["virtual-bus", "--robot", "so101", "--fault-after", "-1"],
        "--fault-after",
        "expected seconds from 0 to 86400, found \"-1\"",
    );
    refused_option(
        &["virtual-bus", "--robot", "so101", "--fault", "1:late=1e300"],
        "--fault",
        "late=MS: milliseconds, a whole number from 0 to 10000",
    );
    refused_option(
        &["play", w, "--port", "virtual", "--speed", "-1"],
        "--speed",
        "expected a speed factor from 0.05 to 4, found \"-1\"",
    );
    refused_option(
        &["play", w, "--port", "virtual", "--readback", "-1"],
        "--readback",
        "a whole number from 0 to 4294967295, found \"-1\"",
    );
    refused_option(
        &["play", w, "--port", "virtual", "--loop", "-2"],
        "--loop",
        "expected a number of loops (1 or more)",
    );
    refused_option(
        &["play", w, "--port", "virtual", "--baud", "-9600"],
        "--baud",
        "a baud rate, a whole number from 1 to 10500000",
    );
    refused_option(
        &["scan", "--port", "virtual", "--baud", "0"],
        "--baud",
        "a baud rate, a whole number from 1 to 10500000, found \"0\"",
    );
    refused_option(
        &[
            "record",
            "-o",
            "x.json",
            "--port",
            "virtual",
            "--tolerance",
            "-1",
        ],
        "--tolerance",
        "expected a tolerance in degrees above 0 and at most 360, found \"-1\"",
    );
    refused_option(
        &[
            "record",
            "-o",
            "x.json",
            "--port",
            "virtual",
            "--duration",
            "1e300",
        ],
        "--duration",
        "expected seconds above 0 and at most 3600, found \"1e300\"",
    );
    refused_option(
        &["sim", w, "--render", "x.png", "--every", "0"],
        "--every",
        "expected seconds above 0 and at most 86400, found \"0\"",
    );
    refused_option(
        &["sim", w, "--speed", "nan"],
        "--speed",
        "expected a speed factor from 0.05 to 4, found \"nan\"",
    );
}

/// Runs `keypose sim ARGS` with an empty cache and asserts it was refused before MuJoCo
/// started: the harness would have written its scripts into the cache.
fn sim_refused_before_starting(args: &[&str], expected: &str) {
    let cache = tempfile::tempdir().unwrap();
    let out = crate::common::keypose()
        .arg("sim")
        .args(args)
        .env("KEYPOSE_CACHE", cache.path())
        .output()
        .unwrap();
    bad_input(&out, expected);
    assert!(
        fs::read_dir(cache.path()).unwrap().next().is_none(),
        "the simulation started: {:?}",
        fs::read_dir(cache.path()).unwrap().collect::<Vec<_>>()
    );
}

#[test]
fn sim_refuses_a_bad_render_name_or_model_before_the_simulation_runs() {
    let wave = repo("sequences/so101_wave.json");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("wave.txt");
    sim_refused_before_starting(
        &[&wave, "--render", out.to_str().unwrap()],
        "wave.txt: expected a .png, .gif or .mp4 file",
    );
    assert!(!out.exists());
    sim_refused_before_starting(
        &[&wave, "--render", "wave.gif", "--every", "1"],
        "--every: only with a .png contact sheet",
    );
    // A sequence is JSON, not a MuJoCo model.
    sim_refused_before_starting(
        &[&wave, "--mjcf", &wave],
        "so101_wave.json: expected a MuJoCo model (XML whose root element is <mujoco>, or a URDF <robot>), found no XML element",
    );
    let html = write(
        dir.path(),
        "page.xml",
        "<?xml version=\"1.0\"?>\n<html><body/></html>",
    );
    sim_refused_before_starting(
        &[&wave, "--mjcf", html.to_str().unwrap()],
        "page.xml: expected a MuJoCo model (XML whose root element is <mujoco>, or a URDF <robot>), found <html>",
    );
    sim_refused_before_starting(
        &[&wave, "--mjcf", "/dev/zero"],
        "/dev/zero: is a character device; expected a regular file",
    );
}

#[test]
fn plot_refuses_a_png_name_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("wave.png");
    let out = keypose(&[
        "plot",
        &repo("sequences/so101_wave.json"),
        "-o",
        png.to_str().unwrap(),
    ]);
    bad_input(&out, "wave.png: expected a .svg file");
    assert!(fs::read_dir(dir.path()).unwrap().next().is_none());
}

/// Joint values typed in radians pass the limit check as degrees (the elbow moving 1.57°):
/// the check says they look like radians.
#[test]
fn joint_values_in_radians_are_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
        {"time": 0, "joints": {"shoulder_lift": -1.2, "elbow_flex": 0}},
        {"time": 2, "joints": {"shoulder_lift": -0.3, "elbow_flex": 1.57}}]}"#;
    let path = write(dir.path(), "radians.json", text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("these look like radians"), "{}", show(&out));
    let degrees = write(dir.path(), "degrees.json", &text_in_degrees());
    let out = keypose(&["check", degrees.to_str().unwrap()]);
    assert!(
        !String::from_utf8_lossy(&out.stdout).contains("radians"),
        "{}",
        show(&out)
    );
}

fn text_in_degrees() -> String {
    r#"{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
        {"time": 0, "joints": {"shoulder_lift": -68.8, "elbow_flex": 0}},
        {"time": 2, "joints": {"shoulder_lift": -17.2, "elbow_flex": 90}}]}"#
        .to_string()
}

/// A two-arm base in millimetres (250 for 0.25 m) puts the arms 500 m apart, where check and
/// sim would pass them: refused, with the reading in metres; so is an absurd one.
#[test]
fn a_cell_base_in_millimetres_or_absurd_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cell = |y: &str| {
        format!(
            r#"{{"format": "keypose-sequence/1",
                "robots": {{"left": {{"robot": "so101", "base": {{"xyz": [0, {y}, 0]}}}}, "right": "so101"}},
                "keyframes": [{{"time": 0, "joints": {{"left/elbow_flex": 0}}}},
                              {{"time": 2, "joints": {{"left/elbow_flex": 30}}}}]}}"#
        )
    };
    let path = write(dir.path(), "mm.json", &cell("250"));
    let err = bad_input(
        &keypose(&["check", path.to_str().unwrap()]),
        "$.robots.left.base.xyz",
    );
    assert!(err.contains("millimetres? that is [0, 0.25, 0] m"), "{err}");
    let path = write(dir.path(), "far.json", &cell("1e308"));
    bad_input(
        &keypose(&["check", path.to_str().unwrap()]),
        "expected metres, within 10 m",
    );
    let path = write(dir.path(), "metres.json", &cell("0.4"));
    let out = keypose(&["check", path.to_str().unwrap()]);
    assert_ne!(out.status.code(), Some(2), "{}", show(&out));
}

#[test]
fn physics_refuses_what_it_cannot_emulate_before_anything_starts() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-scene.xml");
    let m = missing.to_str().unwrap();
    bad_input(
        &keypose(&["virtual-bus", "--robot", "so101", "--physics", "--scene", m]),
        &format!("--scene {m}: no such file; expected \"table\" or an MJCF file of objects"),
    );
    bad_input(
        &keypose(&["read", "--port", "virtual", "--physics", "--scene", m]),
        "no such file",
    );
    bad_input(
        &keypose(&["virtual-bus", "--robot", "so101", "--scene", "table"]),
        "--physics",
    );
    // The SO-101 leader's 1/191 servo has no published drive data: no motor to emulate.
    let mut robot: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot["joints"][1]["servo"]["variant"] = "c044".into();
    let file = write(dir.path(), "leader.json", &robot.to_string());
    let out = keypose(&[
        "read",
        "--port",
        "virtual",
        "--physics",
        "--robot",
        file.to_str().unwrap(),
    ]);
    bad_input(
        &out,
        "joint shoulder_lift: its servo (sts3215) has no drive data at its supply",
    );
}

#[test]
fn a_bad_effort_names_its_key_and_field_and_an_effort_past_the_overload_threshold_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = |effort: &str| {
        format!(
            r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[
            {{"time":0,"joints":{{"gripper":40}}}},
            {{"time":2,"joints":{{"gripper":0}},"effort":{effort}}}]}}"#
        )
    };
    for (effort, expected) in [
        (
            r#"{"gripper":150}"#,
            "$.keyframes[1].effort.gripper: expected a percent of the servo's stall torque, above 0 and at most 100",
        ),
        (r#"{"gripper":0}"#, "above 0 and at most 100"),
        (r#"{"gripper":"30%"}"#, "$.keyframes[1].effort.gripper"),
        (r#"[30]"#, "$.keyframes[1].effort"),
        (
            r#"{"grip":30}"#,
            "$.keyframes[1].effort.grip: unknown joint \"grip\"; expected one of: shoulder_pan",
        ),
    ] {
        let file = write(dir.path(), "effort.json", &sequence(effort));
        bad_input(&keypose(&["check", file.to_str().unwrap()]), expected);
    }
    // The STS3215 counts 80 % as an overload from the factory: a grasp held at 85 % would
    // trip it. Refused before anything is sent (the virtual servos' torque stays off).
    let file = write(dir.path(), "hard.json", &sequence(r#"{"gripper":85}"#));
    let out = keypose(&[
        "play",
        file.to_str().unwrap(),
        "--port",
        "virtual",
        "--quiet",
    ]);
    bad_input(
        &out,
        "key #1: gripper effort 85 % is at or above its servo's overload threshold (80 %)",
    );
    // No export format carries an effort: refused, not written at full effort.
    let file = write(dir.path(), "grasp.json", &sequence(r#"{"gripper":30}"#));
    let out_file = dir.path().join("grasp.yaml");
    let out = keypose(&[
        "export",
        "ros2",
        file.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
    ]);
    bad_input(
        &out,
        "key #1 limits gripper's effort, which no export format carries",
    );
    assert!(!out_file.exists());
}
