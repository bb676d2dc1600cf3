//! The player against emulated servos, in process: the native driver encodes real packets, the
//! virtual bus decodes them, moves, and answers; nothing is mocked but the wire itself (an
//! in-memory transport; the pseudo-terminal path is covered in `tests/servos/play.rs`).

use crate::player_stalls::play_on;
use keypose::bus::NativeBus;
use keypose::bus::{Alarms, BusError};
use keypose::pacing::Clock;
use keypose::plan::Loops;
use keypose::plan::Trajectory;
use keypose::player::{play, play_with_clock, Outcome, PlayError, PlayOptions, StopSignal};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::testing::MemoryTransport;
use keypose::testing::VirtualClock;
use keypose::testing::{ServoFault, VirtualBus, VirtualServos};
use proptest::prelude::*;
use std::time::Duration;

fn trajectory(robot: &Robot, text: &str) -> Trajectory {
    let sequence = Sequence::from_json("test.json", text).unwrap();
    Trajectory::build(&sequence, robot).unwrap()
}

/// Joint values of every goal the virtual servos received, per cycle (one sync write each).
fn goal_history(robot: &Robot, bus: &VirtualBus) -> Vec<Vec<f64>> {
    let goals = bus.lock().goals_received();
    goals
        .chunks(robot.joints.len())
        .filter(|c| c.len() == robot.joints.len())
        .map(|cycle| {
            cycle
                .iter()
                .map(|(id, tick)| {
                    let joint = robot.joints.iter().find(|j| j.servo.id == *id).unwrap();
                    joint.servo.value(*tick)
                })
                .collect()
        })
        .collect()
}

/// A virtual clock that requests a stop once its time reaches `at`, as a person pressing
/// Ctrl-C at that moment of the playback would.
struct StopAt {
    clock: VirtualClock,
    at: Duration,
    stop: StopSignal,
}

impl Clock for StopAt {
    fn now(&self) -> Duration {
        self.clock.now()
    }
    fn sleep_until(&self, deadline: Duration, stop: &StopSignal, seen: u32) {
        self.clock.sleep_until(deadline, stop, seen);
        if self.clock.now() >= self.at && self.stop.count() == 0 {
            self.stop.request();
        }
    }
}

/// Options for a playback on the wall clock whose subject is not its timing: on a loaded
/// machine (CI beside busy loops) the test process is kept off the CPU for over a second now
/// and then, which the default stall bound rightly calls a fault (stalls have their own tests,
/// tests/servos/player_stalls.rs).
fn patient(rate: f64) -> PlayOptions {
    PlayOptions {
        max_stall: 30.0,
        max_stalls_per_second: None,
        ..PlayOptions::new(rate)
    }
}

const ELBOW_SWING: &str = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
  {"time":0,"joints":{"elbow_flex":-20}},{"time":1.0,"joints":{"elbow_flex":20}}]}"#;

/// The arm rests with the elbow at 30° and the wrist at −85.5°, clear of the desk; the first
/// key has the wrist at +85.5°, clear too. The approach ramp's straight line swings the gripper
/// through the desk on the way (from about 38°, src/collision/sweep.rs), so the player refuses
/// it before torque comes on, and not one goal is written. With the wrist resting at +82°,
/// past the desk (it points the gripper at it from about 38° to 78°), the same key is reached.
#[test]
fn an_approach_through_the_desk_is_refused_before_anything_is_written() {
    let robot = Robot::builtin("so101").unwrap();
    let key = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
      {"time":0,"joints":{"elbow_flex":30,"wrist_flex":85.5}}]}"#;
    let traj = trajectory(&robot, key);
    for (wrist, refused) in [(-85.5, true), (82.0, false)] {
        let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
        for (id, value) in [(3u8, 30.0), (4, wrist)] {
            let tick = robot.joints[id as usize - 1].servo.tick_exact(value);
            virtual_bus
                .lock()
                .servo_mut(id)
                .unwrap()
                .motion
                .push_to(tick);
        }
        let result = play(
            &mut bus,
            &robot,
            &traj,
            &patient(100.0),
            &StopSignal::default(),
        );
        if refused {
            let error = result.expect_err("refused");
            assert!(
                matches!(error, PlayError::ApproachContact { .. }),
                "{error}"
            );
            assert!(error.to_string().contains("the floor"), "{error}");
            assert_eq!(virtual_bus.lock().goals_received(), vec![]);
            assert!(virtual_bus.lock().servos.iter().all(|s| !s.motion.torque));
        } else {
            assert_eq!(result.unwrap().0, Outcome::Finished);
        }
    }
}

