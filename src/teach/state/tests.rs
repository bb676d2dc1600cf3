//! The rules of the teaching session, checked on the state machine alone: a perfect bus is
//! played by `apply`, which confirms every command as the session driver would.

use super::*;
use crate::curve::Interp;
use crate::sequence::{Ends, KeyValue, Keyframe};
use crate::teach::files;

pub(super) fn so101() -> Robot {
    Robot::builtin("so101").expect("built-in so101")
}

const PAN: usize = 0;
const LIFT: usize = 1;
const ELBOW: usize = 2;
const WRIST: usize = 3;

/// A fresh session on an empty list, journaled in `dir`, the arm at home and held.
pub(super) fn session(dir: &Path) -> TeachState {
    let robot = so101();
    let present = robot.home.clone();
    let output = dir.join("taught.json");
    let journal = Journal::for_target(dir, &output);
    let mut state = TeachState::new(
        robot,
        KeyframeList::new(Sequence::new("so101")),
        output,
        Some(journal),
        present,
    );
    let start = state.start();
    apply(&mut state, start);
    state
}

/// A session on `sequence` without a journal, the arm at home (not yet held).
fn unjournaled(sequence: Sequence, output: PathBuf) -> TeachState {
    let robot = so101();
    let present = robot.home.clone();
    TeachState::new(robot, KeyframeList::new(sequence), output, None, present)
}

/// Confirms bus commands as a bus that does exactly what it is told (jogs arrive at once), and
/// carries out file commands for real, as the session's drivers would.
pub(super) fn apply(state: &mut TeachState, commands: Vec<Command>) -> Vec<Command> {
    for command in commands.clone() {
        let events = match command {
            Command::Bus(command) => perfect_bus(state, command),
            Command::File(command) => vec![files::execute(command)],
        };
        for event in events {
            let follow = state.on_event(event);
            apply(state, follow);
        }
    }
    commands
}

fn perfect_bus(state: &TeachState, command: BusCommand) -> Vec<Event> {
    match command {
        BusCommand::Torque { joints, on: true } => {
            let values = joints
                .iter()
                .map(|&j| tidy(&state.robot().joints[j], state.present()[j]))
                .collect();
            vec![Event::Held { joints, values }]
        }
        BusCommand::Torque { joints, on: false } => vec![Event::Released { joints }],
        // A jog arrives at once: started, finished, and read where it went.
        BusCommand::Run(plan) if plan.kind == MotionKind::Jog => {
            let mut present = state.present().to_vec();
            for &j in &plan.joints {
                present[j] = plan.end_pose[j];
            }
            vec![
                Event::MotionStarted {
                    kind: plan.kind,
                    end_pose: plan.end_pose.clone(),
                    joints: plan.joints.clone(),
                },
                Event::MotionEnded {
                    outcome: Ok(Outcome::Finished),
                    last_goals: Some(plan.end_pose.clone()),
                    warnings: Vec::new(),
                },
                Event::Reading(present),
            ]
        }
        BusCommand::Run(plan) => vec![Event::MotionStarted {
            kind: plan.kind,
            end_pose: plan.end_pose.clone(),
            joints: plan.joints.clone(),
        }],
        BusCommand::Stop { .. } | BusCommand::Reverse { .. } => Vec::new(),
    }
}

pub(super) fn press(state: &mut TeachState, key: Key) -> Vec<Command> {
    let commands = state.handle_key(key);
    apply(state, commands)
}

pub(super) fn press_all(state: &mut TeachState, keys: &[Key]) {
    for key in keys {
        press(state, key.clone());
    }
}

pub(super) fn key_values(state: &TeachState, index: usize) -> Vec<f64> {
    state.list().sequence().keyframes[index]
        .values
        .iter()
        .map(|(_, v)| match v {
            KeyValue::Joint(x) => *x,
            KeyValue::Transform(_) | KeyValue::Percent(_) => {
                panic!("a captured key holds joint values")
            }
        })
        .collect()
}

pub(super) fn journal_keys(state: &TeachState) -> Option<usize> {
    let path = state.journal().expect("journaled").path();
    path.exists()
        .then(|| journaled(state).expect("journal loads").keyframes.len())
}

/// The list the journal holds.
pub(super) fn journaled(state: &TeachState) -> Result<Sequence, crate::json::InputError> {
    let journal = state.journal().expect("journaled");
    journal.read().map(|entry| entry.list.sequence)
}

#[test]
fn the_session_starts_by_holding_every_joint() {
    let dir = tempfile::tempdir().unwrap();
    let state = session(dir.path());
    assert!(state.torque().iter().all(|&t| t));
    assert_eq!(state.goals(), state.robot().home.as_slice());
}

#[test]
fn jogs_step_one_or_ten_degrees_and_stop_at_the_limits() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press_all(&mut state, &[Key::Right, Key::ShiftRight, Key::Left]);
    assert_eq!(state.goals()[PAN], 10.0);
    // Wrist flex: limits ±95°, so ten big steps end exactly at the limit, not past it. (Not
    // the elbow: folded at the stretched home pose, it puts the gripper into the desk, a jog
    // the collision rule refuses.)
    press_all(&mut state, &[Key::Down, Key::Down, Key::Down]);
    assert_eq!(state.selected(), WRIST);
    for _ in 0..10 {
        press(&mut state, Key::ShiftRight);
    }
    assert_eq!(state.goals()[WRIST], 95.0, "{}", state.status().text);
    let commands = press(&mut state, Key::Right);
    assert!(commands.is_empty(), "no goal past the limit");
    assert!(state.status().error && state.status().text.contains("limit"));
    for _ in 0..25 {
        press(&mut state, Key::ShiftLeft);
    }
    assert_eq!(state.goals()[WRIST], -95.0, "{}", state.status().text);
    // Selection wraps around.
    press_all(&mut state, &[Key::Up, Key::Up, Key::Up, Key::Up]);
    assert_eq!(state.selected(), 5);
}

#[test]
fn a_limp_joint_is_not_jogged() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('t')); // the pan carries no weight: released at once
    assert!(!state.torque()[PAN]);
    assert!(press(&mut state, Key::Right).is_empty());
    assert!(state.status().error && state.status().text.contains("limp"));
    press(&mut state, Key::Char('t'));
    assert!(state.torque()[PAN]);
    assert_eq!(press(&mut state, Key::Right).len(), 1);
}

#[test]
fn releasing_a_joint_that_carries_weight_asks_first() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Down);
    assert!(press(&mut state, Key::Char('t')).is_empty(), "asks first");
    assert!(matches!(state.prompt(), Some(Prompt::Release { .. })));
    assert!(format::question(&state).unwrap().contains("shoulder_lift"));
    // Another key does not answer; the question stays.
    assert!(press(&mut state, Key::Right).is_empty());
    assert!(state.prompt().is_some() && state.status().error);
    press(&mut state, Key::Char('n'));
    assert!(state.torque()[LIFT], "declined: torque stays on");
    press(&mut state, Key::Char('t'));
    let commands = press(&mut state, Key::Char('y'));
    assert!(
        matches!(&commands[..], [Command::Bus(BusCommand::Torque { joints, on: false })] if joints == &[LIFT])
    );
    assert!(!state.torque()[LIFT]);
}

#[test]
fn all_joints_release_together_after_one_question_and_hold_together() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('T'));
    let question = format::question(&state).expect("asks");
    assert!(
        question.contains("shoulder_lift, elbow_flex, wrist_flex") && !question.contains("pan"),
        "{question}"
    );
    press(&mut state, Key::Char('y'));
    assert!(state.torque().iter().all(|&t| !t));
    // Holding asks nothing.
    press(&mut state, Key::Char('t'));
    assert!(state.torque()[PAN] && !state.torque()[LIFT]);
    // Mixed: T holds the limp ones, the safe direction.
    let commands = press(&mut state, Key::Char('T'));
    assert!(
        matches!(&commands[..], [Command::Bus(BusCommand::Torque { joints, on: true })] if joints == &[1, 2, 3, 4, 5])
    );
    assert!(state.torque().iter().all(|&t| t));
}

