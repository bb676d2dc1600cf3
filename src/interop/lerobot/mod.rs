//! A LeRobotDataset v3.0 episode as editable keyframes (docs/interop.md §1).
//!
//! [`DatasetInfo`] reads `meta/info.json`, [`layout`] decides which files are read (all inside
//! the dataset), a reader gets the episode's metadata and rows out of the parquet files
//! (through pyarrow); everything pyarrow returns is judged here, in Rust, before anything is
//! made of it: the episode's span ([`EpisodeSpan`]), its rows ([`Frames`]), its timestamps
//! against the frame rate, its values against the joints' limits once they are turned from
//! LeRobot's normalisation ([`BodyUnits`]) into joint values. The frames then go through the same fitting
//! as a recording made by hand ([`crate::record::keyframes`]): the fewest keys within the
//! tolerance, retimed until the limit check passes.
//!
//! Every problem of the dataset is a [`LeRobotError`] that names the file (meta/info.json) or
//! the dataset, the episode and the frame where there is one, and the field (exit 2); nothing
//! is written.

mod arms;
mod episode;
mod error;
pub mod export;
mod frames;
mod info;
pub mod layout;
mod limits;
pub mod motor_norm;
mod reader;
mod timing;
mod units;

pub use arms::{arm_robot_type, dataset_arms};
pub use episode::{EpisodeSpan, MAX_FRAMES};
pub use error::{DuplicateJoint, Frame, LeRobotError, PathProblem, Place, Problem};
pub use frames::Frames;
pub use info::DatasetInfo;
pub use limits::Clipped;
pub use units::{BodyUnits, UnitsPerArm};

use crate::record::{self, KeyframeOptions, Keyframes, Recording, StopReason};
use crate::robot::Robot;
use std::path::Path;

/// LeRobot's suffix of a motor's position value in feature names (`shoulder_pan.pos`).
const POSITION_SUFFIX: &str = ".pos";

/// What to import and how.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// The episode's index in the dataset.
    pub episode: u64,
    /// `action` or `observation.state`.
    pub field: String,
    /// The units of the body joints; `None`: decided from the values.
    pub units: Option<BodyUnits>,
    /// Clip values outside a joint's limits to them (and say so) instead of refusing them.
    pub clip: bool,
    /// How the keys are fitted to the frames.
    pub keyframes: KeyframeOptions,
}

