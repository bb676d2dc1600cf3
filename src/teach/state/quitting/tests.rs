//! Ctrl-C and `q` with unsaved work, on the state machine alone: the stop always goes out first.

use super::super::{tidy, BusCommand, Command, Event, Key, KeyframeList, Prompt, TeachState};
use crate::robot::Robot;
use crate::sequence::Sequence;
use crate::teach::files;
use std::path::Path;

/// Confirms torque and file commands as the drivers would; a motion starts and keeps going.
fn apply(state: &mut TeachState, commands: &[Command]) {
    for command in commands.iter().cloned() {
        let event = match command {
            Command::File(command) => files::execute(command),
            Command::Bus(BusCommand::Torque { joints, on: true }) => {
                let values = joints
                    .iter()
                    .map(|&j| tidy(&state.robot().joints[j], state.present()[j]))
                    .collect();
                Event::Held { joints, values }
            }
            Command::Bus(BusCommand::Run(plan)) => Event::MotionStarted {
                kind: plan.kind,
                end_pose: plan.end_pose.clone(),
                joints: plan.joints.clone(),
            },
            Command::Bus(_) => continue,
        };
        let follow = state.on_event(event);
        apply(state, &follow);
    }
}

fn press(state: &mut TeachState, key: Key) -> Vec<Command> {
    let commands = state.handle_key(key);
    apply(state, &commands);
    commands
}

/// A held arm with two keys taught and not written.
fn unsaved(dir: &Path) -> TeachState {
    let robot = Robot::builtin("so101").unwrap();
    let present = robot.home.clone();
    let list = KeyframeList::new(Sequence::new("so101"));
    let mut state = TeachState::new(robot, list, dir.join("taught.json"), None, present);
    let start = state.start();
    apply(&mut state, &start);
    press(&mut state, Key::Char('n'));
    press(&mut state, Key::Char('n'));
    assert!(state.is_dirty());
    state
}

fn playing(dir: &Path) -> TeachState {
    let mut state = unsaved(dir);
    press(&mut state, Key::Char('<'));
    press(&mut state, Key::Char('y'));
    assert!(state.is_moving());
    state
}

fn is_stop(commands: &[Command], requests: u32) -> bool {
    matches!(commands, [Command::Bus(BusCommand::Stop { requests: r })] if *r == requests)
}

#[test]
fn ctrl_c_during_motion_stops_first_then_asks() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = playing(dir.path());
    let commands = state.handle_key(Key::Interrupt);
    assert!(is_stop(&commands, 1), "{commands:?}");
    assert_eq!(state.prompt(), Some(&Prompt::Quit));
    assert!(!state.should_quit());
    // Quitting without the changes waits for the arm to hold.
    state.handle_key(Key::Char('y'));
    assert!(!state.should_quit());
    assert_eq!(state.prompt(), Some(&Prompt::Quit));
}

#[test]
fn a_stop_is_never_taken_as_the_answer_to_an_open_question() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = playing(dir.path());
    assert!(is_stop(&state.handle_key(Key::Interrupt), 1));
    // The question is open; Esc and Ctrl-C still reach the arm (now: hold at once).
    let again = state.handle_key(Key::Esc);
    assert!(is_stop(&again, 2), "{again:?}");
    assert_eq!(state.prompt(), Some(&Prompt::Quit));
}

#[test]
fn the_quit_question_writes_discards_or_stays() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("taught.json");
    // n: stays, nothing written.
    let mut state = unsaved(dir.path());
    press(&mut state, Key::Interrupt);
    assert_eq!(state.prompt(), Some(&Prompt::Quit));
    press(&mut state, Key::Char('n'));
    assert!(!state.should_quit() && state.prompt().is_none());
    assert!(!path.exists());
    // y: quits, nothing written.
    press(&mut state, Key::Char('q'));
    press(&mut state, Key::Char('y'));
    assert!(state.should_quit());
    assert!(!path.exists());
    // w: written, then quits; the file holds the two keys.
    let mut state = unsaved(dir.path());
    press(&mut state, Key::Interrupt);
    press(&mut state, Key::Char('w'));
    assert!(state.should_quit(), "{}", state.status().text);
    assert!(!state.is_dirty());
    let written = Sequence::load(&path).unwrap();
    assert_eq!(written.keyframes.len(), 2);
}