#[test]
fn a_new_key_is_the_present_pose_rounded_and_inside_the_limits() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    // Moved by hand: 12.34° reads as 12.3; a lift 0.4° past its stop is clamped to it.
    state.on_event(Event::Reading(vec![12.34, 100.4, -0.04, -45.06, 0.0, 5.0]));
    press(&mut state, Key::Char('n'));
    assert_eq!(key_values(&state, 0), [12.3, 100.0, 0.0, -45.1, 0.0, 5.0]);
    assert!(state.status().text.contains("shoulder_lift clamped"));
    assert!(
        key_values(&state, 0)[2].is_sign_positive(),
        "-0.04 rounds to +0.0, never -0.0 in the file"
    );
    assert_eq!(journal_keys(&state), Some(1));
}

#[test]
fn edits_update_delete_and_reorder_each_reach_the_journal() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    for _ in 0..3 {
        press(&mut state, Key::Char('n'));
        press(&mut state, Key::ShiftRight);
    }
    assert_eq!(journal_keys(&state), Some(3));
    // Pan was captured at 0, 10, 20; it is now at 30: update the middle key.
    press(&mut state, Key::Char('<'));
    press(&mut state, Key::Char('u'));
    assert_eq!(key_values(&state, 1)[PAN], 30.0);
    press(&mut state, Key::Char(']'));
    assert_eq!(state.list().current_index(), 2);
    let pans: Vec<f64> = (0..3).map(|i| key_values(&state, i)[PAN]).collect();
    assert_eq!(pans, [0.0, 20.0, 30.0]);
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.to_json(), state.list().sequence().to_json());
    press(&mut state, Key::Char('d'));
    assert_eq!(journal_keys(&state), Some(2));
    press_all(&mut state, &[Key::Char('d'), Key::Char('d')]);
    assert_eq!(journal_keys(&state), None, "nothing left to recover");
    assert!(press(&mut state, Key::Char('d')).is_empty() && state.status().error);
}

#[test]
fn the_interval_moves_in_tenths_and_never_below_a_tenth() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    press(&mut state, Key::Char('+'));
    assert_eq!(state.list().sequence().key_interval, Some(2.1));
    for _ in 0..30 {
        press(&mut state, Key::Char('-'));
    }
    assert_eq!(state.list().sequence().key_interval, Some(0.1));
    assert!(state.status().error);
    press(&mut state, Key::Char('='));
    assert_eq!(state.list().sequence().key_interval, Some(0.2));
    assert!(state.is_dirty());
}

#[test]
fn timed_sequences_change_the_playback_speed_instead() {
    let dir = tempfile::tempdir().unwrap();
    let mut sequence = Sequence::new("so101");
    sequence.key_interval = None;
    let mut key = Keyframe::new(vec![("gripper".into(), KeyValue::Joint(0.0))]);
    key.time = Some(0.0);
    sequence.keyframes.push(key);
    let mut state = unjournaled(sequence, dir.path().join("t.json"));
    for _ in 0..5 {
        press(&mut state, Key::Char('+'));
    }
    assert!((state.speed() - 1.5).abs() < 1e-12);
    for _ in 0..50 {
        press(&mut state, Key::Char('+'));
    }
    assert_eq!(state.speed(), MAX_SPEED);
    for _ in 0..100 {
        press(&mut state, Key::Char('-'));
    }
    assert!((state.speed() - MIN_SPEED).abs() < 1e-12);
    assert!(
        !state.is_dirty(),
        "the speed is a session setting, not an edit"
    );
}

#[test]
fn quitting_with_unsaved_changes_asks_and_a_clean_quit_removes_the_journal() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('q'));
    assert!(state.should_quit(), "nothing unsaved: quits at once");

    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    press(&mut state, Key::Char('q'));
    assert_eq!(state.prompt(), Some(&Prompt::Quit));
    press(&mut state, Key::Char('n'));
    assert!(!state.should_quit());
    assert_eq!(journal_keys(&state), Some(1));
    press(&mut state, Key::Char('q'));
    press(&mut state, Key::Char('y'));
    assert!(state.should_quit());
    assert_eq!(journal_keys(&state), None, "discarded on purpose");
}

#[test]
fn writing_saves_atomically_cleans_the_list_and_drops_the_journal() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('w'));
    assert!(state.status().error, "an empty list is not a sequence file");
    press_all(
        &mut state,
        &[Key::Char('n'), Key::ShiftRight, Key::Char('n')],
    );
    press(&mut state, Key::Char('w'));
    assert!(!state.status().error, "{}", state.status().text);
    assert!(state.status().text.contains("check passes"));
    assert!(!state.is_dirty());
    assert_eq!(journal_keys(&state), None);
    let written = Sequence::load(&dir.path().join("taught.json")).unwrap();
    assert_eq!(written.to_json(), state.list().sequence().to_json());
    // Save-as: the new file is the output from now on.
    let other = dir.path().join("other.json");
    press(&mut state, Key::Write(other.clone()));
    assert_eq!(state.output(), other.as_path());
    assert!(other.exists());
}

#[test]
fn a_journal_is_offered_and_recovered_or_declined() {
    let dir = tempfile::tempdir().unwrap();
    let mut crashed = session(dir.path());
    press_all(&mut crashed, &[Key::Char('n'), Key::Right, Key::Char('n')]);
    let journal = crashed.journal().unwrap().clone();
    drop(crashed);

    for (answer, keys) in [('y', 2), ('n', 0)] {
        let mut state = session(dir.path());
        let pending = journal
            .pending(state.output())
            .unwrap()
            .expect("the journal is newer than the (missing) file");
        state.offer_recovery(pending);
        assert!(matches!(state.prompt(), Some(Prompt::Recover { keys: 2 })));
        press(&mut state, Key::Char(answer));
        assert_eq!(state.list().len(), keys);
        assert_eq!(state.is_dirty(), answer == 'y', "recovered work is unsaved");
    }
}

#[test]
fn importing_replaces_the_list_but_asks_over_unsaved_work() {
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("wave.json");
    let mut wave = Sequence::new("so101");
    for deg in [10.0, 20.0, 30.0] {
        wave.keyframes.push(Keyframe::new(vec![(
            "elbow_flex".into(),
            KeyValue::Joint(deg),
        )]));
    }
    wave.save(&source).unwrap();

    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    press(&mut state, Key::Import(source.clone()));
    assert!(matches!(state.prompt(), Some(Prompt::Replace { .. })));
    press(&mut state, Key::Char('y'));
    assert_eq!(state.list().len(), 3);
    assert!(
        state.is_dirty(),
        "the output file does not have these keys yet"
    );
    assert_eq!(journal_keys(&state), Some(3));

    // The path prompt: `i`, edit the prefilled path, Enter.
    let mut state = session(dir.path());
    press(&mut state, Key::Char('i'));
    for _ in 0.."taught.json".len() {
        press(&mut state, Key::Backspace);
    }
    for c in "wave.json".chars() {
        press(&mut state, Key::Char(c));
    }
    press(&mut state, Key::Enter);
    assert_eq!(state.list().len(), 3, "{}", state.status().text);

    // A file this robot cannot play is refused, and the list stays.
    let bad = dir.path().join("bad.json");
    let mut other = Sequence::new("so101");
    other
        .keyframes
        .push(Keyframe::new(vec![("joint9".into(), KeyValue::Joint(0.0))]));
    other.save(&bad).unwrap();
    press(&mut state, Key::Write(dir.path().join("kept.json")));
    press(&mut state, Key::Import(bad));
    assert!(state.status().error && state.status().text.contains("joint9"));
    assert_eq!(state.list().len(), 3);
}

