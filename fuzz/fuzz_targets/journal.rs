//! The teach session's journal and files: the teach state machine of a built-in robot on an
//! in-process virtual bus, driven by fuzzed keys — typed text of any characters into the
//! name, hold and value prompts among them — its journal, saves and imports carried out for
//! real in a directory of its own (`teach::files`); and first, when the first byte says so,
//! a journal file of fuzzed bytes found at start and recovered.
//! Property: no panic; a journal of any bytes is offered or refused with an error naming it;
//! every sequence the session writes (to its journal after each edit, undo and redo, with the
//! whole undo history; to its file on `w`) loads back as written, so a crash loses nothing the
//! journal held.
#![no_main]

use keypose::sequence::{KeyframeList, Sequence};
use keypose::teach::{
    files, BusCommand, Command, Entry, Event, FileCommand, Journal, Key, Session, TeachState,
};
use keypose::testing::VirtualBus;
use keypose_fuzz::{builtin_robot, Choices};
use libfuzzer_sys::fuzz_target;
use std::collections::VecDeque;
use std::path::Path;

/// Presses per input (no motion runs, so each is quick).
const MAX_STEPS: usize = 64;

const KEYS: &[Key] = &[
    Key::Undo,
    Key::Redo,
    Key::Up,
    Key::Down,
    Key::Enter,
    Key::Esc,
    Key::Backspace,
    Key::Interrupt,
];
/// The bindings that edit, name, save, import and quit; digits, signs and points for values.
const CHARS: &str = "undKN><.,][hvpmMURiw+-tTqy0123456789e ";

/// A sequence as saved: without where its keys stood in a file it was read from, nor the
/// file's name.
fn content(sequence: &Sequence) -> Sequence {
    let mut sequence = sequence.clone();
    sequence.file = String::new();
    for key in &mut sequence.keyframes {
        key.source_index = None;
    }
    sequence
}

/// `sequence` was just written to `path`: it loads back the same.
fn reads_back(path: &Path, sequence: &Sequence, what: &str) {
    let read = Sequence::load(path).unwrap_or_else(|e| {
        panic!(
            "the {what} written does not load: {e}\n{}",
            sequence.to_json()
        )
    });
    assert_eq!(
        content(&read),
        content(sequence),
        "the {what} loads back changed"
    );
}

/// The journal just written reads back as written: the list and every version of its history.
fn journal_reads_back(journal: &Journal, entry: &Entry) {
    let read = journal
        .read()
        .unwrap_or_else(|e| panic!("the journal written does not load: {e}"));
    let versions = |e: &Entry| -> Vec<(Sequence, usize)> {
        std::iter::once(&e.list)
            .chain(e.history.undo.iter().map(|s| &s.version))
            .chain(e.history.redo.iter().map(|s| &s.version))
            .map(|v| (content(&v.sequence), v.current))
            .collect()
    };
    assert_eq!(
        versions(&read),
        versions(entry),
        "the journal loads back changed"
    );
    let steps = |e: &Entry| -> Vec<(String, usize)> {
        (e.history.undo.iter().chain(&e.history.redo))
            .map(|s| (s.what.clone(), s.after))
            .collect()
    };
    assert_eq!(steps(&read), steps(entry), "the history loads back changed");
}

/// The state's commands carried out: the bus ones on the session (motions answered as a failed
/// start: they run in wall-clock time), the file ones for real, each write read back.
fn apply(state: &mut TeachState, session: &mut Session, commands: Vec<Command>) {
    let mut queue = VecDeque::from(commands);
    while let Some(command) = queue.pop_front() {
        let events = match command {
            Command::Bus(BusCommand::Run(_)) => {
                vec![Event::BusError("motions are not run while fuzzing".into())]
            }
            Command::Bus(command) => session.execute(command),
            Command::File(FileCommand::Journal { journal, entry }) => {
                let event = files::execute(FileCommand::Journal {
                    journal: journal.clone(),
                    entry: entry.clone(),
                });
                assert_eq!(event, Event::Journaled(Ok(())));
                if !entry.list.sequence.keyframes.is_empty() {
                    journal_reads_back(&journal, &entry);
                }
                vec![event]
            }
            Command::File(FileCommand::Save { path, sequence }) => {
                let event = files::execute(FileCommand::Save {
                    path: path.clone(),
                    sequence: sequence.clone(),
                });
                if let Event::Saved { result: Ok(()), .. } = &event {
                    reads_back(&path, &sequence, "file");
                }
                vec![event]
            }
            Command::File(command) => vec![files::execute(command)],
        };
        for event in events {
            queue.extend(state.on_event(event));
        }
    }
}

/// The next key: a key, a binding, or a character of any code point typed into a prompt.
fn key(choices: &mut Choices) -> Key {
    let b = choices.byte();
    match b {
        0..=7 => KEYS[usize::from(b)].clone(),
        8..=199 => {
            let chars: Vec<char> = CHARS.chars().collect();
            Key::Char(chars[usize::from(b) % chars.len()])
        }
        _ => {
            let code =
                u32::from_le_bytes([choices.byte(), choices.byte(), choices.byte() % 0x11, 0]);
            Key::Char(char::from_u32(code).unwrap_or('\u{fffd}'))
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let mode = choices.byte();
    let robot = builtin_robot(mode >> 1);
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("taught.json");
    let journal = Journal::for_target(dir.path(), &output);
    let (bus, _virtual_bus) = VirtualBus::in_process(robot);
    let mut session = Session::new(Box::new(bus), robot);
    let present = session.read().unwrap().unwrap();
    let mut state = TeachState::new(
        robot.clone(),
        KeyframeList::new(Sequence::new(&robot.name)),
        output.clone(),
        Some(journal.clone()),
        present,
    );
    if mode & 1 == 1 {
        // A journal left behind: whatever its bytes, it is offered or refused by name.
        let length = usize::from(choices.byte()) * 8;
        std::fs::create_dir_all(journal.path().parent().unwrap()).unwrap();
        std::fs::write(journal.path(), choices.take(length)).unwrap();
        match journal.pending(&output) {
            Ok(Some(pending)) => state.offer_recovery(pending),
            Ok(None) => panic!("a journal without its target is always offered"),
            Err(e) => assert_eq!(e.file, journal.path().display().to_string()),
        }
    }
    let start = state.start();
    apply(&mut state, &mut session, start);
    // A second target for a save-as (`Key::Write`), an import of the session's own file.
    let other = dir.path().join("other.json");
    for _ in 0..MAX_STEPS {
        if choices.is_empty() || state.should_quit() {
            break;
        }
        let key = match choices.byte() % 16 {
            0 => Key::Write(other.clone()),
            1 => Key::Import(output.clone()),
            _ => key(&mut choices),
        };
        let commands = state.handle_key(key);
        apply(&mut state, &mut session, commands);
    }
});