/// An imported episode: the keys, and the notices the user should read.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The keys fitted to the frames, as a sequence, with how well they fit.
    pub keyframes: Keyframes,
    /// Frames read.
    pub frames: usize,
    /// The units the body joints' values were read in, per arm.
    pub units: UnitsPerArm,
    /// The feature column's Arrow type (`fixed_size_list<…>[6]`).
    pub column_type: String,
    /// The data file read, relative to the dataset.
    pub data_file: String,
    /// The joints whose values were clipped (`clip`), each once.
    pub clipped: Vec<Clipped>,
    /// Notes for the user (units guessed, values clipped), one line each.
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
/// (a bimanual dataset) `left_shoulder_pan.pos` denotes `left/shoulder_pan`. Two names of one
/// joint are refused: one would silently drive the joint with the other's values.
pub fn map_names(
    info: &DatasetInfo,
    field: &str,
    names: &[String],
    robot: &Robot,
) -> Result<Vec<Option<usize>>, LeRobotError> {
    dataset_arms(info, field, names)?;
    let mut columns: Vec<Option<usize>> = Vec::with_capacity(names.len());
    for (k, name) in names.iter().enumerate() {
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
        if let Some(first) = columns.iter().position(|&c| c == Some(index)) {
            return Err(LeRobotError::DuplicateJoint(Box::new(
                error::DuplicateJoint {
                    file: info.file.clone(),
                    field: field.to_string(),
                    joint: robot.joints[index].name.clone(),
                    first,
                    first_name: names[first].clone(),
                    second: k,
                    second_name: name.clone(),
                },
            )));
        }
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
    let (place, span, frames) = read_episode(dir, info, &names, options)?;
    let episode = Episode {
        dataset: dataset_name(dir),
        info,
        place,
        span,
        names: &names,
        columns: &columns,
        frames,
    };
    fit(&episode, robot, options)
}

/// The episode's frames out of the dataset, judged, with where they are; the reader process
/// has ended when this returns, so that its memory is free while the keys are fitted.
fn read_episode(
    dir: &Path,
    info: &DatasetInfo,
    names: &[String],
    options: &ImportOptions,
) -> Result<(Place, EpisodeSpan, Frames), LeRobotError> {
    let place = Place::episode(&dir.display().to_string(), options.episode);
    let files = layout::episode_files(dir)?;
    let mut reader = reader::Reader::start()?;
    let meta = reader.episode(dir, &files, &place)?;
    let span = EpisodeSpan::from_reply(&place, info.fps, &meta)?;
    let data_file = layout::data_file(dir, info, &span)?;
    let place = place.in_file(&data_file);
    let reply = reader.rows(dir, &data_file, &span, &options.field)?;
    drop(reader);
    let frames = Frames::from_reply(&place, &span, &options.field, names, &reply)?;
    Ok((place, span, frames))
}

/// The folder's own name, for the sequence's description.
fn dataset_name(dir: &Path) -> String {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// An episode's frames as read and judged, with what they are frames of.
#[derive(Debug, Clone)]
pub struct Episode<'a> {
    /// The dataset's name, for the sequence's description.
    pub dataset: String,
    /// The dataset's meta/info.json.
    pub info: &'a DatasetInfo,
    /// The dataset, episode and data file, for messages.
    pub place: Place,
    /// Which frames of the dataset are the episode's.
    pub span: EpisodeSpan,
    /// The feature's value names and the joint each drives ([`map_names`]).
    pub names: &'a [String],
    /// The robot joint each value drives; `None` for a value that is not a joint position.
    pub columns: &'a [Option<usize>],
    /// The episode's rows.
    pub frames: Frames,
}

/// The keys of an episode's frames: units decided, values converted and judged against the
/// limits, times judged against the frame rate, then fitted as a recording.
pub fn fit(
    episode: &Episode,
    robot: &Robot,
    options: &ImportOptions,
) -> Result<Imported, LeRobotError> {
    let rows = &episode.frames.values;
    let times = timing::frame_times(
        &episode.place,
        episode.span.from(),
        episode.info.fps,
        episode.frames.timestamps.as_deref(),
        rows.len(),
    )?;
    // The dataset's own word on its units, where keypose exported it, before any guess.
    let recorded = match (options.units, episode.info.keypose_units) {
        (None, Some(units)) => Some(units),
        _ => None,
    };
    let with_recorded;
    let options = match recorded {
        Some(units) => {
            with_recorded = ImportOptions {
                units: Some(units),
                ..options.clone()
            };
            &with_recorded
        }
        None => options,
    };
    let (recording, units, clipped, mut notices) = recording(episode, robot, times, options)?;
    if let Some(units) = recorded {
        notices.push(format!(
            "note: {} units, as {} says keypose wrote them when it exported the dataset \
             ($.keypose.units)",
            units.name(),
            episode.info.file
        ));
    }
    let mut keyframes = record::keyframes(&recording, robot, &options.keyframes)?;
    keyframes.sequence.description = Some(format!(
        "LeRobot dataset {}, episode {}, {}: {} frames → {} keys within {}°",
        episode.dataset,
        options.episode,
        options.field,
        rows.len(),
        keyframes.keys(),
        options.keyframes.tolerance_deg
    ));
    Ok(Imported {
        frames: rows.len(),
        keyframes,
        units,
        column_type: episode.frames.column_type.clone(),
        data_file: episode.place.file.clone().unwrap_or_default(),
        clipped,
        notices,
    })
}

/// The episode as a [`Recording`] of joint values at `times`: joints the dataset does not name
/// keep the robot's home and are not fitted. The units are decided per arm; values past a
/// limit are refused or clipped ([`limits`]).
fn recording(
    episode: &Episode,
    robot: &Robot,
    times: Vec<f64>,
    options: &ImportOptions,
) -> Result<(Recording, UnitsPerArm, Vec<Clipped>, Vec<String>), LeRobotError> {
    let (rows, columns) = (&episode.frames.values, episode.columns);
    let n = rows.len();
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
        let (decided, notice) = units::decide(options.units, rows, &body, &arm);
        notices.extend(notice);
        joint_units[joints].fill(decided);
        units.push((arm, decided));
    }
    let mut values: Vec<Vec<f64>> = robot.home.iter().map(|&h| vec![h; n]).collect();
    let mut recorded = vec![false; robot.joints.len()];
    let mut clipped = Vec::new();
    for (c, joint) in columns.iter().enumerate() {
        let Some(j) = *joint else { continue };
        let (conversion, notice) = units::conversion(&robot.joints[j], joint_units[j])?;
        notices.extend(notice);
        values[j] = rows.iter().map(|r| conversion.apply(r[c])).collect();
        let column = limits::ColumnLimits {
            joint: &robot.joints[j],
            field: &options.field,
            name: &episode.names[c],
            slack: options.keyframes.tolerance(robot.joints[j].kind),
            clip: options.clip,
        };
        clipped.extend(limits::judge(
            &episode.place,
            episode.span.from(),
            &column,
            &mut values[j],
        )?);
        recorded[j] = true;
    }
    Ok((
        Recording {
            times,
            values,
            recorded,
            rate_hz: episode.info.fps,
            stopped: StopReason::Duration,
            gaps: Default::default(),
            hold_error: None,
        },
        units,
        clipped,
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