#[test]
fn plays_to_the_last_key_after_a_ramp_from_where_the_arm_was() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    // The arm rests with the elbow pushed to +30° (torque off), not at the first key (−20°).
    let start_tick = robot.joints[2].servo.tick_exact(30.0);
    virtual_bus
        .lock()
        .servo_mut(3)
        .unwrap()
        .motion
        .push_to(start_tick);
    let traj = trajectory(&robot, ELBOW_SWING);
    let options = patient(100.0);
    let (outcome, stats) = play(&mut bus, &robot, &traj, &options, &StopSignal::default()).unwrap();
    assert_eq!(outcome, Outcome::Finished);

    let history = goal_history(&robot, &virtual_bus);
    // The first goal holds the measured pose (torque on moves nothing), the ramp follows.
    assert!(
        (history[0][2] - 30.0).abs() < 0.1,
        "first goal {}",
        history[0][2]
    );
    // Never a jump: no goal step is larger than the velocity limit allows in one 10 ms cycle.
    let max_step = robot.joints[2].limits.velocity / 100.0;
    for pair in history.windows(2) {
        let step = (pair[1][2] - pair[0][2]).abs();
        assert!(step <= max_step * 1.01, "step of {step}° in one cycle");
    }
    // The approach covers 50° (less up to a tick of rounding in the measured start) at half
    // the velocity limit: 15/8 · (50 − 0.088)/57.5 = 1.6276 s by hand.
    assert!(
        stats.approach_seconds >= 1.6276,
        "{}",
        stats.approach_seconds
    );
    // The last goal is the last key, and the servo got there (it lags by its time constant).
    // (Goals travel as whole ticks: within half a tick, 0.044°.)
    assert!((history.last().unwrap()[2] - 20.0).abs() <= 360.0 / 4096.0 / 2.0);
    std::thread::sleep(Duration::from_millis(200));
    let end = virtual_bus.lock().positions()[&3];
    assert!((robot.joints[2].servo.value(end.round() as i64) - 20.0).abs() < 0.2);
    // All servos hold with torque on.
    assert!(virtual_bus.lock().servos.iter().all(|s| s.motion.torque));
}

#[test]
fn a_stop_request_decelerates_along_the_path_and_holds_with_torque_on() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let traj = trajectory(
        &robot,
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"linear","keyframes":[
          {"time":0,"joints":{"shoulder_pan":0}},{"time":4.0,"joints":{"shoulder_pan":80}}]}"#,
    );
    let stop = StopSignal::default();
    // The ramp is 0.5 s (already at the first key); stop 1 s into the motion, on the player's
    // own (virtual) time, so that a busy machine cannot move the stop elsewhere.
    let clock = StopAt {
        clock: VirtualClock::new(),
        at: Duration::from_millis(1500),
        stop: stop.clone(),
    };
    let (outcome, _) = play_with_clock(
        &mut bus,
        &robot,
        &traj,
        &PlayOptions::new(100.0),
        &stop,
        &clock,
    )
    .unwrap();
    assert_eq!(outcome, Outcome::Stopped);
    let pan: Vec<f64> = goal_history(&robot, &virtual_bus)
        .iter()
        .map(|g| g[0])
        .collect();
    let last = *pan.last().unwrap();
    assert!(last > 5.0 && last < 80.0, "stopped at {last}");
    // Braking: the steps shrink to nothing without reversing (the path is followed forwards).
    let steps: Vec<f64> = pan.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(steps.iter().all(|s| *s >= -1e-9), "moved backwards");
    let cruise = 80.0 / 4.0 / 100.0;
    let tail = &steps[steps.len() - 5..];
    assert!(
        tail.iter().all(|s| *s < cruise),
        "still at full speed at the end: {tail:?}"
    );
    assert!(virtual_bus.lock().servos.iter().all(|s| s.motion.torque));
}

