//! `keypose play` on a cell of two arms, one bus each: the real binary and its serial code
//! against two buses of emulated servos, each on its own pseudo-terminal served by this test
//! (`PtyServer`, wire-timed at the SO-101's 1 Mbps), so the test reads what each bus received
//! and injects faults into one of them while the binary plays. Nothing is mocked.

use crate::common::{keypose, repo, run, stderr, TOLERATED_STALL};
use keypose::bus::{Alarms, SILENT_FOR};
use keypose::robot::Robot;
use keypose::testing::{PtyServer, ServoFault};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Two SO-101 side by side, 7.2 s: both raise and wave, the right one reaches.
const WAVE: &str = "sequences/bimanual_wave.json";
/// The control rate the SO-101 asks for.
const RATE_HZ: f64 = 100.0;
/// One SO-101 position tick, degrees.
const TICK: f64 = 360.0 / 4096.0;

fn so101() -> Robot {
    Robot::builtin("so101").unwrap()
}

/// One emulated SO-101 on its own pseudo-terminal, at home, wire-timed.
fn arm_bus() -> PtyServer {
    PtyServer::start(&so101()).unwrap()
}

/// Places an arm's elbow (servo 3) at `degrees`, as a hand would, before anything connects.
fn bend_elbow(bus: &PtyServer, degrees: f64) {
    let tick = so101().joints[2].goal_tick(degrees).unwrap();
    let mut servos = bus.bus().lock();
    servos.servo_mut(3).unwrap().place_at(tick as f64);
}