#[test]
fn space_ramps_to_the_key_and_y_plays_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press_all(
        &mut state,
        &[
            Key::Char('n'),
            Key::ShiftRight,
            Key::ShiftRight,
            Key::Char('n'),
        ],
    );
    press(&mut state, Key::Char('<'));
    let commands = press(&mut state, Key::Char(' '));
    let [Command::Bus(BusCommand::Run(plan))] = &commands[..] else {
        panic!("expected a motion, got {commands:?}");
    };
    assert_eq!(plan.kind, MotionKind::ToKey(0));
    assert_eq!(plan.end_pose, vec![0.0; 6]);
    assert!(
        plan.options.timeline.approach,
        "the safe ramp, as in keypose play"
    );
    assert_eq!(plan.trajectory.key_times.len(), 1);

    // While moving: no jogs, no torque changes, no quitting; y stops, twice holds.
    assert!(press(&mut state, Key::Right).is_empty() && state.status().error);
    assert!(press(&mut state, Key::Char('t')).is_empty());
    press(&mut state, Key::Char('q'));
    assert!(!state.should_quit());
    assert!(matches!(
        &press(&mut state, Key::Char('y'))[..],
        [Command::Bus(BusCommand::Stop { .. })]
    ));
    assert!(matches!(
        &press(&mut state, Key::Esc)[..],
        [Command::Bus(BusCommand::Stop { .. })]
    ));
    assert!(state.status().text.contains("at once"));
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Held),
        last_goals: Some(vec![12.04, 0.0, 0.0, 0.0, 0.0, 0.0]),
        warnings: Vec::new(),
    });
    assert!(!state.is_moving());
    assert_eq!(state.goals()[PAN], 12.0, "jogs go on from where it held");

    let commands = press(&mut state, Key::Char('y'));
    let [Command::Bus(BusCommand::Run(plan))] = &commands[..] else {
        panic!("expected playback, got {commands:?}");
    };
    assert_eq!(plan.kind, MotionKind::Play { from: 0 });
    assert_eq!(plan.options.timeline.from_key, Some(0));
    assert_eq!(plan.end_pose[PAN], 20.0);
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: None,
        warnings: Vec::new(),
    });
    assert_eq!(state.goals()[PAN], 20.0);
    assert!(state.torque().iter().all(|&t| t));
}

/// home → elbow 80° (the gripper 75 mm into the desk) → home: `space` to the desk key, and
/// `y` from either end, are refused with the contact, and nothing moves; the list's own check
/// (the write note) names it too.
#[test]
fn space_and_y_into_the_desk_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = Sequence::from_json(
        "desk.json",
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{"name": "home", "time": 0, "joints": {"elbow_flex": 0}},
                          {"name": "into-desk", "time": 3, "joints": {"elbow_flex": 80}},
                          {"name": "back", "time": 6, "joints": {"elbow_flex": 0}}]}"#,
    )
    .unwrap();
    let mut state = unjournaled(sequence, dir.path().join("desk.json"));
    let start = state.start();
    apply(&mut state, start);
    press(&mut state, Key::Char('>'));
    assert!(press(&mut state, Key::Char(' ')).is_empty());
    let text = state.status().text.clone();
    assert!(
        text.contains("refusing to move there") && text.contains("the floor"),
        "{text}"
    );
    for key in ['<', '>'] {
        press(&mut state, Key::Char(key));
        assert!(press(&mut state, Key::Char('y')).is_empty());
        let text = state.status().text.clone();
        assert!(
            text.contains("refusing to play") && text.contains("contact"),
            "{text}"
        );
        assert!(text.contains("raise key 'into-desk'"), "{text}");
    }
    assert!(!state.is_moving());
}

#[test]
fn playback_beyond_the_limits_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    for _ in 0..9 {
        press(&mut state, Key::ShiftRight);
    }
    press(&mut state, Key::Char('n'));
    // 90° in 0.1 s is far beyond 115°/s.
    for _ in 0..19 {
        press(&mut state, Key::Char('-'));
    }
    // From the first key: `y` checks what it plays, from the current key on.
    press(&mut state, Key::Char('<'));
    assert!(press(&mut state, Key::Char('y')).is_empty());
    assert!(
        state.status().text.contains("refusing to play"),
        "{}",
        state.status().text
    );
}

#[test]
fn moving_to_a_control_key_reaches_its_own_pose() {
    let dir = tempfile::tempdir().unwrap();
    let mut sequence = Sequence::new("so101");
    sequence.ends = Ends::Control;
    for deg in [-20.0, 0.0, 10.0, 40.0] {
        sequence.keyframes.push(Keyframe::new(vec![(
            "shoulder_pan".into(),
            KeyValue::Joint(deg),
        )]));
    }
    let mut state = unjournaled(sequence, dir.path().join("c.json"));
    let commands = state.handle_key(Key::Char(' '));
    let [Command::Bus(BusCommand::Run(plan))] = &commands[..] else {
        panic!("expected a motion");
    };
    assert!(
        (plan.end_pose[PAN] + 20.0).abs() < 1e-9,
        "{:?}",
        plan.end_pose
    );
}

/// Types `text` into the open prompt and presses Enter.
pub(super) fn type_line(state: &mut TeachState, text: &str) -> Vec<Command> {
    for c in text.chars() {
        press(state, Key::Char(c));
    }
    press(state, Key::Enter)
}

/// A session with two keys at home, 2 s apart, the first one current.
fn two_keys_at_the_first(dir: &Path) -> TeachState {
    let mut state = session(dir);
    press_all(
        &mut state,
        &[Key::Char('n'), Key::Char('n'), Key::Char('<')],
    );
    state
}

/// `key` opens a prompt, `text` is typed into it and Enter accepts it.
pub(super) fn edit(state: &mut TeachState, key: char, text: &str) -> Vec<Command> {
    press(state, Key::Char(key));
    type_line(state, text)
}

pub(super) fn key_name(state: &TeachState, index: usize) -> Option<&str> {
    state.list().sequence().keyframes[index].name.as_deref()
}

#[test]
fn the_edits_of_a_key_are_refused_without_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    for key in ['N', 'h', 'p', 'v', 'e'] {
        assert!(press(&mut state, Key::Char(key)).is_empty());
        assert!(state.prompt().is_none(), "{key} opened a prompt");
        assert_eq!(
            state.status(),
            &Status {
                text: "no key yet: n adds one from the present pose".into(),
                error: true
            }
        );
    }
}

#[test]
fn a_key_is_named_renamed_and_unnamed_and_a_shared_name_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    edit(&mut state, 'N', "wave");
    assert_eq!(key_name(&state, 0), Some("wave"));
    assert_eq!(state.status().text, "named key 0 (wave)");
    assert!(!state.status().error);
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.keyframes[0].name.as_deref(), Some("wave"));

    // The prompt starts from the present name: two backspaces and "lk" make "walk".
    press(&mut state, Key::Char('N'));
    assert_eq!(
        state.prompt(),
        Some(&Prompt::Text {
            field: Field::Name,
            text: "wave".into()
        })
    );
    press_all(&mut state, &[Key::Backspace, Key::Backspace]);
    type_line(&mut state, "lk");
    assert_eq!(key_name(&state, 0), Some("walk"));

    // Esc leaves it.
    press_all(&mut state, &[Key::Char('N'), Key::Char('x'), Key::Esc]);
    assert_eq!(key_name(&state, 0), Some("walk"));
    assert_eq!(state.status().text, "name unchanged");

    // The same name on key 1 is kept, but warned of.
    press(&mut state, Key::Char('>'));
    edit(&mut state, 'N', "walk");
    assert_eq!(key_name(&state, 1), Some("walk"));
    assert!(state.status().error);
    assert!(
        state.status().text.contains("key 0 has this name too")
            && state.status().text.contains("play --from walk"),
        "{}",
        state.status().text
    );

    // A number is an index to --from.
    press(&mut state, Key::Char('N'));
    for _ in 0..4 {
        press(&mut state, Key::Backspace);
    }
    type_line(&mut state, "3");
    assert!(state.status().error && state.status().text.contains("index"));

    // An empty name clears it.
    press(&mut state, Key::Char('N'));
    press(&mut state, Key::Backspace);
    type_line(&mut state, "  ");
    assert_eq!(key_name(&state, 1), None);
    assert_eq!(state.status().text, "key 1 has no name now");
}