#[test]
fn a_second_stop_request_holds_at_once() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let traj = trajectory(&robot, ELBOW_SWING);
    let stop = StopSignal::default();
    stop.request();
    stop.request();
    let (outcome, stats) = play(&mut bus, &robot, &traj, &patient(100.0), &stop).unwrap();
    assert_eq!(outcome, Outcome::Held);
    assert_eq!(stats.cycles, 0);
    assert!(virtual_bus.lock().servos.iter().all(|s| s.motion.torque));
}

/// Plays a long sequence and injects `fault` into servo 3 after 0.8 s; returns the error and
/// the goal writes before and after the injection.
fn fault_after_start(
    robot_name: &str,
    fault: Option<ServoFault>,
    port_gone: bool,
) -> (PlayError, usize, usize) {
    fault_after_start_on(robot_name, fault, port_gone, MemoryTransport::new)
}

/// [`fault_after_start`] on the in-memory line `line` makes of the virtual bus.
fn fault_after_start_on(
    robot_name: &str,
    fault: Option<ServoFault>,
    port_gone: bool,
    line: fn(VirtualBus) -> MemoryTransport<VirtualBus>,
) -> (PlayError, usize, usize) {
    let robot = Robot::builtin(robot_name).unwrap();
    let virtual_bus = VirtualBus::new(VirtualServos::for_robot(&robot));
    let transport = line(virtual_bus.clone());
    let mut bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &robot.servos());
    let joint = &robot.joints[2].name;
    let traj = trajectory(
        &robot,
        &format!(
            r#"{{"format":"keypose-sequence/1","robot":"{robot_name}","keyframes":[
              {{"time":0,"joints":{{"{joint}":0}}}},{{"time":6,"joints":{{"{joint}":30}}}}]}}"#
        ),
    );
    let injector = {
        let virtual_bus = virtual_bus.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(800));
            // Only the packets' count under the lock: the emulator waits while it is held.
            let mut servos = virtual_bus.lock();
            let packets_before = servos.received.len();
            if port_gone {
                servos.connected = false;
            } else {
                servos.set_fault(3, fault);
            }
            packets_before
        })
    };
    // The bus's faults are the subject: a loaded machine's stall must not come first.
    let options = patient(100.0);
    let played = play(&mut bus, &robot, &traj, &options, &StopSignal::default());
    let error = match played {
        Err(error) => error,
        Ok((outcome, stats)) => panic!(
            "the fault was not noticed: {outcome:?} after {} cycles",
            stats.cycles
        ),
    };
    let packets_before = injector.join().unwrap();
    let (writes_before, writes_after) = {
        let servos = virtual_bus.lock();
        (
            servos.goals_in_first(packets_before).len(),
            servos.goals_received().len(),
        )
    };
    (
        error,
        writes_before / robot.joints.len(),
        writes_after / robot.joints.len(),
    )
}

/// The bus error a playback fault carries.
fn bus_error(error: &PlayError) -> &BusError {
    match error {
        PlayError::Fault { error, .. } => error,
        other => panic!("expected a bus fault, got {other:?}"),
    }
}