/// `keypose play WAVE` on the two buses, with `extra` arguments, started and left running.
fn play(left: &PtyServer, right: &PtyServer, extra: &[&str]) -> Child {
    keypose()
        .args(["play", &repo(WAVE)])
        .args(["--port", &format!("left={}", left.path())])
        .args(["--port", &format!("right={}", right.path())])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Per joint of an SO-101 (chain order, servo ids 1 … 6), the goals its servo received, in
/// joint values.
fn goals_by_joint(bus: &PtyServer) -> Vec<Vec<f64>> {
    let robot = so101();
    let goals = bus.bus().lock().goals_received();
    robot
        .joints
        .iter()
        .map(|joint| {
            goals
                .iter()
                .filter(|(id, _)| *id == joint.servo.id)
                .map(|&(_, tick)| joint.servo.value(tick))
                .collect()
        })
        .collect()
}

/// Per goal written (the hold at the start, then one per row of the playback log), the share
/// of the path rate the arm followed since the goal before: 1, or `T / (T + stall)` after a
/// stall, when the goal before was held `stall` beyond its period (docs/commands.md "Stalls").
fn followed_shares(log: &std::path::Path) -> Vec<f64> {
    let text = std::fs::read_to_string(log).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let stall = header.iter().position(|h| *h == "stall_ms").unwrap();
    let period = 1.0 / RATE_HZ;
    let rows = lines.map(|line| match line.split(',').nth(stall).unwrap_or("") {
        "" => 1.0,
        ms => period / (period + ms.parse::<f64>().unwrap() / 1e3),
    });
    std::iter::once(1.0).chain(rows).collect()
}

/// Every goal inside the joint's limits, every step within what the velocity limit allows over
/// one period, every change of step within the acceleration limit's from the step before
/// (scaled by `followed` after a stall), each goal rounded to a tick (half a tick either way).
fn assert_within_limits(arm: &str, goals: &[Vec<f64>], followed: &[f64]) {
    let period = 1.0 / RATE_HZ;
    let robot = so101();
    for (joint, goals) in robot.joints.iter().zip(goals) {
        let limits = &joint.limits;
        assert!(!goals.is_empty(), "{arm}/{}: no goal received", joint.name);
        assert_eq!(
            goals.len(),
            followed.len(),
            "{arm}/{}: goals received against the log's rows",
            joint.name
        );
        for &g in goals {
            assert!(
                g >= limits.min - TICK / 2.0 && g <= limits.max + TICK / 2.0,
                "{arm}/{}: goal {g}° outside {} … {}",
                joint.name,
                limits.min,
                limits.max
            );
        }
        let steps: Vec<f64> = goals.windows(2).map(|w| w[1] - w[0]).collect();
        for (k, step) in steps.iter().enumerate() {
            assert!(
                step.abs() <= limits.velocity * period + TICK,
                "{arm}/{}: step {step}° at goal {k}, beyond {}°/s over {period} s",
                joint.name,
                limits.velocity
            );
        }
        for (k, pair) in steps.windows(2).enumerate() {
            // Step k + 1 is goal k + 2's.
            let change = pair[1] - pair[0] * followed[k + 2];
            assert!(
                change.abs() <= limits.acceleration * period * period + 2.0 * TICK,
                "{arm}/{}: the step changed by {change}° at goal {k}, beyond {}°/s² over {period} s",
                joint.name,
                limits.acceleration
            );
        }
    }
}

/// The last step of every joint is no larger than one period's braking at the acceleration
/// limit allows from rest: the arm came to rest, it was not cut off moving.
fn assert_at_rest(arm: &str, goals: &[Vec<f64>]) {
    let period = 1.0 / RATE_HZ;
    for (joint, goals) in so101().joints.iter().zip(goals) {
        let last = goals[goals.len() - 1] - goals[goals.len() - 2];
        assert!(
            last.abs() <= joint.limits.acceleration * period * period + TICK,
            "{arm}/{}: still moving {last}° per period at the end",
            joint.name
        );
    }
}

/// The goal-write offsets `play` reports, microseconds: (median, p99, max, cycles).
fn reported_offsets(err: &str) -> (f64, f64, f64, u64) {
    let line = err
        .lines()
        .find(|l| l.starts_with("goal writes of the arms' buses apart by:"))
        .unwrap_or_else(|| panic!("no offset line in {err}"));
    let number_after = |label: &str| -> f64 {
        let rest = &line[line.find(label).unwrap() + label.len()..];
        let end = rest
            .find(|c: char| c != '.' && !c.is_ascii_digit())
            .unwrap();
        rest[..end].parse().unwrap()
    };
    (
        number_after("median "),
        number_after("p99 "),
        number_after("max "),
        number_after("over ") as u64,
    )
}

#[test]
fn two_buses_play_in_step_each_within_its_arms_limits_and_the_log_has_both_arms() {
    let (left, right) = (arm_bus(), arm_bus());
    // The left elbow starts bent to -20° (moved by hand), the right arm at home: the first key
    // is home for both.
    bend_elbow(&left, -20.0);
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("cell.csv");
    // Not quiet: the summary says the goal-write offsets.
    let child = play(&left, &right, &logged_quietly(&log)[1..]);
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");

    let left_goals = goals_by_joint(&left);
    let right_goals = goals_by_joint(&right);
    let followed = followed_shares(&log);
    assert_within_limits("left", &left_goals, &followed);
    assert_within_limits("right", &right_goals, &followed);
    // The sequence's last key is home (0°) for the first five joints of both arms (the
    // grippers are never keyed): each arm's last goal is it, to half a tick.
    for goals in left_goals.iter().take(5).chain(right_goals.iter().take(5)) {
        assert!(
            goals.last().unwrap().abs() <= TICK / 2.0,
            "{:?}",
            goals.last()
        );
    }
    // Both shoulder_lifts start at 0° and are keyed alike up to "raise" (0° at home, −30° at
    // raise, where both arms rest for its hold; the right arm's reach keys its own later): one
    // timeline drives both, so up to the cycle the left shoulder first reaches −30° (to a tick:
    // a goal is a whole tick), each cycle's goal is the same tick on both buses.
    let lifted = left_goals[1]
        .iter()
        .position(|&g| g <= -30.0 + TICK)
        .expect("the left shoulder never lifted to -30°");
    assert_eq!(left_goals[1][..=lifted], right_goals[1][..=lifted]);
    let (median, p99, max, cycles) = reported_offsets(&err);
    println!(
        "goal-write offset between the two buses over {cycles} cycles at {RATE_HZ} Hz: median {median} µs, p99 {p99} µs, max {max} µs"
    );
    assert!(
        cycles as usize >= left_goals[0].len() - 2,
        "{cycles} cycles"
    );
    assert!(median <= p99 && p99 <= max, "{err}");

    // The log: every joint of both arms, commanded and measured, on every row.
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for arm in ["left", "right"] {
        for joint in crate::common::SO101_JOINTS {
            for suffix in ["cmd", "meas"] {
                let column = format!("{arm}/{joint}_{suffix}");
                assert!(header.contains(&column.as_str()), "{column} in {header:?}");
            }
        }
    }
    let measured: Vec<usize> = (0..header.len())
        .filter(|&i| header[i].ends_with("_meas"))
        .collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(
        rows.len() as u64 + 2 >= cycles,
        "{} rows, {cycles} cycles",
        rows.len()
    );
    // The approach ramp starts where each arm is (the left elbow's first goal is where it was
    // bent) and brings both arms to the first pose together: when the approach ends, every
    // keyed joint of both arms is commanded at home (0°).
    assert!(
        (left_goals[2][0] + 20.0).abs() <= TICK,
        "{}",
        left_goals[2][0]
    );
    // The ramp runs before the sequence's clock starts (a stall in it is logged as
    // "resuming"): it has ended at the row before the first with a sequence time past 0.
    let time = header.iter().position(|h| *h == "sequence_time").unwrap();
    let approached = rows
        .iter()
        .position(|r| r[time].parse::<f64>().unwrap() > 0.0)
        .expect("the sequence never started");
    assert!(approached > 0, "no approach");
    for arm in ["left", "right"] {
        for joint in &crate::common::SO101_JOINTS[..5] {
            let column = format!("{arm}/{joint}_cmd");
            let c = header.iter().position(|h| *h == column).unwrap();
            let at: f64 = rows[approached - 1][c].parse().unwrap();
            assert!(at.abs() < 1e-6, "{column} at {at}° when the approach ended");
        }
    }
    // Every arm measured on a row, or — a read one bus did not answer within the cycle, which
    // the other arms are not held for (a busy machine) — none.
    for row in &rows {
        if measured.iter().all(|&c| row[c].is_empty()) {
            continue;
        }
        for &c in &measured {
            row[c]
                .parse::<f64>()
                .unwrap_or_else(|_| panic!("{}: {row:?}", header[c]));
        }
    }
    let read = rows
        .iter()
        .filter(|row| !row[measured[0]].is_empty())
        .count();
    assert!(read > 0, "no row measured");
    println!("{read} of {} rows measured", rows.len());
}

/// What a playback with a fault injected on the right bus left behind.
struct FaultRun {
    out: Output,
    left: Vec<Vec<f64>>,
    right: Vec<Vec<f64>>,
    /// Goals the right bus had received when the fault was injected.
    right_before: usize,
    followed: Vec<f64>,
}

/// [`fault_on_the_right_once`], run again (twice at most) when the fault the player stopped on
/// was not the one injected but a servo of the emulator that did not answer in time: the
/// emulated servos are threads of this test process, and on a machine busy enough a thread
/// does not run for longer than the player tolerates silence, which on a real bus is a fault
/// and here is only the test bench starved. Every other outcome is judged as it came.
fn fault_on_the_right(fault: ServoFault) -> FaultRun {
    let mut run = fault_on_the_right_once(fault);
    for _ in 0..2 {
        let err = stderr(&run.out);
        let starved_bench = err.contains("no answer") && !err.contains("servo 4: ");
        if !starved_bench {
            break;
        }
        eprintln!("{fault:?}: the emulator was starved, again: {err}");
        run = fault_on_the_right_once(fault);
    }
    run
}

/// Plays on two buses, injects `fault` into the right arm's wrist_flex (servo 4) 2.5 s in,
/// waits for the end.
fn fault_on_the_right_once(fault: ServoFault) -> FaultRun {
    let (left, right) = (arm_bus(), arm_bus());
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("fault.csv");
    let child = play(&left, &right, &logged_quietly(&log));
    std::thread::sleep(Duration::from_millis(2500));
    // Only the packets' count under the lock: the emulator waits while it is held.
    let packets_before = {
        let mut servos = right.bus().lock();
        servos.set_fault(4, Some(fault));
        servos.received.len()
    };
    let out = child.wait_with_output().unwrap();
    let right_before = right.bus().lock().goals_in_first(packets_before).len();
    FaultRun {
        out,
        left: goals_by_joint(&left),
        right: goals_by_joint(&right),
        right_before,
        followed: followed_shares(&log),
    }
}

/// `--quiet --log LOG`, and a stall bound a loaded test machine does not reach (a stall is
/// another fault, tests/servos/player_stalls.rs).
fn logged_quietly(log: &std::path::Path) -> Vec<&str> {
    let mut args = vec!["--quiet", "--log", log.to_str().unwrap()];
    args.extend(TOLERATED_STALL);
    args
}

#[test]
fn a_fault_on_one_bus_stops_both_arms_the_other_braking_to_rest() {
    let overload = Alarms {
        overload: true,
        ..Alarms::default()
    };
    let cases = [
        (ServoFault::NoAnswer, "no answer"),
        (ServoFault::Alarm(overload), "alarm: overload"),
    ];
    for (fault, expected) in cases {
        let FaultRun {
            out,
            left,
            right,
            right_before: before,
            followed,
        } = fault_on_the_right(fault);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(3), "{fault:?}: {err}");
        // The fault names the arm, its joint and the servo by the id its own bus knows.
        assert!(
            err.contains("joint right/wrist_flex: right bus: servo 4: "),
            "{fault:?}: {err}"
        );
        assert!(err.contains(expected), "{fault:?}: {err}");
        assert!(
            err.contains(
                "nothing more was sent to the right bus, and the other arms braked to rest"
            ),
            "{fault:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");

        // The healthy arm stopped early (the sequence runs 7.2 s, the fault came at 2.5 s),
        // braking within its limits, and came to rest.
        let full = (7.7 * RATE_HZ) as usize;
        assert!(left[0].len() < full, "{fault:?}: {} goals", left[0].len());
        assert_within_limits("left", &left, &followed);
        assert_at_rest("left", &left);
        // The faulty bus got nothing once the streak of failed reads (or the alarm) was
        // seen: at most one goal per cycle of the streak (cycles take their deadlines one
        // period apart, so SILENT_FOR holds at most SILENT_FOR / T + 2 of them), the cycle
        // under way when the fault came and the one that found the streak over.
        let after = right.iter().map(Vec::len).sum::<usize>() - before;
        let streak_cycles = (SILENT_FOR.as_secs_f64() * RATE_HZ).ceil() as usize + 2;
        let bound = (streak_cycles + 2) * 6;
        assert!(
            after <= bound,
            "{fault:?}: {after} goals reached the faulty bus after the fault, expected at most {bound}"
        );
        // The right bus received fewer goals than there are rows: check the ones it had.
        assert_within_limits("right", &right, &followed[..right[0].len()]);
        println!(
            "{fault:?}: the left arm got {} goals, the right {} after the fault",
            left[0].len(),
            after
        );
    }
}

