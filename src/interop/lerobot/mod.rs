//! A LeRobotDataset v3.0 episode as editable keyframes (docs/interop.md §1).
//!
//! [`info`] reads `meta/info.json`, [`reader`] gets the episode's rows out of the parquet files
//! (through pyarrow), [`units`] turns LeRobot's normalised motor values into joint values; the
//! frames then go through the same fitting as a recording made by hand
//! ([`crate::record::keyframes`]): the fewest keys within the tolerance, clamped into the
//! limits, retimed until the limit check passes.

pub mod arms;
pub mod info;
pub mod reader;
pub mod units;

pub use arms::dataset_arms;
pub use info::DatasetInfo;
pub use reader::{read_episode, EpisodeRows};
pub use units::{BodyUnits, UnitsPerArm};

use crate::json::InputError;
use crate::python::HarnessError;
use crate::record::{self, KeyframeOptions, Keyframes, RecordError, Recording, StopReason};
use crate::robot::Robot;
use std::path::Path;

/// LeRobot's suffix of a motor's position value in feature names (`shoulder_pan.pos`).
const POSITION_SUFFIX: &str = ".pos";

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
        "{file}: {field} names values of an arm (left_…, right_…) and values of none ({unprefixed}); \
         expected every name to start with left_ or right_ (a bimanual dataset) or none to (one arm)"
    )]
    MixedArms {
        file: String,
        field: String,
        unprefixed: String,
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
         calibration: give --calibration {arm}FILE or --robot-id {arm}NAME"
    )]
    NeedsCalibration {
        joint: String,
        /// `left=` for an arm of a cell, else empty: how the options name the arm.
        arm: String,
    },
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
    pub units: UnitsPerArm,
    pub column_type: String,
    pub data_file: String,
    pub notices: Vec<String>,
}

impl Imported {
    /// "degrees", or per arm: "left degrees, right range".
    pub fn units_text(&self) -> String {
        self.units
            .iter()
            .map(|(arm, units)| match arm.as_str() {
                "" => units.name().to_string(),
                arm => format!("{arm} {}", units.name()),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The robot joint each of `names` denotes (`None` for a motor's other quantities). On a cell
/// (a bimanual dataset) `left_shoulder_pan.pos` denotes `left/shoulder_pan`.
pub fn map_names(
    info: &DatasetInfo,
    field: &str,
    names: &[String],
    robot: &Robot,
) -> Result<Vec<Option<usize>>, LeRobotError> {
    dataset_arms(info, field, names)?;
    let mut columns = Vec::with_capacity(names.len());
    for name in names {
        let on_robot = arms::robot_name(name, robot.is_cell());
        // Another quantity of a motor (`.vel`, `.effort`) is not a position: left out.
        let joint = match on_robot.split_once('.') {
            None => on_robot.as_str(),
            Some((motor, _)) if on_robot.ends_with(POSITION_SUFFIX) => motor,
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
                expected: robot
                    .joint_names()
                    .iter()
                    .map(|j| arms::lerobot_name(j))
                    .collect::<Vec<_>>()
                    .join(", "),
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
/// robot's home and are not fitted. The units are decided per arm.
fn recording(
    info: &DatasetInfo,
    robot: &Robot,
    columns: &[Option<usize>],
    rows: &EpisodeRows,
    options: &ImportOptions,
) -> Result<(Recording, UnitsPerArm, Vec<String>), LeRobotError> {
    let n = rows.values.len();
    let mut notices = Vec::new();
    let mut units = Vec::new();
    let mut joint_units = vec![BodyUnits::Degrees; robot.joints.len()];
    for (arm, joints) in arm_joints(robot) {
        let body: Vec<usize> = (0..columns.len())
            .filter(|&c| {
                columns[c]
                    .is_some_and(|j| joints.contains(&j) && !units::is_gripper(&robot.joints[j]))
            })
            .collect();
        let (decided, notice) = units::decide(options.units, &rows.values, &body, &arm);
        notices.extend(notice);
        joint_units[joints].fill(decided);
        units.push((arm, decided));
    }
    let mut values: Vec<Vec<f64>> = robot.home.iter().map(|&h| vec![h; n]).collect();
    let mut recorded = vec![false; robot.joints.len()];
    for (c, joint) in columns.iter().enumerate() {
        let Some(j) = *joint else { continue };
        let (conversion, notice) = units::conversion(&robot.joints[j], joint_units[j])?;
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

/// Each arm's name and joints: a cell's arms, or the whole robot under the empty name.
fn arm_joints(robot: &Robot) -> Vec<(String, std::ops::Range<usize>)> {
    if robot.is_cell() {
        return robot
            .arms
            .iter()
            .map(|a| (a.name.clone(), a.joints.clone()))
            .collect();
    }
    vec![(String::new(), 0..robot.joints.len())]
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
