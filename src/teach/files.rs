//! Carries out the state machine's [`FileCommand`]s: the only file I/O of a session after
//! its start, so that the rules in [`super::state`] stay free of it.

use super::messages::{Event, FileCommand};
use crate::sequence::Sequence;

/// Does what `command` asks and reports how it went.
pub fn execute(command: FileCommand) -> Event {
    match command {
        FileCommand::Load(path) => Event::Loaded {
            result: Sequence::load(&path).map_err(|e| e.to_string()),
            path,
        },
        FileCommand::Save { path, sequence } => Event::Saved {
            result: sequence.save(&path).map_err(|e| e.to_string()),
            path,
        },
        FileCommand::Journal { journal, sequence } => {
            Event::Journaled(journal.save(&sequence).map_err(|e| e.to_string()))
        }
        FileCommand::ClearJournal { journal, why } => Event::JournalCleared {
            why,
            result: journal.remove().map_err(|e| e.to_string()),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::teach::journal::tests::one_key;
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
        assert!(matches!(missing, Event::Loaded { result: Err(e), .. } if e.contains("none.json")));
    }

    #[test]
    fn the_journal_is_written_then_cleared() {
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        let written = execute(FileCommand::Journal {
            journal: journal.clone(),
            sequence: one_key(),
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
