//! Leaving a session: a stop is never swallowed by a question, and unsaved work is asked
//! about — written (`w`), dropped (`y`) or kept by staying (`n`).

use super::{Command, Key, Prompt, TeachState};

impl TeachState {
    /// Esc or Ctrl-C while the arm moves: the arm brakes first, whatever question is open.
    /// Ctrl-C with unsaved changes then asks what to do with them (the question comes after
    /// the stop, never instead of it); an open question stays open.
    pub(super) fn stop_then_ask(&mut self, key: Key) -> Vec<Command> {
        let commands = self.stop();
        if key == Key::Interrupt && self.prompt.is_none() && self.is_dirty() {
            self.prompt = Some(Prompt::Quit);
        }
        commands
    }
}

/// The quit question's own answers: `w` writes the file and quits once it is written; a
/// `y` while the arm still brakes waits for it. `None` leaves the key to the yes/no answers.
pub(super) fn answer(state: &mut TeachState, key: &Key) -> Option<Vec<Command>> {
    match key {
        Key::Char('w') => {
            state.quit_after_write = true;
            let commands = state.write(None);
            if commands.is_empty() {
                state.quit_after_write = false;
            }
            Some(commands)
        }
        Key::Char('y' | 'Y') if state.is_moving() => {
            state.prompt = Some(Prompt::Quit);
            Some(state.fail("the arm is still stopping: answer once it holds"))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests;