/// Instants of `times` within `from ..= to`.
fn within(times: &[Instant], from: Instant, to: Instant) -> Vec<Instant> {
    times
        .iter()
        .copied()
        .filter(|t| (from..=to).contains(t))
        .collect()
}

#[test]
fn a_silent_bus_does_not_hold_the_other_arms_goals() {
    let (left, right) = (arm_bus(), arm_bus());
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("silent.csv");
    let child = play(&left, &right, &logged_quietly(&log));
    // Mid-motion (after the 0.5 s approach the arms raise until 1.5 s of the sequence, then
    // the wrists wave out until 2.6 s), the right bus goes silent as a stopped server or a bus
    // without power does: no servo on it answers any more.
    std::thread::sleep(Duration::from_millis(2500));
    let silent_from = {
        let mut servos = right.bus().lock();
        for joint in so101().joints {
            servos.set_fault(joint.servo.id, Some(ServoFault::NoAnswer));
        }
        servos.received.len()
    };
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("joint right/shoulder_pan: right bus: servo 1: no answer"),
        "{err}"
    );
    assert!(
        err.contains("nothing more was sent to the right bus, and the other arms braked to rest"),
        "{err}"
    );

    // What the silent bus received after it went silent: goal writes, and reads that the
    // binary waited on for an answer that never came.
    let (right_times, right_writes) = {
        let servos = right.bus().lock();
        (
            servos.received_at[silent_from..].to_vec(),
            servos.goal_writes_at(),
        )
    };
    let reads: Vec<Instant> = right_times
        .iter()
        .copied()
        .filter(|t| !right_writes.contains(t))
        .collect();
    assert!(
        reads.len() >= 2,
        "{} reads went to the silent bus",
        reads.len()
    );
    let (first, last) = (reads[0], reads[reads.len() - 1]);
    // While the binary waited on the silent bus, the left bus went on receiving its goals: a
    // read of the right bus cut short within its cycle is followed by the left arm's next goal
    // before the next read (a cycle with a health read besides the positions' has two reads
    // and one goal). A loop held by the silent bus waits a whole answer timeout per attempt
    // (40 ms, three tries a read, while the cycles are 10 ms), with no goal between them.
    let left_writes = left.bus().lock().goal_writes_at();
    let intervals = reads.len() - 1;
    let with_a_goal = reads
        .windows(2)
        .filter(|w| left_writes.iter().any(|t| w[0] < *t && *t < w[1]))
        .count();
    assert!(
        2 * with_a_goal >= intervals,
        "the left bus got a goal between {with_a_goal} of the {} reads of the silent right bus",
        reads.len()
    );
    let during = within(&left_writes, first, last);
    // Then it braked from its real velocity, within its limits, to rest; the braking is logged.
    let left_goals = goals_by_joint(&left);
    let followed = followed_shares(&log);
    assert_within_limits("left", &left_goals, &followed);
    assert_at_rest("left", &left_goals);

    // For the record: the longest the left arm waited for a goal from the bus's silence on.
    let gaps = within(
        &left_writes,
        first - Duration::from_millis(100),
        Instant::now(),
    );
    let longest = gaps
        .windows(2)
        .map(|w| w[1] - w[0])
        .max()
        .unwrap_or_default();
    println!(
        "while the right bus was silent: {} reads of it, {} goals to the left bus; the left arm's longest wait for a goal {:.1} ms ({:.2} periods)",
        reads.len(),
        during.len(),
        longest.as_secs_f64() * 1e3,
        longest.as_secs_f64() * RATE_HZ
    );
}

