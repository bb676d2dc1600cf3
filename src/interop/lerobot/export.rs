//! A sequence as one episode of a LeRobotDataset v3.0 (`keypose export lerobot`, docs/interop.md
//! §1.7): the trajectory sampled at the dataset's frame rate, in LeRobot's units, laid out as
//! LeRobot's own `LeRobotDataset.create` … `save_episode` … `finalize` lays out one episode
//! without cameras.
//!
//! Everything is decided here: frames, units, names, statistics and metadata. The parquet
//! files are written by `sim/dataset_writer.py` (pyarrow, as the import reads them), into a
//! staging folder beside the output that becomes the output only once complete.

use super::units::{conversion, BodyUnits};
use super::LeRobotError;
use crate::plan::Trajectory;
use crate::python::Harness;
use crate::robot::{split_joint_name, Robot};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The writer script (pyarrow) in keypose's Python environment.
const SCRIPT: &str = "dataset_writer.py";
/// Writing one episode's files takes well under a second; a minute is generous.
const WRITE_TIMEOUT: Duration = Duration::from_secs(60);
/// LeRobot's `CODEBASE_VERSION`.
const CODEBASE_VERSION: &str = "v3.0";
/// LeRobot's data file path template (`DEFAULT_DATA_PATH`).
const DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
/// The quantiles LeRobot's statistics carry (`compute_stats.py`), as fractions.
const QUANTILES: [(&str, f64); 5] = [
    ("q01", 0.01),
    ("q10", 0.10),
    ("q50", 0.50),
    ("q90", 0.90),
    ("q99", 0.99),
];

/// What to export and how.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// Frames per second (LeRobot's `fps`, an integer).
    pub fps: u32,
    /// The episode's task, in words (LeRobot's `single_task`).
    pub task: String,
    /// LeRobot's robot type written into `meta/info.json` (`so101_follower`).
    pub robot_type: String,
    /// The units of the body joints (the gripper is always 0…100).
    pub units: BodyUnits,
}

/// What was written.
#[derive(Debug, Clone)]
pub struct Exported {
    /// Frames in the episode.
    pub frames: usize,
    /// The feature names of `action` and `observation.state`, in order.
    pub names: Vec<String>,
    /// Notices (a gripper without a calibration).
    pub notices: Vec<String>,
}

/// The dataset's name of a joint's position: `shoulder_pan.pos`; on a cell, LeRobot's bimanual
/// form `left_shoulder_pan.pos`.
pub fn feature_name(joint: &str) -> String {
    match split_joint_name(joint) {
        Some((arm, rest)) => format!("{arm}_{rest}.pos"),
        None => format!("{joint}.pos"),
    }
}

/// LeRobot's robot type of the follower arm keypose's built-in `robot` is (`so101` →
/// `so101_follower`); a cell of such arms alike is LeRobot's bimanual `bi_…` type. `None` for a
/// robot LeRobot has no type for.
pub fn follower_type(robot: &Robot) -> Option<String> {
    let of = |name: &str| {
        crate::robot::BUILTINS
            .iter()
            .find(|b| b.name == name)?
            .lerobot
            .iter()
            .find(|t| t.role == crate::robot::LeRobotRole::Follower)
            .map(|t| t.name.to_string())
    };
    if !robot.is_cell() {
        return of(&robot.name);
    }
    let types: Vec<Option<String>> = robot.arms.iter().map(|a| of(&a.robot.name)).collect();
    match types.first() {
        Some(Some(first)) if types.iter().all(|t| t.as_ref() == Some(first)) => {
            Some(format!("bi_{first}"))
        }
        _ => None,
    }
}

/// The episode's frames: the pose at each `k / fps` from the trajectory's start to its end, in
/// the joints' units.
pub fn frames(trajectory: &Trajectory, robot: &Robot, fps: u32) -> Vec<Vec<f64>> {
    let mut sampler = trajectory.sampler();
    let mut pose = vec![0.0; robot.joints.len()];
    trajectory
        .grid(f64::from(fps))
        .map(|t| {
            sampler.sample_into(t, &mut pose);
            pose.clone()
        })
        .collect()
}

