//! How importing a dataset episode fails: every error of the dataset names the file or the
//! dataset folder, the episode, the frame where there is one, and the field, and is bad input
//! (exit 2); only a failing Python environment is not.

use crate::json::InputError;
use crate::python::HarnessError;
use crate::record::RecordError;
use std::fmt;

/// Why a dataset episode cannot be imported.
#[derive(Debug, thiserror::Error)]
pub enum LeRobotError {
    /// meta/info.json (or another JSON input) is not what it should be.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The dataset is not LeRobotDataset v3.0.
    #[error(
        "{file}: codebase_version is {found:?}; keypose reads LeRobotDataset v3.0 only: convert \
         the dataset with LeRobot's convert_dataset_v21_to_v30"
    )]
    Version {
        /// meta/info.json's path.
        file: String,
        /// Its `codebase_version`.
        found: String,
    },
    /// Some value names of the feature have an arm prefix and some do not.
    #[error(
        "{file}: {field} names values of an arm (left_…, right_…) and values of none ({unprefixed}); \
         expected every name to start with left_ or right_ (a bimanual dataset) or none to (one arm)"
    )]
    MixedArms {
        /// meta/info.json's path.
        file: String,
        /// The feature (`action`, `observation.state`).
        field: String,
        /// The names without a prefix, comma-separated.
        unprefixed: String,
    },
    /// A value name of the feature is not a joint of the robot.
    #[error("{file}: {field} names {name:?}, which is not a joint of {robot}; expected names from: {expected}")]
    UnknownName {
        /// meta/info.json's path.
        file: String,
        /// The feature.
        field: String,
        /// The value name.
        name: String,
        /// The robot's name.
        robot: String,
        /// The names the robot's joints have in LeRobot, comma-separated.
        expected: String,
    },
    /// No value name of the feature is a joint position of the robot.
    #[error("{file}: {field} names no joint of {robot} (names: {names})")]
    NoJoints {
        /// meta/info.json's path.
        file: String,
        /// The feature.
        field: String,
        /// The robot's name.
        robot: String,
        /// The feature's value names, comma-separated.
        names: String,
    },
    /// Two values of the feature name one joint.
    #[error(transparent)]
    DuplicateJoint(Box<DuplicateJoint>),
    /// `data_path` of meta/info.json, filled in for an episode, names no file inside the
    /// dataset.
    #[error("{file}: $.data_path {template:?} for episode {episode}: {problem}")]
    DataPath {
        /// meta/info.json's path.
        file: String,
        /// The `data_path` template as written.
        template: String,
        /// The episode it was filled in for.
        episode: u64,
        /// Why the path is not followed.
        problem: Box<PathProblem>,
    },
    /// A file the dataset's layout names (meta/episodes) lies outside the dataset folder.
    #[error("{dataset}: {problem}")]
    Layout {
        /// The dataset folder.
        dataset: String,
        /// Why the path is not followed.
        problem: Box<PathProblem>,
    },
    /// The dataset folder cannot be read.
    #[error("{dir}: {message}")]
    Dataset {
        /// The dataset folder.
        dir: String,
        /// What failed.
        message: String,
    },
    /// What an episode's metadata or rows hold is wrong, at `place`.
    #[error("{place}: {problem}")]
    Episode {
        /// The dataset, episode, data file and frame.
        place: Box<Place>,
        /// What is wrong there.
        problem: Box<Problem>,
    },
    /// The values are in LeRobot's −100…100 range normalisation and no calibration was given.
    #[error(
        "joint {joint}: values in LeRobot's −100…100 range normalisation need the arm's \
         calibration: give --calibration {arm}FILE or --robot-id {arm}NAME"
    )]
    NeedsCalibration {
        /// The first joint whose values need it.
        joint: String,
        /// `left=` for an arm of a cell, else empty: how the options name the arm.
        arm: String,
    },
    /// The Python reader (pyarrow) failed: the environment's fault, not the dataset's.
    #[error("reading the dataset: {0}")]
    Reader(#[source] HarnessError),
    /// Writing a dataset's parquet files failed in the writer script (pyarrow).
    #[error("writing the dataset: {0}")]
    Writer(#[source] HarnessError),
    /// The output folder of an export cannot be written.
    #[error("{dir}: {problem}")]
    Output {
        /// The folder (or file in it).
        dir: String,
        /// What is wrong with it.
        problem: String,
        /// The system's reason, when there is one.
        #[source]
        source: Option<std::io::Error>,
    },
    /// The frames could not be fitted with keyframes.
    #[error(transparent)]
    Record(#[from] RecordError),
}

impl LeRobotError {
    /// Whether the dataset or the options are to blame (exit 2), not the Python environment.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, LeRobotError::Reader(_) | LeRobotError::Writer(_))
    }

    /// What kind of failure this is: the dataset's or the options' (bad input), or the
    /// reader process's (hardware: the Python side failed).
    pub fn kind(&self) -> crate::error::ErrorKind {
        if self.is_bad_input() {
            crate::error::ErrorKind::BadInput
        } else {
            crate::error::ErrorKind::Hardware
        }
    }
}

/// Two values of a feature that would drive one joint: the second would silently replace the
/// first.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{file}: {field} value {second} ({second_name:?}) names joint {joint}, as value {first} \
     ({first_name:?}) does; expected each joint named once"
)]
pub struct DuplicateJoint {
    /// meta/info.json's path.
    pub file: String,
    /// The feature.
    pub field: String,
    /// The joint both values name.
    pub joint: String,
    /// Position of the first value in the feature, from 0.
    pub first: usize,
    /// Its name.
    pub first_name: String,
    /// Position of the second value, from 0.
    pub second: usize,
    /// Its name.
    pub second_name: String,
}

