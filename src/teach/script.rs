//! `--keys FILE`: the session driven by a script of keys instead of a terminal — the same state
//! machine and bus code, no drawing. Each step waits until the arm has done what the key asked
//! (a motion has ended, a jog has reached its goal), so a script gives the same file on any
//! machine; the status after each step goes to the echo (standard error).
//!
//! The script is strict where a terminal user would simply look again: a key sent while the
//! session waits for an answer, or a bus failure, stops it with an error.

use super::format;
use super::keys::{parse_line, Key, Step};
use super::messages::Event;
use super::{apply, press, refresh, Session, TeachError, TeachState};
use std::io::{BufRead, Write};
use std::time::Duration;

/// Longest wait for a jogged joint to reach its goal; past it the step goes on with a warning
/// (a real servo under load may never read its exact goal tick).
const SETTLE_TIMEOUT: Duration = Duration::from_secs(5);

/// Runs the script read from `input`, line by line as it arrives (so `-` can be fed from a
/// pipe), writing one status line per step to `echo`.
pub fn run(
    state: &mut TeachState,
    session: &mut Session,
    input: impl BufRead,
    echo: &mut impl Write,
) -> Result<(), TeachError> {
    // The start's hold may move a joint by up to a tick; let it arrive before the first step.
    if let Err(e) = session.settle(SETTLE_TIMEOUT) {
        return Err(TeachError::Hardware(format!(
            "cannot read the present pose: {e}"
        )));
    }
    refresh(state, session);
    show(echo, "start", state);
    let mut step_number = 0;
    for (line_number, line) in input.lines().enumerate() {
        let line =
            line.map_err(|e| TeachError::Script(format!("cannot read the key script: {e}")))?;
        let steps = parse_line(&line)
            .map_err(|e| TeachError::Script(format!("key script line {}: {e}", line_number + 1)))?;
        for (token, step) in steps {
            step_number += 1;
            let where_ = format!(
                "key script line {}, step {step_number} ({token})",
                line_number + 1
            );
            match step {
                Step::Wait(duration) => {
                    std::thread::sleep(duration);
                    refresh(state, session);
                }
                Step::Key(key) => run_key(state, session, key, &where_)?,
            }
            show(echo, &token, state);
            if state.should_quit() {
                return Ok(());
            }
        }
    }
    end(state, session)
}

/// The end of the script is the end of the session, as closing the terminal would be: an
/// error while a question is open or work is unsaved, else a clean `q`.
fn end(state: &mut TeachState, session: &mut Session) -> Result<(), TeachError> {
    if let Some(question) = format::question(state) {
        return Err(TeachError::Script(format!(
            "the key script ended while the session asks: {question}"
        )));
    }
    if state.is_dirty() {
        let journal = state
            .journal()
            .map(|j| format!(" (kept in the journal {})", j.path().display()))
            .unwrap_or_default();
        return Err(TeachError::Script(format!(
            "the key script ended with unsaved changes{journal}: end it with w (and q)"
        )));
    }
    // Not dirty: a clean end, like `q` (which removes the journal).
    let commands = state.handle_key(Key::Char('q'));
    apply(state, session, commands);
    Ok(())
}

fn run_key(
    state: &mut TeachState,
    session: &mut Session,
    key: Key,
    where_: &str,
) -> Result<(), TeachError> {
    if let Some(prompt) = state.prompt() {
        if !prompt.accepts(&key) {
            return Err(TeachError::Script(format!(
                "{where_}: the session asks \"{}\"; expected an answer (yes or no)",
                format::question(state).unwrap_or_default()
            )));
        }
    }
    let mut events = press(state, session, key);
    // Wait for the motion the key started, so the next step sees the arm at rest.
    if let Some(ended) = session.wait_motion()? {
        events.push(ended.clone());
        let follow = state.on_event(ended);
        events.extend(apply(state, session, follow));
    }
    let commanded = events
        .iter()
        .any(|e| matches!(e, Event::Held { .. } | Event::MotionEnded { .. }));
    if commanded {
        match session.settle(SETTLE_TIMEOUT) {
            Ok(true) => {}
            Ok(false) => eprintln!(
                "warning: {where_}: the arm did not reach its goal within {} s",
                SETTLE_TIMEOUT.as_secs()
            ),
            Err(e) => events.push(Event::BusError(e.to_string())),
        }
        refresh(state, session);
    }
    match events.iter().find_map(failure) {
        Some(message) => Err(TeachError::Hardware(format!("{where_}: {message}"))),
        None => Ok(()),
    }
}

/// What a script stops on: a bus failure, or a motion that ended in a fault.
fn failure(event: &Event) -> Option<String> {
    match event {
        Event::BusError(message) => Some(message.clone()),
        Event::MotionEnded {
            outcome: Err(e), ..
        } => Some(crate::error::Report(e).to_string()),
        _ => None,
    }
}

/// One line per step: the status, or the question the session now asks.
fn show(echo: &mut impl Write, token: &str, state: &TeachState) {
    let line = match format::question(state) {
        Some(question) => format!("teach: {token}: ? {question}"),
        None => {
            let status = state.status();
            let mark = if status.error { "error: " } else { "" };
            format!("teach: {token}: {mark}{}", status.text)
        }
    };
    // The echo is a progress report; a closed standard error must not stop the session.
    let _ = writeln!(echo, "{}", crate::terminal_text::escape_controls(&line));
    let _ = echo.flush();
}