/// A trajectory as LeRobot's frames: the feature names and, per frame, the values in LeRobot's
/// units (float32 precision, as LeRobot keeps them).
#[derive(Debug, Clone)]
pub struct LeRobotFrames {
    /// `shoulder_pan.pos` …, in joint order.
    pub names: Vec<String>,
    /// One row per frame, `k / fps` from the trajectory's start to its end.
    pub rows: Vec<Vec<f64>>,
    /// Notices (a gripper without a calibration).
    pub notices: Vec<String>,
}

/// `trajectory` at `fps` in LeRobot's units: the body joints in `units`, the gripper in 0…100 %
/// of its calibrated range (`conversion`, inverted).
pub fn lerobot_frames(
    trajectory: &Trajectory,
    robot: &Robot,
    fps: u32,
    units: BodyUnits,
) -> Result<LeRobotFrames, LeRobotError> {
    let mut notices = Vec::new();
    let mut conversions = Vec::with_capacity(robot.joints.len());
    for joint in &robot.joints {
        let (c, notice) = conversion(joint, units)?;
        conversions.push(c);
        notices.extend(notice);
    }
    let rows = frames(trajectory, robot, fps)
        .iter()
        .map(|pose| {
            pose.iter()
                .zip(&conversions)
                .map(|(&v, c)| f64::from(c.invert(v) as f32))
                .collect()
        })
        .collect();
    Ok(LeRobotFrames {
        names: robot.joints.iter().map(|j| feature_name(&j.name)).collect(),
        rows,
        notices,
    })
}

/// Writes `trajectory` as episode 0 of a new dataset at `dir` (which must not exist).
pub fn export(
    trajectory: &Trajectory,
    robot: &Robot,
    options: &ExportOptions,
    dir: &Path,
) -> Result<Exported, LeRobotError> {
    if dir.exists() {
        return Err(LeRobotError::Output {
            dir: dir.display().to_string(),
            problem: "exists already; LeRobot writes a dataset into a new folder: choose one that does not exist".into(),
            source: None,
        });
    }
    let LeRobotFrames {
        names,
        rows: action,
        notices,
    } = lerobot_frames(trajectory, robot, options.fps, options.units)?;
    // The arm is measured where the previous frame's action sent it (a follower that keeps up).
    let state: Vec<Vec<f64>> = std::iter::once(action[0].clone())
        .chain(action[..action.len() - 1].iter().cloned())
        .collect();
    let n = action.len();
    let timestamps: Vec<f64> = (0..n)
        .map(|k| f64::from((k as f64 / f64::from(options.fps)) as f32))
        .collect();
    let indices: Vec<f64> = (0..n).map(|k| k as f64).collect();
    let zeros = vec![0.0; n];
    let features = features(&names);
    let columns: [(&str, Vec<Vec<f64>>, bool); 7] = [
        ("action", action.clone(), false),
        ("observation.state", state.clone(), false),
        ("timestamp", single(&timestamps), false),
        ("frame_index", single(&indices), true),
        ("episode_index", single(&zeros), true),
        ("index", single(&indices), true),
        ("task_index", single(&zeros), true),
    ];
    let mut stats = Map::new();
    for (name, rows, integer) in &columns {
        stats.insert(name.to_string(), statistics(rows, *integer));
    }
    let info = info(options, &features, n);
    let staging = staging_dir(dir)?;
    let written = write_files(
        &staging,
        options,
        &names,
        &action,
        &state,
        &timestamps,
        &stats,
    )
    .and_then(|()| {
        write_json(&staging.join("meta/info.json"), &info)?;
        write_json(
            &staging.join("meta/stats.json"),
            &Value::Object(stats.clone()),
        )?;
        std::fs::rename(&staging, dir).map_err(|e| output_error(dir, "cannot be created", e))
    });
    if written.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    written?;
    Ok(Exported {
        frames: n,
        names,
        notices,
    })
}

fn single(values: &[f64]) -> Vec<Vec<f64>> {
    values.iter().map(|&v| vec![v]).collect()
}