#[test]
fn an_alarm_stops_streaming_within_the_cycle_and_names_the_servo() {
    for robot in ["so101", "koch"] {
        let overload = Alarms {
            overload: true,
            ..Alarms::default()
        };
        let (error, before, after) =
            fault_after_start(robot, Some(ServoFault::Alarm(overload)), false);
        match &error {
            PlayError::Fault {
                joint: Some(joint),
                error: BusError::Alarm { id: 3, alarms },
                ..
            } => {
                assert_eq!(joint, "elbow_flex");
                assert!(alarms.overload, "{robot}: {alarms}");
            }
            other => panic!("{robot}: unexpected {other:?}"),
        }
        // The cycle in which the alarm is read back had already written its goals; no more.
        assert!(
            after <= before + 1,
            "{robot}: {} cycles streamed after the alarm",
            after - before
        );
        assert!(
            error.to_string().contains("servo 3: alarm: overload"),
            "{error}"
        );
    }
}

/// Whether `error` says servo `id` gave no usable answer (silent, late, or not read because
/// keypose itself was starved: which one a loaded machine decides).
fn no_answer_from(error: &PlayError, id: u8) -> bool {
    let error = bus_error(error);
    error.is_no_answer() && error.servo() == Some(id)
}

#[test]
fn a_servo_that_stops_answering_ends_playback_after_bounded_retries() {
    let (error, before, after) = fault_after_start("so101", Some(ServoFault::NoAnswer), false);
    assert!(no_answer_from(&error, 3), "{error:?}");
    // Three failed read-backs (each retried twice at 40 ms) is the bound.
    assert!(after - before <= 3, "{} cycles streamed", after - before);
}

#[test]
fn corrupt_and_late_answers_end_playback() {
    let (error, _, _) = fault_after_start("koch", Some(ServoFault::CorruptChecksum), false);
    assert!(
        matches!(bus_error(&error), BusError::Corrupt { id: 3, .. }),
        "{error:?}"
    );
    let (error, _, _) = fault_after_start(
        "so101",
        Some(ServoFault::Late(Duration::from_millis(120))),
        false,
    );
    assert!(no_answer_from(&error, 3), "{error:?}");
}

#[test]
fn a_servo_answering_late_is_a_fault_within_three_cycles_never_a_stale_position() {
    // Servo 3 starts answering 300 ms late, on a line where each answer comes when it is due:
    // its late answer to one read arrives while a later read waits for it. Taken for the
    // present position, it would reset the count of failed reads, and playback would stream on
    // with stale positions (a 200 ms-late answer was taken, the fault declared 2.8 s later).
    // Told apart, every read fails: the third failed read ends playback.
    let (error, before, after) = fault_after_start_on(
        "so101",
        Some(ServoFault::Late(Duration::from_millis(300))),
        false,
        MemoryTransport::as_due,
    );
    assert!(no_answer_from(&error, 3), "{error:?}");
    assert!(
        after - before <= 3,
        "{} cycles streamed after servo 3 turned late",
        after - before
    );
}

#[test]
fn the_port_disappearing_ends_playback_at_the_next_write() {
    let (error, before, after) = fault_after_start("so101", None, true);
    assert!(
        matches!(bus_error(&error), BusError::Port { .. }),
        "{error:?}"
    );
    assert_eq!(after, before);
}