#[test]
fn ctrl_c_stops_both_arms_braking_to_rest() {
    let (left, right) = (arm_bus(), arm_bus());
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stopped.csv");
    let child = play(&left, &right, &logged_quietly(&log));
    std::thread::sleep(Duration::from_millis(2500));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("stopped on request"), "{err}");
    let full = (7.7 * RATE_HZ) as usize;
    let followed = followed_shares(&log);
    for (arm, bus) in [("left", &left), ("right", &right)] {
        let goals = goals_by_joint(bus);
        assert!(goals[0].len() < full, "{arm}: {} goals", goals[0].len());
        assert_within_limits(arm, &goals, &followed);
        assert_at_rest(arm, &goals);
    }
}

#[test]
fn ports_that_do_not_fit_the_arms_are_usage_errors() {
    let wave = repo(WAVE);
    let nod = repo("sequences/so101_nod.json");
    let cases: [(&[&str], &str); 6] = [
        (
            &["play", &wave, "--port", "left=virtual"],
            "no port for arm right",
        ),
        (
            &[
                "play",
                &wave,
                "--port",
                "left=virtual",
                "--port",
                "middle=virtual",
            ],
            "the sequence has no arm \"middle\"",
        ),
        (
            &["play", &wave, "--port", "/dev/ttyACM0"],
            "the sequence has several arms",
        ),
        (
            &[
                "play",
                &wave,
                "--port",
                "left=/dev/ttyACM0",
                "--port",
                "right=/dev/ttyACM0",
            ],
            "is given to two arms",
        ),
        (
            &["play", &nod, "--port", "left=virtual"],
            "names an arm (\"left\"), but the robot has one arm",
        ),
        (
            &["play", &nod, "--port", "virtual", "--port", "virtual"],
            "--port is given 2 times",
        ),
    ];
    for (args, expected) in cases {
        let out = run(args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(expected),
            "{args:?}: expected {expected:?} in {err}"
        );
        assert!(!err.contains("playing"), "{args:?}: {err}");
    }
}

