//! The studio's engine on emulated servos (a pseudo-terminal, the real serial and protocol
//! code), without a browser: a controller that stops sending heartbeats loses control, and the
//! playback it started stops the soft way, along its path; a stop behind sixty queued jogs
//! stops the arm within the jog it was on, and none of the sixty runs after it.

use keypose::bus::{self, BusOptions};
use keypose::robot::Robot;
use keypose::sequence::{KeyframeList, Sequence};
use keypose::studio::engine::{self, Action, Ended, Hub, Input, News};
use keypose::teach::{self, Key, Session, TeachState};
use keypose::testing::PtyServer;
use serde_json::Value;
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

type Engine = std::thread::JoinHandle<Result<(Ended, TeachState), teach::TeachError>>;

/// The engine on a virtual SO-101 (every joint at 0°, held), with the servos' server, the
/// published state and the engine's input channel.
fn start_engine() -> (Option<PtyServer>, Arc<Hub>, mpsc::Sender<Input>, Engine) {
    let robot = Robot::builtin("so101").unwrap();
    let options = BusOptions::default();
    let connection = bus::connect_with(&robot, bus::VIRTUAL_PORT, &options).expect("virtual bus");
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
    (connection.virtual_bus, hub, inputs, engine)
}

/// Sends `action` without waiting; the receiver gets its answer.
fn send(inputs: &mpsc::Sender<Input>, action: Action) -> mpsc::Receiver<Value> {
    let (reply, answer) = mpsc::channel();
    inputs.send(Input::Action { action, reply }).unwrap();
    answer
}

#[test]
fn a_stop_behind_sixty_queued_jogs_brakes_the_one_running_and_drops_the_rest() {
    let (servos, hub, inputs, engine) = start_engine();
    let servos = servos.expect("virtual servos");
    let robot = Robot::builtin("so101").unwrap();
    let pan = &robot.joints[0];
    // Sixty shift-right presses (+10° each: 600°, far past the pan's limit), then Stop: the
    // first one answered (its jog has started), the other 59 at once.
    let first = send(&inputs, Action::Key(Key::ShiftRight)).recv().unwrap();
    assert!(
        first["text"]
            .as_str()
            .unwrap()
            .contains("shoulder_pan → 10"),
        "{first}"
    );
    let jogs: Vec<_> = (1..60)
        .map(|_| send(&inputs, Action::Key(Key::ShiftRight)))
        .collect();
    let stop = send(&inputs, Action::Stop);
    stop.recv().unwrap();
    let snapshot = wait_for(&hub, |s| s["activity"]["kind"] == "idle");
    let answers: Vec<Value> = jogs.iter().map(|a| a.recv().unwrap()).collect();
    let dropped = answers
        .iter()
        .filter(|a| a["text"].as_str().unwrap().starts_with("dropped"))
        .count();
    let pan_goals: Vec<f64> = servos
        .bus()
        .lock()
        .goals_received()
        .iter()
        .filter(|(id, _)| *id == pan.servo.id)
        .map(|&(_, tick)| pan.servo.value(tick))
        .collect();
    let last = *pan_goals.last().unwrap();
    eprintln!(
        "{dropped} of the 59 queued jogs dropped; the pan ended at {last:.2}° after {} goals; {}",
        pan_goals.len(),
        snapshot["status"]["text"]
    );
    // Without the stop winning, the sixty jogs ran one after another to the pan's limit
    // (110°). With it, the arm stops within the jog it was on — at most the one jog that
    // waited behind it had started — and every goal step stays within the pan's limits.
    assert!(last < 20.0, "the pan went on to {last}°");
    assert!(dropped >= 58, "{answers:?}");
    assert_decelerated(&snapshot);
    let limit = pan.limits.velocity / robot.control_hz + 360.0 / 4096.0;
    for pair in pan_goals.windows(2) {
        assert!((pair[1] - pair[0]).abs() <= limit, "{pair:?}");
    }
    inputs.send(Input::Interrupt).unwrap();
    let (ended, _) = engine.join().unwrap().unwrap();
    assert_eq!(ended, Ended::Interrupted);
}

#[test]
fn a_silent_controller_loses_control_and_playback_stops_softly() {
    let (_servos, hub, inputs, engine) = start_engine();

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
        s["activity"]["kind"] == "idle"
            && s["status"]["text"].as_str().unwrap().contains("stopped")
            && s["controlled"] == Value::Bool(false)
    });
    // Along its path: stopped for the lapsed lease, or, on a machine loaded enough to stall
    // the playback first (CI beside busy loops), braked by the stall guard. Either way softly.
    let text = snapshot["status"]["text"].as_str().unwrap();
    assert!(
        text.contains("decelerated along its path")
            || text.contains("braked to rest along the path"),
        "{snapshot}"
    );
    inputs.send(Input::Interrupt).unwrap();
    let (ended, state) = engine.join().unwrap().unwrap();
    assert_eq!(ended, Ended::Interrupted);
    assert!(state.torque().iter().all(|&t| t), "the arm holds");
}

/// The snapshot says the arm stopped along its path.
fn assert_decelerated(snapshot: &Value) {
    let text = snapshot["status"]["text"].as_str().unwrap();
    assert!(text.contains("decelerated along its path"), "{snapshot}");
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
