//! Hostile and huge input through the binary: duplicate keys, files that are not files, files
//! too big, too many keys, escape sequences in names, absurd option values. Each is bad input:
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

fn assert_no_control_bytes(text: &[u8]) {
    let bad: Vec<u8> = text
        .iter()
        .copied()
        .filter(|&b| b < 0x20 && b != b'\n')
        .collect();
    assert!(
        bad.is_empty(),
        "control bytes {bad:?} in {:?}",
        String::from_utf8_lossy(text)
    );
}

#[test]
fn key_names_with_escape_sequences_are_printed_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "crafted.json", CRAFTED);
    let p = path.to_str().unwrap();
    // check: the violation names segment 0 (a… → b…).
    let out = keypose(&["check", p]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert_no_control_bytes(&out.stdout);
    assert!(
        stdout_has(&out, r"a\x1b[2J → b\x1b]0;owned\x07"),
        "{}",
        show(&out)
    );
    // retime reports the same segment on stderr.
    let out = keypose(&[
        "retime",
        p,
        "-o",
        dir.path().join("o.json").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert_no_control_bytes(&out.stderr);
    assert!(
        stderr(&out).contains(r"segment 0 (a\x1b[2J → b\x1b]0;owned\x07)"),
        "{}",
        show(&out)
    );
    // An error message quoting a name.
    let text = CRAFTED.replace("elbow_flex\":90", "elbow\u{1b}[31m\":90");
    let path = write(dir.path(), "bad.json", &text);
    let out = keypose(&["check", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert_no_control_bytes(&out.stderr);
}

fn stdout_has(out: &Output, text: &str) -> bool {
    String::from_utf8_lossy(&out.stdout).contains(text)
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
