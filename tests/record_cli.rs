//! `keypose record` as a user runs it: the real binary, the real serial code, emulated servos on
//! a pseudo-terminal (`--port virtual`).

use keypose::sequence::{KeyValue, Sequence};
use std::process::{Command, Output};

fn keypose() -> Command {
    Command::new(env!("CARGO_BIN_EXE_keypose"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn show(out: &Output) -> String {
    format!(
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        text(&out.stdout),
        text(&out.stderr)
    )
}

#[test]
fn recording_a_still_virtual_arm_gives_two_keys_at_home_that_pass_check() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("out.json");
    let out = keypose()
        .args(["record", "-o"])
        .arg(&file)
        .args(["--port", "virtual", "--robot", "so101", "--duration", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // Nothing moves the virtual arm: the first and the last sample, both at home (all 0° on
    // the SO-101), reproduce it exactly.
    let stdout = text(&out.stdout);
    assert!(stdout.contains(" samples → 2 keys"), "{}", show(&out));
    let sequence = Sequence::load(&file).unwrap();
    assert_eq!(sequence.robot, "so101");
    assert_eq!(sequence.keyframes.len(), 2);
    assert_eq!(sequence.key_times()[0], 0.0);
    // --duration 1: the last sample is at about a second (a late read can shift it by a few ms).
    let last = sequence.key_times()[1];
    assert!((0.9..=1.1).contains(&last), "last key at {last} s");
    for key in &sequence.keyframes {
        for (joint, value) in &key.values {
            assert_eq!(*value, KeyValue::Joint(0.0), "{joint}");
        }
    }
    assert_eq!(sequence.keyframes[0].values.len(), 6);

    let check = keypose().arg("check").arg(&file).output().unwrap();
    assert_eq!(check.status.code(), Some(0), "{}", show(&check));
}

#[test]
fn recording_some_joints_keeps_the_others_in_the_first_key() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("elbow.json");
    let out = keypose()
        .args(["record", "-o"])
        .arg(&file)
        .args([
            "--port",
            "virtual",
            "--robot",
            "koch",
            "--joints",
            "elbow_flex,wrist_flex",
            "--duration",
            "0.3",
            "--interpolation",
            "cubic",
            "--rate",
            "50",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let sequence = Sequence::load(&file).unwrap();
    assert_eq!(sequence.interpolation.name(), "cubic");
    let names = |i: usize| -> Vec<String> {
        sequence.keyframes[i]
            .values
            .iter()
            .map(|(n, _)| n.clone())
            .collect()
    };
    assert_eq!(names(0).len(), 6);
    assert_eq!(names(1), ["elbow_flex", "wrist_flex"]);
    let check = keypose().arg("check").arg(&file).output().unwrap();
    assert_eq!(check.status.code(), Some(0), "{}", show(&check));
}

#[test]
fn bad_arguments_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("never.json");
    let file_arg = file.to_str().unwrap();
    let missing_dir = dir.path().join("no/such/dir/out.json");
    let cases: Vec<Vec<&str>> = vec![
        // No port.
        vec!["record", "-o", file_arg, "--duration", "1"],
        // A joint the robot does not have.
        vec![
            "record", "-o", file_arg, "--port", "virtual", "--joints", "knee",
        ],
        // Step jumps: refused.
        vec![
            "record",
            "-o",
            file_arg,
            "--port",
            "virtual",
            "--interpolation",
            "step",
        ],
        vec![
            "record",
            "-o",
            file_arg,
            "--port",
            "virtual",
            "--tolerance",
            "0",
        ],
        vec![
            "record", "-o", file_arg, "--port", "virtual", "--rate", "5000",
        ],
        vec![
            "record",
            "-o",
            file_arg,
            "--port",
            "virtual",
            "--duration",
            "-1",
        ],
        vec![
            "record",
            "-o",
            missing_dir.to_str().unwrap(),
            "--port",
            "virtual",
            "--duration",
            "1",
        ],
    ];
    for args in cases {
        let out = keypose().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}\n{}", show(&out));
    }
    assert!(!file.exists());
}

#[test]
fn a_port_that_does_not_exist_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("never.json");
    let out = keypose()
        .args(["record", "-o"])
        .arg(&file)
        .args(["--port", "/dev/keypose-no-such-port", "--duration", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{}", show(&out));
    assert!(!file.exists());
}
