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