#[test]
fn a_key_name_with_a_control_character_is_refused_and_the_journal_still_loads() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    edit(&mut state, 'N', "wave");
    // What the studio's page may send as a line: a line break, an escape sequence, U+2028.
    for name in ["two\nlines", "red\u{1b}[31m", "a\u{2028}b"] {
        edit(&mut state, 'N', name);
        assert_eq!(key_name(&state, 0), Some("wave"), "{name:?}");
        assert!(state.status().error, "{name:?}");
        assert!(
            state.status().text.contains("control character"),
            "{}",
            state.status().text
        );
    }
    // Every name the session keeps loads back from its journal (load refuses control
    // characters in names).
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.keyframes[0].name.as_deref(), Some("wave"));
}

#[test]
fn an_effort_is_set_on_the_selected_joint_cleared_and_refused_past_the_overload_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    // The SO-101's gripper is its sixth joint.
    press_all(&mut state, &[const { Key::Down }; 5]);
    edit(&mut state, 'e', "30");
    let effort = |state: &TeachState| state.list().sequence().keyframes[0].effort.clone();
    assert_eq!(effort(&state), [("gripper".to_string(), 30.0)]);
    assert_eq!(
        state.status().text,
        "key 0: gripper pushes with at most 30 % of its torque"
    );
    assert_eq!(
        journaled(&state).unwrap().keyframes[0].effort,
        effort(&state)
    );
    // The STS3215 counts 80 % as an overload from the factory.
    for refused in ["85", "0", "150", "much"] {
        edit(&mut state, 'e', refused);
        assert!(state.status().error, "{refused:?} is refused");
        assert_eq!(effort(&state), [("gripper".to_string(), 30.0)]);
    }
    edit(&mut state, 'e', "100 %");
    assert_eq!(effort(&state), [("gripper".to_string(), 100.0)]);
    edit(&mut state, 'e', "");
    assert!(effort(&state).is_empty());
}

#[test]
fn a_hold_is_set_cleared_and_refused_when_it_reaches_the_next_key() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    edit(&mut state, 'h', "1.5");
    assert_eq!(state.list().sequence().keyframes[0].hold, 1.5);
    assert_eq!(state.status().text, "key 0 holds 1.5 s");
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.keyframes[0].hold, 1.5);

    // Keys are 2 s apart: a 2 s hold leaves no time to move.
    edit(&mut state, 'h', "2");
    assert!(state.status().error);
    assert_eq!(
        state.status().text,
        "a 2 s hold runs into key 1, 2.00 s later: hold unchanged"
    );
    for refused in ["-1", "soon", ""] {
        edit(&mut state, 'h', refused);
        assert!(state.status().error, "{refused:?} is refused");
        assert_eq!(state.list().sequence().keyframes[0].hold, 1.5);
    }

    // A comma works as the decimal point; 0 clears.
    edit(&mut state, 'h', "0,5");
    assert_eq!(state.list().sequence().keyframes[0].hold, 0.5);
    edit(&mut state, 'h', "0");
    assert_eq!(state.list().sequence().keyframes[0].hold, 0.0);
    assert_eq!(state.status().text, "key 0 holds no longer");

    // The last key too: a key added after it comes one interval, 2 s, later (found by the
    // journal fuzz target: a 5 s hold there, then `n`, was journaled and did not load).
    press(&mut state, Key::Char('>'));
    edit(&mut state, 'h', "5");
    assert_eq!(
        state.status().text,
        "a 5 s hold is as long as the 2.00 s between keys (a key added after it would come \
         then): hold unchanged"
    );
    edit(&mut state, 'h', "1.5");
    press(&mut state, Key::Char('n'));
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.keyframes.len(), 3);
    assert_eq!(journal.keyframes[1].hold, 1.5);
}

#[test]
fn new_sequences_are_monotone_and_p_cycles_a_segment_through_the_modes() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    assert_eq!(state.list().sequence().interpolation, Interp::Monotone);
    press_all(&mut state, &[Key::Char('n'), Key::Char('n')]);
    press(&mut state, Key::Char('p'));
    assert!(state.status().error, "the last key starts no segment");
    assert_eq!(
        state.status().text,
        "key 1 is the last key: no segment follows it (n adds a key)"
    );
    assert_eq!(state.list().sequence().keyframes[1].interp, None);

    press(&mut state, Key::Char('<'));
    let mut seen = Vec::new();
    for _ in 0..6 {
        press(&mut state, Key::Char('p'));
        seen.push(state.list().sequence().keyframes[0].interp);
    }
    // The default (monotone) is no override; after it the cycle starts again.
    assert_eq!(
        seen,
        [
            Some(Interp::Step),
            Some(Interp::Linear),
            Some(Interp::Cubic),
            Some(Interp::Smooth),
            None,
            Some(Interp::Step)
        ]
    );
    assert_eq!(state.status().text, "key 0 → key 1: step");
    let journal = journaled(&state).unwrap();
    assert_eq!(journal.keyframes[0].interp, Some(Interp::Step));
}

#[test]
fn a_typed_value_is_kept_within_the_limits_and_the_arm_moves_there_by_the_ramp() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    press_all(&mut state, &[Key::Down, Key::Down]);
    press(&mut state, Key::Char('v'));
    assert!(
        format::question(&state)
            .unwrap()
            .contains("elbow_flex of key 0 in degrees, now 0 (limits -96.83° … 96.83°)"),
        "{:?}",
        format::question(&state)
    );
    // Outside the limits: refused, naming them; the key keeps its value.
    type_line(&mut state, "97");
    assert_eq!(
        state.status().text,
        "97° is outside elbow_flex's limits -96.83° … 96.83°: unchanged"
    );
    edit(&mut state, 'v', "up");
    assert!(state.status().error);
    assert_eq!(key_values(&state, 0), [0.0; 6]);

    // Inside: set, then with the arm held the question is whether to move it there.
    edit(&mut state, 'v', "-45.5");
    assert_eq!(key_values(&state, 0), [0.0, 0.0, -45.5, 0.0, 0.0, 0.0]);
    assert_eq!(state.prompt(), Some(&Prompt::MoveThere));
    assert_eq!(state.goals()[ELBOW], 0.0, "nothing moves before the answer");
    let commands = press(&mut state, Key::Char('y'));
    let [Command::Bus(BusCommand::Run(plan))] = &commands[..] else {
        panic!("expected the ramp to the key, got {commands:?}");
    };
    assert_eq!(plan.kind, MotionKind::ToKey(0));
    assert!(plan.options.timeline.approach, "the safe ramp, not a jump");
    assert_eq!(plan.end_pose, [0.0, 0.0, -45.5, 0.0, 0.0, 0.0]);
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: None,
        warnings: Vec::new(),
    });

    // Declined: the key changes, the arm does not.
    edit(&mut state, 'v', "96.83");
    assert!(press(&mut state, Key::Char('n')).is_empty());
    assert_eq!(key_values(&state, 0)[ELBOW], 96.83);

    // A limp arm is not offered the move.
    press(&mut state, Key::Up);
    press(&mut state, Key::Char('T'));
    press(&mut state, Key::Char('y'));
    edit(&mut state, 'v', "12");
    assert!(state.prompt().is_none());
    assert!(state.status().text.contains("once the arm is held"));
    assert_eq!(key_values(&state, 0)[LIFT], 12.0);
}