#[test]
fn teach_on_a_cell_reads_each_arm_on_its_own_bus() {
    let (left, right) = (arm_bus(), arm_bus());
    // The right arm's elbow (its servo 3) bent to -30° by hand; the left one at home.
    bend_elbow(&right, -30.0);
    let dir = tempfile::tempdir().unwrap();
    let sequence = dir.path().join("cell.json");
    std::fs::copy(repo(WAVE), &sequence).unwrap();
    std::fs::write(dir.path().join("s.keys"), "n w q\n").unwrap();
    let out = keypose()
        .current_dir(dir.path())
        .args(["teach", "cell.json", "--keys", "s.keys"])
        .args(["--port", &format!("left={}", left.path())])
        .args(["--port", &format!("right={}", right.path())])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&sequence).unwrap()).unwrap();
    let keys = written["keyframes"].as_array().unwrap();
    assert_eq!(keys.len(), 7, "{err}");
    // The new key (after the first) holds the pose each arm's bus reported.
    let new = &keys[1]["joints"];
    let right_elbow = new["right/elbow_flex"].as_f64().unwrap();
    let left_elbow = new["left/elbow_flex"].as_f64().unwrap();
    assert!((right_elbow + 30.0).abs() <= TICK, "{new}");
    assert!(left_elbow.abs() <= TICK, "{new}");
}

