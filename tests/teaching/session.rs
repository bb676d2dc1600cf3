//! The teaching state machine and session driver on emulated servos (a pseudo-terminal, the
//! real serial and protocol code): a limp joint moved by hand is captured where it was put,
//! and playback started with `y` stops along its path on the next `y`.

use keypose::bus::{self, BusOptions, Connection, Driver};
use keypose::player::Outcome;
use keypose::robot::Robot;
use keypose::sequence::{KeyValue, KeyframeList, Sequence};
use keypose::teach::{self, Event, Key, Session, TeachState};
use keypose::testing::PtyServer;

/// Emulated servos of `robot` and a session on them; the server lives as long as the first.
fn open(robot: &Robot) -> (Option<PtyServer>, Session) {
    let Connection { bus, virtual_bus } = bus::connect_with(
        robot,
        bus::VIRTUAL_PORT,
        &BusOptions {
            driver: Driver::Native,
            baud: None,
            fast_sync_read: false,
            ..BusOptions::default()
        },
    )
    .expect("virtual bus");
    (virtual_bus, Session::new(bus, robot))
}

fn start(robot: &Robot, session: &mut Session) -> TeachState {
    let present = session.read().expect("read").expect("a pose");
    let mut state = TeachState::new(
        robot.clone(),
        KeyframeList::new(Sequence::new(&robot.name)),
        "unused.json".into(),
        None,
        present,
    );
    let commands = state.start();
    teach::apply(&mut state, session, commands);
    state
}

/// The goals `joint`'s servo received after the first `before` goals of the bus, as values.
fn goals_of(server: &PtyServer, joint: &keypose::robot::Joint, before: usize) -> Vec<f64> {
    server.bus().lock().goals_received()[before..]
        .iter()
        .filter(|(id, _)| *id == joint.servo.id)
        .map(|&(_, tick)| joint.servo.value(tick))
        .collect()
}

/// Every step of the pan's goals, from `start`, within 115 °/s over 10 ms and a tick of
/// rounding: no jump.
fn assert_pan_steps_within_its_speed(start: f64, goals: &[f64]) {
    let tick = 360.0 / 4096.0;
    let mut previous = start;
    for &goal in goals {
        assert!(
            (goal - previous).abs() <= 1.15 + tick,
            "{previous} → {goal}"
        );
        previous = goal;
    }
}

/// The motion ended in a stop along its path.
fn assert_stopped(ended: &Event) {
    assert!(
        matches!(
            ended,
            Event::MotionEnded {
                outcome: Ok(Outcome::Stopped),
                ..
            }
        ),
        "{ended:?}"
    );
}

/// A key press, then (as a script step does) waiting until the motion it started, a jog
/// included, is over and the arm has arrived.
fn press(state: &mut TeachState, session: &mut Session, key: Key) {
    let mut events = teach::press(state, session, key);
    if let Some(ended) = session.wait_motion().expect("the motion thread") {
        let follow = state.on_event(ended.clone());
        events.push(ended);
        events.extend(teach::apply(state, session, follow));
    }
    assert!(
        !events.iter().any(|e| matches!(
            e,
            Event::BusError(_)
                | Event::MotionEnded {
                    outcome: Err(_),
                    ..
                }
        )),
        "{events:?}"
    );
    assert!(session
        .settle(std::time::Duration::from_secs(5))
        .expect("settle"));
    teach::refresh(state, session);
}

