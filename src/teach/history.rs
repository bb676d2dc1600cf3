//! Undo and redo of the list's edits: before each edit the list as it was (its keys and its
//! current key) goes on the undo stack with what the edit was; undoing puts it back and moves
//! the list it replaces onto the redo stack, and the next edit empties that. The stacks are
//! pure data, owned by the state ([`super::TeachState`]) and written with the list to the
//! journal, so every front end shares them and a crash keeps them.
//!
//! A version is the whole list rather than the edit's inverse: every edit (a capture, a
//! delete, a mirror of every key, an import) undoes the same way, and a teaching list is a
//! few kilobytes, so [`DEPTH`] of them stay small.

use crate::sequence::Sequence;

/// How many edits can be undone; older ones are forgotten.
pub const DEPTH: usize = 100;

/// The list at one point of its history.
#[derive(Debug, Clone, PartialEq)]
pub struct Version {
    /// Its keys and settings.
    pub sequence: Sequence,
    /// Its current key (0 when it has none).
    pub current: usize,
}

/// One step of the history: the edit, and the version of the list undoing (or redoing) it
/// goes back (or forward) to.
#[derive(Debug, Clone, PartialEq)]
pub struct Edit {
    /// What the edit did, as the status line said it ("deleted key 3 (7 left)").
    pub what: String,
    /// The list to go to.
    pub version: Version,
    /// The current key the edit left (what a redo makes current again, wherever the user
    /// went since).
    pub after: usize,
}

/// The steps that can be undone (oldest first) and redone (the next one last).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct History {
    /// What undo goes back to, the most recent edit last; at most [`DEPTH`].
    pub undo: Vec<Edit>,
    /// What redo goes forward to, the next one last.
    pub redo: Vec<Edit>,
}

impl History {
    /// An edit `what` was made to `before`, leaving key `after` current: it can be undone,
    /// and nothing undone earlier can be redone any more.
    pub fn record(&mut self, what: String, before: Version, after: usize) {
        self.redo.clear();
        self.undo.push(Edit {
            what,
            version: before,
            after,
        });
        if self.undo.len() > DEPTH {
            self.undo.remove(0);
        }
    }

    /// Undoes the most recent edit of `now`: the step to go back to, with `now` kept for redo;
    /// `None` when there is nothing to undo.
    pub fn undo(&mut self, now: Version) -> Option<Edit> {
        let step = self.undo.pop()?;
        self.redo.push(Edit {
            what: step.what.clone(),
            version: Version {
                current: step.after,
                ..now
            },
            after: step.version.current,
        });
        Some(step)
    }

    /// Redoes the edit undone last: the step to go forward to, with `now` kept for undo;
    /// `None` when there is nothing to redo.
    pub fn redo(&mut self, now: Version) -> Option<Edit> {
        let step = self.redo.pop()?;
        self.undo.push(Edit {
            what: step.what.clone(),
            version: now,
            after: step.version.current,
        });
        Some(step)
    }

    /// What undo would undo next.
    pub fn next_undo(&self) -> Option<&str> {
        self.undo.last().map(|s| s.what.as_str())
    }

    /// What redo would redo next.
    pub fn next_redo(&self) -> Option<&str> {
        self.redo.last().map(|s| s.what.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn version(robot: &str, current: usize) -> Version {
        Version {
            sequence: Sequence::new(robot),
            current,
        }
    }

    #[test]
    fn undo_then_redo_walks_back_and_forth_and_an_edit_forgets_the_redo() {
        let mut history = History::default();
        history.record("first".into(), version("a", 0), 1);
        history.record("second".into(), version("b", 1), 2);
        // Now at "c" (key 5 selected since): undo goes to b, then a; redo comes back to b,
        // then c, each with the key its edit left current.
        let back = history.undo(version("c", 5)).unwrap();
        assert_eq!((back.what.as_str(), back.version.current), ("second", 1));
        let back = history.undo(back.version).unwrap();
        assert_eq!((back.what.as_str(), back.version.current), ("first", 0));
        assert!(history.undo(back.version.clone()).is_none());
        let forward = history.redo(back.version).unwrap();
        assert_eq!(
            (forward.what.as_str(), forward.version.current),
            ("first", 1)
        );
        assert_eq!(forward.version.sequence.robot, "b");
        let again = history.undo(forward.version.clone()).unwrap();
        assert_eq!(
            (again.version.sequence.robot.as_str(), again.version.current),
            ("a", 0)
        );
        let forward = history.redo(again.version).unwrap();
        assert_eq!(history.next_redo(), Some("second"));
        history.record("third".into(), forward.version, 3);
        assert_eq!(history.next_redo(), None, "a new edit ends the redo");
        assert_eq!(history.next_undo(), Some("third"));
    }

    #[test]
    fn the_oldest_edit_goes_past_the_depth() {
        let mut history = History::default();
        for i in 0..DEPTH + 5 {
            history.record(format!("edit {i}"), version("a", i), i + 1);
        }
        assert_eq!(history.undo.len(), DEPTH);
        assert_eq!(history.undo[0].what, "edit 5");
        assert_eq!(
            history.next_undo(),
            Some(format!("edit {}", DEPTH + 4).as_str())
        );
    }
}
