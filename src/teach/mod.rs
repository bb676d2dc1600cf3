//! The key-by-key teaching session: jog or limp the arm, capture keys, edit the list, play it,
//! write it.
//!
//! Three layers, so that the rules are tested without a terminal, servos or files:
//! - the state: the [`TeachState`] machine — [`Key`]s and driver [`Event`]s in; list edits,
//!   [`Command`]s and screen state out; it plans what `space` and `y` play ([`MotionPlan`]),
//!   rounds a pose into a key, and holds the questions ([`Prompt`]);
//! - the drivers: the [`Session`] carries out the bus commands on a
//!   [`crate::bus::ServoBus`], playback through the player on its own thread (with no arm
//!   attached, on a [`DrawnArm`]: the same motions, drawn only); [`files`] carries out the
//!   file ones;
//! - the front ends: the binary's terminal UI (`src/commands/teach/ui.rs`, ratatui +
//!   crossterm) draws the state and maps key presses, the studio does so in a browser;
//!   [`script`] feeds the keys of a `--keys` file, for tests and demos; all word things
//!   through [`format`](mod@format). The terminal and the studio queue what arrives in an
//!   [`InputQueue`], where a stop wins over everything queued before it.
//!
//! Every edit can be undone and redone ([`History`], kept by the state) and is journaled with
//! that history ([`Journal`]) so a crash loses nothing.

mod capture;
mod drawn;
pub mod files;
pub mod format;
mod history;
mod inputs;
mod journal;
mod keys;
mod messages;
mod motion;
mod prompt;
mod robot_file;
pub mod script;
mod session;
mod state;

pub use drawn::DrawnArm;
pub use history::{Edit, History, Version, DEPTH as UNDO_DEPTH};
pub use inputs::{Input, InputQueue, MAX_WAITING};
pub use journal::{Entry, Journal, Pending, JOURNAL_FORMAT};
pub use keys::{help_text, Binding, Key, BINDINGS};
pub(crate) use keys::{parse_token, Step, TokenError};
pub use messages::{BusCommand, Clearing, Command, Event, FileCommand};
pub(crate) use motion::{key_poses, pose_contacts};
pub use motion::{MotionKind, MotionPlan};
pub use prompt::{Field, Prompt};
pub(crate) use session::panic_message;
pub use session::{Brake, BusCommandError, MotionError, Session, SessionError};
pub(crate) use state::selected_tool;
pub use state::{tool_positions, Activity, DirectionRecord, Status, TeachState};

/// What ends a session early.
#[derive(Debug, thiserror::Error)]
pub enum TeachError {
    /// The servos were lost with a motion thread.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The terminal cannot be read or drawn on.
    #[error("terminal")]
    Terminal(#[from] std::io::Error),
    /// A `--keys` script that cannot be run as written.
    #[error("{0}")]
    Script(String),
    /// The servos failed during a scripted step.
    #[error("{0}")]
    Hardware(String),
}

impl TeachError {
    /// What kind of failure this is: a terminal that cannot be used or a script that cannot
    /// be run is bad input; a lost bus is the hardware's.
    pub fn kind(&self) -> crate::error::ErrorKind {
        match self {
            TeachError::Terminal(_) | TeachError::Script(_) => crate::error::ErrorKind::BadInput,
            TeachError::Session(_) | TeachError::Hardware(_) => crate::error::ErrorKind::Hardware,
        }
    }
}

/// Carries out `commands` (bus ones on the session, file ones by [`files`]), feeding every
/// resulting event back into the state and carrying out what the state asks in return (a
/// write is followed by the journal's removal); returns the events for callers that judge
/// them (the script stops on a bus failure).
pub fn apply(state: &mut TeachState, session: &mut Session, commands: Vec<Command>) -> Vec<Event> {
    let mut queue = std::collections::VecDeque::from(commands);
    let mut seen = Vec::new();
    while let Some(command) = queue.pop_front() {
        let events = match command {
            Command::Bus(command) => session.execute(command),
            Command::File(command) => vec![files::execute(command)],
        };
        for event in events {
            seen.push(event.clone());
            queue.extend(state.on_event(event));
        }
    }
    seen
}

/// Reads the present pose into the state; a failed read shows on the status line.
pub fn refresh(state: &mut TeachState, session: &mut Session) -> Option<Event> {
    let event = match session.read() {
        Ok(Some(values)) => Event::Reading(values),
        Ok(None) => return None,
        Err(e) => Event::BusError(format!("cannot read the present pose: {e}")),
    };
    let follow = state.on_event(event.clone());
    apply(state, session, follow);
    Some(event)
}

/// Feeds a key to the state with a fresh reading first (a capture must see where the arm is
/// now, not 50 ms ago), then carries out what it asks.
pub fn press(state: &mut TeachState, session: &mut Session, key: Key) -> Vec<Event> {
    let mut events: Vec<Event> = refresh(state, session).into_iter().collect();
    let commands = state.handle_key(key);
    events.extend(apply(state, session, commands));
    events
}
