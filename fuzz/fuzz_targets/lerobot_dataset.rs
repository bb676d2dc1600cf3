//! The LeRobot dataset reader's Rust side: meta/info.json text, then (after a 0 byte) choices
//! that build what pyarrow would return for an episode — its meta/episodes rows and its data
//! rows (indices, episode indices, timestamps, list lengths, values) — sound by default (every
//! choice byte 0: a smooth 20-frame episode) and corrupted where the bytes say: indices
//! repeated, skipped or not whole numbers, another episode's rows, rows too wide or missing,
//! NaN, infinite, huge or out-of-limit values, timestamps that repeat, fall, jump or are not
//! numbers, spans empty, reversed, listed twice or beyond the cap. They go through the same
//! pure functions `keypose import lerobot` runs once pyarrow has answered
//! (src/interop/lerobot/: names, data path, span, frames, units, limits, timing, fitting).
//! Python cannot run at the fuzzer's speed; the pyarrow side is covered by
//! tests/commands/lerobot_import.rs.
//!
//! Property: no panic; every error is bad input (exit 2), never the reader's or keypose's own;
//! an import that succeeds has one frame per index of its span and keys inside every joint's
//! limits.
#![no_main]

use keypose::curve::Interp;
use keypose::interop::lerobot::{
    dataset_arms, fit, layout, map_names, BodyUnits, DatasetInfo, Episode, EpisodeSpan, Frames,
    ImportOptions, LeRobotError, Place, MAX_FRAMES,
};
use keypose::record::KeyframeOptions;
use keypose::robot::Robot;
use keypose::sequence::KeyValue;
use keypose_fuzz::{builtin_named, Choices};
use libfuzzer_sys::fuzz_target;
use serde_json::{json, Value};
use std::sync::OnceLock;

/// Frames of an episode at most here: longer ones are valid but slow the fitting.
const MOST_FRAMES: u64 = 60;

fuzz_target!(|data: &[u8]| {
    let split = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    let Ok(text) = std::str::from_utf8(&data[..split]) else {
        return;
    };
    let mut choices = Choices::new(data.get(split + 1..).unwrap_or_default());
    if let Err(error) = import(text, &mut choices) {
        assert!(error.is_bad_input(), "not an error of the input: {error}");
    }
});

fn import(text: &str, c: &mut Choices) -> Result<(), LeRobotError> {
    let info = DatasetInfo::from_text("meta/info.json", text)?;
    let field = c.pick(&["action", "observation.state"]);
    let names = info.names(field)?;
    let bimanual = !dataset_arms(&info, field, &names)?.is_empty();
    let robot = robot(bimanual, c.byte());
    let columns = map_names(&info, field, &names, robot)?;
    let episode = u64::from(c.byte() % 3);
    let place = Place::episode("dataset", episode);
    let span = EpisodeSpan::from_reply(&place, info.fps, &meta_reply(c, episode))?;
    let place = place.in_file(&layout::data_path(&info, &span)?);
    let reply = rows_reply(c, &span, names.len(), info.fps);
    let frames = Frames::from_reply(&place, &span, field, &names, &reply)?;
    let options = ImportOptions {
        episode,
        field: field.to_string(),
        units: c.pick(&[None, Some(BodyUnits::Degrees), Some(BodyUnits::Range)]),
        clip: c.byte() & 1 == 1,
        keyframes: KeyframeOptions {
            interpolation: c.pick(&[Interp::Monotone, Interp::Cubic, Interp::Linear]),
            tolerance_deg: 1.0,
            tolerance_m: 0.001,
            check_rate_hz: robot.control_hz,
        },
    };
    let episode = Episode {
        dataset: "dataset".into(),
        info: &info,
        place,
        span,
        names: &names,
        columns: &columns,
        frames,
    };
    let imported = fit(&episode, robot, &options)?;
    assert_eq!(imported.frames as u64, span.frames());
    for key in &imported.keyframes.sequence.keyframes {
        for (name, value) in &key.values {
            let joint = &robot.joints[robot.joint_index(name).expect("a joint of the robot")];
            if let KeyValue::Joint(v) = value {
                assert!(
                    joint.limits.contains(*v),
                    "key value {v} of {name} outside {:?}",
                    joint.limits
                );
            }
        }
    }
    Ok(())
}

/// The SO-101 (calibrated with the repository's LeRobot calibration, or not) or the SO-100 for
/// one arm; two calibrated SO-101s for a bimanual dataset.
fn robot(bimanual: bool, choice: u8) -> &'static Robot {
    static ROBOTS: OnceLock<[Robot; 2]> = OnceLock::new();
    let [calibrated, cell] = ROBOTS.get_or_init(|| {
        let mut so101 = Robot::builtin("so101").expect("the SO-101");
        keypose::robot::import_lerobot_calibration(
            &mut so101,
            "calibration.json",
            include_str!("../../tests/data/lerobot_so101_follower.json"),
        )
        .expect("the repository's calibration");
        let at = |y| {
            keypose::pose::RigidTransform::new(glam::DVec3::new(0.0, y, 0.0), glam::DQuat::IDENTITY)
        };
        let cell = Robot::cell(vec![
            ("left".into(), so101.clone(), at(0.2)),
            ("right".into(), so101.clone(), at(-0.2)),
        ])
        .expect("a cell of two SO-101s");
        [so101, cell]
    });
    if bimanual {
        return cell;
    }
    match choice % 3 {
        0 => builtin_named("so101").expect("the SO-101"),
        1 => calibrated,
        _ => builtin_named("so100").expect("the SO-100"),
    }
}