#[test]
fn loops_and_ping_pong_pass_through_every_key() {
    let robot = Robot::builtin("so101").unwrap();
    let traj = trajectory(&robot, ELBOW_SWING);
    for (ping_pong, expected_turns) in [(false, 2), (true, 2)] {
        let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
        // The goals are the subject, not the pacing: on a virtual clock the six passes take
        // no wall time.
        let mut options = PlayOptions::new(100.0);
        options.timeline.loops = Loops::Count(3);
        options.timeline.ping_pong = ping_pong;
        play_on(&mut bus, &robot, &traj, &options, &VirtualClock::new()).unwrap();
        let elbow: Vec<f64> = goal_history(&robot, &virtual_bus)
            .iter()
            .map(|g| g[2])
            .collect();
        // Count the visits to the end key (+20°) and the returns to the first (−20°).
        let at_end = elbow
            .windows(2)
            .filter(|w| w[0] < 19.99 && w[1] >= 19.99)
            .count();
        assert_eq!(
            at_end,
            if ping_pong { expected_turns } else { 3 },
            "ping-pong {ping_pong}"
        );
        // Never a jump, also between loops.
        let max_step = robot.joints[2].limits.velocity / 100.0;
        assert!(elbow
            .windows(2)
            .all(|w| (w[1] - w[0]).abs() <= max_step * 1.01));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

    /// Whatever the sequence — cubic overshoots next to a limit included — no goal outside the
    /// joint limits ever reaches the servos: decoded from the bytes the virtual bus received.
    #[test]
    fn no_goal_outside_the_limits_reaches_the_servos(
        values in prop::collection::vec(-1.0f64..=1.0, 3..6),
        gaps in prop::collection::vec(0.15f64..0.4, 6),
    ) {
        let robot = Robot::builtin("so101").unwrap();
        let joint = &robot.joints[3];
        let (min, max) = (joint.limits.min, joint.limits.max);
        let mut time = 0.0;
        let keys: Vec<String> = values
            .iter()
            .zip(&gaps)
            .map(|(v, gap)| {
                let key = format!(r#"{{"time":{time},"joints":{{"wrist_flex":{}}}}}"#, min + (v + 1.0) / 2.0 * (max - min));
                time += gap;
                key
            })
            .collect();
        let text = format!(
            r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[{}]}}"#,
            keys.join(",")
        );
        let traj = trajectory(&robot, &text);
        let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
        // The guard is the subject, not the pacing: on a virtual clock the playback has the
        // timing of an idle machine whatever this one is doing, and takes no wall time.
        let options = PlayOptions {
            readback_every: Some(10),
            ..PlayOptions::new(200.0)
        };
        let result = play_on(&mut bus, &robot, &traj, &options, &VirtualClock::new());
        for goals in goal_history(&robot, &virtual_bus) {
            for (value, joint) in goals.iter().zip(&robot.joints) {
                prop_assert!(joint.limits.contains(*value), "{} received {value}", joint.name);
            }
        }
        if let Err(e) = result {
            // The only acceptable refusal is the guard's, before anything was sent.
            prop_assert!(matches!(e, PlayError::Limit(_)), "{e}");
        }
    }
}

#[test]
fn from_a_key_ramps_to_that_key_and_release_at_end_lets_go_only_at_the_end() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let traj = trajectory(
        &robot,
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"name":"a","time":0,"joints":{"elbow_flex":-40}},
          {"name":"b","time":1,"joints":{"elbow_flex":10}},
          {"name":"c","time":2,"joints":{"elbow_flex":30}}]}"#,
    );
    let mut options = PlayOptions {
        release_at_end: true,
        ..patient(100.0)
    };
    options.timeline.from_key = Some(1);
    play(&mut bus, &robot, &traj, &options, &StopSignal::default()).unwrap();
    let elbow: Vec<f64> = goal_history(&robot, &virtual_bus)
        .iter()
        .map(|g| g[2])
        .collect();
    // From home (0°) the ramp goes up to key b (10°) and never down towards key a (−40°).
    assert!(elbow.iter().all(|v| *v >= -0.05), "went towards key a");
    assert!((elbow.last().unwrap() - 30.0).abs() <= 0.05);
    // Released only after arriving: the servos are limp and where the last key put them.
    let mut servos = virtual_bus.lock();
    assert!(servos.servos.iter().all(|s| !s.motion.torque));
    let end = servos.positions()[&3];
    assert!((robot.joints[2].servo.value(end.round() as i64) - 30.0).abs() <= 2.0);
}