/// `features` of meta/info.json: the two vectors and LeRobot's default per-frame columns.
fn features(names: &[String]) -> Value {
    let vector = json!({"dtype": "float32", "shape": [names.len()], "names": names});
    let scalar = |dtype: &str| json!({"dtype": dtype, "shape": [1], "names": null});
    json!({
        "action": vector,
        "observation.state": vector,
        "timestamp": scalar("float32"),
        "frame_index": scalar("int64"),
        "episode_index": scalar("int64"),
        "index": scalar("int64"),
        "task_index": scalar("int64"),
    })
}

/// meta/info.json as LeRobot's `create_empty_dataset_info`, filled in for one episode.
fn info(options: &ExportOptions, features: &Value, frames: usize) -> Value {
    json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": options.robot_type,
        "total_episodes": 1,
        "total_frames": frames,
        "total_tasks": 1,
        "chunks_size": 1000,
        "data_files_size_in_mb": 100,
        "video_files_size_in_mb": 200,
        "fps": options.fps,
        "splits": {"train": "0:1"},
        "data_path": DATA_PATH,
        "video_path": null,
        "features": features,
        // keypose's own word on the body joints' units, which the values alone cannot always
        // tell (−100…100 may be either): its import reads it back. LeRobot keeps info.json as
        // a dict and ignores what it does not know.
        "keypose": {"units": options.units.name()},
    })
}

/// LeRobot's statistics of one feature over the episode's frames (`compute_stats.py`): per
/// value min, max, mean, population standard deviation, the count of frames and quantiles
/// (linear between the sorted samples, as numpy's default). An integer column keeps its
/// minimum and maximum as integers, as LeRobot's do.
pub fn statistics(rows: &[Vec<f64>], integer: bool) -> Value {
    let width = rows.first().map_or(0, Vec::len);
    let n = rows.len() as f64;
    let mut out = Map::new();
    let columns: Vec<Vec<f64>> = (0..width)
        .map(|c| {
            let mut column: Vec<f64> = rows.iter().map(|r| r[c]).collect();
            column.sort_by(f64::total_cmp);
            column
        })
        .collect();
    let number = |v: f64| match integer {
        true => json!(v as i64),
        false => json!(v),
    };
    let per = |f: &dyn Fn(&[f64]) -> Value| columns.iter().map(|c| f(c)).collect::<Vec<_>>();
    out.insert("min".into(), json!(per(&|c| number(c[0]))));
    out.insert("max".into(), json!(per(&|c| number(c[c.len() - 1]))));
    let mean = |c: &[f64]| c.iter().sum::<f64>() / n;
    out.insert("mean".into(), json!(per(&|c| json!(mean(c)))));
    let std = |c: &[f64]| {
        let m = mean(c);
        (c.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt()
    };
    out.insert("std".into(), json!(per(&|c| json!(std(c)))));
    out.insert("count".into(), json!([rows.len()]));
    for (name, q) in QUANTILES {
        out.insert(name.into(), json!(per(&|c| json!(quantile(c, q)))));
    }
    Value::Object(out)
}

/// The `q` quantile of sorted `values`, linear between neighbours (numpy's default).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let position = q * (sorted.len() - 1) as f64;
    let below = position.floor() as usize;
    let above = (below + 1).min(sorted.len() - 1);
    let share = position - below as f64;
    sorted[below] + (sorted[above] - sorted[below]) * share
}

