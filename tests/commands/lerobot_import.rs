//! `keypose import lerobot` against LeRobotDataset v3.0 folders that the tests write with
//! pyarrow (tests/data/make_lerobot_dataset.py, in keypose's own Python environment) from known
//! motions: the frames are the oracle. Without python3 3.11+ or PyPI the environment cannot be
//! built and these tests fail.

use crate::common::{python_cache, repo, run_sim, show, stderr, stdout, SO101_JOINTS};
use keypose::plan::{check, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
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
    let spec = json!({
        "root": root,
        "version": version,
        "robot_type": robot_type,
        "fps": FPS,
        "names": names,
        "column": column,
        "episodes": episodes.iter().map(|(file, values)| json!({"file_index": file, "values": values})).collect::<Vec<_>>(),
    });
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
        stderr(&missing).contains("episode 7 is not in meta/episodes"),
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
    // In degrees: the left arm the usual motion, the right one its mirror image (body joints
    // negated), both grippers the same %.
    let left = motion(6.0, 60.0);
    let right: Vec<Vec<f64>> = left
        .iter()
        .map(|r| {
            let mut m: Vec<f64> = r.iter().map(|d| -d).collect();
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
    // alike: which one is asked for, not guessed.
    let mut args = vec!["--episode", "0", "--units", "range"];
    args.extend_from_slice(&calibrations);
    let refused = import(&dir, &out, &args);
    assert_eq!(refused.status.code(), Some(2), "{}", show(&refused));
    assert!(
        stderr(&refused).contains("give --robot so101 or --robot so100"),
        "{}",
        show(&refused)
    );
    assert!(!out.exists());

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
