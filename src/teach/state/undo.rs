//! Undo and redo in teaching: `U` (Ctrl+Z in the page) puts the list back as it was before the
//! last edit, `R` (Ctrl+Shift+Z, Ctrl+Y) makes the edit again. Only the list changes: the arm
//! stays where it is (`space` moves it to the key, as after any edit), and the history is
//! journaled with the list, so a session recovered after a crash undoes as before.

use super::*;
use crate::teach::history::Version;

impl TeachState {
    /// What undo and redo can go back and forward to.
    pub fn history(&self) -> &History {
        &self.history
    }

    /// The list as it is now, for the history.
    pub(super) fn version(&self) -> Version {
        Version {
            sequence: self.list.sequence().clone(),
            current: self.list.current_index(),
        }
    }

    /// Every edit ends here: the list as it was before goes into the history, and the journal
    /// gets the list and the history, so a crash loses nothing.
    pub(super) fn edited(&mut self) -> Vec<Command> {
        let now = self.version();
        let before = std::mem::replace(&mut self.last, now);
        let after = self.list.current_index();
        self.history.record(self.status.text.clone(), before, after);
        self.journal_now()
    }

    pub(super) fn undo(&mut self) -> Vec<Command> {
        match self.history.undo(self.version()) {
            Some(step) => self.go_to(step.version, format!("undid: {} (R redoes)", step.what)),
            None => self.fail("nothing to undo"),
        }
    }

    pub(super) fn redo(&mut self) -> Vec<Command> {
        match self.history.redo(self.version()) {
            Some(step) => self.go_to(step.version, format!("redid: {} (U undoes)", step.what)),
            None => self.fail("nothing to redo"),
        }
    }

    /// Puts `version` in place of the list: it is unsaved (the file holds something else, or
    /// at best the same) and journaled. The file it names stays the session's.
    fn go_to(&mut self, version: Version, message: String) -> Vec<Command> {
        let Version {
            mut sequence,
            current,
        } = version;
        sequence.file = self.list.sequence().file.clone();
        self.list.restore(sequence, current);
        self.last = self.version();
        self.info(message);
        self.journal_now()
    }

    /// The journal's copy of the list and its history, made now.
    fn journal_now(&self) -> Vec<Command> {
        match &self.journal {
            Some(journal) => file(FileCommand::Journal {
                journal: journal.clone(),
                entry: Entry {
                    list: self.version(),
                    history: self.history.clone(),
                },
            }),
            None => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests;
