//! A cell of several arms in MuJoCo, for real: the harness composes one scene of every arm at
//! its base (sim/sim_scene.py), and `keypose sim` judges the arms together, contacts between
//! them included.
//!
//! The oracles: hand-worked geometry of a small two-body model (where a rotated base puts a
//! site, how deep two boxes overlap), the so101's reach from keypose's own forward kinematics
//! (`keypose pose`, robots/so101.json) against the distance between the bases, the symmetry of
//! two identical arms facing each other, and the values the sequence file gives its keys.
//!
//! The Python environment is the simulation suites' (`crate::common::python_cache`), built on first use;
//! without python3, PyPI or MuJoCo these tests fail and say so, never skip.

use crate::common::{python_cache, run_sim as keypose, show};
use keypose::python::{Harness, PyConfig};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// Two hinged boxes side by side, both on the world body (so MuJoCo's parent-child filter does
/// not keep them apart), overlapping, and an exclusion between them: alone, this "arm" has no
/// contact only because the exclusion holds. Box half-size 0.02 m at z = 0.5 (off the floor);
/// site `tip` 0.1 m along body `a`'s x.
const PAIR_MJCF: &str = r#"<mujoco model="pair">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <light pos="0 0 2" dir="0 0 -1"/>
    <body name="a" pos="0 0 0.5">
      <joint name="ja" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
      <site name="tip" pos="0.1 0 0"/>
    </body>
    <body name="b" pos="0.01 0 0.5">
      <joint name="jb" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
    </body>
  </worldbody>
  <contact>
    <exclude body1="a" body2="b"/>
  </contact>
  <actuator>
    <position joint="ja" kp="10"/>
    <position joint="jb" kp="10"/>
  </actuator>
</mujoco>
"#;

/// The harness, the pair's model file and a copy of it at half the timestep (0.001 s).
fn harness(dir: &Path) -> (Harness, String, String) {
    let config = PyConfig::with_cache_dir(python_cache());
    config
        .ensure_python()
        .unwrap_or_else(|e| panic!("keypose's Python environment (MuJoCo) is needed: {e}"));
    let harness = Harness::start_in(&config, "sim_harness.py", crate::common::patient_harness())
        .unwrap_or_else(|e| panic!("the MuJoCo harness did not start: {e}"));
    let path = dir.join("pair.xml");
    std::fs::write(&path, PAIR_MJCF).unwrap();
    let fine = dir.join("pair-fine.xml");
    let text = PAIR_MJCF.replace(r#"timestep="0.002""#, r#"timestep="0.001""#);
    std::fs::write(&fine, text).unwrap();
    (
        harness,
        path.display().to_string(),
        fine.display().to_string(),
    )
}

/// Arm `name` of model `mjcf` at `x` on the x axis, turned `yaw` about z.
fn arm(name: &str, mjcf: &str, x: f64, yaw: f64) -> Value {
    json!({"name": name, "mjcf": mjcf, "pos": [x, 0.0, 0.0],
           "quat": [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()]})
}

fn request(harness: &mut Harness, request: Value) -> Value {
    harness
        .request(&request)
        .unwrap_or_else(|e| panic!("{request}: {e}"))
}

/// The (body1, body2, kind, arm1, arm2) of a contacts reply, each pair once, sorted.
fn contact_pairs(reply: &Value) -> Vec<(String, String, String, String, String)> {
    let mut pairs: Vec<_> = reply["contacts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let s = |k: &str| c[k].as_str().unwrap_or("-").to_string();
            (s("body1"), s("body2"), s("kind"), s("arm1"), s("arm2"))
        })
        .collect();
    pairs.sort();
    pairs.dedup();
    pairs
}

