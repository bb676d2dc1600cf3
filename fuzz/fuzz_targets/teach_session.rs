//! The teach state machine and its session driver on the emulated servos of a built-in robot
//! (in process: the native driver, the real packet code), driven by fuzzed key presses and
//! by fuzzed pushes of limp joints by hand, anywhere in the servo's range.
//! Property: no panic, and every goal position any servo received, as a joint value, is inside
//! that joint's limits.
//!
//! Jogs run on the player (a fraction of a second each, to the end); the other motions (`space`,
//! `y`) are answered as a failed start instead of run: the player paces them in wall-clock time
//! (seconds per input) and has its own limit guard, tested in tests/servos/player.rs. File commands
//! are answered as failed writes and reads: no files here.
#![no_main]

use keypose::json::{InputError, Location};
use keypose::sequence::{KeyframeList, Sequence};
use keypose::teach::files::FileError;
use keypose::teach::{
    self, BusCommand, Command, Event, FileCommand, Key, MotionKind, Session, TeachState,
};
use keypose::testing::VirtualBus;
use keypose_fuzz::{builtin_robot, Choices};
use libfuzzer_sys::fuzz_target;
use std::collections::VecDeque;
use std::io;
use std::path::Path;
use std::sync::Arc;

/// Presses per input: a jog ramps in wall-clock time, so long inputs would time out.
const MAX_STEPS: usize = 24;

const KEYS: &[Key] = &[
    Key::Up,
    Key::Down,
    Key::Left,
    Key::Right,
    Key::ShiftLeft,
    Key::ShiftRight,
    Key::Enter,
    Key::Esc,
    Key::Backspace,
    Key::Interrupt,
];
const CHARS: &str = " undN><.,][hvpyUR+=-tTqwi0123456789eDmr";

/// The state's commands carried out as `teach::apply` does, a jog waited for to its end, the
/// other motions and files answered by a refusal.
fn apply(state: &mut TeachState, session: &mut Session, commands: Vec<Command>) {
    let mut queue = VecDeque::from(commands);
    while let Some(command) = queue.pop_front() {
        let events = match command {
            Command::Bus(BusCommand::Run(plan)) if plan.kind == MotionKind::Jog => {
                let mut events = session.execute(BusCommand::Run(plan));
                events.extend(session.wait_motion().ok().flatten());
                events
            }
            Command::Bus(BusCommand::Run(_)) => {
                vec![Event::BusError("motions are not run while fuzzing".into())]
            }
            Command::Bus(command) => session.execute(command),
            Command::File(FileCommand::Load(path)) => vec![Event::Loaded {
                result: Err(FileError::Load(no_files(&path))),
                path,
            }],
            Command::File(FileCommand::Save { path, .. }) => vec![Event::Saved {
                result: Err(FileError::Save(no_files(&path))),
                path,
            }],
            Command::File(FileCommand::Journal { journal, .. }) => {
                vec![Event::Journaled(Err(FileError::Journal {
                    path: journal.path().to_path_buf(),
                    source: Arc::new(io::Error::other("no journal while fuzzing")),
                }))]
            }
            Command::File(FileCommand::WriteDirection { path, joint, .. }) => {
                vec![Event::DirectionWritten {
                    result: Err(FileError::Direction(no_files(&path))),
                    joint,
                    path,
                }]
            }
            Command::File(FileCommand::ClearJournal { why, .. }) => vec![Event::JournalCleared {
                why,
                result: Err(FileError::ClearJournal(Arc::new(io::Error::other(
                    "no journal while fuzzing",
                )))),
            }],
        };
        for event in events {
            queue.extend(state.on_event(event));
        }
    }
}

fn key(choices: &mut Choices) -> Key {
    let b = usize::from(choices.byte());
    let chars: Vec<char> = CHARS.chars().collect();
    if b < KEYS.len() {
        KEYS[b].clone()
    } else {
        Key::Char(chars[b % chars.len()])
    }
}

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let robot = builtin_robot(choices.byte());
    let (bus, virtual_bus) = VirtualBus::in_process(robot);
    let mut session = Session::new(Box::new(bus), robot);
    let present = session.read().unwrap().unwrap();
    let mut state = TeachState::new(
        robot.clone(),
        KeyframeList::new(Sequence::new(&robot.name)),
        "unused.json".into(),
        None,
        present,
    );
    let start = state.start();
    apply(&mut state, &mut session, start);
    for _ in 0..MAX_STEPS {
        if choices.is_empty() || state.should_quit() {
            break;
        }
        match choices.byte() % 4 {
            // A push by hand: a joint, to anywhere from half its span below its limits to
            // half its span above.
            0 => {
                let joint = &robot.joints[usize::from(choices.byte()) % robot.joints.len()];
                let (min, max) = (joint.limits.min, joint.limits.max);
                let share = f64::from(u16::from_le_bytes([choices.byte(), choices.byte()]));
                let value = min + (max - min) * (2.0 * share / f64::from(u16::MAX) - 0.5);
                let tick = joint.servo.tick_exact(value);
                if let Some(servo) = virtual_bus.lock().servo_mut(joint.servo.id) {
                    servo.motion.push_to(tick);
                }
            }
            _ => {
                teach::refresh(&mut state, &mut session);
                let commands = state.handle_key(key(&mut choices));
                apply(&mut state, &mut session, commands);
            }
        }
    }
    let servos = virtual_bus.lock();
    for (id, tick) in servos.goals_received() {
        let joint = robot.joints.iter().find(|j| j.servo.id == id).unwrap();
        let value = joint.servo.value(tick);
        assert!(
            joint.limits.contains(value),
            "{} received goal tick {tick} = {value}, outside {}..{}",
            joint.name,
            joint.limits.min,
            joint.limits.max
        );
    }
});

/// What a read or a write is answered with here: no file is touched while fuzzing.
fn no_files(path: &Path) -> InputError {
    InputError::new(
        &path.display().to_string(),
        Location::File,
        "no files while fuzzing",
    )
}