fn pan(state: &TeachState, key: usize) -> f64 {
    match state.list().sequence().keyframes[key].value("shoulder_pan") {
        Some(KeyValue::Joint(v)) => *v,
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_limp_joint_moved_by_hand_is_captured_where_it_was_put() {
    let robot = Robot::builtin("so101").unwrap();
    let (server, mut session) = open(&robot);
    let mut state = start(&robot, &mut session);
    press(&mut state, &mut session, Key::Char('t'));
    assert!(!state.torque()[0], "{}", state.status().text);

    // Turn the pan by hand to 33.3°; the other joints hold.
    let pan_servo = &robot.joints[0].servo;
    let server = server.as_ref().expect("virtual servos");
    server
        .bus()
        .lock()
        .servo_mut(pan_servo.id)
        .expect("pan servo")
        .motion
        .push_to(pan_servo.tick_exact(33.3));
    press(&mut state, &mut session, Key::Char('n'));
    assert_eq!(pan(&state, 0), 33.3);

    // Held again where it is, it jogs from there.
    press(&mut state, &mut session, Key::Char('t'));
    press(&mut state, &mut session, Key::ShiftRight);
    press(&mut state, &mut session, Key::Char('n'));
    assert_eq!(pan(&state, 1), 43.3);

    // A held joint is not moved by a push.
    server
        .bus()
        .lock()
        .servo_mut(pan_servo.id)
        .unwrap()
        .motion
        .push_to(pan_servo.tick_exact(-50.0));
    press(&mut state, &mut session, Key::Char('u'));
    assert_eq!(pan(&state, 1), 43.3);
}

#[test]
fn y_plays_and_a_second_y_stops_along_the_path() {
    let robot = Robot::builtin("so101").unwrap();
    let (_connection, mut session) = open(&robot);
    let mut state = start(&robot, &mut session);
    press(&mut state, &mut session, Key::Char('n'));
    for _ in 0..9 {
        press(&mut state, &mut session, Key::ShiftRight);
    }
    press(&mut state, &mut session, Key::Char('n'));
    press(&mut state, &mut session, Key::Char('<'));

    // From key 0: a ramp from 90° back to 0°, then the 90° sweep; stopped at once, it
    // decelerates and holds wherever it was, torque on.
    let events = teach::press(&mut state, &mut session, Key::Char('y'));
    assert!(
        events
            .iter()
            .any(|e| matches!(e, Event::MotionStarted { .. })),
        "{events:?}"
    );
    assert!(state.is_moving() && session.is_moving());
    // Keys are still read while it moves; bus keys are refused, not queued.
    let _ = teach::press(&mut state, &mut session, Key::Right);
    assert!(state.status().error);
    let _ = teach::press(&mut state, &mut session, Key::Char('y'));
    let ended = session.wait_motion().expect("joined").expect("ended");
    assert_stopped(&ended);
    state.on_event(ended);
    assert!(!state.is_moving());
    assert!(state.torque().iter().all(|&t| t));
    // The bus is back: jogging works again.
    press(&mut state, &mut session, Key::Right);
    assert!(!state.status().error, "{}", state.status().text);
}

#[test]
fn a_joint_pushed_far_past_its_limit_is_not_held_until_moved_inside() {
    // Torque on where a joint is would need a goal outside its limits, and pulling it to the
    // limit at once would be a jump: `t` says so and leaves it limp. A joint just past (within
    // the player's 2° start slack) is held at its limit. No goal past a limit reaches a servo.
    let robot = Robot::builtin("so101").unwrap();
    let (server, mut session) = open(&robot);
    let mut state = start(&robot, &mut session);
    let pan = &robot.joints[0];
    let server = server.as_ref().expect("virtual servos");
    let push = |value: f64| {
        server
            .bus()
            .lock()
            .servo_mut(pan.servo.id)
            .unwrap()
            .motion
            .push_to(pan.servo.tick_exact(value))
    };
    press(&mut state, &mut session, Key::Char('t'));
    assert!(!state.torque()[0]);
    push(pan.limits.max + 10.0);
    let events = teach::press(&mut state, &mut session, Key::Char('t'));
    assert!(
        events
            .iter()
            .any(|e| matches!(e, Event::BusError(m) if m.contains("shoulder_pan"))),
        "{events:?}"
    );
    assert!(!state.torque()[0], "{}", state.status().text);
    assert!(
        !server
            .bus()
            .lock()
            .servo_mut(pan.servo.id)
            .unwrap()
            .motion
            .torque
    );

    push(pan.limits.max + 1.0);
    press(&mut state, &mut session, Key::Char('t'));
    assert!(state.torque()[0], "{}", state.status().text);
    let goals = server.bus().lock().goals_received();
    let (_, last) = goals
        .iter()
        .rev()
        .find(|(id, _)| *id == pan.servo.id)
        .unwrap();
    assert!((pan.servo.value(*last) - pan.limits.max).abs() < 0.1);
    for (id, tick) in goals {
        let joint = robot.joints.iter().find(|j| j.servo.id == id).unwrap();
        assert!(
            joint.limits.contains(joint.servo.value(tick)),
            "{}",
            joint.name
        );
    }
}

#[test]
fn a_big_jog_moves_along_a_ramp_within_the_limits_not_in_one_jump() {
    let robot = Robot::builtin("so101").unwrap();
    let (server, mut session) = open(&robot);
    let mut state = start(&robot, &mut session);
    let server = server.as_ref().expect("virtual servos");
    let pan = &robot.joints[0];
    let before = server.bus().lock().goals_received().len();
    // Shift+right: +10° on the selected joint (the pan), from 0°.
    press(&mut state, &mut session, Key::ShiftRight);
    let pan_goals = goals_of(server, pan, before);
    // A minimum-jerk ramp at half the limits: 10° needs 15/8 · 10 / 57.5 = 0.326 s (velocity)
    // and √(5.774 · 10 / 172) = 0.579 s (acceleration), so about 58 goals at 100 Hz.
    assert!(
        pan_goals.len() >= 50,
        "{} goals: {pan_goals:?}",
        pan_goals.len()
    );
    let tick = 360.0 / 4096.0;
    assert_pan_steps_within_its_speed(0.0, &pan_goals);
    assert!((pan_goals.last().unwrap() - 10.0).abs() <= tick / 2.0);
}

#[test]
fn esc_brakes_a_jog_mid_ramp_and_drops_the_jog_waiting_behind_it() {
    let robot = Robot::builtin("so101").unwrap();
    let (server, mut session) = open(&robot);
    let mut state = start(&robot, &mut session);
    let server = server.as_ref().expect("virtual servos");
    let pan = &robot.joints[0];
    let before = server.bus().lock().goals_received().len();
    // Shift+right (+10°, a 0.58 s ramp) and another behind it; Esc at once.
    teach::press(&mut state, &mut session, Key::ShiftRight);
    assert!(
        state.is_moving(),
        "the jog runs while keys are read: {}",
        state.status().text
    );
    teach::press(&mut state, &mut session, Key::ShiftRight);
    assert_eq!(state.pending_jog(), Some(&Key::ShiftRight));
    teach::press(&mut state, &mut session, Key::Esc);
    let ended = session.wait_motion().unwrap().expect("a motion");
    assert_stopped(&ended);
    let follow = state.on_event(ended);
    assert!(follow.is_empty(), "nothing runs after the stop: {follow:?}");
    let pan_goals = goals_of(server, pan, before);
    // Braked along the ramp, well short of 10°, never a step beyond 115 °/s over 10 ms.
    let last = *pan_goals.last().unwrap();
    assert!(last < 10.0 - 1.0, "{pan_goals:?}");
    let tick = 360.0 / 4096.0;
    assert_pan_steps_within_its_speed(0.0, &pan_goals);
    assert!(
        (state.goals()[0] - last).abs() <= tick,
        "the screen holds where it stopped"
    );
}