#[test]
fn a_scene_places_each_arm_at_its_base_and_keeps_its_exclusions() {
    let dir = tempfile::tempdir().unwrap();
    let (mut harness, pair, fine) = harness(dir.path());
    let yaw = std::f64::consts::PI;
    let loaded = request(
        &mut harness,
        json!({"op": "load", "arms": [arm("left", &pair, 0.0, 0.0), arm("right", &fine, 1.0, yaw)]}),
    );
    // The finer of the two arms' timesteps.
    assert_eq!(loaded["timestep"], json!(0.001));
    let joints: Vec<&str> = loaded["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["name"].as_str().unwrap())
        .collect();
    assert_eq!(joints, ["left/ja", "left/jb", "right/ja", "right/jb"]);
    assert_eq!(loaded["arms"]["right"], json!(["right/a", "right/b"]));
    assert_eq!(
        loaded["bodies"],
        json!(["world", "left/a", "left/b", "right/a", "right/b"])
    );

    // Right's base at x = 1 turned half a turn: its tip, 0.1 m along its body a's x turned by
    // ja = 0.3 rad, is at (1 - 0.1 cos 0.3, -0.1 sin 0.3, 0.5).
    let q = 0.3_f64;
    let at = request(
        &mut harness,
        json!({"op": "kinematics", "qpos": {"right/ja": q}, "sites": ["left/tip", "right/tip"]}),
    );
    let tip = |site: &str| -> Vec<f64> {
        at["sites"][site]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let expected = [1.0 - 0.1 * q.cos(), -0.1 * q.sin(), 0.5];
    for (got, want) in tip("right/tip").iter().zip(expected) {
        assert!(
            (got - want).abs() < 1e-9,
            "{:?} vs {expected:?}",
            tip("right/tip")
        );
    }
    assert_eq!(
        tip("left/tip")
            .iter()
            .map(|v| (v * 1e9).round() / 1e9)
            .collect::<Vec<_>>(),
        [0.1, 0.0, 0.5]
    );

    // Each arm's a and b overlap, excluded: no contact at all a metre apart.
    let apart = request(&mut harness, json!({"op": "contacts", "qpos": {}}));
    assert_eq!(contact_pairs(&apart), [], "{apart}");

    // 0.02 m apart, unturned: along x, left/a spans -0.02 … 0.02 and left/b -0.01 … 0.03,
    // right/a 0 … 0.04 and right/b 0.01 … 0.05 (all alike in y and z). Every pair across the
    // arms overlaps and none is excluded; within each arm the exclusion still holds.
    request(
        &mut harness,
        json!({"op": "load", "arms": [arm("left", &pair, 0.0, 0.0), arm("right", &pair, 0.02, 0.0)]}),
    );
    let close = request(&mut harness, json!({"op": "contacts", "qpos": {}}));
    let pairs = contact_pairs(&close);
    // Named in the cell's order of arms: left's body first.
    let across = |x: &str, y: &str| {
        pairs.iter().any(|(b1, b2, kind, a1, a2)| {
            kind == "arms" && b1 == x && b2 == y && a1 == "left" && a2 == "right"
        })
    };
    for (x, y) in [
        ("left/a", "right/a"),
        ("left/a", "right/b"),
        ("left/b", "right/a"),
        ("left/b", "right/b"),
    ] {
        assert!(across(x, y), "{x} against {y} missing: {pairs:?}");
    }
    assert_eq!(pairs.len(), 4, "only the pairs across the arms: {pairs:?}");
    let depth = |x: &str, y: &str| {
        close["contacts"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| {
                (c["body1"] == x && c["body2"] == y) || (c["body1"] == y && c["body2"] == x)
            })
            .map(|c| c["depth"].as_f64().unwrap())
            .fold(0.0, f64::max)
    };
    for (x, y, overlap) in [
        ("left/a", "right/a", 0.02),
        ("left/a", "right/b", 0.01),
        ("left/b", "right/a", 0.03),
        ("left/b", "right/b", 0.02),
    ] {
        let found = depth(x, y);
        assert!(
            (found - overlap).abs() < 1e-6,
            "{x}–{y}: {found} m deep, expected {overlap}"
        );
    }
}

/// Two SO-101 facing each other along x, `distance` apart (right turned half a turn), both
/// reaching forward from home: shoulder_lift 30°, elbow_flex -30° at 1 s, held 0.2 s.
fn facing(dir: &Path, distance: f64) -> String {
    let path = dir.join(format!("facing-{distance}.json"));
    let text = format!(
        r#"{{"format": "keypose-sequence/1",
  "robots": {{
    "left": {{"robot": "so101", "base": {{"xyz": [0, 0, 0], "rpy": [0, 0, 0]}}}},
    "right": {{"robot": "so101", "base": {{"xyz": [{distance}, 0, 0], "rpy": [0, 0, 3.141592653589793]}}}}
  }},
  "keyframes": [
    {{"time": 0, "joints": {{"left/shoulder_lift": 0, "left/elbow_flex": 0, "right/shoulder_lift": 0, "right/elbow_flex": 0}}}},
    {{"name": "reach", "time": 1.0, "hold": 0.2, "joints": {{"left/shoulder_lift": 30, "left/elbow_flex": -30, "right/shoulder_lift": 30, "right/elbow_flex": -30}}}}
  ]}}"#
    );
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// The tool point's x in the base frame at `joints` (keypose's forward kinematics).
fn tool_x(joints: &[&str]) -> f64 {
    let mut args = vec!["pose", "--robot", "so101"];
    args.extend_from_slice(joints);
    let out = keypose(&args);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let line = text
        .lines()
        .find(|l| l.starts_with("tool"))
        .unwrap_or_else(|| panic!("{}", show(&out)));
    let x = line.split(" x ").nth(1).unwrap().split_whitespace().next();
    x.unwrap().parse().unwrap()
}

/// `keypose sim ARGS` on the SO-101s' 12 V build (the standard 5 V one sags past the
/// settling tolerance at home, tests/simulation/cli.rs), its wall time printed under `label`.
fn sim(label: &str, args: &[&str]) -> std::process::Output {
    let started = Instant::now();
    let out = keypose(&[&["sim"], args, &["--robot-variant", "12v"]].concat());
    println!(
        "{label}: keypose sim took {:.2} s",
        started.elapsed().as_secs_f64()
    );
    out
}

fn read_report(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The findings of `report` whose kind `kind` accepts.
fn findings(report: &Value, kind: impl Fn(&str) -> bool) -> Vec<Value> {
    report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| kind(f["kind"].as_str().unwrap()))
        .cloned()
        .collect()
}

/// The CSV at `path` as columns by header name.
fn columns(path: &Path) -> HashMap<String, Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut out: HashMap<String, Vec<String>> =
        header.iter().map(|h| (h.clone(), Vec::new())).collect();
    for line in lines {
        for (h, v) in header.iter().zip(line.split(',')) {
            out.get_mut(h).unwrap().push(v.to_string());
        }
    }
    out
}

