//! A LeRobotDataset v3.0 episode as editable keyframes (docs/interop.md §1).
//!
//! [`info`] reads `meta/info.json`, [`reader`] gets the episode's rows out of the parquet files
//! (through pyarrow), [`units`] turns LeRobot's normalised motor values into joint values; the
//! frames then go through the same fitting as a recording made by hand
//! ([`crate::record::keyframes`]): the fewest keys within the tolerance, clamped into the
//! limits, retimed until the limit check passes.

pub mod info;
pub mod reader;
pub mod units;

pub use info::DatasetInfo;
pub use reader::{read_episode, EpisodeRows};
pub use units::BodyUnits;

use crate::json::InputError;
use crate::python::HarnessError;
use crate::record::{self, KeyframeOptions, Keyframes, RecordError, Recording, StopReason};
use crate::robot::Robot;
use std::path::Path;

/// LeRobot's suffix of a motor's position value in feature names (`shoulder_pan.pos`).
const POSITION_SUFFIX: &str = ".pos";
/// Prefixes of a bimanual robot's two arms (LeRobot's `bi_so_follower`: `left_`, `right_`).
const ARM_PREFIXES: [&str; 2] = ["left_", "right_"];

#[derive(Debug, thiserror::Error)]
pub enum LeRobotError {
    #[error(transparent)]
    Input(#[from] InputError),
    #[error(
        "{file}: codebase_version is {found:?}; keypose reads LeRobotDataset v3.0 only: convert \
         the dataset with LeRobot's convert_dataset_v21_to_v30"
    )]
    Version { file: String, found: String },
    #[error(
        "{file}: {field} names two arms ({names}): a bimanual dataset becomes a two-arm sequence, \
         which keypose does not support yet"
    )]
    Bimanual {
        file: String,
        field: String,
        names: String,
    },
    #[error("{file}: {field} names {name:?}, which is not a joint of {robot}; expected names from: {expected}")]
    UnknownName {
        file: String,
        field: String,
        name: String,
        robot: String,
        expected: String,
    },
    #[error("{file}: {field} names no joint of {robot} (names: {names})")]
    NoJoints {
        file: String,
        field: String,
        robot: String,
        names: String,
    },
    #[error("{dir}: {message}")]
    Dataset { dir: String, message: String },
    #[error(
        "joint {joint}: values in LeRobot's −100…100 range normalisation need the arm's \
         calibration: give --calibration FILE or --robot-id NAME"
    )]
    NeedsCalibration { joint: String },
    #[error("reading the dataset: {0}")]
    Reader(HarnessError),
    #[error(transparent)]
    Record(#[from] RecordError),
}

impl LeRobotError {
    /// Whether the dataset or the options are to blame (exit 2), not the Python environment.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, LeRobotError::Reader(_))
    }
}

/// What to import and how.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    pub episode: u64,
    /// `action` or `observation.state`.
    pub field: String,
    /// The units of the body joints; `None`: decided from the values.
    pub units: Option<BodyUnits>,
    pub keyframes: KeyframeOptions,
}

/// An imported episode: the keys, and the notices the user should read.
#[derive(Debug, Clone)]
pub struct Imported {
    pub keyframes: Keyframes,
    pub frames: usize,
    pub units: BodyUnits,
    pub column_type: String,
    pub data_file: String,
    pub notices: Vec<String>,
}

/// The robot joint each of `names` denotes (`None` for a motor's other quantities).
/// Bimanual names are refused: two-arm sequences do not exist yet.
pub fn map_names(
    info: &DatasetInfo,
    field: &str,
    names: &[String],
    robot: &Robot,
) -> Result<Vec<Option<usize>>, LeRobotError> {
    refuse_two_arms(info, field, names)?;
    let mut columns = Vec::with_capacity(names.len());
    for name in names {
        // Another quantity of a motor (`.vel`, `.effort`) is not a position: left out.
        let joint = match name.split_once('.') {
            None => name.as_str(),
            Some((motor, _)) if name.ends_with(POSITION_SUFFIX) => motor,
            Some(_) => {
                columns.push(None);
                continue;
            }
        };
        let index = robot
            .joint_index(joint)
            .ok_or_else(|| LeRobotError::UnknownName {
                file: info.file.clone(),
                field: field.to_string(),
                name: name.clone(),
                robot: robot.name.clone(),
                expected: robot.joint_names().join(", "),
            })?;
        columns.push(Some(index));
    }
    if columns.iter().all(Option::is_none) {
        return Err(LeRobotError::NoJoints {
            file: info.file.clone(),
            field: field.to_string(),
            robot: robot.name.clone(),
            names: names.join(", "),
        });
    }
    Ok(columns)
}

