//! `keypose mirror` through the binary: the mirrored sequences sampled (`keypose sample`) against
//! the originals, with the signs derived by hand from the arms' axes (docs/robots.md §13: on the
//! SO-101 the pan and the wrist roll turn about axes in the arm's vertical plane and change sign;
//! the pitch axes are square to it and the gripper's opening is not mirrored).

use crate::common::{repo, run as keypose, show, SO101_JOINTS};
use keypose::robot::Robot;
use std::fs;
use std::path::Path;

/// Which SO-101 joints (chain order) change sign in the mirror image, by hand: shoulder_pan
/// (vertical axis) and wrist_roll (along the forearm) lie in the plane; shoulder_lift,
/// elbow_flex and wrist_flex are square to it; the gripper keeps its opening.
const SO101_SIGNS: [f64; 6] = [-1.0, 1.0, 1.0, 1.0, -1.0, 1.0];

/// `keypose sample` of a sequence: the column names and the rows (time first).
fn sample(path: &Path, extra: &[&str]) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut args = vec!["sample", path.to_str().unwrap(), "--format", "json"];
    args.extend_from_slice(extra);
    let out = keypose(&args);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let columns = json["columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap().to_string())
        .collect();
    let rows = json["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        })
        .collect();
    (columns, rows)
}

fn mirror(input: &Path, output: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "mirror",
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    keypose(&args)
}

fn column(columns: &[String], name: &str) -> usize {
    columns
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("{name}"))
}

#[test]
fn a_one_arm_so101_sequence_mirrors_pan_and_roll_and_keeps_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(&repo("sequences/so101_wave.json")).to_path_buf();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let (columns, original) = sample(&input, &[]);
    let (mirrored_columns, mirrored) = sample(&output, &[]);
    assert_eq!(columns, mirrored_columns);
    assert_eq!(original.len(), mirrored.len());
    let mut largest = 0.0f64;
    for (a, b) in original.iter().zip(&mirrored) {
        assert_eq!(a[0], b[0], "times");
        for (j, name) in SO101_JOINTS.iter().enumerate() {
            let c = column(&columns, name);
            let error = (b[c] - SO101_SIGNS[j] * a[c]).abs();
            largest = largest.max(error);
            assert!(error < 1e-6, "{name} at {} s: {} vs {}", a[0], b[c], a[c]);
        }
    }
    // The wave rolls the hand 90° (a transform key): mirrored it rolls −90°.
    let roll = column(&columns, "wrist_roll");
    let deepest = mirrored
        .iter()
        .map(|r| r[roll])
        .fold(f64::INFINITY, f64::min);
    assert!((deepest + 90.0).abs() < 0.01, "{deepest}");
    println!(
        "{} samples, largest departure from the hand rule {largest:.2e}",
        original.len()
    );
}