fn numbers(column: &[String]) -> Vec<f64> {
    column.iter().map(|v| v.parse().unwrap()).collect()
}

#[test]
fn arms_reaching_into_each_other_collide_and_far_apart_pass() {
    let dir = tempfile::tempdir().unwrap();
    // At home each tool point is this far in front of its base, at the reach this far: two
    // bases 0.84 m apart leave room at home and not at the reach; 1.0 m leaves room at both.
    let home = tool_x(&[]);
    let reach = tool_x(&["shoulder_lift=30", "elbow_flex=-30"]);
    println!("tool point in front of the base: {home:.3} m at home, {reach:.3} m at the reach");
    assert!(2.0 * home < 0.84 && 2.0 * reach > 0.84 && 2.0 * reach < 1.0);

    let close = facing(dir.path(), 0.84);
    let close_report = dir.path().join("close.json");
    let out = sim(
        "0.84 m apart",
        &[&close, "--report", close_report.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let line = stdout
        .lines()
        .find(|l| l.contains("arm collision"))
        .unwrap_or_else(|| panic!("no arm collision: {}", show(&out)));
    assert!(
        line.contains("arms left and right: left/") && line.contains(" touches right/"),
        "{line}"
    );
    let report = read_report(&close_report);
    assert_eq!(report["arms"][1]["name"], "right");
    assert_eq!(report["arms"][1]["base"]["xyz"], json!([0.84, 0.0, 0.0]));
    let yaw = report["arms"][1]["base"]["rpy"][2].as_f64().unwrap();
    assert!(
        (yaw - std::f64::consts::PI).abs() < 1e-9,
        "{}",
        report["arms"]
    );
    let collisions = findings(&report, |kind| kind == "arm collision");
    let first = &collisions[0];
    assert_eq!(first["arms"], json!(["left", "right"]), "{first}");
    // They meet on the way: home leaves room, so not before the motion starts; the servos lag
    // their goals, so up to a few tenths of a second after the reach's key at 1.2 s.
    let time = first["time"].as_f64().unwrap();
    assert!(time > 0.0 && time <= 1.5, "{first}");
    println!("first arm collision at {time:.2} s: {}", first["message"]);

    let far = facing(dir.path(), 1.0);
    let log = dir.path().join("far.csv");
    let out = sim("1.0 m apart", &[&far, "--log", log.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // The scene is symmetric under the half turn about x = 0.5 m: both arms move alike.
    let log = columns(&log);
    for joint in crate::common::SO101_JOINTS {
        let left = numbers(&log[&format!("left/{joint}_meas")]);
        let right = numbers(&log[&format!("right/{joint}_meas")]);
        let worst = left
            .iter()
            .zip(&right)
            .map(|(l, r)| (l - r).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "{joint}: left and right differ by {worst}°");
    }
}

#[test]
fn the_bimanual_wave_passes_and_each_arm_moves_as_sampled() {
    let dir = tempfile::tempdir().unwrap();
    let wave = crate::common::repo("sequences/bimanual_wave.json");
    let log = dir.path().join("wave.csv");
    let out = sim("bimanual_wave", &[&wave, "--log", log.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let sampled_path = dir.path().join("sampled.csv");
    let out = keypose(&[
        "sample",
        &wave,
        "--rate",
        "100",
        "-o",
        sampled_path.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let sampled = columns(&sampled_path);
    let sample_times = numbers(&sampled["time"]);
    let log = columns(&log);
    let phases = &log["phase"];
    let times = numbers(&log["sequence_time"]);
    // The wave's keys are on the 10 ms grid: each played row has its sample.
    let row_of = |t: f64| sample_times.iter().position(|s| (s - t).abs() < 1e-6);
    let mut worst: Vec<(String, f64)> = Vec::new();
    for arm in ["left", "right"] {
        for joint in crate::common::SO101_JOINTS {
            let name = format!("{arm}/{joint}");
            let commanded = numbers(&log[&format!("{name}_cmd")]);
            let measured = numbers(&log[&format!("{name}_meas")]);
            let expected = numbers(&sampled[&name]);
            let mut off: f64 = 0.0;
            for row in (0..times.len()).filter(|&r| phases[r] == "play") {
                let s = row_of(times[row]).unwrap_or_else(|| panic!("no sample at {}", times[row]));
                assert!(
                    (commanded[row] - expected[s]).abs() < 1e-6,
                    "{name} at {}: commanded {} but sampled {}",
                    times[row],
                    commanded[row],
                    expected[s]
                );
                off = off.max((measured[row] - expected[s]).abs());
            }
            // Within what the verdict allows in motion (Thresholds: 15°).
            assert!(off < 15.0, "{name}: {off}° from the sample");
            worst.push((name, off));
        }
    }
    println!("largest simulated − sampled per joint (°): {worst:?}");
    // At the end of the "raise" hold (1.8 s) each arm is where the file puts it: the pans turn
    // opposite ways (left +20°, right −20°), the other joints alike (within the 3° a settled
    // joint may be off).
    let at = times.iter().position(|t| (t - 1.8).abs() < 1e-6).unwrap();
    for (name, value) in [
        ("left/shoulder_pan", 20.0),
        ("right/shoulder_pan", -20.0),
        ("left/elbow_flex", -45.0),
        ("right/elbow_flex", -45.0),
        ("left/wrist_flex", 10.0),
        ("right/wrist_flex", 10.0),
    ] {
        let measured = numbers(&log[&format!("{name}_meas")])[at];
        assert!(
            (measured - value).abs() < 3.0,
            "{name}: {measured}° at 1.8 s, the file says {value}°"
        );
    }
}

#[test]
fn a_cell_curling_one_arm_onto_itself_is_that_arms_self_collision() {
    let dir = tempfile::tempdir().unwrap();
    // As simulation/cli.rs's self-collision: elbow and wrist folded to their stops curl the gripper back
    // onto the base; here only the left arm does, the right one 0.5 m away holds home.
    let path = dir.path().join("curl.json");
    std::fs::write(
        &path,
        r#"{"format": "keypose-sequence/1",
  "robots": {"left": "so101", "right": {"robot": "so101", "base": {"xyz": [0, -0.5, 0], "rpy": [0, 0, 0]}}},
  "keyframes": [
    {"time": 0, "joints": {"left/elbow_flex": 0, "left/wrist_flex": 0}},
    {"time": 2.0, "hold": 0.3, "joints": {"left/elbow_flex": 96, "left/wrist_flex": 95}}
  ]}"#,
    )
    .unwrap();
    let report_path = dir.path().join("curl-report.json");
    let out = sim(
        "one arm curled",
        &[
            path.to_str().unwrap(),
            "--report",
            report_path.to_str().unwrap(),
        ],
    );
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let collisions = findings(&read_report(&report_path), |kind| {
        kind.contains("collision")
    });
    // The gripper may graze the floor on the way too: every collision is the left arm's.
    for f in &collisions {
        assert_eq!(f["arms"], json!(["left"]), "{f}");
    }
    let own: Vec<&Value> = collisions
        .iter()
        .filter(|f| f["kind"] == "self collision")
        .collect();
    assert!(!own.is_empty(), "{}", show(&out));
    for f in own {
        let message = f["message"].as_str().unwrap();
        assert!(
            message.starts_with("left/") && message.contains("touches left/"),
            "{f}"
        );
    }
}

#[test]
fn another_model_is_refused_on_a_cell() {
    let wave = crate::common::repo("sequences/bimanual_wave.json");
    let model = crate::common::repo("sim/models/so101.xml");
    let out = keypose(&["sim", &wave, "--mjcf", &model]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--mjcf") && stderr.contains("a cell of 2 arms"),
        "{stderr}"
    );
}

#[test]
fn the_servo_profile_and_a_render_work_on_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let far = facing(dir.path(), 1.0);
    let sheet = dir.path().join("facing.png");
    let out = sim(
        "servo profile and render",
        &[&far, "--servo-profile", "--render", sheet.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // Two keys: a sheet of two 320 × 240 tiles side by side.
    assert_eq!(crate::common::png_size(&sheet), (640, 240));
    let stderr = crate::common::stderr(&out);
    assert!(
        stderr.contains("rendered 2 frame(s) of left=so101,right=so101"),
        "{stderr}"
    );
}
