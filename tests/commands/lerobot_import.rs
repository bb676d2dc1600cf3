//! `keypose import lerobot` against LeRobotDataset v3.0 folders that the tests write with
//! pyarrow (tests/data/make_lerobot_dataset.py, in keypose's own Python environment) from known
//! motions: the frames are the oracle. Without python3 3.11+ or PyPI the environment cannot be
//! built and these tests fail.

use crate::common::{python_cache, repo, run_sim, show, stderr, stdout, SO101_JOINTS};
use keypose::plan::{check, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::{KeyValue, Sequence};
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const FPS: f64 = 30.0;
/// Tolerance asked for, degrees.
const TOLERANCE: f64 = 1.0;
/// Key times are whole milliseconds while frames are k/30 s apart: the curve is judged at the
/// frames' own times, up to 0.5 ms from the nearest key time; at the test motions' largest
/// speed (about 130 °/s) that moves the curve by up to 0.07°.
const TIME_SNAP_SLACK: f64 = 0.07;

/// keypose's Python environment (with pyarrow), built once for the tests of this file.
fn python() -> PathBuf {
    static PYTHON: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    PYTHON
        .get_or_init(|| {
            keypose::python::PyConfig::with_cache_dir(python_cache())
                .ensure_python()
                .unwrap_or_else(|e| {
                    panic!("keypose's Python environment (with pyarrow) is needed: {e}")
                })
                .python
        })
        .clone()
}

/// Writes a dataset of an SO-101 at `root` from `episodes` (rows of values per frame) with
/// `names`.
fn write_dataset(
    root: &Path,
    version: &str,
    names: &[String],
    column: &str,
    episodes: &[(u32, Vec<Vec<f64>>)],
) {
    write_dataset_of(root, "so101_follower", version, names, column, episodes)
}

/// [`write_dataset`] for the LeRobot robot type `robot_type`.
fn write_dataset_of(
    root: &Path,
    robot_type: &str,
    version: &str,
    names: &[String],
    column: &str,
    episodes: &[(u32, Vec<Vec<f64>>)],
) {
    write_spec(&json!({
        "root": root,
        "version": version,
        "robot_type": robot_type,
        "fps": FPS,
        "names": names,
        "column": column,
        "episodes": episodes.iter().map(|(file, values)| json!({"file_index": file, "values": values})).collect::<Vec<_>>(),
    }));
}

/// Runs tests/data/make_lerobot_dataset.py on `spec` (its docstring says what a spec holds).
fn write_spec(spec: &serde_json::Value) {
    let mut child = Command::new(python())
        .arg(repo("tests/data/make_lerobot_dataset.py"))
        .stdin(Stdio::piped())
        .spawn()
        .expect("start the dataset writer");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(spec.to_string().as_bytes())
        .unwrap();
    assert!(child.wait().unwrap().success(), "the dataset writer failed");
}

fn pos_names(joints: &[&str]) -> Vec<String> {
    joints.iter().map(|j| format!("{j}.pos")).collect()
}

/// A smooth motion of the SO-101's six joints in degrees (gripper in %), from rest to rest
/// (a recorded motion starts and ends still; one that did not would have to be retimed, since
/// playback starts from rest): per joint `a · (1 − cos wt)/2 + b · sin² wt` with w = 2π/seconds,
/// whose velocity is 0 at both ends, and `amplitude` as wrist_roll's a (beyond 100 it can only be
/// degrees). Largest acceleration `a·w²/2 + 2·b·w²`: 66 + 22 °/s² for 120 and 10 over 6 s, well
/// within the SO-101's 344 °/s².
fn motion(seconds: f64, amplitude: f64) -> Vec<Vec<f64>> {
    let frames = (seconds * FPS) as usize + 1;
    let w = std::f64::consts::TAU / seconds;
    let shape =
        |a: f64, b: f64, t: f64| a * (1.0 - (w * t).cos()) / 2.0 + b * (w * t).sin().powi(2);
    (0..frames)
        .map(|k| {
            let t = k as f64 / FPS;
            vec![
                shape(40.0, 10.0, t),
                shape(-30.0, 15.0, t),
                shape(25.0, -10.0, t),
                shape(-20.0, 20.0, t),
                shape(amplitude, 10.0, t),
                50.0 + shape(30.0, 10.0, t),
            ]
        })
        .collect()
}

/// The sequence written by an import, its robot (with `calibration`) and the largest deviation
/// of its curve from `expected` (joint values per frame at k/FPS), per joint.
fn deviations(
    sequence: &Path,
    calibration: Option<&Path>,
    expected: &[Vec<f64>],
) -> (usize, Vec<f64>, bool) {
    robot_deviations(sequence, &so101_with(calibration), expected)
}

/// The built-in SO-101 with the LeRobot calibration at `calibration`, if any.
fn so101_with(calibration: Option<&Path>) -> Robot {
    let mut robot = Robot::builtin("so101").unwrap();
    if let Some(path) = calibration {
        let text = std::fs::read_to_string(path).unwrap();
        keypose::robot::import_lerobot_calibration(&mut robot, "cal.json", &text).unwrap();
    }
    robot
}

fn import(dir: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "import",
        "lerobot",
        dir.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_sim(&args)
}

#[test]
fn degree_episodes_from_list_columns_become_few_keys_within_tolerance() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let (small, large) = (motion(6.0, 60.0), motion(6.0, 120.0));
    // Three episodes over two data files; the one imported is alone in the second.
    write_dataset(
        &dir,
        "v3.0",
        &pos_names(&SO101_JOINTS),
        "list",
        &[
            (0, small.clone()),
            (0, motion(3.0, 10.0)),
            (1, large.clone()),
        ],
    );

    let out = tmp.path().join("two.json");
    let result = import(&dir, &out, &["--episode", "2"]);
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    assert!(
        stdout(&result).contains("data/chunk-000/file-001.parquet"),
        "{}",
        show(&result)
    );
    // wrist_roll reaches 120: only degrees can, so the tool does not have to guess.
    assert!(
        !stderr(&result).contains("may be degrees"),
        "{}",
        show(&result)
    );
    // Gripper in % without a calibration: mapped onto its limits, and said.
    assert!(
        stderr(&result).contains("gripper is in 0…100 %"),
        "{}",
        show(&result)
    );
    // The gripper's % onto the built-in limits −10 … 100: −10 + p · 1.1.
    let expected: Vec<Vec<f64>> = large
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r[5] = -10.0 + r[5] * 1.1;
            r
        })
        .collect();
    let (keys, worst, passed) = deviations(&out, None, &expected);
    assert!(
        keys * 5 < expected.len(),
        "{keys} keys for {} frames",
        expected.len()
    );
    for (j, w) in worst.iter().enumerate() {
        assert!(
            *w <= TOLERANCE + TIME_SNAP_SLACK,
            "{}: {w}°",
            SO101_JOINTS[j]
        );
    }
    assert!(passed, "the imported sequence must pass the limit check");

    // Every value of episode 0 is within ±100: the tool cannot tell and says so.
    let out0 = tmp.path().join("zero.json");
    let result = import(
        &dir,
        &out0,
        &["--episode", "0", "--field", "observation.state"],
    );
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    assert!(
        stderr(&result).contains("may be degrees or LeRobot's −100…100"),
        "{}",
        show(&result)
    );

    let check = run_sim(&["check", out.to_str().unwrap()]);
    assert_eq!(check.status.code(), Some(0), "{}", show(&check));

    // Played straight from the dataset on emulated servos: imported in memory, checked, ramped.
    let played = run_sim(&[
        "play",
        "--lerobot",
        dir.to_str().unwrap(),
        "--episode",
        "1",
        "--port",
        "virtual",
        "-q",
        crate::common::TOLERATED_STALL[0],
        crate::common::TOLERATED_STALL[1],
    ]);
    assert_eq!(played.status.code(), Some(0), "{}", show(&played));
    assert!(stderr(&played).contains("samples →"), "{}", show(&played));

    let missing = import(&dir, &tmp.path().join("x.json"), &["--episode", "7"]);
    assert_eq!(missing.status.code(), Some(2), "{}", show(&missing));
    assert!(
        stderr(&missing).contains("episode 7: not in meta/episodes (episodes there: 0, 1, 2)"),
        "{}",
        show(&missing)
    );
    assert!(!tmp.path().join("x.json").exists());
}