/// A LeRobot calibration of an SO-101: the whole turn on every joint, `offset` as every
/// servo's homing offset.
fn so101_calibration(offset: i64) -> String {
    let joints: Vec<String> = crate::common::SO101_JOINTS
        .iter()
        .zip(1..)
        .map(|(joint, id)| {
            format!(
                r#""{joint}": {{"id": {id}, "drive_mode": 0, "homing_offset": {offset}, "range_min": 0, "range_max": 4095}}"#
            )
        })
        .collect();
    format!("{{{}}}", joints.join(", "))
}

#[test]
fn each_arm_is_checked_against_its_own_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("right.json");
    let text = so101_calibration(100);
    std::fs::write(&cal, &text).unwrap();
    let calibration = format!("right={}", cal.display());
    let mut calibrated = so101();
    keypose::robot::import_lerobot_calibration(&mut calibrated, "right.json", &text).unwrap();

    // The right arm's servos hold the calibration's offsets, the left's none: it plays.
    let (left, right) = (arm_bus(), PtyServer::start(&calibrated).unwrap());
    let out = play(
        &left,
        &right,
        &[
            "--quiet",
            "--calibration",
            &calibration,
            TOLERATED_STALL[0],
            TOLERATED_STALL[1],
        ],
    )
    .wait_with_output()
    .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));

    // Servos at factory offsets on the right: refused before anything moved, naming the arm.
    let (left, right) = (arm_bus(), arm_bus());
    let out = play(&left, &right, &["--quiet", "--calibration", &calibration])
        .wait_with_output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("right bus: homing offset differs from the servo's: joint shoulder_pan (servo 1): the file says 100, the servo holds 0"),
        "{err}"
    );
    assert!(left.bus().lock().goals_received().is_empty());
    assert!(right.bus().lock().goals_received().is_empty());
}

/// The cycles' instants of a playback log, seconds.
fn cycle_times(log: &std::path::Path) -> Vec<f64> {
    std::fs::read_to_string(log)
        .unwrap()
        .lines()
        .skip(1)
        .map(|line| line.split(',').next().unwrap().parse().unwrap())
        .collect()
}

#[test]
fn a_stopped_server_on_one_bus_does_not_freeze_the_other_arms_goal_writes() {
    // Two `keypose virtual-bus` servers, as a user runs them; 2.5 s in, mid-motion, the right
    // one is stopped (SIGSTOP): it reads nothing more, so its pseudo-terminal fills and the
    // right bus's writes stick as a deaf adapter's would. The left arm's goals must keep going
    // out every period while it brakes: the log's cycles are its writes.
    let left = crate::common::VirtualBusProcess::start(&["--robot", "so101"]);
    let right = crate::common::VirtualBusProcess::start(&["--robot", "so101"]);
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stopped.csv");
    let child = keypose()
        .args(["play", &repo(WAVE)])
        .args(["--port", &format!("left={}", left.path)])
        .args(["--port", &format!("right={}", right.path)])
        .args(logged_quietly(&log))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(2500));
    let signal = |name: &str| {
        let pid = right.child.id().to_string();
        let status = Command::new("kill").args([name, &pid]).status().unwrap();
        assert!(status.success());
    };
    signal("-STOP");
    let stopped_at = Instant::now();
    let out = child.wait_with_output().unwrap();
    signal("-CONT");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("right bus"), "{err}");
    assert!(
        err.contains("nothing more was sent to the right bus, and the other arms braked to rest"),
        "{err}"
    );
    let times = cycle_times(&log);
    let gaps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let largest = gaps.iter().copied().fold(0.0, f64::max);
    println!(
        "the left arm's largest write gap: {:.1} ms ({} cycles; the playback ended {:.2} s after the stop)",
        largest * 1e3,
        times.len(),
        stopped_at.elapsed().as_secs_f64()
    );
    // The player's own default bound on a goal held (--max-stall is raised here so that a
    // busy machine's stalls do not end the test): the stuck bus must not come near it.
    assert!(
        largest < keypose::player::DEFAULT_MAX_STALL,
        "the left arm's goals stopped for {:.0} ms",
        largest * 1e3
    );
}
