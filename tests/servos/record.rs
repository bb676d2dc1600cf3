//! `keypose record` as a user runs it: the real binary, the real serial code, emulated servos on
//! a pseudo-terminal (`--port virtual`).

use crate::common::{keypose, show, stdout as text_out};
use keypose::sequence::{KeyValue, Sequence};

/// `keypose record -o FILE ARGS` to the end.
fn record(file: &std::path::Path, args: &[&str]) -> std::process::Output {
    keypose()
        .args(["record", "-o"])
        .arg(file)
        .args(args)
        .output()
        .expect("run keypose record")
}

/// `keypose check FILE` exits 0.
fn assert_passes_check(file: &std::path::Path) {
    let check = keypose().arg("check").arg(file).output().unwrap();
    assert_eq!(check.status.code(), Some(0), "{}", show(&check));
}

#[test]
fn recording_a_still_virtual_arm_gives_two_keys_at_home_that_pass_check() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("out.json");
    let out = record(
        &file,
        &["--port", "virtual", "--robot", "so101", "--duration", "1"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // Nothing moves the virtual arm: the first and the last sample, both at home (all 0° on
    // the SO-101), reproduce it exactly.
    let stdout = text_out(&out);
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

    assert_passes_check(&file);
}

#[test]
fn recording_some_joints_keeps_the_others_in_the_first_key() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("elbow.json");
    let out = record(
        &file,
        &[
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
        ],
    );
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
    assert_passes_check(&file);
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
    let out = record(
        &file,
        &["--port", "/dev/keypose-no-such-port", "--duration", "1"],
    );
    assert_eq!(out.status.code(), Some(3), "{}", show(&out));
    assert!(!file.exists());
}

/// Where on the example's path, from `from` on, the arm held `pose`: the time (on a 0.5 ms grid)
/// and the largest joint difference there.
fn nearest_on_path(original: &keypose::plan::Trajectory, pose: &[f64], from: f64) -> (f64, f64) {
    let mut best = (from, f64::INFINITY);
    let end = original.start() + original.duration();
    let mut t = from;
    while t <= end + 1e-9 {
        let distance = original
            .sample(t)
            .iter()
            .zip(pose)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if distance < best.1 {
            best = (t, distance);
        }
        t += 0.0005;
    }
    best
}

#[test]
fn a_motion_made_by_the_virtual_hand_comes_back_as_a_few_keys_on_its_path() {
    // The oracle is the hand-written example: `keypose virtual-bus --hand` moves the limp servos
    // along it, `keypose record` reads them over the pseudo-terminal, and what it keeps must be
    // that motion. Key times may be stretched (the recording follows the example within 1°,
    // which near the example's 95 % of the acceleration limit can need a little more time), so
    // the comparison is on the path: every key is a pose the hand really held, in order.
    use keypose::plan::Trajectory;
    use keypose::robot::Robot;
    let robot = Robot::builtin("so101").unwrap();
    let wave = crate::common::repo("sequences/so101_wave.json");
    let example = Sequence::load(std::path::Path::new(&wave)).unwrap();
    let original = Trajectory::build(&example, &robot).unwrap();
    let bus = crate::common::VirtualBusProcess::start(&["--robot", "so101", "--hand", &wave]);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("recorded.json");
    // The whole motion, then half a second at rest.
    let duration = format!("{:.3}", original.duration() + 0.5);
    let out = record(
        &file,
        &[
            "--port",
            &bus.path,
            "--robot",
            "so101",
            "--quiet",
            "--duration",
            &duration,
            "--interpolation",
            "cubic",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert_passes_check(&file);
    let summary = text_out(&out);
    println!("{summary}");

    let sequence = Sequence::load(&file).unwrap();
    // The example has 8 keys, two with holds: 10 places where the motion changes. Of about 900
    // samples a few keys more may be kept (1° is tight next to 0.09° encoder ticks); far from
    // a key per sample.
    let keys = sequence.keyframes.len();
    assert!((5..=16).contains(&keys), "{keys} keys\n{summary}");
    let recorded = Trajectory::build(&sequence, &robot).unwrap();
    // Each key is a sample: a pose the hand held, so it lies on the example's path up to half
    // an encoder tick (0.044°) and the 0.5 ms search grid (≤ 0.03° at 115 °/s).
    let mut from = original.start();
    for (k, &time) in sequence.key_times().iter().enumerate() {
        let pose = recorded.sample(time);
        let (at, distance) = nearest_on_path(&original, &pose, from);
        assert!(
            distance <= 0.1,
            "key {k} at {time} s is {distance:.3}° from the path (nearest at {at:.4} s)\n{summary}"
        );
        from = at;
    }
    // And the motion is all there: every joint reaches the example's extremes within the
    // tolerance (a cubic between samples may pass them by at most as much).
    for (j, joint) in robot.joints.iter().enumerate() {
        let range = |t: &Trajectory| {
            t.grid(500.0)
                .map(|s| t.sample(s)[j])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let (a, b) = (range(&original), range(&recorded));
        assert!(
            (a.0 - b.0).abs() <= 1.0 && (a.1 - b.1).abs() <= 1.0,
            "{}: example {a:?}, recorded {b:?}",
            joint.name
        );
    }
}