#[test]
fn one_arm_of_a_cell_mirrored_onto_the_other() {
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(&repo("sequences/bimanual_wave.json")).to_path_buf();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &["--arms", "left:right"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let (columns, original) = sample(&input, &[]);
    let (mirrored_columns, mirrored) = sample(&output, &[]);
    assert_eq!(columns, mirrored_columns);
    for (a, b) in original.iter().zip(&mirrored) {
        for (j, name) in SO101_JOINTS.iter().enumerate() {
            let left = column(&columns, &format!("left/{name}"));
            let right = column(&columns, &format!("right/{name}"));
            // Left unchanged; right does left's motion, mirrored.
            assert!(
                (b[left] - a[left]).abs() < 1e-9,
                "left/{name} at {} s",
                a[0]
            );
            let error = (b[right] - SO101_SIGNS[j] * a[left]).abs();
            assert!(
                error < 1e-6,
                "right/{name} at {} s: {} vs {}",
                a[0],
                b[right],
                a[left]
            );
        }
    }
    // Right's own tool key ("reach") went with the rest of its keys.
    let text = fs::read_to_string(&output).unwrap();
    assert!(!text.contains("\"tool\""), "{text}");
}

#[test]
fn a_mirrored_tool_key_is_solved_to_the_reflected_target() {
    // The target: the SO-101's tool pose at pan 20, lift −30, elbow 40, wrist flex 30, roll 25.
    let robot = Robot::builtin("so101").unwrap();
    let q = [20.0, -30.0, 40.0, 30.0, 25.0, 0.0];
    let target = robot.tcp_frame(&q);
    let (r, p, y) = keypose::pose::rpy_from_quat(target.r);
    let t = target.t;
    let sequence = format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
            "keyframes": [{{"time": 0, "joints": {{"shoulder_pan": 0}}}},
                          {{"time": 4, "tool": {{"xyz": [{}, {}, {}], "rpy": [{r}, {p}, {y}]}}}}]}}"#,
        t.x, t.y, t.z
    );
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("tool.json");
    fs::write(&input, sequence).unwrap();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));

    // Reflected across the x-z plane, by hand: (x, y, z) → (x, −y, z). The orientation: the
    // one the hand rule's joints give (pan and roll negated), which is the mirror image of the
    // turn from the zero-pose orientation.
    let want_xyz = glam::DVec3::new(t.x, -t.y, t.z);
    let hand: Vec<f64> = q.iter().zip(SO101_SIGNS).map(|(v, s)| v * s).collect();
    let want_r = robot.tcp_frame(&hand).r;
    let (columns, rows) = sample(&output, &[]);
    let last = rows.last().unwrap();
    let solved: Vec<f64> = SO101_JOINTS
        .iter()
        .map(|n| last[column(&columns, n)])
        .collect();
    let reached = robot.tcp_frame(&solved);
    let position_error = (reached.t - want_xyz).length();
    let angle_error = reached.r.angle_between(want_r).to_degrees();
    println!(
        "original target {t:?} rpy ({r:.4}, {p:.4}, {y:.4}); mirrored solution {solved:?}; \
         position error {position_error:.2e} m, orientation error {angle_error:.2e}°"
    );
    // The SO-101's plane (through the pan anchor and the tcp at zero, §13) is 3.2e-5 rad off
    // x-z, which moves a point 0.09 m off it by about 14 µm from the hand-made (x, −y, z).
    assert!(position_error < 3e-5, "{position_error}");
    assert!(angle_error < 0.01, "{angle_error}");
    // And the joints are the hand rule's: pan and roll negated, the pitches as they were, to
    // within what the arm's own asymmetry asks (its roll axis passes 0.17 mm beside the plane,
    // so the rule's joints put the tool 0.15 mm from the reflected point; measured 0.08°).
    for (j, name) in SO101_JOINTS.iter().enumerate().take(5) {
        let want = hand[j];
        assert!(
            (solved[j] - want).abs() < 0.1,
            "{name}: {} vs {want}",
            solved[j]
        );
    }
}

#[test]
fn a_value_past_the_other_side_limit_is_clipped_and_reported() {
    // wrist_roll's range is −157.21 … 162.79° (docs/robots.md §1.2): 160° mirrors to −160°.
    let sequence = r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
        "keyframes": [{"name": "start", "time": 0, "joints": {"wrist_roll": 0}},
                      {"name": "far", "time": 5, "joints": {"wrist_roll": 160, "shoulder_pan": 30}}]}"#;
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("roll.json");
    fs::write(&input, sequence).unwrap();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &[]);
    let stderr = crate::common::stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert!(
        stderr.contains("key 1 (far): wrist_roll mirrored to -160.000 deg")
            && stderr.contains("clipped to -157.21 deg"),
        "{stderr}"
    );
    assert!(stderr.contains("1 value(s) clipped"), "{stderr}");
    // Written all the same, with the limit, and it plays.
    let (columns, rows) = sample(&output, &[]);
    let last = rows.last().unwrap();
    assert_eq!(last[column(&columns, "wrist_roll")], -157.21);
    assert_eq!(last[column(&columns, "shoulder_pan")], -30.0);
    assert_eq!(
        keypose(&["check", output.to_str().unwrap()]).status.code(),
        Some(0)
    );
}