/// A fresh folder beside `dir` to write into, renamed to `dir` once complete.
fn staging_dir(dir: &Path) -> Result<PathBuf, LeRobotError> {
    let name = dir
        .file_name()
        .map_or("dataset".into(), |n| n.to_string_lossy().into_owned());
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let staging = parent.join(format!(".{name}.keypose-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&staging);
    std::fs::create_dir_all(staging.join("meta"))
        .map_err(|e| output_error(dir, "cannot be written beside", e))?;
    Ok(staging)
}

/// The parquet files, through the writer script.
#[allow(clippy::too_many_arguments)]
fn write_files(
    root: &Path,
    options: &ExportOptions,
    names: &[String],
    action: &[Vec<f64>],
    state: &[Vec<f64>],
    timestamps: &[f64],
    stats: &Map<String, Value>,
) -> Result<(), LeRobotError> {
    let n = action.len();
    let mut episode = Map::new();
    episode.insert("episode_index".into(), json!(0));
    episode.insert("tasks".into(), json!([options.task]));
    episode.insert("length".into(), json!(n));
    episode.insert("data/chunk_index".into(), json!(0));
    episode.insert("data/file_index".into(), json!(0));
    episode.insert("dataset_from_index".into(), json!(0));
    episode.insert("dataset_to_index".into(), json!(n));
    for (feature, values) in stats {
        for (stat, value) in values.as_object().into_iter().flatten() {
            episode.insert(format!("stats/{feature}/{stat}"), value.clone());
        }
    }
    episode.insert("meta/episodes/chunk_index".into(), json!(0));
    episode.insert("meta/episodes/file_index".into(), json!(0));
    let request = json!({
        "op": "write",
        "root": root.display().to_string(),
        "width": names.len(),
        "action": action,
        "observation.state": state,
        "timestamp": timestamps,
        "episode": episode,
        "task": options.task,
    });
    let mut harness = Harness::start(SCRIPT).map_err(LeRobotError::Writer)?;
    harness
        .request_within(&request, WRITE_TIMEOUT)
        .map_err(LeRobotError::Writer)?;
    Ok(())
}

fn write_json(path: &Path, value: &Value) -> Result<(), LeRobotError> {
    let text = serde_json::to_string_pretty(value).expect("JSON values serialise");
    std::fs::write(path, text + "\n").map_err(|e| output_error(path, "cannot be written", e))
}

fn output_error(path: &Path, problem: &str, source: std::io::Error) -> LeRobotError {
    LeRobotError::Output {
        dir: path.display().to_string(),
        problem: problem.into(),
        source: Some(source),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy: np.quantile([0, 1, 2, 3, 4], [.01, .1, .5, .9, .99]) = [0.04, 0.4, 2, 3.6, 3.96];
    /// np.std([0, 1, 2, 3, 4]) = √2.
    #[test]
    fn statistics_are_numpys() {
        let rows: Vec<Vec<f64>> = (0..5).map(|k| vec![k as f64, 2.0 * k as f64]).collect();
        let stats = statistics(&rows, false);
        assert_eq!(stats["min"], json!([0.0, 0.0]));
        assert_eq!(stats["max"], json!([4.0, 8.0]));
        assert_eq!(stats["mean"], json!([2.0, 4.0]));
        assert!((stats["std"][0].as_f64().unwrap() - 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(stats["count"], json!([5]));
        for (name, want) in [
            ("q01", 0.04),
            ("q10", 0.4),
            ("q50", 2.0),
            ("q90", 3.6),
            ("q99", 3.96),
        ] {
            assert!(
                (stats[name][0].as_f64().unwrap() - want).abs() < 1e-12,
                "{name}"
            );
        }
        assert_eq!(statistics(&rows, true)["max"], json!([4, 8]));
    }

    /// A gripper of limits −10 … 100 without a calibration: 45 is (45 + 10) / 110 of the way,
    /// 50 %; a body joint in degrees is as it is.
    #[test]
    fn joint_values_become_lerobots_by_hand() {
        use super::super::units::Conversion;
        use crate::robot::CalibratedRange;
        let gripper = Conversion::Range {
            low: 0.0,
            high: 100.0,
            ends: CalibratedRange {
                at_0: -10.0,
                at_100: 100.0,
            },
        };
        assert!((gripper.invert(45.0) - 50.0).abs() < 1e-12);
        assert_eq!(Conversion::Identity.invert(12.5), 12.5);
    }

    #[test]
    fn names_are_lerobots() {
        assert_eq!(feature_name("gripper"), "gripper.pos");
        assert_eq!(feature_name("left/gripper"), "left_gripper.pos");
    }
}
