//! What the state machine asks of its drivers and what they report back. The state never
//! touches the servos or a file itself: it emits [`Command`]s, the session driver carries out
//! the bus ones and [`super::files`] the file ones, and each answers with [`Event`]s.

use super::files::FileError;
use super::journal::Journal;
use super::motion::{MotionKind, MotionPlan};
use super::session::MotionError;
use crate::player::Outcome;
use crate::sequence::Sequence;
use std::path::PathBuf;

/// What the state asks for: of the servos, or of the file system.
#[derive(Debug, Clone)]
pub enum Command {
    Bus(BusCommand),
    File(FileCommand),
}

/// What the session asks of the servos. Joint indices are in robot order.
#[derive(Debug, Clone)]
pub enum BusCommand {
    /// On: hold these joints where they are now (goal = present, then torque on). Off: limp.
    Torque { joints: Vec<usize>, on: bool },
    /// Run the player (safe approach ramp, then the trajectory) while keys are still read: a
    /// move to a key, playback, or a jog.
    Run(Box<MotionPlan>),
    /// Stop the running motion: the first request decelerates along the path, a second holds
    /// at once. `requests` counts this one: a stop already requested by a quicker path (the
    /// studio's HTTP thread, a signal) is not requested twice.
    Stop { requests: u32 },
}

/// What the session asks of the file system; each is answered by one [`Event`].
#[derive(Debug, Clone)]
pub enum FileCommand {
    /// Read the sequence file at this path (an import): [`Event::Loaded`].
    Load(PathBuf),
    /// Write `sequence` atomically to `path` (`w`): [`Event::Saved`].
    Save { path: PathBuf, sequence: Sequence },
    /// Write the whole list to the journal (after every edit): [`Event::Journaled`].
    Journal {
        journal: Journal,
        sequence: Sequence,
    },
    /// Remove a journal: [`Event::JournalCleared`].
    ClearJournal { journal: Journal, why: Clearing },
}

/// Why a journal is removed, which decides what its failure means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clearing {
    /// The list was just written to the journal's target: a failure is worth a note.
    Written,
    /// A save-as moved the target: the old journal holds nothing the new file lacks, so a
    /// failure does not matter.
    Moved,
    /// The session ends, with nothing unsaved or the user's choice to discard it.
    Quit,
}

/// What the drivers report back. File errors arrive as their messages.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The present pose, in robot joint order.
    Reading(Vec<f64>),
    /// Torque came on; the joints hold at these values.
    Held {
        joints: Vec<usize>,
        values: Vec<f64>,
    },
    Released {
        joints: Vec<usize>,
    },
    MotionStarted {
        kind: MotionKind,
        end_pose: Vec<f64>,
        /// The joints it drives (robot order).
        joints: Vec<usize>,
    },
    /// The player returned; every joint has torque on. `last_goals` is the last pose it
    /// commanded, when known.
    MotionEnded {
        outcome: Result<Outcome, MotionError>,
        last_goals: Option<Vec<f64>>,
        /// What the player warned of, as `keypose play` says it: stalls (the motion ran late,
        /// by how much), the step limiter holding goals back.
        warnings: Vec<String>,
    },
    BusError(String),
    Loaded {
        path: PathBuf,
        result: Result<Sequence, FileError>,
    },
    Saved {
        path: PathBuf,
        result: Result<(), FileError>,
    },
    Journaled(Result<(), FileError>),
    JournalCleared {
        why: Clearing,
        result: Result<(), FileError>,
    },
}
