//! Carries out the state machine's [`FileCommand`]s: the only file I/O of a session after
//! its start, so that the rules of the [`TeachState`] stay free of it.
//!
//! [`TeachState`]: super::TeachState

use super::messages::{Event, FileCommand};
use crate::error::Report;
use crate::json::InputError;
use crate::sequence::Sequence;
use std::io;
use std::path::PathBuf;
use std::sync::Arc;

/// Why a file command failed. The message says what the session could not do; the file's
/// own error is the source ([`Report`] says both). The I/O errors are shared so that the
/// [`Event`] that carries them can be cloned.
#[derive(Debug, Clone, thiserror::Error)]
pub enum FileError {
    /// The sequence file to import cannot be read, or is not a valid sequence.
    #[error("cannot import")]
    Load(#[source] InputError),
    /// The sequence cannot be written to its file (`w`).
    #[error("not written")]
    Save(#[source] InputError),
    /// The direction check's answer cannot be written into the robot file.
    #[error("the direction is not recorded")]
    Direction(#[source] InputError),
    /// The journal cannot be written after an edit.
    #[error("the journal {} cannot be written", path.display())]
    Journal {
        /// The journal's file.
        path: PathBuf,
        /// What the file system said.
        source: Arc<io::Error>,
    },
    /// The journal cannot be removed.
    #[error("cannot remove the journal")]
    ClearJournal(#[source] Arc<io::Error>),
}

/// Two failures are equal when they say the same ([`io::Error`] has no equality of its own).
impl PartialEq for FileError {
    fn eq(&self, other: &Self) -> bool {
        std::mem::discriminant(self) == std::mem::discriminant(other)
            && Report(self).to_string() == Report(other).to_string()
    }
}

/// Does what `command` asks and reports how it went.
pub fn execute(command: FileCommand) -> Event {
    match command {
        FileCommand::Load(path) => Event::Loaded {
            result: Sequence::load(&path).map_err(FileError::Load),
            path,
        },
        FileCommand::Save { path, sequence } => Event::Saved {
            result: sequence.save(&path).map_err(FileError::Save),
            path,
        },
        FileCommand::Journal { journal, entry } => {
            Event::Journaled(journal.save(&entry).map_err(|e| FileError::Journal {
                path: journal.path().to_path_buf(),
                source: Arc::new(e),
            }))
        }
        FileCommand::WriteDirection {
            path,
            joint,
            name,
            direction,
        } => Event::DirectionWritten {
            result: super::robot_file::write_direction(&path, &name, direction)
                .map_err(FileError::Direction),
            joint,
            path,
        },
        FileCommand::ClearJournal { journal, why } => Event::JournalCleared {
            why,
            result: journal
                .remove()
                .map_err(|e| FileError::ClearJournal(Arc::new(e))),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::teach::journal::tests::{entry, one_key};
    use crate::teach::journal::Journal;
    use crate::teach::messages::Clearing;

    #[test]
    fn a_saved_list_loads_back_and_a_missing_file_is_an_error_message() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.json");
        let saved = execute(FileCommand::Save {
            path: path.clone(),
            sequence: one_key(),
        });
        assert_eq!(
            saved,
            Event::Saved {
                path: path.clone(),
                result: Ok(())
            }
        );
        let Event::Loaded { result, .. } = execute(FileCommand::Load(path)) else {
            panic!("a load is answered by Loaded");
        };
        assert_eq!(result.unwrap().to_json(), one_key().to_json());
        let missing = execute(FileCommand::Load(dir.path().join("none.json")));
        let Event::Loaded { result: Err(e), .. } = missing else {
            panic!("a missing file is an error, got {missing:?}");
        };
        let said = Report(&e).to_string();
        assert!(said.starts_with("cannot import: "), "{said}");
        assert!(said.contains("none.json"), "{said}");
    }

    #[test]
    fn the_journal_is_written_then_cleared() {
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        let written = execute(FileCommand::Journal {
            journal: journal.clone(),
            entry: entry(one_key()),
        });
        assert_eq!(written, Event::Journaled(Ok(())));
        assert!(journal.path().exists());
        let cleared = execute(FileCommand::ClearJournal {
            journal: journal.clone(),
            why: Clearing::Quit,
        });
        assert_eq!(
            cleared,
            Event::JournalCleared {
                why: Clearing::Quit,
                result: Ok(())
            }
        );
        assert!(!journal.path().exists());
    }
}
