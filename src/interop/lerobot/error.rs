//! How importing a dataset episode fails: every error of the dataset names the file or the
//! dataset folder, the episode, the frame where there is one, and the field, and is bad input
//! (exit 2); only a failing Python environment is not.

use crate::json::InputError;
use crate::python::HarnessError;
use crate::record::RecordError;
use std::fmt;

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
    #[error(transparent)]
    DuplicateJoint(Box<DuplicateJoint>),
    /// `data_path` of meta/info.json, filled in for an episode, names no file inside the
    /// dataset.
    #[error("{file}: $.data_path {template:?} for episode {episode}: {problem}")]
    DataPath {
        file: String,
        template: String,
        episode: u64,
        problem: Box<PathProblem>,
    },
    /// A file the dataset's layout names (meta/episodes) lies outside the dataset folder.
    #[error("{dataset}: {problem}")]
    Layout {
        dataset: String,
        problem: Box<PathProblem>,
    },
    #[error("{dir}: {message}")]
    Dataset { dir: String, message: String },
    /// What an episode's metadata or rows hold is wrong, at `place`.
    #[error("{place}: {problem}")]
    Episode {
        place: Box<Place>,
        problem: Box<Problem>,
    },
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
    pub file: String,
    pub field: String,
    pub joint: String,
    pub first: usize,
    pub first_name: String,
    pub second: usize,
    pub second_name: String,
}

/// Where in a dataset a problem is: the folder, the episode, and where known the data file and
/// the frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Place {
    pub dataset: String,
    pub episode: u64,
    /// The data file, relative to the dataset.
    pub file: Option<String>,
    pub frame: Option<Frame>,
}

/// A frame of an episode: its number from the episode's start, and its global `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    pub number: u64,
    pub index: u64,
}

impl Place {
    pub fn episode(dataset: &str, episode: u64) -> Place {
        Place {
            dataset: dataset.to_string(),
            episode,
            file: None,
            frame: None,
        }
    }

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
    #[error("{reason}; expected a template such as {example:?}", example = super::info::DEFAULT_DATA_PATH)]
    Template {
        reason: super::layout::TemplateError,
    },
    #[error("{path:?} is an absolute path; expected a path inside the dataset folder")]
    Absolute { path: String },
    #[error("{path:?} leads out of the dataset folder through \"..\"; expected a path inside it")]
    Escapes { path: String },
    #[error("{path:?} resolves to {resolved} (through a symbolic link), outside the dataset folder {dir}")]
    LinkedOut {
        path: String,
        resolved: String,
        dir: String,
    },
    #[error("{path:?}: {reason}")]
    Unreadable { path: String, reason: String },
}

/// What is wrong with an episode's metadata or rows, with what was expected and found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    /// The reader could not get what it needs out of a file: the message names the file.
    #[error("{message}")]
    Unreadable { message: String },
    #[error("not in meta/episodes (episodes there: {known})")]
    NotListed { known: String },
    #[error("listed {count} times in meta/episodes ({rows}); expected once")]
    ListedTwice { count: usize, rows: String },
    #[error("meta/episodes ({row}) gives {column} = {found}; expected a whole number from 0")]
    MetaNumber {
        row: String,
        column: String,
        found: String,
    },
    #[error(
        "meta/episodes gives dataset_from_index {from} and dataset_to_index {to}: no frames; \
         expected dataset_to_index above dataset_from_index"
    )]
    Empty { from: u64, to: u64 },
    #[error(
        "meta/episodes gives length {length}, but dataset_to_index − dataset_from_index = \
         {to} − {from} = {span}; expected the same count"
    )]
    Length {
        length: u64,
        from: u64,
        to: u64,
        span: u64,
    },
    #[error(
        "{frames} frames, {seconds:.1} s at fps {fps} (dataset_from_index {from} … \
         dataset_to_index {to}); keypose imports episodes of at most {max_frames} frames and \
         {max_seconds} s: split the episode, or keep a part of it with LeRobot's dataset tools"
    )]
    TooLong {
        frames: u64,
        seconds: f64,
        fps: f64,
        from: u64,
        to: u64,
        max_frames: u64,
        max_seconds: f64,
    },
    #[error("{column} is {found}; expected a whole number")]
    RowNumber { column: &'static str, found: String },
    #[error("index {index} is outside the episode's dataset_from_index … dataset_to_index ({from} … {to})")]
    IndexOutside { index: u64, from: u64, to: u64 },
    #[error("a second row of index {index}; expected one row per frame")]
    DuplicateIndex { index: u64 },
    #[error(
        "no row of index {index}: the data file holds {found} of the {expected} rows that \
         meta/episodes' dataset_from_index … dataset_to_index ({from} … {to}) give the episode"
    )]
    MissingIndex {
        index: u64,
        found: u64,
        expected: u64,
        from: u64,
        to: u64,
    },
    #[error(
        "episode_index is {found}, expected {expected}: meta/episodes' dataset_from_index … \
         dataset_to_index reach into another episode's rows"
    )]
    OtherEpisode { found: String, expected: u64 },
    #[error(
        "the data file holds {found} rows of episode_index {episode}, but meta/episodes gives \
         the episode {expected} (dataset_from_index {from} … dataset_to_index {to}); expected \
         the same count"
    )]
    EpisodeRows {
        episode: u64,
        found: u64,
        expected: u64,
        from: u64,
        to: u64,
    },
    #[error("{field} holds {found} values; meta/info.json names {expected}")]
    Width {
        field: String,
        found: String,
        expected: usize,
    },
    #[error("{field} {name} is {found}; expected a finite number")]
    NotFinite {
        field: String,
        name: String,
        found: String,
    },
    #[error("timestamp is {found}; expected a finite number of seconds")]
    TimestampNotFinite { found: String },
    #[error(
        "timestamp {} s does not come after the previous frame's {} s; expected increasing \
         timestamps",
        seconds_text(*.value),
        seconds_text(*.previous)
    )]
    NotIncreasing { previous: f64, value: f64 },
    #[error(
        "the timestamps step by {} s (the median step), but meta/info.json's fps {fps} \
         means {} s; expected within {tolerance_percent} % of it",
        seconds_text(*.median),
        seconds_text(*.expected)
    )]
    FpsMismatch {
        fps: f64,
        median: f64,
        expected: f64,
        tolerance_percent: f64,
    },
    #[error(
        "timestamp {} s is {} s after the previous frame's {} s, {periods:.1} frame periods at \
         fps {fps}; expected at most {max} (frames missing, or a corrupt timestamp)",
        seconds_text(*.value),
        seconds_text(*.step),
        seconds_text(*.previous)
    )]
    Gap {
        previous: f64,
        value: f64,
        step: f64,
        periods: f64,
        fps: f64,
        max: f64,
    },
    #[error(
        "{field} {name} is {shown} {unit} as joint {joint}, outside its limits {min} … {max} \
         {unit} by more than the tolerance ({slack} {unit}); give --clip to clip such values \
         to the limits",
        shown = number_text(*.value)
    )]
    OutsideLimits {
        field: String,
        name: String,
        joint: String,
        value: f64,
        min: f64,
        max: f64,
        unit: &'static str,
        slack: f64,
    },
}

/// A number for messages: as Rust writes it, but in exponent form from 10⁷ on (a corrupt
/// 1e30 reads as such, not as 31 digits).
pub fn number_text(value: f64) -> String {
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
