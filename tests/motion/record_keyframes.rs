//! From a recording to a sequence that passes the limit check: synthetic recordings of the
//! built-in robots, no bus. Each result is checked the way a user would: the sequence is written
//! to JSON, read back, built into a trajectory and checked against the robot's limits.

use keypose::curve::Interp;
use keypose::plan::{check, Trajectory};
use keypose::record::{keyframes, KeyframeOptions, Keyframes, RecordError, Recording, StopReason};
use keypose::robot::Robot;
use keypose::sequence::{KeyValue, Sequence};

const RATE: f64 = 100.0;

fn options(interpolation: Interp) -> KeyframeOptions {
    KeyframeOptions {
        interpolation,
        tolerance_deg: 1.0,
        tolerance_m: 0.001,
        check_rate_hz: RATE,
    }
}

/// A recording of `robot` over `seconds` at RATE: each joint's value from `motion(joint, t)`.
fn recording(
    robot: &Robot,
    seconds: f64,
    recorded: &[&str],
    motion: impl Fn(usize, f64) -> f64,
) -> Recording {
    let n = (seconds * RATE).round() as usize + 1;
    let times: Vec<f64> = (0..n).map(|k| k as f64 / RATE).collect();
    Recording {
        values: (0..robot.joints.len())
            .map(|j| times.iter().map(|&t| motion(j, t)).collect())
            .collect(),
        recorded: robot
            .joints
            .iter()
            .map(|j| recorded.contains(&j.name.as_str()))
            .collect(),
        times,
        rate_hz: RATE,
        stopped: StopReason::Duration,
        gaps: Default::default(),
        hold_error: None,
    }
}

