//! Undo and redo on the state machine alone: the oracle is the list as the test saw it before
//! and after each edit, never the history the state keeps.

use super::super::tests::{apply, journal_keys, press, press_all, session, type_line};
use super::*;
use crate::teach::history;

/// The list as the user sees it: its file text and its current key.
fn seen(state: &TeachState) -> (String, usize) {
    (
        state.list().sequence().to_json(),
        state.list().current_index(),
    )
}

/// Presses `key`, which must undo or redo: returns its commands, checked to ask nothing of
/// the servos.
fn undo_key(state: &mut TeachState, key: Key) -> Vec<Command> {
    let (goals, torque) = (state.goals().to_vec(), state.torque().to_vec());
    let commands = press(state, key.clone());
    assert!(
        !commands.iter().any(|c| matches!(c, Command::Bus(_))),
        "{key:?} asked the servos for {commands:?}"
    );
    assert!(!state.is_moving());
    assert_eq!((state.goals(), state.torque()), (&goals[..], &torque[..]));
    commands
}

/// Every kind of edit, each pressed on the state as the user would: what the list looked like
/// before and after each.
fn every_edit(state: &mut TeachState) -> Vec<((String, usize), (String, usize))> {
    let steps: Vec<Vec<Key>> = vec![
        vec![Key::Char('n')],                             // capture
        vec![Key::Char('n')],                             // capture
        vec![Key::Char('K')],                             // tool key
        vec![Key::Char('u')],                             // update
        vec![Key::Char('N'), Key::Char('w'), Key::Enter], // rename
        vec![Key::Char('h'), Key::Char('1'), Key::Enter], // hold
        vec![Key::Char('<'), Key::Char('p')],             // interpolation
        vec![Key::Char('[')],                             // move earlier
        vec![Key::Char('+')],                             // interval
        vec![Key::Char('m')],                             // mirror a key
        vec![Key::Char('M')],                             // mirror all
        vec![Key::SelectKey(2), Key::KeyTime(9_500)],     // move in time
        vec![Key::Char('v'), Key::Char('5'), Key::Enter], // typed value
        vec![Key::SelectKey(1), Key::Char('d')],          // delete
    ];
    let mut seen_edits = Vec::new();
    for keys in steps {
        let (last, rest) = keys.split_last().unwrap();
        press_all(state, rest);
        let before = seen(state);
        press(state, last.clone());
        // The typed value's "move the arm there?" is answered no: only the key changes.
        if matches!(state.prompt(), Some(Prompt::MoveThere)) {
            press(state, Key::Char('n'));
        }
        assert!(!state.status().error, "{keys:?}: {}", state.status().text);
        let after = seen(state);
        assert_ne!(before.0, after.0, "{keys:?} changed nothing");
        seen_edits.push((before, after));
    }
    seen_edits
}

#[test]
fn every_edit_is_undone_to_the_list_before_it_then_redone_and_the_arm_stays() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    // The arm somewhere else than home, so that captures differ from the keys they replace.
    press_all(&mut state, &[Key::ShiftRight, Key::Down, Key::ShiftLeft]);
    let edits = every_edit(&mut state);
    for (before, after) in edits.iter().rev() {
        // The keys as the edit left them (a selection since is no edit: it stays).
        assert_eq!(seen(&state).0, after.0);
        undo_key(&mut state, Key::Char('U'));
        assert_eq!(&seen(&state), before, "{}", state.status().text);
        assert!(state.status().text.starts_with("undid: "));
    }
    assert!(press(&mut state, Key::Undo).is_empty() && state.status().error);
    assert_eq!(state.status().text, "nothing to undo");
    for (_, after) in &edits {
        undo_key(&mut state, Key::Redo);
        assert_eq!(&seen(&state), after, "{}", state.status().text);
    }
    assert!(press(&mut state, Key::Char('R')).is_empty() && state.status().error);
    assert!(state.is_dirty());
}