/// A calibration with every joint's recorded range 1024 … 3072 (drive_mode 0). Hand-derived:
/// the middle, 2048, is 0°, and keypose's degrees are (raw − 2048) · 360/4096. LeRobot's
/// −100…100 puts 1024 at −100 and 3072 at +100, so v ↦ raw = 2048 + v · 10.24 ↦ 0.9 · v
/// degrees; its gripper 0…100 % puts 0 at 1024: p ↦ (p − 50) · 1.8 degrees.
fn calibration(path: &Path) {
    calibration_of_range(path, 1024, 3072);
}

/// A calibration with every joint's recorded range `min` … `max` (drive_mode 0).
fn calibration_of_range(path: &Path, min: u32, max: u32) {
    let entries: serde_json::Map<String, serde_json::Value> = SO101_JOINTS
        .iter()
        .enumerate()
        .map(|(i, j)| {
            (j.to_string(), json!({"id": i + 1, "drive_mode": 0, "homing_offset": 0, "range_min": min, "range_max": max}))
        })
        .collect();
    std::fs::write(path, serde_json::Value::Object(entries).to_string()).unwrap();
}

#[test]
fn range_normalised_episode_from_fixed_size_lists_needs_and_uses_the_calibration() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    // In degrees: within ±80 so that the calibrated range (±90°) holds them.
    let degrees = motion(6.0, 60.0);
    let normalised: Vec<Vec<f64>> = degrees
        .iter()
        .map(|r| {
            let mut v: Vec<f64> = r.iter().map(|d| d / 0.9).collect();
            v[5] = r[5]; // gripper %: stays
            v
        })
        .collect();
    write_dataset(
        &dir,
        "v3.0",
        &pos_names(&SO101_JOINTS),
        "fixed",
        &[(0, normalised)],
    );
    let cal = tmp.path().join("cal.json");
    calibration(&cal);

    let out = tmp.path().join("range.json");
    let refused = import(&dir, &out, &["--episode", "0", "--units", "range"]);
    assert_eq!(refused.status.code(), Some(2), "{}", show(&refused));
    assert!(
        stderr(&refused).contains("need the arm's calibration"),
        "{}",
        show(&refused)
    );

    let result = import(
        &dir,
        &out,
        &[
            "--episode",
            "0",
            "--units",
            "range",
            "--calibration",
            cal.to_str().unwrap(),
        ],
    );
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    assert!(
        stdout(&result).contains("fixed_size_list"),
        "{}",
        show(&result)
    );
    let expected: Vec<Vec<f64>> = degrees
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r[5] = (r[5] - 50.0) * 1.8;
            r
        })
        .collect();
    let (keys, worst, passed) = deviations(&out, Some(&cal), &expected);
    assert!(
        keys * 5 < expected.len(),
        "{keys} keys for {} frames",
        expected.len()
    );
    for (j, w) in worst.iter().enumerate() {
        assert!(
            *w <= TOLERANCE + TIME_SNAP_SLACK,
            "{}: {w}°",
            SO101_JOINTS[j]
        );
    }
    assert!(passed);
}