/// Where in a dataset a problem is: the folder, the episode, and where known the data file and
/// the frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Place {
    /// The dataset folder, as the user named it.
    pub dataset: String,
    /// The episode's index.
    pub episode: u64,
    /// The data file, relative to the dataset; `None` before it is known.
    pub file: Option<String>,
    /// The frame; `None` for a problem of the whole episode.
    pub frame: Option<Frame>,
}

/// A frame of an episode: its number from the episode's start, and its global `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Frames since the episode's first, from 0.
    pub number: u64,
    /// The frame's `index` across the whole dataset.
    pub index: u64,
}

impl Place {
    /// Episode `episode` of the dataset in folder `dataset`, no file or frame yet.
    pub fn episode(dataset: &str, episode: u64) -> Place {
        Place {
            dataset: dataset.to_string(),
            episode,
            file: None,
            frame: None,
        }
    }

    /// The same place in data file `file` (relative to the dataset).
    pub fn in_file(&self, file: &str) -> Place {
        Place {
            file: Some(file.to_string()),
            ..self.clone()
        }
    }

    /// The frame of global index `index` in an episode starting at `from`.
    pub fn at_index(&self, from: u64, index: u64) -> Place {
        Place {
            frame: Some(Frame {
                number: index.saturating_sub(from),
                index,
            }),
            ..self.clone()
        }
    }

    /// `problem` at this place, as an error.
    pub fn error(&self, problem: Problem) -> LeRobotError {
        LeRobotError::Episode {
            place: Box::new(self.clone()),
            problem: Box::new(problem),
        }
    }
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: episode {}", self.dataset, self.episode)?;
        if let Some(file) = &self.file {
            write!(f, ", {file}")?;
        }
        if let Some(frame) = self.frame {
            write!(f, ", frame {} (index {})", frame.number, frame.index)?;
        }
        Ok(())
    }
}

/// Why a path the dataset gives is not followed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PathProblem {
    /// The `data_path` template cannot be filled in.
    #[error("{reason}; expected a template such as {example:?}", example = super::info::DEFAULT_DATA_PATH)]
    Template {
        /// Why.
        reason: super::layout::TemplateError,
    },
    /// The path is absolute.
    #[error("{path:?} is an absolute path; expected a path inside the dataset folder")]
    Absolute {
        /// The path as the dataset gives it.
        path: String,
    },
    /// The path climbs out of the dataset folder with `..`.
    #[error("{path:?} leads out of the dataset folder through \"..\"; expected a path inside it")]
    Escapes {
        /// The path as the dataset gives it.
        path: String,
    },
    /// A symbolic link on the path leads out of the dataset folder.
    #[error("{path:?} resolves to {resolved} (through a symbolic link), outside the dataset folder {dir}")]
    LinkedOut {
        /// The path as the dataset gives it.
        path: String,
        /// Where it leads.
        resolved: String,
        /// The dataset folder.
        dir: String,
    },
    /// The path is empty, or its file cannot be resolved (no such file, no permission).
    #[error("{path:?}: {reason}")]
    Unreadable {
        /// The path as the dataset gives it.
        path: String,
        /// Why it cannot be read.
        reason: String,
    },
}

