//! The studio's engine on emulated servos (a pseudo-terminal, the real serial and protocol
//! code), without a browser: a controller that stops sending heartbeats loses control, and the
//! playback it started stops the soft way, along its path.

use keypose::bus::{self, BusOptions};
use keypose::robot::Robot;
use keypose::sequence::{KeyframeList, Sequence};
use keypose::studio::engine::{self, Action, Ended, Hub, Input, News};
use keypose::teach::{self, Key, Session, TeachState};
use serde_json::Value;
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[test]
fn a_silent_controller_loses_control_and_playback_stops_softly() {
    let robot = Robot::builtin("so101").unwrap();
    let options = BusOptions::default();
    let connection = bus::connect_with(&robot, bus::VIRTUAL_PORT, &options).expect("virtual bus");
    let _servos = connection.virtual_bus;
    let mut session = Session::new(connection.bus, &robot);
    let present = session.read().unwrap().unwrap();
    let list = KeyframeList::new(Sequence::new("so101"));
    let mut state = TeachState::new(robot, list, "unused.json".into(), None, present);
    let start = state.start();
    teach::apply(&mut state, &mut session, start);
    let hub = Arc::new(Hub::default());
    let (inputs, received) = mpsc::channel();
    let engine_hub = hub.clone();
    let engine = std::thread::spawn(move || {
        engine::run(&mut state, &mut session, &engine_hub, received).map(|ended| (ended, state))
    });

    // Four keys 2 s apart, each 10° further on the pan: six seconds of playback, far longer
    // than the 2 s lease. (The engine takes keys from the channel as they come; the server
    // is what checks the lease before it passes one on.)
    let key = |key: Key| {
        let (reply, answer) = mpsc::channel();
        inputs
            .send(Input::Action {
                action: Action::Key(key),
                reply,
            })
            .unwrap();
        answer.recv().unwrap()
    };
    for _ in 0..3 {
        key(Key::Char('n'));
        key(Key::ShiftRight);
    }
    key(Key::Char('n'));
    for _ in 0..3 {
        key(Key::Char('<'));
    }
    hub.lease().claim("page", Instant::now()).unwrap();
    let status = key(Key::Char('y'));
    assert!(
        status["text"].as_str().unwrap().contains("playing"),
        "{status}"
    );
    // No heartbeat from here on: the engine lets the page go and stops the arm.
    let snapshot = wait_for(&hub, |s| {
        s["activity"]["kind"] == "idle" && s["status"]["text"].as_str().unwrap().contains("stopped")
    });
    assert!(
        snapshot["status"]["text"]
            .as_str()
            .unwrap()
            .contains("decelerated along its path"),
        "{snapshot}"
    );
    assert_eq!(snapshot["controlled"], Value::Bool(false));
    inputs.send(Input::Interrupt).unwrap();
    let (ended, state) = engine.join().unwrap().unwrap();
    assert_eq!(ended, Ended::Interrupted);
    assert!(state.torque().iter().all(|&t| t), "the arm holds");
}

/// The first snapshot that satisfies `done` (a hang guard of a minute, not a timing check).
fn wait_for(hub: &Hub, done: impl Fn(&Value) -> bool) -> Value {
    let give_up = Instant::now() + Duration::from_secs(60);
    let mut seen = 0;
    while Instant::now() < give_up {
        if let News::Snapshot(seq, json) = hub.wait_news(seen, Duration::from_millis(200)) {
            seen = seq;
            let value: Value = serde_json::from_str(&json).unwrap();
            if done(&value) {
                return value;
            }
        }
    }
    panic!("no such snapshot within a minute");
}