#[test]
fn the_gripper_lands_anywhere_in_its_recorded_range_with_a_lerobot_calibration() {
    // The calibration LeRobot wrote for an SO-101 follower: gripper recorded over 1956 … 3128,
    // so LeRobot's RANGE_0_100 puts p % at tick 1956 + p/100 · 1172 and keypose's zero, the
    // middle, at 2542; keypose's degrees are 360/4096 a tick: p ↦ (p/100 · 1172 − 586) · 360/4096.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    // Body joints in degrees, within every recorded range; the gripper 0 % → 100 % → 0 %
    // (passing 10 % both ways), from rest to rest.
    let seconds = 6.0;
    let w = std::f64::consts::TAU / seconds;
    let frames: Vec<Vec<f64>> = motion(seconds, 60.0)
        .into_iter()
        .enumerate()
        .map(|(k, mut row)| {
            row[5] = 100.0 * (1.0 - (w * k as f64 / FPS).cos()) / 2.0;
            row
        })
        .collect();
    write_dataset(
        &dir,
        "v3.0",
        &pos_names(&SO101_JOINTS),
        "list",
        &[(0, frames.clone())],
    );
    let cal = PathBuf::from(repo("tests/data/lerobot_so101_follower.json"));
    let out = tmp.path().join("grip.json");
    let result = import(
        &dir,
        &out,
        &["--episode", "0", "--calibration", cal.to_str().unwrap()],
    );
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    let degrees = |p: f64| (p / 100.0 * 1172.0 - 586.0) * 360.0 / 4096.0;
    let expected: Vec<Vec<f64>> = frames
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r[5] = degrees(r[5]);
            r
        })
        .collect();
    let (_, worst, passed) = deviations(&out, Some(&cal), &expected);
    assert!(
        worst.iter().all(|w| *w <= TOLERANCE + TIME_SNAP_SLACK),
        "largest deviation per joint ({SO101_JOINTS:?}): {worst:?}°"
    );
    assert!(passed, "the imported sequence must pass the limit check");
}

/// LeRobot's bimanual names (`bi_so_follower`: every feature of an arm prefixed `left_` or
/// `right_`) for the SO-101's joints.
fn bimanual_names() -> Vec<String> {
    ["left_", "right_"]
        .iter()
        .flat_map(|side| SO101_JOINTS.iter().map(move |j| format!("{side}{j}.pos")))
        .collect()
}

/// A two-arm cell of SO-101s, each with its own LeRobot calibration file.
fn calibrated_cell(left: &Path, right: &Path) -> Robot {
    let arm = |path: &Path| so101_with(Some(path));
    let at = |y: f64| {
        keypose::pose::RigidTransform::new(glam::DVec3::new(0.0, y, 0.0), glam::DQuat::IDENTITY)
    };
    Robot::cell(vec![
        ("left".into(), arm(left), at(0.2)),
        ("right".into(), arm(right), at(-0.2)),
    ])
    .unwrap()
}

/// The largest deviation per joint of `sequence`'s curve (on `robot`) from `expected` (joint
/// values per frame at k/FPS), its key count, and whether it passes the limit check on `robot`.
fn robot_deviations(
    sequence: &Path,
    robot: &Robot,
    expected: &[Vec<f64>],
) -> (usize, Vec<f64>, bool) {
    let sequence = Sequence::load(sequence).unwrap();
    let trajectory = Trajectory::build(&sequence, robot).unwrap();
    let mut worst = vec![0.0f64; robot.joints.len()];
    for (k, row) in expected.iter().enumerate() {
        let at = trajectory.sample(k as f64 / FPS);
        for (j, (&want, got)) in row.iter().zip(at).enumerate() {
            worst[j] = worst[j].max((want - got).abs());
        }
    }
    let passed = check(&trajectory, robot, robot.control_hz).passed();
    (sequence.keyframes.len(), worst, passed)
}

