//! Recording against emulated servos, in process: the native driver encodes real packets, the
//! virtual bus decodes them and answers, and a "hand" on another thread moves a limp servo
//! along a known path (the virtual servo only lets itself be pushed while its torque is off).
//! Nothing is mocked but the wire (an in-memory transport; the pseudo-terminal path is covered
//! in `tests/servos/record.rs`).

use keypose::bus::NativeBus;
use keypose::bus::ServoBus;
use keypose::curve::{Interp, Track, TrackKey};
use keypose::plan::{check, Trajectory};
use keypose::player::StopSignal;
use keypose::record::{keyframes, record, KeyframeOptions, RecordError, RecordOptions};
use keypose::robot::Robot;
use keypose::sequence::{KeyValue, Sequence};
use keypose::testing::{ServoFault, VirtualBus};
use std::time::{Duration, Instant};

/// The arm powered and holding where it rests, as before any recording.
/// An SO-101 of emulated servos holding at home, as before any recording, and the indices of
/// the two joints the tests record.
struct Arm {
    robot: Robot,
    bus: NativeBus,
    virtual_bus: VirtualBus,
    elbow: usize,
    wrist: usize,
}

fn so101_holding() -> Arm {
    let robot = Robot::builtin("so101").unwrap();
    let elbow = robot.joint_index("elbow_flex").unwrap();
    let wrist = robot.joint_index("wrist_flex").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    hold_all(&mut bus, &robot);
    Arm {
        robot,
        bus,
        virtual_bus,
        elbow,
        wrist,
    }
}

fn hold_all(bus: &mut NativeBus, robot: &Robot) {
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let ticks = bus.read_positions(&ids).unwrap();
    let goals: Vec<(u8, i64)> = ids.iter().copied().zip(ticks).collect();
    bus.write_goals(&goals).unwrap();
    bus.set_torque(&ids, true).unwrap();
}

fn torque(virtual_bus: &VirtualBus, id: u8) -> bool {
    virtual_bus.lock().servo_mut(id).unwrap().motion.torque
}