/// What is wrong with an episode's metadata or rows, with what was expected and found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    /// The reader could not get what it needs out of a file: the message names the file.
    #[error("{message}")]
    Unreadable {
        /// The reader's message.
        message: String,
    },
    /// meta/episodes has no row for the episode.
    #[error("not in meta/episodes (episodes there: {known})")]
    NotListed {
        /// The episodes meta/episodes lists.
        known: String,
    },
    /// meta/episodes has several rows for the episode.
    #[error("listed {count} times in meta/episodes ({rows}); expected once")]
    ListedTwice {
        /// How many.
        count: usize,
        /// Where they are, comma-separated.
        rows: String,
    },
    /// A column of the episode's meta/episodes row is not a whole number from 0.
    #[error("meta/episodes ({row}) gives {column} = {found}; expected a whole number from 0")]
    MetaNumber {
        /// Where the row is.
        row: String,
        /// The column.
        column: String,
        /// Its value, described.
        found: String,
    },
    /// The episode's span of frame indices is empty.
    #[error(
        "meta/episodes gives dataset_from_index {from} and dataset_to_index {to}: no frames; \
         expected dataset_to_index above dataset_from_index"
    )]
    Empty {
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
    },
    /// meta/episodes' `length` disagrees with the span of indices.
    #[error(
        "meta/episodes gives length {length}, but dataset_to_index − dataset_from_index = \
         {to} − {from} = {span}; expected the same count"
    )]
    Length {
        /// `length`.
        length: u64,
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
        /// `to − from`.
        span: u64,
    },
    /// The episode has more frames or seconds than keypose imports.
    #[error(
        "{frames} frames, {seconds:.1} s at fps {fps} (dataset_from_index {from} … \
         dataset_to_index {to}); keypose imports episodes of at most {max_frames} frames and \
         {max_seconds} s: split the episode, or keep a part of it with LeRobot's dataset tools"
    )]
    TooLong {
        /// The episode's frames.
        frames: u64,
        /// Its length, seconds.
        seconds: f64,
        /// The dataset's frame rate, frames per second.
        fps: f64,
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
        /// Most frames imported.
        max_frames: u64,
        /// Longest episode imported, seconds.
        max_seconds: f64,
    },
    /// A row's `index` or `episode_index` is not a whole number.
    #[error("{column} is {found}; expected a whole number")]
    RowNumber {
        /// The column.
        column: &'static str,
        /// Its value, described.
        found: String,
    },
    /// A row's index is outside the episode's span.
    #[error("index {index} is outside the episode's dataset_from_index … dataset_to_index ({from} … {to})")]
    IndexOutside {
        /// The row's index.
        index: u64,
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
    },
    /// Two rows have the same index.
    #[error("a second row of index {index}; expected one row per frame")]
    DuplicateIndex {
        /// The index.
        index: u64,
    },
    /// A frame of the span has no row.
    #[error(
        "no row of index {index}: the data file holds {found} of the {expected} rows that \
         meta/episodes' dataset_from_index … dataset_to_index ({from} … {to}) give the episode"
    )]
    MissingIndex {
        /// The first index without a row.
        index: u64,
        /// Rows the data file holds in the span.
        found: u64,
        /// Rows the span needs.
        expected: u64,
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
    },
    /// A row of the span belongs to another episode.
    #[error(
        "episode_index is {found}, expected {expected}: meta/episodes' dataset_from_index … \
         dataset_to_index reach into another episode's rows"
    )]
    OtherEpisode {
        /// The row's `episode_index`, described.
        found: String,
        /// The episode imported.
        expected: u64,
    },
    /// The data file holds another number of the episode's rows than meta/episodes gives.
    #[error(
        "the data file holds {found} rows of episode_index {episode}, but meta/episodes gives \
         the episode {expected} (dataset_from_index {from} … dataset_to_index {to}); expected \
         the same count"
    )]
    EpisodeRows {
        /// The episode.
        episode: u64,
        /// Its rows in the data file.
        found: u64,
        /// Its rows according to meta/episodes.
        expected: u64,
        /// `dataset_from_index`.
        from: u64,
        /// `dataset_to_index`.
        to: u64,
    },
    /// A row holds another number of values than the feature names.
    #[error("{field} holds {found} values; meta/info.json names {expected}")]
    Width {
        /// The feature.
        field: String,
        /// The row's number of values (or that it has no list).
        found: String,
        /// The number of names.
        expected: usize,
    },
    /// A value is NaN or infinite.
    #[error("{field} {name} is {found}; expected a finite number")]
    NotFinite {
        /// The feature.
        field: String,
        /// The value's name.
        name: String,
        /// The value, described.
        found: String,
    },
    /// A timestamp is NaN or infinite.
    #[error("timestamp is {found}; expected a finite number of seconds")]
    TimestampNotFinite {
        /// The timestamp, described.
        found: String,
    },
    /// A timestamp is not after the previous frame's.
    #[error(
        "timestamp {} s does not come after the previous frame's {} s; expected increasing \
         timestamps",
        seconds_text(*.value),
        seconds_text(*.previous)
    )]
    NotIncreasing {
        /// The previous frame's timestamp, seconds.
        previous: f64,
        /// This frame's, seconds.
        value: f64,
    },
    /// The timestamps' median step does not match the frame rate.
    #[error(
        "the timestamps step by {} s (the median step), but meta/info.json's fps {fps} \
         means {} s; expected within {tolerance_percent} % of it",
        seconds_text(*.median),
        seconds_text(*.expected)
    )]
    FpsMismatch {
        /// meta/info.json's frame rate, frames per second.
        fps: f64,
        /// The median step between timestamps, seconds.
        median: f64,
        /// The period the frame rate means, seconds.
        expected: f64,
        /// How far the step may be from the period, percent.
        tolerance_percent: f64,
    },
    /// Two timestamps are further apart than a few frame periods.
    #[error(
        "timestamp {} s is {} s after the previous frame's {} s, {periods:.1} frame periods at \
         fps {fps}; expected at most {max} (frames missing, or a corrupt timestamp)",
        seconds_text(*.value),
        seconds_text(*.step),
        seconds_text(*.previous)
    )]
    Gap {
        /// The previous frame's timestamp, seconds.
        previous: f64,
        /// This frame's, seconds.
        value: f64,
        /// The step between them, seconds.
        step: f64,
        /// The step in frame periods.
        periods: f64,
        /// The frame rate, frames per second.
        fps: f64,
        /// Largest step allowed, frame periods.
        max: f64,
    },
    /// A value is outside its joint's limits by more than the slack (and `--clip` was not given).
    #[error(
        "{field} {name} is {shown} {unit} as joint {joint}, outside its limits {min} … {max} \
         {unit} by more than the tolerance ({slack} {unit}); give --clip to clip such values \
         to the limits",
        shown = number_text(*.value)
    )]
    OutsideLimits {
        /// The feature.
        field: String,
        /// The value's name.
        name: String,
        /// The joint it drives.
        joint: String,
        /// The value, in the joint's unit.
        value: f64,
        /// The joint's lower limit.
        min: f64,
        /// The joint's upper limit.
        max: f64,
        /// The joint's unit, `"deg"` or `"m"`.
        unit: &'static str,
        /// How far past a limit a value may be and still be accepted (the fit clamps it), in
        /// `unit`.
        slack: f64,
    },
}

/// A number for messages: as Rust writes it, but in exponent form from 10⁷ on (a corrupt
/// 1e30 reads as such, not as 31 digits).
pub(crate) fn number_text(value: f64) -> String {
    if value.abs() >= 1e7 {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

/// Seconds to the microsecond, without trailing zeros: float32 timestamps read back as
/// 0.09999990463256836 and are meant as 0.1.
fn seconds_text(seconds: f64) -> String {
    let text = format!("{seconds:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text.is_empty() || text == "-" {
        return "0".into();
    }
    text.to_string()
}