#[test]
fn bimanual_episode_becomes_a_two_arm_cell_with_each_arms_calibration() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("bi");
    // In degrees: the left arm the usual motion, the right one its other joints negated but
    // panning the same way (a mirror image would swing the two grippers into each other at
    // the default placement, which the check refuses), both grippers the same %.
    let left = motion(6.0, 60.0);
    let right: Vec<Vec<f64>> = left
        .iter()
        .map(|r| {
            let mut m: Vec<f64> = r.iter().map(|d| -d).collect();
            m[0] = r[0];
            m[5] = r[5];
            m
        })
        .collect();
    // Two calibrations, so that a swap shows: the left arm's range 1024 … 3072 (v ↦ 0.9 · v°,
    // gripper p ↦ (p − 50) · 1.8°, see `calibration`); the right arm's 512 … 3584, whose
    // middle is 2048 too: v ↦ raw = 2048 + v · 15.36 ↦ 15.36 · 360/4096 · v = 1.35 · v°,
    // gripper 0 % at 512 = −135° and 100 % at 3584 = +135°: p ↦ (p − 50) · 2.7°.
    let (left_cal, right_cal) = (tmp.path().join("left.json"), tmp.path().join("right.json"));
    calibration_of_range(&left_cal, 1024, 3072);
    calibration_of_range(&right_cal, 512, 3584);
    let normalised: Vec<Vec<f64>> = left
        .iter()
        .zip(&right)
        .map(|(l, r)| {
            let mut row: Vec<f64> = l.iter().map(|d| d / 0.9).collect();
            row[5] = l[5];
            row.extend(r.iter().map(|d| d / 1.35));
            row[11] = r[5];
            row
        })
        .collect();
    // What current LeRobot writes for two SO arms: robot_type bi_so_follower.
    write_dataset_of(
        &dir,
        "bi_so_follower",
        "v3.0",
        &bimanual_names(),
        "list",
        &[(0, normalised)],
    );
    let (l, r) = (
        format!("left={}", left_cal.display()),
        format!("right={}", right_cal.display()),
    );
    let calibrations = ["--calibration", l.as_str(), "--calibration", r.as_str()];
    let out = tmp.path().join("cell.json");

    // bi_so_follower's arms are LeRobot's so_follower, the class of the SO-100 and the SO-101
    // alike, which lerobot-record writes for either: taken as the SO-101, and said.
    let mut args = vec!["--episode", "0", "--units", "range"];
    args.extend_from_slice(&calibrations);
    let taken = import(&dir, &out, &args);
    assert_eq!(taken.status.code(), Some(0), "{}", show(&taken));
    assert!(
        show(&taken).contains(
            "robot_type \"so_follower\" is LeRobot's class of both the SO-100 and the SO-101"
        ) && show(&taken).contains("taken as the SO-101 (so101_follower); give --robot so100"),
        "{}",
        show(&taken)
    );
    let named: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(
        named["robots"]["left"]["robot"], "so101_follower",
        "{named}"
    );
    std::fs::remove_file(&out).unwrap();

    args.extend_from_slice(&["--robot", "so101"]);
    let result = import(&dir, &out, &args);
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    assert!(
        stdout(&result).contains("left range, right range units"),
        "{}",
        show(&result)
    );
    assert!(
        stderr(&result).contains("does not say where its arms stand"),
        "{}",
        show(&result)
    );
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(saved.get("robot").is_none(), "{saved}");
    for (arm, y) in [("left", 0.2), ("right", -0.2)] {
        let spec = &saved["robots"][arm];
        assert_eq!(spec["robot"], "so101", "{saved}");
        assert_eq!(spec["base"]["xyz"], json!([0.0, y, 0.0]), "{saved}");
    }
    assert!(
        saved["keyframes"][0]["joints"]["right/gripper"].is_number(),
        "{saved}"
    );

    let expected: Vec<Vec<f64>> = left
        .iter()
        .zip(&right)
        .map(|(l, r)| {
            let mut row = l.clone();
            row[5] = (l[5] - 50.0) * 1.8;
            row.extend_from_slice(r);
            row[11] = (r[5] - 50.0) * 2.7;
            row
        })
        .collect();
    let robot = calibrated_cell(&left_cal, &right_cal);
    let names: Vec<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    let (keys, worst, passed) = robot_deviations(&out, &robot, &expected);
    println!(
        "bimanual: {keys} keys for {} frames; worst per joint {worst:.3?}",
        expected.len()
    );
    assert!(
        keys * 5 < expected.len(),
        "{keys} keys for {} frames",
        expected.len()
    );
    for (j, w) in worst.iter().enumerate() {
        assert!(*w <= TOLERANCE + TIME_SNAP_SLACK, "{}: {w}°", names[j]);
    }
    assert!(
        passed,
        "the imported cell sequence must pass the limit check"
    );

    // The file names its arms: `check` builds the same cell with the same per-arm calibrations.
    let mut check_args = vec!["check", out.to_str().unwrap()];
    check_args.extend_from_slice(&calibrations);
    let checked = run_sim(&check_args);
    assert_eq!(checked.status.code(), Some(0), "{}", show(&checked));

    // LeRobot calibrates a bimanual robot of id NAME as arms NAME_left and NAME_right, under
    // so_follower: --robot-id NAME finds both.
    let root = tmp.path().join("lerobot_calibration");
    let so = root.join("robots/so_follower");
    std::fs::create_dir_all(&so).unwrap();
    std::fs::copy(&left_cal, so.join("bench_left.json")).unwrap();
    std::fs::copy(&right_cal, so.join("bench_right.json")).unwrap();
    let by_id = tmp.path().join("by_id.json");
    let result = crate::common::keypose()
        .args([
            "import",
            "lerobot",
            dir.to_str().unwrap(),
            "-o",
            by_id.to_str().unwrap(),
        ])
        .args([
            "--episode",
            "0",
            "--units",
            "range",
            "--robot",
            "so101",
            "--robot-id",
            "bench",
        ])
        .env("KEYPOSE_CACHE", python_cache())
        .env("HF_LEROBOT_CALIBRATION", &root)
        .output()
        .unwrap();
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    let (_, worst, _) = robot_deviations(&by_id, &robot, &expected);
    for (j, w) in worst.iter().enumerate() {
        assert!(
            *w <= TOLERANCE + TIME_SNAP_SLACK,
            "{} by id: {w}°",
            names[j]
        );
    }
}