fn smoothstep(t: f64, from: f64, to: f64) -> f64 {
    let x = ((t - from) / (to - from)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The hand's path for the elbow, degrees, over its own time: rest at 0°, up to 25° (peak
/// 54 °/s), a short rest, down to 10°, rest.
fn path(t: f64) -> f64 {
    25.0 * smoothstep(t, 0.1, 0.8) - 15.0 * smoothstep(t, 0.9, 1.45)
}

const PATH_SECONDS: f64 = 1.5;

/// What the hand did: the value it pushed the servo to at each instant.
struct HandLog {
    pushes: Vec<(Instant, f64)>,
}

impl HandLog {
    /// The lowest and highest position the hand held the servo at between two instants.
    fn range(&self, from: Instant, to: Instant) -> (f64, f64) {
        let start = self.at(from);
        let a = self.pushes.partition_point(|(t, _)| *t <= from);
        let b = self.pushes.partition_point(|(t, _)| *t <= to);
        self.pushes[a..b.max(a)]
            .iter()
            .fold((start, start), |(lo, hi), &(_, v)| (lo.min(v), hi.max(v)))
    }

    /// Where the hand held the servo at `when`: its last push before then (0° before any).
    fn at(&self, when: Instant) -> f64 {
        let i = self.pushes.partition_point(|(t, _)| *t <= when);
        if i == 0 {
            0.0
        } else {
            self.pushes[i - 1].1
        }
    }
}

#[test]
fn a_hand_moved_elbow_is_recorded_and_its_keys_trace_the_path() {
    let Arm {
        robot,
        mut bus,
        virtual_bus,
        elbow,
        wrist,
    } = so101_holding();
    let elbow_id = robot.joints[elbow].servo.id;
    let wrist_id = robot.joints[wrist].servo.id;
    let elbow_servo = robot.joints[elbow].servo.clone();

    let stop = StopSignal::default();
    let hand = {
        let virtual_bus = virtual_bus.clone();
        let stop = stop.clone();
        let elbow_servo = elbow_servo.clone();
        std::thread::spawn(move || {
            // The hand waits for the elbow to go limp: a powered servo cannot be pushed.
            let give_up = Instant::now() + Duration::from_secs(10);
            while torque(&virtual_bus, elbow_id) {
                assert!(Instant::now() < give_up, "the elbow never went limp");
                std::thread::sleep(Duration::from_micros(200));
            }
            let start = Instant::now();
            let mut pushes = Vec::new();
            loop {
                let t = start.elapsed().as_secs_f64().min(PATH_SECONDS);
                let value = path(t);
                virtual_bus
                    .lock()
                    .servo_mut(elbow_id)
                    .unwrap()
                    .motion
                    .push_to(elbow_servo.tick_exact(value));
                pushes.push((Instant::now(), value));
                if t >= PATH_SECONDS {
                    break;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            // Let go, let the recorder see the arm at rest, then press Enter.
            std::thread::sleep(Duration::from_millis(200));
            stop.request();
            HandLog { pushes }
        })
    };
    let options = RecordOptions {
        rate_hz: 100.0,
        joints: vec![elbow, wrist],
        duration: None,
        progress: false,
    };
    let called = Instant::now();
    let recording = record(&mut bus, &robot, &options, &stop).unwrap();
    let hand = hand.join().unwrap();
    assert!(recording.hold_error.is_none());
    assert!(recording.recorded[elbow] && recording.recorded[wrist]);
    // About 200 samples at 100 Hz on an idle machine; a loaded one (CI beside busy loops)
    // keeps the recorder off the CPU for some of them, which is not what this test is about:
    // enough samples to trace the path is.
    assert!(
        recording.times.len() > 40,
        "{} samples",
        recording.times.len()
    );

    // Torque is back on the recorded joints, holding where the hand left the elbow: goal and
    // position agree (no jump), and a moment later it is still there (no drop).
    let last = hand.pushes.last().unwrap().1;
    for id in [elbow_id, wrist_id] {
        assert!(torque(&virtual_bus, id), "servo {id} is limp");
    }
    let (position, goal) = {
        let mut servos = virtual_bus.lock();
        let motion = &mut servos.servo_mut(elbow_id).unwrap().motion;
        motion.update();
        (motion.position, motion.goal)
    };
    assert!((position - elbow_servo.tick_exact(last)).abs() <= 1.0);
    assert!(
        (goal - position).abs() <= 0.5,
        "goal {goal}, position {position}"
    );
    std::thread::sleep(Duration::from_millis(100));
    let later = virtual_bus.lock().positions()[&elbow_id];
    assert!((later - position).abs() <= 0.5);
    // The joints that were not recorded kept their torque all along.
    for (j, joint) in robot.joints.iter().enumerate() {
        if j != elbow && j != wrist {
            assert!(torque(&virtual_bus, joint.servo.id), "{}", joint.name);
        }
    }

    let tolerance = 1.0;
    let result = keyframes(
        &recording,
        &robot,
        &KeyframeOptions {
            interpolation: Interp::Monotone,
            tolerance_deg: tolerance,
            tolerance_m: 0.001,
            check_rate_hz: 100.0,
        },
    )
    .unwrap();
    assert!(
        result.keys() < 20,
        "{} keys for {} samples",
        result.keys(),
        result.samples
    );

    // The file passes the check, as `keypose check` would run it.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("recorded.json");
    result.sequence.save(&file).unwrap();
    let loaded = Sequence::load(&file).unwrap();
    let trajectory = Trajectory::build(&loaded, &robot).unwrap();
    assert!(check(&trajectory, &robot, 100.0).passed());

    // The keys trace the hand's path. The recorder's clock starts at its first sample, a
    // moment after `record` was called; find that offset (to a quarter millisecond), then
    // compare the curve at every sample time with where the hand held the elbow around then.
    // "Around": a sample's time is the middle of its read, and a thread that is descheduled
    // for a while (a busy test machine) shifts that by up to the stall, so the curve is
    // compared with the range of the hand's positions within WINDOW either side. Allowed: the
    // tolerance plus half a tick (0.044°) of encoder rounding.
    const WINDOW: f64 = 0.025;
    // Compared at the recorded key times: retiming (should the fitted curve have come out
    // faster than the limits) moves keys later than the hand put them.
    let key_times = match &result.retimed {
        Some(r) => r.key_times_before.clone(),
        None => result.sequence.key_times(),
    };
    let track = &elbow_track(&result.sequence, &key_times);
    let times = recording_times(&key_times, &recording.times);
    let mut best = (f64::INFINITY, 0.0);
    for step in 0..=400 {
        let offset = step as f64 * 0.00025;
        let worst = times
            .iter()
            .map(|&t| {
                let at = |dt: f64| called + Duration::from_secs_f64((offset + t + dt).max(0.0));
                let (low, high) = hand.range(at(-WINDOW), at(WINDOW));
                let v = track.sample(t);
                (v - high).max(low - v).max(0.0)
            })
            .fold(0.0, f64::max);
        if worst < best.0 {
            best = (worst, offset);
        }
    }
    assert!(
        best.0 <= tolerance + 0.044,
        "the curve strays {:.3}° from the hand's path (offset {:.4} s)",
        best.0,
        best.1
    );
    // And by shape, free of any timing: the top of the motion and where it came to rest.
    let top = (0..=300)
        .map(|k| track.sample(k as f64 * 0.01))
        .fold(f64::NEG_INFINITY, f64::max);
    assert!((top - 25.0).abs() <= tolerance + 0.1, "top {top}");
    let end = *track.values().last().unwrap();
    assert!((end - 10.0).abs() <= tolerance + 0.1, "end {end}");
    // The wrist was limp but untouched: it stays where it was.
    let wrist_track = &trajectory.tracks()[wrist];
    assert!((0..=300).all(|k| wrist_track.sample(k as f64 * 0.01).abs() <= 0.1));
}

/// The elbow's keys at the given key times.
fn elbow_track(sequence: &Sequence, key_times: &[f64]) -> Track<f64> {
    let keys: Vec<TrackKey<f64>> = sequence
        .keyframes
        .iter()
        .zip(key_times)
        .map(|(key, &t)| match key.value("elbow_flex") {
            Some(KeyValue::Joint(v)) => TrackKey::new(t, *v, Interp::Monotone),
            other => panic!("the elbow is in every key, found {other:?}"),
        })
        .collect();
    Track::new(&keys).unwrap()
}

/// The recorded times, snapped as the sequence snaps them (whole milliseconds).
fn recording_times(key_times: &[f64], times: &[f64]) -> Vec<f64> {
    let end = key_times.last().copied().unwrap_or(0.0);
    times
        .iter()
        .map(|t| (t * 1000.0).round() / 1000.0)
        .filter(|&t| t <= end)
        .collect()
}

#[test]
fn a_servo_that_stops_answering_ends_the_recording_and_the_others_hold() {
    let Arm {
        robot,
        mut bus,
        virtual_bus,
        elbow,
        wrist,
    } = so101_holding();
    let elbow_id = robot.joints[elbow].servo.id;
    let wrist_id = robot.joints[wrist].servo.id;
    let breaker = {
        let virtual_bus = virtual_bus.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(300));
            virtual_bus
                .lock()
                .set_fault(elbow_id, Some(ServoFault::NoAnswer));
        })
    };
    let options = RecordOptions {
        rate_hz: 100.0,
        joints: vec![elbow, wrist],
        duration: Some(5.0),
        progress: false,
    };
    let result = record(&mut bus, &robot, &options, &StopSignal::default());
    breaker.join().unwrap();
    match result {
        Err(RecordError::Fault { joint, at, .. }) => {
            assert_eq!(joint.as_deref(), Some("elbow_flex"));
            assert!(at > 0.2 && at < 5.0, "at {at}");
        }
        other => panic!("expected a fault, got {other:?}"),
    }
    // The wrist, limp for the recording, holds again although the elbow does not answer.
    assert!(torque(&virtual_bus, wrist_id));
}

#[test]
fn a_recording_ends_after_its_duration_with_every_sample_in_order() {
    let robot = Robot::builtin("koch").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let all: Vec<usize> = (0..robot.joints.len()).collect();
    let options = RecordOptions {
        rate_hz: 50.0,
        joints: all,
        duration: Some(0.5),
        progress: false,
    };
    let recording = record(&mut bus, &robot, &options, &StopSignal::default()).unwrap();
    // Samples at 0, 0.02, … 0.5 s: at most 26, fewer only if a deadline was missed.
    assert!(recording.times.len() <= 26 && recording.times.len() > 10);
    assert_eq!(recording.times[0], 0.0);
    assert!(recording.times.windows(2).all(|w| w[0] < w[1]));
    assert!(recording
        .values
        .iter()
        .all(|v| v.len() == recording.times.len()));
    // Every servo holds at the end (the virtual arm started limp).
    for joint in &robot.joints {
        assert!(torque(&virtual_bus, joint.servo.id), "{}", joint.name);
    }
}

#[test]
fn bad_options_are_refused_before_anything_goes_limp() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    hold_all(&mut bus, &robot);
    for options in [
        RecordOptions {
            rate_hz: 0.0,
            joints: vec![0],
            duration: Some(1.0),
            progress: false,
        },
        RecordOptions {
            rate_hz: 100.0,
            joints: vec![],
            duration: Some(1.0),
            progress: false,
        },
        RecordOptions {
            rate_hz: 100.0,
            joints: vec![0, 0],
            duration: Some(1.0),
            progress: false,
        },
        RecordOptions {
            rate_hz: 100.0,
            joints: vec![17],
            duration: Some(1.0),
            progress: false,
        },
        RecordOptions {
            rate_hz: 100.0,
            joints: vec![0],
            duration: Some(-1.0),
            progress: false,
        },
    ] {
        let result = record(&mut bus, &robot, &options, &StopSignal::default());
        assert!(
            matches!(result, Err(RecordError::Invalid(_))),
            "{options:?}"
        );
    }
    assert!(robot
        .joints
        .iter()
        .all(|j| torque(&virtual_bus, j.servo.id)));
}