#[test]
fn a_delete_comes_back_where_it_was_and_a_new_edit_ends_the_redo() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press_all(
        &mut state,
        &[
            Key::Char('n'),
            Key::Right,
            Key::Char('n'),
            Key::Right,
            Key::Char('n'),
        ],
    );
    press_all(&mut state, &[Key::SelectKey(1)]);
    type_line(&mut state, "");
    press(&mut state, Key::Char('d'));
    assert_eq!(state.list().len(), 2);
    undo_key(&mut state, Key::Undo);
    assert_eq!(state.list().len(), 3);
    assert_eq!(
        state.list().current_index(),
        1,
        "the deleted key is current again"
    );
    assert_eq!(
        state.status().text,
        "undid: deleted key 1 (2 keys left) (R redoes)"
    );
    assert_eq!(journal_keys(&state), Some(3), "an undo is journaled");
    press(&mut state, Key::Char('n'));
    assert!(press(&mut state, Key::Redo).is_empty() && state.status().error);
    assert_eq!(state.list().len(), 4);
}

#[test]
fn a_hundred_edits_can_be_undone() {
    let mut state = unjournaled_at_home();
    for _ in 0..history::DEPTH + 20 {
        press(&mut state, Key::Char('n'));
    }
    for undone in 1..=history::DEPTH {
        undo_key(&mut state, Key::Undo);
        assert_eq!(state.list().len(), history::DEPTH + 20 - undone);
    }
    assert!(press(&mut state, Key::Undo).is_empty() && state.status().error);
    assert_eq!(state.list().len(), 20);
}

#[test]
fn undoing_back_to_the_saved_list_leaves_it_clean_and_redoing_leaves_it_unsaved() {
    let mut state = unjournaled_at_home();
    assert!(!state.is_dirty());
    press(&mut state, Key::Char('n'));
    assert!(state.is_dirty());
    undo_key(&mut state, Key::Undo);
    assert!(!state.is_dirty(), "back to the list as it started");
    undo_key(&mut state, Key::Redo);
    assert!(state.is_dirty());
    // Saved with one key: undoing the second capture comes back to the file's list, undoing
    // the first goes past it.
    let mut list = state.list().clone();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("taught.json");
    list.save(&path).unwrap();
    assert!(!list.is_dirty());
    list.insert_after(Vec::new());
    let saved = state.list().sequence().clone();
    list.restore(saved, 0);
    assert!(!list.is_dirty(), "restored to what was saved");
    list.restore(Sequence::new("so101"), 0);
    assert!(list.is_dirty(), "restored to before the save");
}

fn unjournaled_at_home() -> TeachState {
    let robot = super::super::tests::so101();
    let present = robot.home.clone();
    let mut state = TeachState::new(
        robot,
        KeyframeList::new(Sequence::new("so101")),
        "taught.json".into(),
        None,
        present,
    );
    let start = state.start();
    apply(&mut state, start);
    state
}

#[test]
fn the_history_survives_a_crash_in_the_journal() {
    let dir = tempfile::tempdir().unwrap();
    let mut crashed = session(dir.path());
    press_all(&mut crashed, &[Key::Char('n'), Key::Right, Key::Char('n')]);
    let two = seen(&crashed);
    press_all(&mut crashed, &[Key::Right, Key::Char('n'), Key::Char('U')]);
    let journal = crashed.journal().unwrap().clone();
    drop(crashed);

    let mut state = session(dir.path());
    let pending = journal.pending(state.output()).unwrap().expect("offered");
    state.offer_recovery(pending);
    press(&mut state, Key::Char('y'));
    assert_eq!(seen(&state), two, "{}", state.status().text);
    undo_key(&mut state, Key::Redo);
    assert_eq!(state.list().len(), 3, "the undone capture is redone");
    undo_key(&mut state, Key::Undo);
    undo_key(&mut state, Key::Undo);
    assert_eq!(state.list().len(), 1, "{}", state.status().text);
}