#[test]
fn mixed_arm_names_and_older_datasets_are_refused_with_the_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let two = tmp.path().join("mixed");
    // The left arm's joints prefixed, the right arm's not: no arm for those values.
    let mut names = bimanual_names();
    for name in &mut names[6..] {
        *name = name.trim_start_matches("right_").to_string();
    }
    let rows: Vec<Vec<f64>> = vec![vec![0.0; 12]; 10];
    write_dataset_of(&two, "bi_so_follower", "v3.0", &names, "list", &[(0, rows)]);
    let out = tmp.path().join("mixed.json");
    let result = import(&two, &out, &["--episode", "0", "--robot", "so101"]);
    assert_eq!(result.status.code(), Some(2), "{}", show(&result));
    assert!(
        stderr(&result).contains(
            "info.json: action names values of an arm (left_…, right_…) and values of none \
             (shoulder_pan.pos, shoulder_lift.pos"
        ),
        "{}",
        show(&result)
    );
    assert!(!out.exists());

    // A v2.1 info.json: refused before any parquet file is opened.
    let old = tmp.path().join("old");
    std::fs::create_dir_all(old.join("meta")).unwrap();
    std::fs::write(
        old.join("meta/info.json"),
        r#"{"codebase_version": "v2.1", "fps": 30, "features": {}}"#,
    )
    .unwrap();
    let result = import(&old, &out, &["--episode", "0"]);
    assert_eq!(result.status.code(), Some(2), "{}", show(&result));
    assert!(
        stderr(&result)
            .contains("codebase_version is \"v2.1\"; keypose reads LeRobotDataset v3.0 only"),
        "{}",
        show(&result)
    );
    // A v3.0 info.json with a bad frame rate: the file and the JSON path are named.
    std::fs::write(
        old.join("meta/info.json"),
        r#"{"codebase_version": "v3.0", "fps": -30, "features": {}}"#,
    )
    .unwrap();
    let result = import(&old, &out, &["--episode", "0"]);
    assert_eq!(result.status.code(), Some(2), "{}", show(&result));
    assert!(
        stderr(&result).contains("info.json: $.fps: expected frames per second above 0"),
        "{}",
        show(&result)
    );
}

// Corrupt datasets: each refused with exit 2, naming the dataset, the episode, the frame where
// there is one and the field, with nothing written.

/// A dataset of the SO-101 at `dir`: one episode of `motion(3.0, 60.0)` in degrees (91 frames
/// at 30 fps) in data file 0, with `changes`'s members over these (make_lerobot_dataset.py's
/// docstring says what they may be).
fn write_with(dir: &Path, changes: serde_json::Value) {
    let mut spec = json!({
        "root": dir,
        "version": "v3.0",
        "robot_type": "so101_follower",
        "fps": FPS,
        "names": pos_names(&SO101_JOINTS),
        "column": "list",
        "episodes": [{"file_index": 0, "values": motion(3.0, 60.0)}],
    });
    for (key, value) in changes.as_object().expect("an object of changes") {
        spec[key] = value.clone();
    }
    write_spec(&spec);
}