/// Refuses a bimanual dataset (`left_…`/`right_…` names): it would become a two-arm sequence,
/// which does not exist yet. Called before the robot is resolved: a bimanual robot_type
/// (`bi_so_follower`) is no robot of keypose's either.
pub fn refuse_two_arms(
    info: &DatasetInfo,
    field: &str,
    names: &[String],
) -> Result<(), LeRobotError> {
    if names
        .iter()
        .any(|n| ARM_PREFIXES.iter().any(|p| n.starts_with(p)))
    {
        return Err(LeRobotError::Bimanual {
            file: info.file.clone(),
            field: field.to_string(),
            names: names.join(", "),
        });
    }
    Ok(())
}

/// Imports episode `options.episode` of the dataset at `dir` for `robot` (its calibration, if
/// any, already applied).
pub fn import(
    dir: &Path,
    info: &DatasetInfo,
    robot: &Robot,
    options: &ImportOptions,
) -> Result<Imported, LeRobotError> {
    let names = info.names(&options.field)?;
    let columns = map_names(info, &options.field, &names, robot)?;
    let rows = read_episode(dir, info, options.episode, &options.field)?;
    check_widths(dir, &rows, names.len())?;
    let (recording, units, notices) = recording(info, robot, &columns, &rows, options)?;
    let mut keyframes = record::keyframes(&recording, robot, &options.keyframes)?;
    keyframes.sequence.description = Some(format!(
        "LeRobot dataset {}, episode {}, {}: {} frames → {} keys within {}°",
        dir.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        options.episode,
        options.field,
        rows.values.len(),
        keyframes.keys(),
        options.keyframes.tolerance_deg
    ));
    Ok(Imported {
        frames: rows.values.len(),
        keyframes,
        units,
        column_type: rows.column_type,
        data_file: rows.file,
        notices,
    })
}

fn check_widths(dir: &Path, rows: &EpisodeRows, width: usize) -> Result<(), LeRobotError> {
    if rows.values.is_empty() {
        return Err(LeRobotError::Dataset {
            dir: dir.display().to_string(),
            message: format!("{}: the episode has no frames", rows.file),
        });
    }
    if let Some((k, row)) = rows
        .values
        .iter()
        .enumerate()
        .find(|(_, r)| r.len() != width)
    {
        return Err(LeRobotError::Dataset {
            dir: dir.display().to_string(),
            message: format!(
                "{}: row of index {} has {} values, meta/info.json names {width}",
                rows.file,
                rows.from + k as u64,
                row.len()
            ),
        });
    }
    Ok(())
}

/// The episode as a [`Recording`] of joint values: joints the dataset does not name keep the
/// robot's home and are not fitted.
fn recording(
    info: &DatasetInfo,
    robot: &Robot,
    columns: &[Option<usize>],
    rows: &EpisodeRows,
    options: &ImportOptions,
) -> Result<(Recording, BodyUnits, Vec<String>), LeRobotError> {
    let n = rows.values.len();
    let body: Vec<usize> = (0..columns.len())
        .filter(|&c| columns[c].is_some_and(|j| robot.joints[j].name != units::GRIPPER))
        .collect();
    let (units, notice) = units::decide(options.units, &rows.values, &body);
    let mut notices: Vec<String> = notice.into_iter().collect();
    let mut values: Vec<Vec<f64>> = robot.home.iter().map(|&h| vec![h; n]).collect();
    let mut recorded = vec![false; robot.joints.len()];
    for (c, joint) in columns.iter().enumerate() {
        let Some(j) = *joint else { continue };
        let (conversion, notice) = units::conversion(&robot.joints[j], units)?;
        notices.extend(notice);
        values[j] = rows.values.iter().map(|r| conversion.apply(r[c])).collect();
        recorded[j] = true;
    }
    let times = frame_times(info, rows);
    Ok((
        Recording {
            times,
            values,
            recorded,
            rate_hz: info.fps,
            stopped: StopReason::Duration,
            gaps: Default::default(),
            hold_error: None,
        },
        units,
        notices,
    ))
}

/// Seconds from the episode's first frame: its timestamps, else frame number over fps.
fn frame_times(info: &DatasetInfo, rows: &EpisodeRows) -> Vec<f64> {
    match &rows.timestamps {
        Some(ts) if ts.len() == rows.values.len() => ts.iter().map(|t| t - ts[0]).collect(),
        _ => (0..rows.values.len())
            .map(|k| k as f64 / info.fps)
            .collect(),
    }
}
