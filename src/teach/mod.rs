//! The key-by-key teaching session: jog or limp the arm, capture keys, edit the list, play it,
//! write it.
//!
//! Three layers, so that the rules are tested without a terminal, servos or files:
//! - [`state`]: the [`TeachState`] machine — keys and driver events in; list edits,
//!   [`Command`]s ([`messages`]) and screen state out; [`motion`] plans what `space` and `y`
//!   play, [`capture`] rounds a pose into a key, [`prompt`] holds the questions;
//! - the drivers: [`session`] carries out the bus commands on a [`crate::bus::ServoBus`],
//!   playback through the player on its own thread; [`files`] carries out the file ones;
//! - the front ends: the binary's terminal UI (`src/commands/teach/ui.rs`, ratatui +
//!   crossterm) draws the state and maps key presses, the studio does so in a browser;
//!   [`script`] feeds the keys of a `--keys` file, for tests and demos; all word things through
//!   [`format`]. The terminal and the studio queue what arrives in
//!   [`inputs::InputQueue`], where a stop wins over everything queued before it.
//!
//! Every edit is journaled ([`journal`]) so a crash loses nothing.

pub mod capture;
pub mod files;
pub mod format;
pub mod inputs;
pub mod journal;
pub mod keys;
pub mod messages;
pub mod motion;
pub mod prompt;
pub mod script;
pub mod session;
pub mod state;

pub use journal::{Journal, Pending};
pub use keys::{help_text, Key, BINDINGS};
pub use messages::{BusCommand, Command, Event, FileCommand};
pub use prompt::Prompt;
pub use session::{Brake, BusCommandError, Session, SessionError};
pub use state::TeachState;

/// What ends a session early.
#[derive(Debug, thiserror::Error)]
pub enum TeachError {
    #[error(transparent)]
    Session(#[from] SessionError),
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