/// Motion rows (`motion(3.0, 60.0)`) with `joint`'s value replaced at the given frames (JSON
/// numbers, or "nan", "inf").
fn motion_with(joint: usize, frames: &[(usize, serde_json::Value)]) -> serde_json::Value {
    let mut rows = json!(motion(3.0, 60.0));
    for (frame, value) in frames {
        rows[frame][joint] = value.clone();
    }
    rows
}

/// Imports episode `episode` of `dir` with `extra` options; asserts exit 2, that standard error
/// says each of `says`, and that no file was written.
fn assert_refused(dir: &Path, episode: &str, extra: &[&str], says: &[&str]) {
    let out = dir.with_extension("json");
    let mut args = vec!["--episode", episode];
    args.extend_from_slice(extra);
    let result = import(dir, &out, &args);
    assert_eq!(result.status.code(), Some(2), "{}", show(&result));
    for said in says {
        assert!(
            stderr(&result).contains(said),
            "{said:?}: {}",
            show(&result)
        );
    }
    assert!(!out.exists(), "{} was written", out.display());
}

/// "DIR: episode N, data/chunk-000/file-000.parquet, frame K (index K)": how a frame of the
/// first data file is named.
fn frame_of(dir: &Path, episode: u64, frame: u64, index: u64) -> String {
    format!(
        "{}: episode {episode}, data/chunk-000/file-000.parquet, frame {frame} (index {index})",
        dir.display()
    )
}

#[test]
fn two_values_naming_one_joint_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    // The lift's column named as the pan (with and without LeRobot's .pos): before, the lift's
    // motion drove the pan.
    for (case, second) in [("same", "shoulder_pan.pos"), ("bare", "shoulder_pan")] {
        let dir = tmp.path().join(case);
        let mut names = pos_names(&SO101_JOINTS);
        names[1] = second.to_string();
        write_with(&dir, json!({ "names": names }));
        let says = format!(
            "{}: action value 1 ({second:?}) names joint shoulder_pan, as value 0 \
             (\"shoulder_pan.pos\") does; expected each joint named once",
            dir.join("meta/info.json").display()
        );
        assert_refused(&dir, "0", &[], &[&says]);
    }
}

#[test]
fn a_corrupt_frame_is_refused_by_frame_and_value_and_clipped_only_when_asked() {
    let tmp = tempfile::tempdir().unwrap();
    let limits = Robot::builtin("so101").unwrap().joints[3].limits;
    assert_eq!(
        (limits.min, limits.max),
        (-95.0, 95.0),
        "wrist_flex's limits"
    );
    // 1e30 in a float32 column reads back as 1.0000000150474662e30.
    let huge = tmp.path().join("huge");
    write_with(
        &huge,
        json!({"episodes": [{"file_index": 0, "values": motion_with(3, &[(40, json!(1e30))])}]}),
    );
    let frame = frame_of(&huge, 0, 40, 40);
    assert_refused(
        &huge,
        "0",
        &[],
        &[&format!(
            "{frame}: action wrist_flex.pos is 1.0000000150474662e30 deg as joint wrist_flex, \
             outside its limits -95 … 95 deg by more than the tolerance (1 deg); give --clip"
        )],
    );
    for (case, value, shown) in [("nan", "nan", "NaN"), ("inf", "inf", "inf")] {
        let dir = tmp.path().join(case);
        write_with(
            &dir,
            json!({"episodes": [{"file_index": 0, "values": motion_with(3, &[(41, json!(value))])}]}),
        );
        let says = format!(
            "{}: action wrist_flex.pos is {shown}; expected a finite number",
            frame_of(&dir, 0, 41, 41)
        );
        // Clipping does not make a number of what is none.
        assert_refused(&dir, "0", &["--clip"], &[&says]);
    }

    // Three frames past the upper limit: refused at the first, or with --clip clipped and
    // reported — 3 frames, the worst 160° at frame 41.
    let past = tmp.path().join("past");
    let bad = [(40, json!(150.0)), (41, json!(160.0)), (42, json!(155.0))];
    write_with(
        &past,
        json!({"episodes": [{"file_index": 0, "values": motion_with(3, &bad)}]}),
    );
    assert_refused(
        &past,
        "0",
        &[],
        &[&format!(
            "{}: action wrist_flex.pos is 150 deg",
            frame_of(&past, 0, 40, 40)
        )],
    );
    let out = tmp.path().join("clipped.json");
    let result = import(&past, &out, &["--episode", "0", "--clip"]);
    assert!(result.status.code() == Some(0), "{}", show(&result));
    assert!(
        stderr(&result).contains(
            "clipped wrist_flex: 3 frame(s) outside its limits -95 … 95 deg, the worst 160 deg \
             (frame 41)"
        ),
        "{}",
        show(&result)
    );
    // The keys stay within the limits, and reach the limit where the frames were clipped to
    // it: a monotone curve keeps between its keys, and it passes within the tolerance (1°) of
    // the clipped frames at 95°.
    let saved = Sequence::load(&out).unwrap();
    let wrist: Vec<f64> = saved
        .keyframes
        .iter()
        .filter_map(|key| match key.value("wrist_flex") {
            Some(KeyValue::Joint(v)) => Some(*v),
            _ => None,
        })
        .collect();
    assert!(
        wrist.iter().all(|v| (limits.min..=limits.max).contains(v)),
        "a key outside wrist_flex's limits: {wrist:?}"
    );
    let highest = wrist.iter().fold(f64::MIN, |a, &b| a.max(b));
    assert!(highest >= limits.max - TOLERANCE, "{wrist:?}");
}

