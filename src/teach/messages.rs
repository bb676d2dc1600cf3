//! What the state machine asks of its drivers and what they report back. The state never
//! touches the servos or a file itself: it emits [`Command`]s, the session driver carries out
//! the bus ones and [`super::files`] the file ones, and each answers with [`Event`]s.

use super::files::FileError;
use super::journal::{Entry, Journal};
use super::motion::{MotionKind, MotionPlan};
use super::session::MotionError;
use crate::player::Outcome;
use crate::sequence::Sequence;
use std::path::PathBuf;

/// What the state asks for: of the servos, or of the file system.
#[derive(Debug, Clone)]
pub enum Command {
    /// For the session driver ([`super::Session::execute`]).
    Bus(BusCommand),
    /// For [`super::files::execute`].
    File(FileCommand),
}

/// What the session asks of the servos. Joint indices are in robot order.
#[derive(Debug, Clone)]
pub enum BusCommand {
    /// On: hold these joints where they are now (goal = present, then torque on). Off: limp.
    Torque {
        /// The joints to hold or release.
        joints: Vec<usize>,
        /// Hold (true) or release (false).
        on: bool,
    },
    /// Run the player (safe approach ramp, then the trajectory) while keys are still read: a
    /// move to a key, playback, or a jog.
    Run(Box<MotionPlan>),
    /// Stop the running motion: the first request decelerates along the path, a second holds
    /// at once. `requests` counts this one: a stop already requested by a quicker path (the
    /// studio's HTTP thread, a signal) is not requested twice.
    Stop {
        /// Stop requests of this motion so far, this one included.
        requests: u32,
    },
    /// The direction check found `joint` reversed: map its ticks the other way from now on
    /// (the servo mapping's `direction` flips; the servos are not written).
    Reverse {
        /// The joint (robot order).
        joint: usize,
    },
}

/// What the session asks of the file system; each is answered by one [`Event`].
#[derive(Debug, Clone)]
pub enum FileCommand {
    /// Read the sequence file at this path (an import): [`Event::Loaded`].
    Load(PathBuf),
    /// Write `sequence` atomically to `path` (`w`): [`Event::Saved`].
    Save {
        /// The file to write.
        path: PathBuf,
        /// The list as it is now.
        sequence: Sequence,
    },
    /// Write the whole list and its undo history to the journal (after every edit, undo and
    /// redo): [`Event::Journaled`].
    Journal {
        /// The session's journal.
        journal: Journal,
        /// The list as it is now, and its history.
        entry: Entry,
    },
    /// Write a joint's servo direction into the robot file the session uses (the direction
    /// check): [`Event::DirectionWritten`].
    WriteDirection {
        /// The robot file.
        path: PathBuf,
        /// The joint's index (robot order), for the answer.
        joint: usize,
        /// The joint's name in the file.
        name: String,
        /// The direction to write: 1 or -1.
        direction: i8,
    },
    /// Remove a journal: [`Event::JournalCleared`].
    ClearJournal {
        /// The journal to remove.
        journal: Journal,
        /// Why, which decides what a failure means.
        why: Clearing,
    },
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

/// What the drivers report back.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The present pose, in robot joint order.
    Reading(Vec<f64>),
    /// Torque came on; the joints hold at these values.
    Held {
        /// The joints now held (robot order).
        joints: Vec<usize>,
        /// Each one's goal, in its unit (degrees or metres).
        values: Vec<f64>,
    },
    /// Torque went off: these joints are limp.
    Released {
        /// The joints released (robot order).
        joints: Vec<usize>,
    },
    /// The player's thread started a motion.
    MotionStarted {
        /// What the motion is for.
        kind: MotionKind,
        /// Where it ends when it finishes, every joint in robot order.
        end_pose: Vec<f64>,
        /// The joints it drives (robot order).
        joints: Vec<usize>,
    },
    /// The player returned; every joint has torque on. `last_goals` is the last pose it
    /// commanded, when known.
    MotionEnded {
        /// How it ended: finished, stopped or held, or the fault that ended it.
        outcome: Result<Outcome, MotionError>,
        /// The last pose commanded, every joint in robot order; `None` when not known.
        last_goals: Option<Vec<f64>>,
        /// What the player warned of, as `keypose play` says it: stalls (the motion ran late,
        /// by how much), the step limiter holding goals back.
        warnings: Vec<String>,
    },
    /// A bus command or a read failed: what went wrong, for the status line.
    BusError(String),
    /// An import ([`FileCommand::Load`]) ended.
    Loaded {
        /// The file read.
        path: PathBuf,
        /// The sequence read, or why it could not be.
        result: Result<Sequence, FileError>,
    },
    /// A write ([`FileCommand::Save`]) ended.
    Saved {
        /// The file written.
        path: PathBuf,
        /// Whether it was written.
        result: Result<(), FileError>,
    },
    /// A joint's direction was written to the robot file (or could not be).
    DirectionWritten {
        /// The joint (robot order).
        joint: usize,
        /// The robot file.
        path: PathBuf,
        /// Whether it was written.
        result: Result<(), FileError>,
    },
    /// The journal was written (or could not be).
    Journaled(Result<(), FileError>),
    /// The journal was removed (or could not be).
    JournalCleared {
        /// Why it was removed.
        why: Clearing,
        /// Whether it was removed.
        result: Result<(), FileError>,
    },
}