#[test]
fn a_joint_given_as_a_transform_is_not_typed_over() {
    let dir = tempfile::tempdir().unwrap();
    let mut sequence = Sequence::new("so101");
    sequence.keyframes.push(Keyframe::new(vec![(
        "shoulder_pan".into(),
        KeyValue::Transform(crate::pose::RigidTransform::IDENTITY),
    )]));
    let mut state = unjournaled(sequence, dir.path().join("tf.json"));
    assert!(press(&mut state, Key::Char('v')).is_empty());
    assert!(state.prompt().is_none());
    assert_eq!(
        state.status().text,
        "key 0 gives shoulder_pan as a transform: edit it in the file"
    );
    assert!(!state.is_dirty());
}

#[test]
fn a_click_selects_a_key_or_a_joint_and_a_missing_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    press(&mut state, Key::SelectKey(1));
    assert_eq!(state.list().current_index(), 1);
    press(&mut state, Key::SelectKey(2));
    assert_eq!(
        state.list().current_index(),
        1,
        "no key 2: the current key stays"
    );
    assert!(state.status().error && state.status().text.contains("no key 2"));
    press(&mut state, Key::SelectJoint(ELBOW));
    assert_eq!(state.selected(), ELBOW);
    // The SO-101 has six joints, 0 … 5.
    press(&mut state, Key::SelectJoint(6));
    assert_eq!(state.selected(), ELBOW);
    assert!(state.status().error);
}

#[test]
fn dragging_a_key_in_time_keeps_the_order_and_reaches_the_journal() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    press(&mut state, Key::Char('n'));
    // `n` inserts after the current key 0: keys at 0, 2 and 4 s (uniform, 2 s apart), the
    // new one (key 1, at 2 s) current.
    assert_eq!(state.list().current_index(), 1);
    press(&mut state, Key::KeyTime(2_500));
    let sequence = state.list().sequence();
    assert_eq!(sequence.key_interval, None, "the spacing is made explicit");
    assert_eq!(sequence.key_times(), vec![0.0, 2.5, 4.0]);
    assert!(state.is_dirty());
    let journal = journaled(&state).expect("journaled");
    assert_eq!(journal.key_times(), vec![0.0, 2.5, 4.0]);

    // Past the next key (4 s) or before the previous one (0 s): refused, the key stays.
    for millis in [4_000, 5_000, 0] {
        press(&mut state, Key::KeyTime(millis));
        assert!(state.status().error, "{millis} ms: {:?}", state.status());
        assert_eq!(state.list().sequence().key_times(), vec![0.0, 2.5, 4.0]);
    }
    // The previous key's hold counts: a 1 s hold at 0 s ends at 1 s.
    press_all(&mut state, &[Key::Char('<')]);
    edit(&mut state, 'h', "1");
    press_all(&mut state, &[Key::Char('>'), Key::KeyTime(900)]);
    assert!(
        state.status().text.contains("earliest"),
        "{:?}",
        state.status()
    );
    press(&mut state, Key::KeyTime(1_001));
    assert_eq!(state.list().sequence().key_times(), vec![0.0, 1.001, 4.0]);
}

#[test]
fn a_key_captured_at_a_parked_time_goes_there_and_no_other_key_moves() {
    let dir = tempfile::tempdir().unwrap();
    // Keys at 0 and 2 s (uniform, 2 s apart), key 0 current.
    let mut state = two_keys_at_the_first(dir.path());
    press(&mut state, Key::CaptureAt(1_250));
    let sequence = state.list().sequence();
    // Between them, at 1.25 s: the others stay at 0 and 2 s (`n` there would have pushed
    // the second key to 4 s).
    assert_eq!(sequence.key_times(), vec![0.0, 1.25, 2.0]);
    assert_eq!(state.list().current_index(), 1);
    assert!(!state.status().error, "{:?}", state.status());
    let journal = state.journal().unwrap().read().expect("journaled");
    assert_eq!(journal.list.sequence.key_times(), vec![0.0, 1.25, 2.0]);
    // After the last key: appended.
    press(&mut state, Key::CaptureAt(3_000));
    assert_eq!(
        state.list().sequence().key_times(),
        vec![0.0, 1.25, 2.0, 3.0]
    );
    // On a key's time: refused, nothing added.
    for millis in [2_000, 1_250] {
        press(&mut state, Key::CaptureAt(millis));
        assert!(state.status().error, "{millis} ms: {:?}", state.status());
        assert_eq!(state.list().len(), 4);
    }
}

#[test]
fn a_lost_front_end_stops_playback_softly_once() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = two_keys_at_the_first(dir.path());
    assert!(state.soft_stop().is_empty(), "idle: nothing to stop");
    press(&mut state, Key::Char('y'));
    assert!(state.is_moving());
    assert!(matches!(
        &state.soft_stop()[..],
        [Command::Bus(BusCommand::Stop { .. })]
    ));
    assert!(
        state.soft_stop().is_empty(),
        "a second request would hold at once: not asked for"
    );
}

/// Tool jogs: from a bent pose (the stretched home is singular), x then z then −x, each 5 mm;
/// the goals' tool point (forward kinematics) moves by exactly that, and the gripper stays.
#[test]
fn tool_jogs_move_the_tool_point_five_millimetres_along_an_axis() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press_all(
        &mut state,
        &[Key::Down, Key::ShiftLeft, Key::ShiftLeft, Key::ShiftLeft],
    );
    press_all(
        &mut state,
        &[Key::Down, Key::ShiftRight, Key::ShiftRight, Key::ShiftRight],
    );
    let start = state.robot().tcp_position(state.goals());
    let gripper = state.goals()[5];
    for (key, step) in [
        (Key::Char('x'), glam::DVec3::new(0.005, 0.0, 0.0)),
        (Key::Char('z'), glam::DVec3::new(0.005, 0.0, 0.005)),
        (Key::Char('X'), glam::DVec3::new(0.0, 0.0, 0.005)),
    ] {
        press(&mut state, key);
        let tool = state.robot().tcp_position(state.goals());
        assert!(
            (tool - start - step).length() < 1e-6,
            "{tool:?} vs {start:?} + {step:?}: {:?}",
            state.status()
        );
    }
    assert_eq!(state.goals()[5], gripper);
}

/// Jogging the tool forward from home (0.39 m out; the SO-101 reaches about 0.48 m) ends in
/// a refusal, out of reach or a jump, never a goal outside the limits.
#[test]
fn a_tool_jog_out_of_reach_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    let refused = (0..40).find(|_| press(&mut state, Key::Char('x')).is_empty());
    assert!(refused.is_some(), "40 jogs of 5 mm all went through");
    let status = state.status();
    assert!(
        status.error && (status.text.contains("cannot reach") || status.text.contains("jump")),
        "{status:?}"
    );
    let robot = state.robot();
    assert!(robot
        .joints
        .iter()
        .zip(state.goals())
        .all(|(j, &g)| j.limits.contains(g)));
}