#[test]
fn timestamps_that_do_not_rise_or_are_no_numbers_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let rows = motion(3.0, 60.0);
    let at_fps: Vec<serde_json::Value> = (0..rows.len()).map(|k| json!(k as f64 / FPS)).collect();
    let backwards: Vec<serde_json::Value> = at_fps.iter().rev().cloned().collect();
    let mut repeated = at_fps.clone();
    repeated[50] = repeated[49].clone();
    let mut nan = at_fps.clone();
    nan[10] = json!("nan");
    for (case, timestamps, frame, says) in [
        (
            "backwards",
            backwards,
            1,
            "does not come after the previous frame's 3 s",
        ),
        (
            "repeated",
            repeated,
            50,
            "does not come after the previous frame's",
        ),
        (
            "nan",
            nan,
            10,
            "timestamp is NaN; expected a finite number of seconds",
        ),
    ] {
        let dir = tmp.path().join(case);
        write_with(
            &dir,
            json!({"episodes": [{"file_index": 0, "values": rows, "timestamps": timestamps}]}),
        );
        let at = format!("{}: ", frame_of(&dir, 0, frame, frame));
        assert_refused(&dir, "0", &[], &[&at, says]);
    }
}

#[test]
fn an_fps_the_timestamps_contradict_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    let rows = motion(3.0, 60.0);
    // info.json says 30 fps; the timestamps step by 0.1 s (10 fps).
    let tenth: Vec<f64> = (0..rows.len()).map(|k| k as f64 / 10.0).collect();
    write_with(
        &dir,
        json!({"episodes": [{"file_index": 0, "values": rows, "timestamps": tenth}]}),
    );
    let says = format!(
        "{}: episode 0, data/chunk-000/file-000.parquet: the timestamps step by 0.1 s (the \
         median step), but meta/info.json's fps 30 means 0.033333 s; expected within 5 % of it",
        dir.display()
    );
    assert_refused(&dir, "0", &[], &[&says]);
}

#[test]
fn data_paths_leading_out_of_the_dataset_are_not_followed() {
    let tmp = tempfile::tempdir().unwrap();
    // A sound dataset beside the one imported: every path below reaches its data file.
    let outside = tmp.path().join("outside");
    write_with(&outside, json!({}));
    let template = "chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
    let absolute = format!("{}/data/{template}", outside.display());
    let cases = [
        (
            "absolute",
            absolute,
            "is an absolute path; expected a path inside the dataset folder",
        ),
        (
            "dotdot",
            format!("../outside/data/{template}"),
            "leads out of the dataset folder through \"..\"",
        ),
        (
            "linked",
            format!("data/link/{template}"),
            "(through a symbolic link), outside the dataset folder",
        ),
    ];
    for (case, data_path, says) in cases {
        let dir = tmp.path().join(case);
        write_with(&dir, json!({"info": {"data_path": data_path}}));
        std::os::unix::fs::symlink(outside.join("data"), dir.join("data/link")).unwrap();
        let at = format!(
            "{}: $.data_path {data_path:?} for episode 0: ",
            dir.join("meta/info.json").display()
        );
        assert_refused(&dir, "0", &[], &[&at, says]);
    }
    // meta/episodes through a link out of the dataset: not read either.
    let dir = tmp.path().join("episodes_linked");
    write_with(&dir, json!({}));
    let file = dir.join("meta/episodes/chunk-000/file-000.parquet");
    std::fs::remove_file(&file).unwrap();
    std::os::unix::fs::symlink(
        outside.join("meta/episodes/chunk-000/file-000.parquet"),
        &file,
    )
    .unwrap();
    let says = format!(
        "{}: \"meta/episodes/chunk-000/file-000.parquet\" resolves to",
        dir.display()
    );
    assert_refused(&dir, "0", &[], &[&says]);
}

#[test]
fn episode_bounds_that_take_a_neighbours_rows_or_leave_its_own_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    // Two episodes of 91 frames in one data file: episode 0 is rows 0 … 90, episode 1 91 … 181.
    let episodes = |meta: serde_json::Value| {
        json!([
            {"file_index": 0, "values": motion(3.0, 60.0), "meta": meta},
            {"file_index": 0, "values": motion(3.0, 30.0)},
        ])
    };
    let into = tmp.path().join("into");
    write_with(
        &into,
        json!({"episodes": episodes(json!({"dataset_to_index": 96, "length": 96}))}),
    );
    let says = format!(
        "{}: episode_index is 1, expected 0: meta/episodes' dataset_from_index … dataset_to_index \
         reach into another episode's rows",
        frame_of(&into, 0, 91, 91)
    );
    assert_refused(&into, "0", &[], &[&says]);

    let short = tmp.path().join("short");
    write_with(
        &short,
        json!({"episodes": episodes(json!({"dataset_to_index": 86, "length": 86}))}),
    );
    let says = format!(
        "{}: episode 0, data/chunk-000/file-000.parquet: the data file holds 91 rows of \
         episode_index 0, but meta/episodes gives the episode 86 (dataset_from_index 0 … \
         dataset_to_index 86)",
        short.display()
    );
    assert_refused(&short, "0", &[], &[&says]);
}

