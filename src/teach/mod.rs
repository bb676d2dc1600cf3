//! The key-by-key teaching session: jog or limp the arm, capture keys, edit the list, play it,
//! write it.
//!
//! Three layers, so that the rules are tested without a terminal or servos:
//! - [`state`]: the [`TeachState`] machine — keys and bus events in; list edits, bus
//!   [`Command`]s and screen state out;
//! - [`session`]: carries out the commands on a [`crate::bus::ServoBus`], playback through the
//!   player on its own thread;
//! - the front ends: [`ui`] draws the state in a terminal (ratatui + crossterm) and maps key
//!   presses; [`script`] feeds it the keys of a `--keys` file, for tests and demos.
//!
//! Every edit is journaled ([`journal`]) so a crash loses nothing.

pub mod journal;
pub mod keys;
pub mod script;
pub mod session;
pub mod state;
pub mod ui;

pub use journal::{Journal, Pending};
pub use keys::{help_text, Key, BINDINGS};
pub use session::{Session, SessionError};
pub use state::{Command, Event, Prompt, TeachState};

/// What ends a session early.
#[derive(Debug, thiserror::Error)]
pub enum TeachError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error("terminal: {0}")]
    Terminal(#[from] std::io::Error),
    /// A `--keys` script that cannot be run as written.
    #[error("{0}")]
    Script(String),
    /// The servos failed during a scripted step.
    #[error("{0}")]
    Hardware(String),
}

/// Carries out `commands`, feeding every resulting event back into the state; returns the
/// events for callers that judge them (the script stops on a bus failure).
pub fn apply(state: &mut TeachState, session: &mut Session, commands: Vec<Command>) -> Vec<Event> {
    let mut seen = Vec::new();
    for command in commands {
        for event in session.execute(command) {
            seen.push(event.clone());
            state.on_event(event);
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
    state.on_event(event.clone());
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