#[test]
fn bad_arms_exit_2_naming_what_was_expected() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.json");
    let cell = Path::new(&repo("sequences/bimanual_wave.json")).to_path_buf();
    let out = mirror(&cell, &output, &["--arms", "left:middle"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let stderr = crate::common::stderr(&out);
    assert!(
        stderr.contains("unknown arm \"middle\"")
            && stderr.contains("expected one of: left, right"),
        "{stderr}"
    );
    let one = Path::new(&repo("sequences/so101_wave.json")).to_path_buf();
    let out = mirror(&one, &output, &["--arms", "left:right"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let stderr = crate::common::stderr(&out);
    assert!(
        stderr.contains("a sequence for one arm; expected a sequence for several"),
        "{stderr}"
    );
    let out = mirror(&cell, &output, &["--arms", "left"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(crate::common::stderr(&out).contains("FROM:TO"));
    assert!(!output.exists(), "nothing is written on bad input");
}

#[test]
fn a_tool_key_of_one_arm_mirrored_onto_the_other_reaches_the_reflected_point() {
    // Left's tool target, in left's base frame; mirrored onto right, in right's own frame, it
    // is (x, −y, z) by hand (both SO-101, whose plane is x-z).
    let sequence = r#"{"format": "keypose-sequence/1",
        "robots": {"left": {"robot": "so101", "base": {"xyz": [0, 0.25, 0], "rpy": [0, 0, 0]}},
                   "right": {"robot": "so101", "base": {"xyz": [0, -0.25, 0], "rpy": [0, 0, 0]}}},
        "interpolation": "monotone",
        "keyframes": [{"time": 0, "joints": {"left/shoulder_pan": 0, "right/elbow_flex": 30}},
                      {"time": 4, "tool": {"left": {"xyz": [0.25, 0.08, 0.15]}}}]}"#;
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("cell.json");
    fs::write(&input, sequence).unwrap();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &["--arms", "left:right"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let (columns, rows) = sample(&output, &[]);
    let last = rows.last().unwrap();
    let arm = |name: &str| -> Vec<f64> {
        SO101_JOINTS
            .iter()
            .map(|j| last[column(&columns, &format!("{name}/{j}"))])
            .collect()
    };
    let so101 = Robot::builtin("so101").unwrap();
    let left = so101.tcp_position(&arm("left"));
    let right = so101.tcp_position(&arm("right"));
    println!("left tool {left:?}, right tool {right:?}");
    assert!((left - glam::DVec3::new(0.25, 0.08, 0.15)).length() < 1e-6);
    // 14 µm of it is the SO-101 plane's 3.2e-5 rad off x-z (see above).
    assert!(
        (right - glam::DVec3::new(0.25, -0.08, 0.15)).length() < 3e-5,
        "{right:?}"
    );
}

#[test]
fn on_the_symmetric_omx_a_mirrored_tool_key_lands_exactly_on_the_hand_reflected_point() {
    // The OMX's plane is exactly x-z (docs/robots.md §13): (0.2, 0.05, 0.15) → (0.2, −0.05, 0.15).
    let sequence = r#"{"format": "keypose-sequence/1", "robot": "omx", "interpolation": "monotone",
        "keyframes": [{"time": 0, "joints": {"joint1": 0}},
                      {"time": 4, "tool": {"xyz": [0.2, 0.05, 0.15]}}]}"#;
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("omx.json");
    fs::write(&input, sequence).unwrap();
    let output = dir.path().join("mirrored.json");
    let out = mirror(&input, &output, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let (columns, rows) = sample(&output, &["--tool"]);
    let last = rows.last().unwrap();
    let tool: Vec<f64> = ["tool_x", "tool_y", "tool_z"]
        .iter()
        .map(|c| last[column(&columns, c)])
        .collect();
    println!("omx mirrored tool at {tool:?}");
    for (got, want) in tool.iter().zip([0.2, -0.05, 0.15]) {
        assert!((got - want).abs() < 1e-6, "{tool:?}");
    }
    // The pan turned the other way, the pitches as they were: joint1 = −atan2(0.05, 0.2 − 0.012).
    let pan = last[column(&columns, "joint1")];
    let want = -(0.05f64).atan2(0.2 - 0.012).to_degrees();
    assert!((pan - want).abs() < 1e-3, "{pan} vs {want}");
}