/// The reader's answer to "episode": episode `episode` listed once over `frames` frames from
/// global index 100, or one of the ways a meta/episodes row goes wrong.
fn meta_reply(c: &mut Choices, episode: u64) -> Value {
    let frames = 20 + u64::from(c.byte()) % (MOST_FRAMES - 19);
    let (from, to) = (json!(100), json!(100 + frames));
    let row = |from: Value, to: Value, length: Value| {
        json!({"file": "meta/episodes/chunk-000/file-000.parquet", "row": episode,
            "episode_index": episode, "data/chunk_index": 0, "data/file_index": 0,
            "dataset_from_index": from, "dataset_to_index": to, "length": length})
    };
    let rows = match c.byte() {
        1 => vec![row(from.clone(), to.clone(), json!(frames)); 2],
        2 => vec![],
        3 => vec![row(json!(100.5), to, json!(frames))],
        4 => vec![row(to, from, json!(frames))],
        5 => vec![row(from, to, json!(frames + 1))],
        6 => vec![row(json!(0), json!(MAX_FRAMES + 1), Value::Null)],
        7 => vec![row(json!(-1), to, Value::Null)],
        8 => vec![row(json!("nan"), to, Value::Null)],
        9 => vec![row(from.clone(), from, json!(0))],
        10 => vec![row(json!(u64::MAX - 5), json!(u64::MAX), Value::Null)],
        _ => vec![row(from, to, json!(frames))],
    };
    json!({"rows": rows, "episodes": [0, 1, 2]})
}

/// A value of joint column `column` at frame `k` of `frames`: a smooth motion from rest, well
/// inside every SO arm's limits in degrees and in LeRobot's ranges.
fn smooth(column: usize, k: u64, frames: u64) -> f64 {
    let phase = std::f64::consts::TAU * k as f64 / frames as f64;
    let amplitude = [30.0, -25.0, 20.0, -15.0, 40.0, 30.0][column % 6];
    let offset = if column % 6 == 5 { 50.0 } else { 0.0 };
    offset + amplitude * (1.0 - phase.cos()) / 2.0
}

/// Values a corrupt cell may hold, as the reader writes them.
fn corrupt_value(c: &mut Choices) -> Value {
    match c.byte() % 10 {
        0 => json!(1e30),
        1 => json!(-1e30),
        2 => json!("nan"),
        3 => json!("inf"),
        4 => json!("-inf"),
        5 => Value::Null,
        6 => json!(150.0),
        7 => json!(-101.0),
        8 => json!(f64::from(c.byte()) * 1.5 - 190.0),
        _ => json!("7"),
    }
}

/// The reader's answer to "rows" for `span`: one sound row per frame in index order, unless
/// the choices corrupt a row or the whole.
fn rows_reply(c: &mut Choices, span: &EpisodeSpan, width: usize, fps: f64) -> Value {
    let mut index = Vec::new();
    let mut episode = Vec::new();
    let mut timestamps = Vec::new();
    let mut lengths = Vec::new();
    let mut values = Vec::new();
    let with_timestamps = c.byte() % 4 != 1;
    let frames = span.frames().min(MOST_FRAMES);
    for k in 0..frames {
        let mut i = json!(span.from() + k);
        let mut e = json!(span.episode());
        let mut t = json!(k as f64 / fps);
        let mut length = Some(width);
        let mut row: Vec<Value> = (0..width).map(|j| json!(smooth(j, k, frames))).collect();
        match c.byte() {
            1 => i = json!(span.from() + k.saturating_sub(1)),
            2 => i = json!(span.from() + k + 1),
            3 => e = json!(span.episode() + 1),
            4 => e = Value::Null,
            5 => length = Some(width + 1),
            6 => length = None,
            7 => {
                let j = usize::from(c.byte()) % width.max(1);
                if let Some(cell) = row.get_mut(j) {
                    *cell = corrupt_value(c);
                }
            }
            8 => {
                t = match c.byte() % 6 {
                    0 => json!("nan"),
                    1 => json!("inf"),
                    2 => Value::Null,
                    3 => json!((k as f64 - 1.0) / fps),
                    4 => json!((k as f64 - 2.0) / fps),
                    _ => json!(k as f64 / fps + 100.0),
                }
            }
            9 => i = json!(1.5),
            10 => i = json!("x"),
            11 => t = json!(k as f64 / (fps * 2.0)),
            _ => {}
        }
        if length == Some(width + 1) {
            row.push(json!(0.0));
        }
        index.push(i);
        episode.push(e);
        timestamps.push(t);
        lengths.push(length.map_or(Value::Null, |n| json!(n)));
        if length.is_some() {
            values.extend(row);
        }
    }
    let episode_rows = match c.byte() {
        1 => span.frames() + 1,
        2 => span.frames().saturating_sub(1),
        _ => span.frames(),
    };
    json!({"column_type": "list<element: float>", "index": index, "episode_index": episode,
        "timestamp": if with_timestamps { json!(timestamps) } else { Value::Null },
        "lengths": lengths, "values": values, "episode_rows": episode_rows})
}