fn smoothstep(t: f64, from: f64, to: f64) -> f64 {
    let x = ((t - from) / (to - from)).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The sequence as saved and loaded again, checked against the robot: the verdict of
/// `keypose check` on the written file.
fn check_as_saved(result: &Keyframes, robot: &Robot) -> Sequence {
    let text = result.sequence.to_json();
    let loaded = Sequence::from_json("recorded.json", &text).expect("the JSON reads back");
    let trajectory = Trajectory::build(&loaded, robot).expect("the keys are valid for the robot");
    let report = check(&trajectory, robot, RATE);
    assert!(
        report.passed(),
        "{}",
        keypose::report::check_text(&report, "recorded.json", robot)
    );
    loaded
}

fn joint_value(key: &keypose::sequence::Keyframe, joint: &str) -> Option<f64> {
    match key.value(joint) {
        Some(KeyValue::Joint(v)) => Some(*v),
        _ => None,
    }
}

#[test]
fn a_hand_faster_than_the_limits_is_retimed() {
    let robot = Robot::builtin("so101").unwrap();
    let elbow = robot.joint_index("elbow_flex").unwrap();
    // 90° in 0.4 s: a smoothstep peaks at 1.5 × 90 / 0.4 = 337 °/s, the limit is 115 °/s. The
    // elbow bends back, the forearm up, clear of the desk.
    let rec = recording(&robot, 1.5, &["elbow_flex"], |j, t| {
        if j == elbow {
            -90.0 * smoothstep(t, 0.3, 0.7)
        } else {
            0.0
        }
    });
    let result = keyframes(&rec, &robot, &options(Interp::Monotone)).unwrap();
    let retimed = result.retimed.as_ref().expect("retimed");
    assert_eq!(retimed.before(), 1.5);
    // Stretching only adds time: the move needs at least 337/115 of its 0.4 s.
    assert!(
        retimed.after() >= 1.5 + 0.4 * (337.0 / 115.0 - 1.0) * 0.9,
        "{retimed:?}"
    );
    // Keys move later, never earlier, and the first stays at 0.
    assert_eq!(retimed.key_times_after[0], 0.0);
    assert!(retimed
        .key_times_before
        .iter()
        .zip(&retimed.key_times_after)
        .all(|(a, b)| b >= a));
    assert_eq!(result.sequence.key_times(), retimed.key_times_after);
    let loaded = check_as_saved(&result, &robot);
    // The keys keep their recorded values; the move still goes from 0° to −90°.
    let first = &loaded.keyframes[0];
    let last = loaded.keyframes.last().unwrap();
    assert_eq!(joint_value(first, "elbow_flex"), Some(0.0));
    assert!((joint_value(last, "elbow_flex").unwrap() + 90.0).abs() < 1e-9);
    assert!(result.deviations.iter().all(|d| d.value <= 1.0));
}

#[test]
fn a_joint_pushed_past_its_limit_is_clamped_to_it() {
    let robot = Robot::builtin("so101").unwrap();
    let lift = robot.joint_index("shoulder_lift").unwrap();
    let limit = robot.joints[lift].limits.min;
    assert_eq!(limit, -100.0);
    // Up to −104° (4° past the limit, the arm raised and leaning back, clear of the desk) and
    // back to −90°, slowly enough for the limits.
    let rec = recording(&robot, 4.0, &["shoulder_lift"], |j, t| {
        if j == lift {
            -80.0 - 24.0 * smoothstep(t, 0.0, 2.0) + 14.0 * smoothstep(t, 2.5, 4.0)
        } else {
            0.0
        }
    });
    for mode in [Interp::Monotone, Interp::Cubic] {
        let result = keyframes(&rec, &robot, &options(mode)).unwrap();
        assert_eq!(result.clamps.len(), 1, "{mode}");
        let clamp = &result.clamps[0];
        assert_eq!(clamp.joint, "shoulder_lift");
        assert_eq!(clamp.limit, limit);
        assert!((clamp.excess - 4.0).abs() < 0.01, "{mode}: {clamp:?}");
        let loaded = check_as_saved(&result, &robot);
        for key in &loaded.keyframes {
            assert!(
                joint_value(key, "shoulder_lift").unwrap() >= limit,
                "{mode}"
            );
        }
        // The fit is against the clamped recording.
        assert!(result.deviations[0].value <= 1.0, "{mode}");
    }
}

#[test]
fn a_cubic_resting_against_a_limit_does_not_overshoot_it() {
    // Pushed hard against the stop for a second (clamped: a plateau at the limit) with quick
    // moves on either side: a cubic through keys at the plateau's edges overshoots it unless
    // those segments are made monotone.
    let robot = Robot::builtin("so101").unwrap();
    let pan = robot.joint_index("shoulder_pan").unwrap();
    let rec = recording(&robot, 3.0, &["shoulder_pan"], |j, t| {
        if j == pan {
            60.0 + 60.0 * smoothstep(t, 0.2, 1.0) - 50.0 * smoothstep(t, 2.0, 2.8)
        } else {
            0.0
        }
    });
    let result = keyframes(&rec, &robot, &options(Interp::Cubic)).unwrap();
    assert!(!result.clamps.is_empty());
    check_as_saved(&result, &robot);
    assert!(result.deviations[0].value <= 1.0);
}

#[test]
fn joints_not_recorded_are_in_the_first_key_only_and_their_drift_is_reported() {
    let robot = Robot::builtin("so101").unwrap();
    let elbow = robot.joint_index("elbow_flex").unwrap();
    let roll = robot.joint_index("wrist_roll").unwrap();
    let rec = recording(&robot, 2.0, &["elbow_flex"], |j, t| {
        if j == elbow {
            30.0 * smoothstep(t, 0.2, 1.6)
        } else if j == roll {
            // Not recorded, but it sagged by 5°: the file can only hold its first value.
            -20.0 - 5.0 * smoothstep(t, 0.5, 1.5)
        } else {
            j as f64
        }
    });
    let result = keyframes(&rec, &robot, &options(Interp::Monotone)).unwrap();
    let loaded = check_as_saved(&result, &robot);
    let first = &loaded.keyframes[0];
    assert_eq!(first.values.len(), robot.joints.len());
    assert_eq!(joint_value(first, "wrist_roll"), Some(-20.0));
    assert_eq!(joint_value(first, "shoulder_lift"), Some(1.0));
    for key in &loaded.keyframes[1..] {
        let names: Vec<&str> = key.values.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["elbow_flex"]);
    }
    assert_eq!(result.drifts.len(), 1);
    assert_eq!(result.drifts[0].joint, "wrist_roll");
    assert!((result.drifts[0].moved - 5.0).abs() < 1e-9);
    assert_eq!(result.deviations.len(), 1);
    assert_eq!(result.deviations[0].joint, "elbow_flex");
}