/// `K` captures the present pose as a tool key whose solution, through the forward kinematics,
/// is the present tool position (rounded to 0.1 mm); the gripper stays a joint value.
#[test]
fn a_tool_key_captures_the_present_tool_pose() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press_all(
        &mut state,
        &[
            Key::Down,
            Key::ShiftLeft,
            Key::ShiftLeft,
            Key::Down,
            Key::ShiftRight,
        ],
    );
    press(&mut state, Key::Char('K'));
    let key = state.list().show().expect("a key").clone();
    let tool = key.tool.expect("a tool key");
    let present = state.robot().tcp_position(state.goals());
    assert!(
        (tool.xyz - present).abs().max_element() <= 0.00005 + 1e-12,
        "{tool:?} vs {present:?}"
    );
    assert!(
        key.value("gripper").is_some() && key.value("elbow_flex").is_none(),
        "{key:?}"
    );
    let trajectory = Trajectory::build(state.list().sequence(), state.robot()).expect("solves");
    let solved = state
        .robot()
        .tcp_position(&trajectory.sample(trajectory.start));
    assert!(solved.distance(tool.xyz) < 1e-6, "{solved:?}");
}

/// The bent pose of the tool-jog tests (lift −30°, elbow +30°): away from the stretched,
/// singular home.
fn bent(dir: &Path) -> TeachState {
    let mut state = session(dir);
    press_all(
        &mut state,
        &[Key::Down, Key::ShiftLeft, Key::ShiftLeft, Key::ShiftLeft],
    );
    press_all(
        &mut state,
        &[Key::Down, Key::ShiftRight, Key::ShiftRight, Key::ShiftRight],
    );
    state
}

/// A tool target in whole micrometres, `offset` metres from where the goals put the tool.
fn target_from_tool(state: &TeachState, offset: glam::DVec3) -> [i64; 3] {
    let p = state.robot().tcp_position(state.goals()) + offset;
    p.to_array().map(|x| (x * 1e6).round() as i64)
}

/// The studio's tool handle: a target 12 mm away (x +8, y −6, z +7 mm) moves the goals so that
/// the forward kinematics puts the tool on it, and the gripper stays.
#[test]
fn a_reachable_tool_target_moves_the_tool_there() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = bent(dir.path());
    let gripper = state.goals()[5];
    let target = target_from_tool(&state, glam::DVec3::new(0.008, -0.006, 0.007));
    let commands = press(&mut state, Key::ToolTarget(target));
    assert!(
        matches!(&commands[..], [Command::Bus(BusCommand::Run(plan))] if plan.kind == MotionKind::Jog),
        "{commands:?} {:?}",
        state.status()
    );
    let tool = state.robot().tcp_position(state.goals());
    let asked = glam::DVec3::from_array(target.map(|um| um as f64 * 1e-6));
    assert!(tool.distance(asked) < 0.0001, "{tool:?} vs {asked:?}");
    let shown = format!(
        "tool → ({:.1}, {:.1}, {:.1} mm)",
        target[0] as f64 / 1000.0,
        target[1] as f64 / 1000.0,
        target[2] as f64 / 1000.0
    );
    assert_eq!(state.status().text, shown);
    assert_eq!(state.goals()[5], gripper);
}

/// A target a metre out (the SO-101's links from the shoulder to the tool add up to well under
/// half a metre) is refused with the miss and the nearest point, and the goals stay.
#[test]
fn an_unreachable_tool_target_is_refused_and_the_arm_stays() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = bent(dir.path());
    let before = state.goals().to_vec();
    let commands = press(&mut state, Key::ToolTarget([1_000_000, 0, 100_000]));
    assert!(commands.is_empty(), "{commands:?}");
    let status = state.status();
    assert!(status.error, "{status:?}");
    assert!(
        status
            .text
            .starts_with("tool target: the tool cannot reach (1000.0, 0.0, 100.0 mm)")
            && status.text.contains("nearest reachable point"),
        "{status:?}"
    );
    let miss: f64 = status
        .text
        .split("misses by ")
        .nth(1)
        .unwrap()
        .split(" mm")
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(miss > 500.0, "{status:?}");
    assert_eq!(state.goals(), before.as_slice());
}

/// A target 15 cm to the side is reachable, but with the tool 0.33 m out the pan alone would
/// turn by atan(0.15 / 0.33) ≈ 24° at once: refused as a jump, the goals unchanged.
#[test]
fn a_tool_target_that_needs_a_joint_jump_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = bent(dir.path());
    let before = state.goals().to_vec();
    let target = target_from_tool(&state, glam::DVec3::new(0.0, 0.15, 0.0));
    let commands = press(&mut state, Key::ToolTarget(target));
    assert!(commands.is_empty(), "{commands:?}");
    let status = state.status();
    assert!(
        status.error && status.text.contains("shoulder_pan would jump"),
        "{status:?}"
    );
    assert_eq!(state.goals(), before.as_slice());
}

/// Two SO-101s: left at y +0.2 m, right at y −0.2 m turned 90° about z, so that the right
/// arm's base frame is not the cell's.
fn two_arm_cell() -> (Robot, Vec<crate::sequence::ArmSpec>) {
    use crate::pose::RigidTransform;
    let bases = [
        (
            "left",
            RigidTransform::new(glam::DVec3::new(0.0, 0.2, 0.0), glam::DQuat::IDENTITY),
        ),
        (
            "right",
            RigidTransform::new(
                glam::DVec3::new(0.0, -0.2, 0.0),
                glam::DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
            ),
        ),
    ];
    let cell = Robot::cell(
        bases
            .iter()
            .map(|&(name, base)| (name.to_string(), so101(), base))
            .collect(),
    )
    .unwrap();
    let specs = bases
        .iter()
        .map(|&(name, base)| crate::sequence::ArmSpec {
            name: name.into(),
            robot: "so101".into(),
            base: Some(crate::sequence::Placement::from_transform(base)),
        })
        .collect();
    (cell, specs)
}

/// A session on the two-arm cell, both arms at home and held, the right arm bent (lift −30°,
/// elbow +30°, away from the stretched, singular home) and its elbow selected.
fn bent_right_arm(dir: &Path) -> TeachState {
    let (cell, specs) = two_arm_cell();
    let present = cell.home.clone();
    let mut state = TeachState::new(
        cell,
        KeyframeList::new(Sequence::new_cell(specs)),
        dir.join("taught.json"),
        None,
        present,
    );
    let start = state.start();
    apply(&mut state, start);
    // Down from the left arm's shoulder_pan to the right arm's shoulder_lift (joint 7).
    for (key, times) in [
        (Key::Down, 7),
        (Key::ShiftLeft, 3),
        (Key::Down, 1),
        (Key::ShiftRight, 3),
    ] {
        for _ in 0..times {
            press(&mut state, key.clone());
        }
    }
    assert_eq!(
        state.robot().joints[state.selected()].name,
        "right/elbow_flex"
    );
    state
}

/// The right arm's tool point in its own base frame at the goals.
fn right_tool(state: &TeachState) -> glam::DVec3 {
    let arm = state.robot().arm("right").unwrap();
    arm.robot.tcp_position(arm.values(state.goals()))
}

/// On a cell a tool jog moves the selected joint's arm, along its own base frame's axis (the
/// right arm is turned, so the cell's x is not its x): 5 mm exactly, the other arm untouched.
#[test]
fn on_a_cell_tool_jogs_move_the_selected_joints_arm_in_its_base_frame() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = bent_right_arm(dir.path());
    let left_before = state.goals()[..6].to_vec();
    let start = right_tool(&state);
    press(&mut state, Key::Char('x'));
    let moved = right_tool(&state) - start;
    assert!(
        (moved - glam::DVec3::new(0.005, 0.0, 0.0)).length() < 1e-6,
        "{moved:?}: {:?}",
        state.status()
    );
    assert_eq!(&state.goals()[..6], &left_before[..]);
    // The status says where the right arm's tool went, in the right arm's base frame.
    let said = format!(
        "tool (right) → ({})",
        crate::kinematics::mm3(right_tool(&state))
    );
    assert_eq!(state.status().text, said);
}