#[test]
fn an_empty_episode_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write_with(
        &dir,
        json!({"episodes": [
            {"file_index": 0, "values": motion(3.0, 60.0)},
            {"file_index": 0, "values": []},
        ]}),
    );
    let says = format!(
        "{}: episode 1: meta/episodes gives dataset_from_index 91 and dataset_to_index 91: no frames",
        dir.display()
    );
    assert_refused(&dir, "1", &[], &[&says]);
}

#[test]
fn an_episode_beyond_the_frame_cap_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    // One frame more than keypose imports (an hour at 30 fps): before, 2 M frames took 1.8 GB
    // and more than 10 minutes.
    let frames = keypose::interop::lerobot::MAX_FRAMES + 1;
    write_with(
        &dir,
        json!({"episodes": [{"file_index": 0, "values": {"row": [0.0, 0.0, 0.0, 0.0, 0.0, 50.0], "count": frames}}]}),
    );
    let says = format!(
        "{}: episode 0: 108001 frames, 3600.0 s at fps 30 (dataset_from_index 0 … \
         dataset_to_index 108001); keypose imports episodes of at most 108000 frames and 3600 s",
        dir.display()
    );
    assert_refused(&dir, "0", &[], &[&says]);
}

#[test]
fn feature_names_in_lerobots_older_motors_form_are_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    // "names": {"motors": [...]}, the motors' bare names, as LeRobot wrote them before `.pos`;
    // over 6 s, a motion the fit need not retime (see `motion`).
    let rows = motion(6.0, 60.0);
    write_with(
        &dir,
        json!({"names": {"motors": SO101_JOINTS}, "episodes": [{"file_index": 0, "values": rows}]}),
    );
    let out = tmp.path().join("motors.json");
    let result = import(&dir, &out, &["--episode", "0"]);
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    // The gripper's % onto the built-in limits −10 … 100: −10 + p · 1.1.
    let expected: Vec<Vec<f64>> = rows
        .into_iter()
        .map(|mut r| {
            r[5] = -10.0 + r[5] * 1.1;
            r
        })
        .collect();
    let (_, worst, passed) = deviations(&out, None, &expected);
    for (j, w) in worst.iter().enumerate() {
        assert!(
            *w <= TOLERANCE + TIME_SNAP_SLACK,
            "{}: {w}°",
            SO101_JOINTS[j]
        );
    }
    assert!(passed);
}

/// A dataset `ds` of one SO-101 episode of 2 s in a temporary folder (kept while it lives).
fn one_episode_dataset() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ds");
    write_dataset(
        &dir,
        "v3.0",
        &pos_names(&SO101_JOINTS),
        "list",
        &[(0, motion(2.0, 30.0))],
    );
    (tmp, dir)
}

/// `-o` inside the dataset being read (its own metadata here) is refused, and the dataset's
/// file is left as it was.
#[test]
fn an_output_inside_the_dataset_is_refused_and_the_dataset_kept() {
    let (_tmp, dir) = one_episode_dataset();
    let info = dir.join("meta").join("info.json");
    let before = std::fs::read(&info).unwrap();
    let out = import(&dir, &info, &["--episode", "0"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        stderr(&out).contains("inside the dataset"),
        "{}",
        show(&out)
    );
    assert_eq!(std::fs::read(&info).unwrap(), before);
    // Spelled another way round, the same.
    let sideways = dir.join("..").join("ds").join("wave.json");
    let out = import(&dir, &sideways, &["--episode", "0"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(!dir.join("wave.json").exists());
}

/// A FIFO where the episode's parquet file should be is bad input at once (exit 2), not a
/// reader waiting on it until its timeout.
#[cfg(unix)]
#[test]
fn a_fifo_as_the_parquet_file_is_refused_at_once() {
    let (tmp, dir) = one_episode_dataset();
    let data = dir.join("data").join("chunk-000").join("file-000.parquet");
    std::fs::remove_file(&data).unwrap();
    let made = Command::new("mkfifo").arg(&data).status().unwrap();
    assert!(made.success());
    let out = import(&dir, &tmp.path().join("wave.json"), &["--episode", "0"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    // Exit 2 naming the FIFO, where the reader waiting on it timed out with exit 3.
    assert!(
        stderr(&out).contains("is a FIFO (named pipe); expected a regular file"),
        "{}",
        show(&out)
    );
}