#[test]
fn a_joint_pushed_past_its_limit_is_held_at_the_limit_or_left_limp_never_sent_past_it() {
    // The hand (the virtual bus's own) pushes the elbow 10° past its upper limit and the wrist
    // 1° past its own, once they go limp. At the end no goal may go past a limit: the wrist,
    // within the 2° slack the player also allows, is held at its limit (a 1° move); the elbow
    // would need a 10° jump, so it stays limp and the error names it.
    let Arm {
        robot,
        mut bus,
        virtual_bus,
        elbow,
        wrist,
    } = so101_holding();
    let servos = [&robot.joints[elbow], &robot.joints[wrist]];
    let beyond = [servos[0].limits.max + 10.0, servos[1].limits.max + 1.0];
    let ticks: Vec<f64> = servos
        .iter()
        .zip(beyond)
        .map(|(joint, value)| joint.servo.tick_exact(value))
        .collect();
    let ids = servos.iter().map(|j| j.servo.id).collect();
    let _hand = keypose::testing::Hand::start(
        virtual_bus.clone(),
        ids,
        0.0,
        Box::new(move |_, out: &mut [f64]| out.copy_from_slice(&ticks)),
    );
    let options = RecordOptions {
        rate_hz: 100.0,
        joints: vec![elbow, wrist],
        duration: Some(0.3),
        progress: false,
    };
    let recording = record(&mut bus, &robot, &options, &StopSignal::default()).unwrap();
    // The recording saw the hand's poses (to a tick).
    let last = |j: usize| *recording.values[j].last().unwrap();
    assert!((last(elbow) - beyond[0]).abs() < 0.1, "{}", last(elbow));
    assert!((last(wrist) - beyond[1]).abs() < 0.1, "{}", last(wrist));
    match &recording.hold_error {
        Some(keypose::record::HoldError::OutsideLimits(joints)) => {
            assert_eq!(joints, &["elbow_flex"])
        }
        other => panic!("expected the elbow left limp, got {other:?}"),
    }
    assert!(!torque(&virtual_bus, servos[0].servo.id));
    assert!(torque(&virtual_bus, servos[1].servo.id));
    // Every goal the servos received, decoded from the bytes: inside the limits. The wrist's
    // last one is its limit.
    let goals = virtual_bus.lock().goals_received();
    for &(id, tick) in &goals {
        let joint = robot.joints.iter().find(|j| j.servo.id == id).unwrap();
        let value = joint.servo.value(tick);
        assert!(joint.limits.contains(value), "{} got {value}", joint.name);
    }
    let wrist_goal = goals
        .iter()
        .rev()
        .find(|(id, _)| *id == servos[1].servo.id)
        .map(|&(_, tick)| servos[1].servo.value(tick))
        .unwrap();
    assert!(
        (wrist_goal - servos[1].limits.max).abs() < 0.1,
        "{wrist_goal}"
    );
}