/// `K` on a cell captures a tool key of the selected joint's arm (`"tool": {"right": …}`, in
/// its base frame), every other joint as a joint value; the key solves back onto that point.
#[test]
fn on_a_cell_a_tool_key_is_the_selected_arms() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = bent_right_arm(dir.path());
    press(&mut state, Key::Char('K'));
    let key = state.list().show().expect("a key").clone();
    assert!(key.tool.is_none(), "{key:?}");
    let [(arm, tool)] = key.arm_tools.as_slice() else {
        panic!("one arm's tool: {key:?}")
    };
    assert_eq!(arm, "right");
    let present = right_tool(&state);
    assert!(
        (tool.xyz - present).abs().max_element() <= 0.00005 + 1e-12,
        "{tool:?} vs {present:?}"
    );
    assert!(
        key.value("right/gripper").is_some()
            && key.value("left/elbow_flex").is_some()
            && key.value("right/elbow_flex").is_none(),
        "{key:?}"
    );
    let trajectory = Trajectory::build(state.list().sequence(), state.robot()).expect("solves");
    let sample = trajectory.sample(trajectory.start);
    let right = state.robot().arm("right").unwrap();
    let solved = right.robot.tcp_position(right.values(&sample));
    assert!(solved.distance(tool.xyz) < 1e-6, "{solved:?}");
}

/// The plan of the one motion `commands` start.
fn started(state: &mut TeachState, commands: Vec<Command>) -> super::motion::MotionPlan {
    let [Command::Bus(BusCommand::Run(plan))] = &commands[..] else {
        panic!("expected a motion, got {commands:?}");
    };
    state.on_event(Event::MotionStarted {
        kind: plan.kind,
        end_pose: plan.end_pose.clone(),
        joints: plan.joints.clone(),
    });
    (**plan).clone()
}

#[test]
fn jogs_pressed_while_a_jog_runs_keep_the_newest_only_and_a_stop_drops_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    let commands = state.handle_key(Key::Right);
    let first = started(&mut state, commands);
    assert_eq!(
        (first.kind, &first.joints[..]),
        (MotionKind::Jog, &[PAN][..])
    );
    assert_eq!(first.end_pose[PAN], 1.0);
    // A held key's repeats (sixty of them) and a shift-left: nothing is sent meanwhile, and
    // only the newest waits.
    for _ in 0..60 {
        assert!(state.handle_key(Key::Right).is_empty());
    }
    assert!(state.handle_key(Key::ShiftLeft).is_empty());
    assert_eq!(state.pending_jog(), Some(&Key::ShiftLeft));
    // The first jog arrives: the waiting one starts from where it went, 1 − 10 = −9°.
    let follow = state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: Some(first.end_pose.clone()),
        warnings: Vec::new(),
    });
    let second = started(&mut state, follow);
    assert_eq!(second.end_pose[PAN], -9.0);
    assert_eq!(state.pending_jog(), None);
    // A stop drops what waits and asks the player for its first request (brake).
    assert!(state.handle_key(Key::Right).is_empty());
    let stop = state.handle_key(Key::Esc);
    assert!(
        matches!(&stop[..], [Command::Bus(BusCommand::Stop { requests: 1 })]),
        "{stop:?}"
    );
    assert_eq!(state.pending_jog(), None);
    // Braked part-way: the goal is where it stopped, and nothing else runs.
    let follow = state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Stopped),
        last_goals: Some(vec![-4.3, 0.0, 0.0, 0.0, 0.0, 0.0]),
        warnings: Vec::new(),
    });
    assert!(follow.is_empty(), "{follow:?}");
    assert!(!state.is_moving());
    assert_eq!(state.goals()[PAN], -4.3);
}

#[test]
fn a_jog_of_one_joint_leaves_a_limp_joint_limp() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    const GRIPPER: usize = 5;
    press(&mut state, Key::SelectJoint(GRIPPER));
    press(&mut state, Key::Char('t'));
    press(&mut state, Key::SelectJoint(PAN));
    assert!(!state.torque()[GRIPPER]);
    let commands = state.handle_key(Key::Right);
    let plan = started(&mut state, commands);
    assert_eq!(plan.joints, [PAN], "the player drives the pan alone");
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: Some(plan.end_pose.clone()),
        warnings: Vec::new(),
    });
    assert!(!state.torque()[GRIPPER], "still limp");
    assert_eq!(state.goals()[PAN], 1.0);
}

#[test]
fn a_playback_that_ran_late_says_so_instead_of_played_to_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Char('n'));
    press(&mut state, Key::ShiftRight);
    press(&mut state, Key::Char('n'));
    let commands = state.handle_key(Key::Char('y'));
    started(&mut state, commands);
    let late = "40 stall(s): the longest held a goal 250 ms beyond its period; 300 deadline(s) \
                skipped, the sequence ran 3.200 s late; largest lateness 250.0 ms";
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: None,
        warnings: vec![late.into()],
    });
    let status = state.status();
    assert!(status.error, "{status:?}");
    assert!(status.text.starts_with("played to the end"), "{status:?}");
    assert!(status.text.contains("ran 3.200 s late"), "{status:?}");
}

#[test]
fn a_jog_that_stalled_on_a_busy_machine_is_no_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    let commands = state.handle_key(Key::Right);
    let plan = started(&mut state, commands);
    state.on_event(Event::MotionEnded {
        outcome: Ok(Outcome::Finished),
        last_goals: Some(plan.end_pose.clone()),
        warnings: vec!["3 stall(s): the longest held a goal 10 ms beyond its period".into()],
    });
    assert!(!state.status().error, "{:?}", state.status());
    assert_eq!(state.goals()[PAN], 1.0);
}

#[test]
fn a_journal_that_cannot_be_written_says_why_in_brackets_and_that_w_saves() {
    let dir = tempfile::tempdir().unwrap();
    // A cache "directory" that is a file: the journal's directory cannot be made in it.
    let cache = dir.path().join("cache");
    std::fs::write(&cache, "").unwrap();
    let output = dir.path().join("taught.json");
    let journal = Journal::for_target(&cache, &output);
    let robot = so101();
    let present = robot.home.clone();
    let mut state = TeachState::new(
        robot,
        KeyframeList::new(Sequence::new("so101")),
        output,
        Some(journal.clone()),
        present,
    );
    let start = state.start();
    apply(&mut state, start);
    press(&mut state, Key::Char('n'));
    let status = state.status();
    assert!(status.error, "{status:?}");
    let expected = format!(
        "; but the journal {} cannot be written (",
        journal.path().display()
    );
    assert!(status.text.contains(&expected), "{status:?}");
    assert!(status.text.ends_with("): w saves your work"), "{status:?}");
}

#[test]
fn a_motion_that_failed_says_the_player_error_and_its_cause() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    let commands = state.handle_key(Key::Right);
    started(&mut state, commands);
    let error = crate::player::PlayError::Log {
        path: "teach.csv".into(),
        source: std::io::Error::other("disk full"),
    };
    state.on_event(Event::MotionEnded {
        outcome: Err(crate::teach::MotionError(std::sync::Arc::new(error))),
        last_goals: None,
        warnings: Vec::new(),
    });
    let status = state.status();
    assert!(status.error, "{status:?}");
    assert_eq!(
        status.text,
        "motion stopped: cannot write log teach.csv: disk full"
    );
}