#[test]
fn key_times_are_whole_milliseconds_from_zero() {
    let robot = Robot::builtin("so101").unwrap();
    let mut rec = recording(&robot, 2.0, &["elbow_flex"], |j, t| {
        if j == 2 {
            40.0 * (3.0 * t).sin()
        } else {
            0.0
        }
    });
    // Measured times jitter around the grid, and one stall put two reads 0.3 ms apart.
    for (k, t) in rec.times.iter_mut().enumerate() {
        *t += 0.0004 * ((k * 7) % 5) as f64 / 4.0;
    }
    rec.times[51] = rec.times[50] + 0.0003;
    let result = keyframes(&rec, &robot, &options(Interp::Monotone)).unwrap();
    // The sample that shared a millisecond with the one before it was dropped.
    assert_eq!(result.samples, rec.times.len() - 1);
    let times = result.sequence.key_times();
    assert_eq!(times[0], 0.0);
    for t in &times {
        let ms = t * 1000.0;
        assert!((ms - ms.round()).abs() < 1e-6, "{t}");
    }
    check_as_saved(&result, &robot);
}

#[test]
fn a_prismatic_gripper_is_fitted_in_metres() {
    let robot = Robot::builtin("omx").unwrap();
    let gripper = robot
        .joints
        .iter()
        .position(|j| j.kind == keypose::robot::JointKind::Prismatic)
        .unwrap();
    let name = robot.joints[gripper].name.clone();
    // 15 mm open, then 10 mm closed again, within the gripper's 0.0333 m/s.
    let rec = recording(&robot, 3.0, &[name.as_str()], |j, t| {
        if j == gripper {
            0.015 * smoothstep(t, 0.2, 1.4) - 0.010 * smoothstep(t, 1.8, 2.9)
        } else {
            robot.home[j]
        }
    });
    let result = keyframes(&rec, &robot, &options(Interp::Monotone)).unwrap();
    check_as_saved(&result, &robot);
    let d = &result.deviations[0];
    assert_eq!(d.unit, "m");
    assert!(d.value <= 0.001, "{d:?}");
    // Metres, not degrees: a 1° tolerance on a 15 mm motion would have left two keys.
    assert!(result.keys() > 2);
    assert!(result.summary().contains(" m ("), "{}", result.summary());
}

#[test]
fn a_still_recording_is_two_keys_at_the_pose() {
    let robot = Robot::builtin("koch").unwrap();
    let all: Vec<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    let rec = recording(&robot, 1.0, &all, |j, _| robot.home[j]);
    let result = keyframes(&rec, &robot, &options(Interp::Monotone)).unwrap();
    assert_eq!(result.keys(), 2);
    assert_eq!(result.samples, 101);
    assert!(result.retimed.is_none());
    assert!(result.summary().starts_with("101 samples → 2 keys"));
    check_as_saved(&result, &robot);
}

#[test]
fn step_and_nonsense_are_refused() {
    let robot = Robot::builtin("so101").unwrap();
    let rec = recording(&robot, 0.5, &["elbow_flex"], |_, _| 0.0);
    assert!(matches!(
        keyframes(&rec, &robot, &options(Interp::Step)),
        Err(RecordError::Invalid(_))
    ));
    let mut bad = options(Interp::Monotone);
    bad.tolerance_deg = 0.0;
    assert!(matches!(
        keyframes(&rec, &robot, &bad),
        Err(RecordError::Invalid(_))
    ));
    let other = Robot::builtin("omx").unwrap();
    assert!(matches!(
        keyframes(&rec, &other, &options(Interp::Monotone)),
        Err(RecordError::Invalid(_))
    ));
}