/// Issue 24, part 4: a jog into the floor is refused before the arm moves, as the studio's
/// page and the terminal share this rule; the arm can still be jogged back. The SO-101's
/// shoulder lift at its +100° limit folds the stretched arm into the desk (its model's
/// capsules, which MuJoCo's contacts agree with: tests/simulation/collision.rs).
#[test]
fn a_jog_into_the_floor_is_refused_and_the_arm_may_jog_back() {
    let dir = tempfile::tempdir().unwrap();
    let mut state = session(dir.path());
    press(&mut state, Key::Down);
    let mut refused = None;
    for _ in 0..10 {
        let before = state.goals()[1];
        let commands = press(&mut state, Key::ShiftRight);
        if state.status().error {
            assert!(commands.is_empty(), "nothing sent: {commands:?}");
            assert_eq!(state.goals()[1], before, "the arm stays");
            refused = Some(state.status().text.clone());
            break;
        }
    }
    let text = refused.expect("a jog was refused before the limit");
    assert!(
        text.starts_with("cannot jog shoulder_lift to") && text.contains("the floor"),
        "{text}"
    );
    assert!(state.goals()[1] < 100.0);
    let back = state.goals()[1] - 10.0;
    press(&mut state, Key::ShiftLeft);
    assert_eq!(state.goals()[1], back, "{}", state.status().text);
}

#[test]
fn several_selected_keys_copy_paste_move_and_delete_as_one_undoable_step_each() {
    let dir = tempfile::tempdir().unwrap();
    // Keys at 0, 2 and 4 s (uniform), key 0 current.
    let mut state = two_keys_at_the_first(dir.path());
    press_all(
        &mut state,
        &[Key::Char('>'), Key::Char('n'), Key::SelectKey(0)],
    );
    assert_eq!(state.list().len(), 3);
    press(&mut state, Key::RangeKey(1));
    assert_eq!(state.list().selection(), [0, 1]);
    assert!(
        state.status().text.contains("keys 0 and 1 selected"),
        "{:?}",
        state.status()
    );
    press_all(&mut state, &[Key::Copy, Key::SelectKey(2), Key::Paste]);
    assert_eq!(state.list().len(), 5, "{:?}", state.status());
    assert_eq!(
        state.list().selection(),
        [3, 4],
        "the pasted keys are the selection"
    );
    assert_eq!(key_values(&state, 3), key_values(&state, 0));
    assert_eq!(journaled(&state).unwrap().keyframes.len(), 5);
    // Their move in time: the list gets absolute times, the two keys move together.
    press(&mut state, Key::ShiftKeys(500));
    assert_eq!(
        state.list().sequence().key_times(),
        [0.0, 2.0, 4.0, 6.5, 8.5]
    );
    // A move through the unselected key 2 is refused whole.
    press(&mut state, Key::ShiftKeys(-3_000));
    assert!(state.status().error, "{:?}", state.status());
    assert_eq!(
        state.list().sequence().key_times(),
        [0.0, 2.0, 4.0, 6.5, 8.5]
    );
    // `d` deletes both; each edit is one step of undo.
    press(&mut state, Key::Char('d'));
    assert_eq!(state.list().len(), 3);
    press(&mut state, Key::Undo);
    assert_eq!(state.list().len(), 5);
    press(&mut state, Key::Undo);
    assert_eq!(
        state.list().sequence().key_times()[3],
        6.0,
        "the move undone"
    );
    press(&mut state, Key::Undo);
    assert_eq!(state.list().len(), 3, "the paste undone");
    // Nothing copied in a new session: paste says so.
    let mut fresh = session(&dir.path().join("other"));
    press(&mut fresh, Key::Paste);
    assert!(fresh.status().text.contains("nothing copied"));
}

/// A list recovered from the journal is written in its file's layout, as it would have been
/// before the crash: the file's spacing, field order and numbers as typed (`10.50`, `0.7071`)
/// stay, and only the edited name changes. Once the file has changed since, the journal's list
/// is written in the canonical layout instead (its places would point into another text).
#[test]
fn a_recovered_list_keeps_its_files_layout_while_the_file_is_the_one_it_came_from() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("taught.json");
    let written = "{ \"format\": \"keypose-sequence/1\", \"robot\": \"so101\",\n  \"keyframes\": [\n    \
                   {\"name\": \"a\",  \"joints\": {\"elbow_flex\": 10.50, \"wrist_flex\": 0.7071}},\n    \
                   {\"name\": \"b\",  \"joints\": {\"elbow_flex\": 20}}\n  ] }\n";
    let on = |list: KeyframeList| {
        let robot = so101();
        let present = robot.home.clone();
        let journal = Journal::for_target(dir.path(), &output);
        TeachState::new(robot, list, output.clone(), Some(journal), present)
    };
    for file_changed in [false, true] {
        std::fs::write(&output, written).unwrap();
        let mut crashed = on(KeyframeList::load(&output).unwrap());
        press(&mut crashed, Key::Char('>'));
        // The name prompt starts from the key's name, "b".
        edit(&mut crashed, 'N', "2");
        let journal = crashed.journal().unwrap().clone();
        drop(crashed);
        if file_changed {
            std::fs::write(&output, written.replace("10.50", "10.5")).unwrap();
            // The journal written again after the file, so that it is still offered.
            let text = std::fs::read(journal.path()).unwrap();
            std::fs::write(journal.path(), text).unwrap();
        }
        let mut state = on(KeyframeList::load(&output).unwrap());
        let pending = journal.pending(&output).unwrap().expect("offered");
        state.recover(pending);
        press(&mut state, Key::Char('w'));
        let text = std::fs::read_to_string(&output).unwrap();
        if file_changed {
            assert!(text.starts_with("{\n"), "the canonical layout:\n{text}");
        } else {
            assert_eq!(text, written.replace("\"b\"", "\"b2\""));
        }
        let back = Sequence::load(&output).unwrap();
        assert_eq!(back.keyframes[1].name.as_deref(), Some("b2"));
    }
}

#[test]
fn easing_is_for_linear_segments_and_one_step_of_undo() {
    let dir = tempfile::tempdir().unwrap();
    // Keys at 0, 2 and 4 s, monotone (a new list's mode), key 0 current.
    let mut state = two_keys_at_the_first(dir.path());
    press(&mut state, Key::Ease { out: 20, into: 30 });
    assert!(state.status().error, "{:?}", state.status());
    assert!(
        state.status().text.contains("linear"),
        "{:?}",
        state.status()
    );
    assert!(state.list().sequence().keyframes[0].timing.is_none());
    // p: monotone → step → linear.
    press_all(&mut state, &[Key::Char('p'), Key::Char('p')]);
    press(&mut state, Key::Ease { out: 20, into: 30 });
    assert!(!state.status().error, "{:?}", state.status());
    let timing = state.list().sequence().keyframes[0]
        .timing
        .clone()
        .expect("eased");
    assert_eq!(timing.path_time, 2.0, "the segment's own 2 s");
    let (out, into) = timing.ease_shares();
    assert!((out - 0.2).abs() < 1e-12 && (into - 0.3).abs() < 1e-12);
    assert_eq!(journaled(&state).unwrap().keyframes[0].timing, Some(timing));
    for (out, into) in [(60, 50), (7, 0)] {
        press(&mut state, Key::Ease { out, into });
        assert!(state.status().error, "{out} {into}: {:?}", state.status());
    }
    press(&mut state, Key::Ease { out: 0, into: 0 });
    assert!(
        state.list().sequence().keyframes[0].timing.is_none(),
        "steady"
    );
    press(&mut state, Key::Undo);
    assert!(
        state.list().sequence().keyframes[0].timing.is_some(),
        "undone"
    );
    press(&mut state, Key::Char('>'));
    press(&mut state, Key::Char('>'));
    press(&mut state, Key::Ease { out: 20, into: 30 });
    assert!(
        state.status().text.contains("last key"),
        "{:?}",
        state.status()
    );
}
