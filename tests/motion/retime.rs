//! `keypose retime`, through the binary: each segment stretched as much as its limits need and
//! no more, advice that fits the segment; `retime --fastest`: timing profiles that pass the
//! exact check, against hand-derived time-optimal moves and against TOPP-RA (the `toppra`
//! package in keypose's Python environment, which these tests need: without it they fail).

use crate::common::{python_cache, repo, run, show, stderr, stdout};
use keypose::plan::{builtin_robot_of, fastest, Trajectory};
use keypose::sequence::Sequence;
use std::path::Path;

#[path = "../../benches/common/topp.rs"]
mod topp;

/// The SO-101's elbow_flex limits (robots/so101.json): 115 deg/s, 344 deg/s².
const VELOCITY: f64 = 115.0;
const ACCELERATION: f64 = 344.0;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn key_times(path: &str) -> Vec<f64> {
    Sequence::load(Path::new(path)).unwrap().key_times()
}

/// Elbow keys `(time, hold, value)` in `mode`.
fn elbow(mode: &str, keys: &[(f64, f64, f64)]) -> String {
    let keys: Vec<String> = keys
        .iter()
        .map(|(t, h, v)| {
            format!(r#"{{"time": {t}, "hold": {h}, "joints": {{"elbow_flex": {v}}}}}"#)
        })
        .collect();
    format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "{mode}",
            "keyframes": [{}]}}"#,
        keys.join(",")
    )
}

/// A cubic from rest to rest is the smoothstep Δ·(3f² − 2f³): over T seconds its peak velocity
/// is 1.5·Δ/T and its peak acceleration 6·Δ/T² (at its ends). 90° in 0.4 s asks for 337.5 deg/s
/// and 3375 deg/s²; the acceleration needs T ≥ √(6·90/344) = 1.25294 s, the velocity only
/// 1.5·90/115 = 1.17391 s. So the segment becomes 1.253 s (key times to the millisecond, up),
/// and 1.252 s would still be over: 6·90/1.252² = 344.5 deg/s². The segment before it, slow
/// enough and parted from it by a hold, keeps its 2 s.
#[test]
fn retime_stretches_a_segment_to_the_time_its_limit_needs_and_no_more() {
    let dir = tempfile::tempdir().unwrap();
    let fast = write(
        dir.path(),
        "fast.json",
        &elbow("cubic", &[(0.0, 0.0, 0.0), (2.0, 0.5, -40.0), (2.9, 0.0, 50.0)]),
    );
    let fixed = dir.path().join("fixed.json");
    let out = run(&["retime", &fast, "-o", fixed.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let times = key_times(fixed.to_str().unwrap());
    assert_eq!(times[1], 2.0, "{times:?}");
    let moving = times[2] - times[1] - 0.5;
    let needed = (6.0 * 90.0 / ACCELERATION).sqrt();
    assert!(
        moving >= needed && moving <= needed + 0.001 + 1e-9,
        "{moving} s, needed {needed} s"
    );
    let out = run(&["check", fixed.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // A millisecond less is over the limit.
    let shorter = write(
        dir.path(),
        "shorter.json",
        &elbow("cubic", &[(0.0, 0.0, 0.0), (2.0, 0.5, -40.0), (3.752, 0.0, 50.0)]),
    );
    assert_eq!(run(&["check", &shorter]).status.code(), Some(1));
}

/// A 0.4 s straight tool line over 20 cm (tests/motion/tool_keys.rs has it too) is too fast for
/// the joints. The shortest time in which it passes `check` is found here by trying the line's
/// times 10 ms apart through the binary; `retime` must land within 5 % above it. (Whether a
/// line's time passes flickers from one 10 ms to the next, since the line is solved again at
/// the control rate and its samples' monotone interpolation changes with their count: 1.11 s
/// passes, 1.12 s does not, 1.15 s does. `retime` climbs in steps of 3 %.) On main at bb14c46
/// it stretched the line to 1.300 s, its peaks at 77 % of the velocity limit and 70 % of the
/// acceleration limit.
#[test]
fn retime_stretches_a_straight_line_no_further_than_the_first_time_that_passes() {
    let dir = tempfile::tempdir().unwrap();
    let line = |span: f64| {
        format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
            "keyframes": [
              {{"name": "start", "time": 0, "joints": {{"shoulder_pan": 0, "shoulder_lift": 0, "elbow_flex": 0, "wrist_flex": 0, "wrist_roll": 0, "gripper": 0}}}},
              {{"name": "above", "time": 2.0, "interp": "line", "tool": {{"xyz": [0.25, -0.05, 0.12]}}}},
              {{"name": "grasp", "time": {}, "tool": {{"xyz": [0.15, 0.1, 0.06]}}, "joints": {{"gripper": 30}}}},
              {{"name": "lift", "time": {}, "tool": {{"xyz": [0.25, 0.05, 0.12]}}}}]}}"#,
            2.0 + span,
            3.6 + span
        )
    };
    let first_pass = (40..=200)
        .map(|k| k as f64 * 0.01)
        .find(|&span| {
            let file = write(dir.path(), "try.json", &line(span));
            run(&["check", &file]).status.code() == Some(0)
        })
        .expect("some time up to 2 s passes");
    let fast = write(dir.path(), "fast.json", &line(0.4));
    let fixed = dir.path().join("fixed.json");
    let out = run(&["retime", &fast, "-o", fixed.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let times = key_times(fixed.to_str().unwrap());
    let span = times[2] - times[1];
    assert!(
        span <= first_pass * 1.05 + 0.001,
        "retimed to {span} s; {first_pass} s passes"
    );
    let out = run(&["check", fixed.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

/// What retime cannot mend is said with advice that fits the segment: a step's jump (no time
/// smooths it) asks for another interpolation, not "a smooth mode" in general; a cubic that
/// overshoots a limit between its keys asks for monotone.
#[test]
fn retime_advises_per_segment_kind() {
    let dir = tempfile::tempdir().unwrap();
    let step = write(
        dir.path(),
        "step.json",
        &elbow("step", &[(0.0, 0.0, 0.0), (1.0, 0.0, 40.0), (2.0, 0.0, 40.0)]),
    );
    let out = run(&["retime", &step]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let said = stderr(&out);
    assert!(said.contains("a step jumps within one control period"), "{said}");
    assert!(said.contains("give this segment linear, cubic or monotone"), "{said}");
    assert!(!said.contains("smooth mode"), "{said}");
    // elbow_flex's upper limit is 96.83° (robots/so101.json). Keys 60, 95, 96 a second apart
    // give the middle key the slope (96 − 60)/2 = 18 deg/s and the last 0, so the second
    // segment is 95 + 18f − 33f² + 16f³, which peaks at f = 0.375 at 97.953°: over the limit
    // between two keys inside it, which no timing changes.
    let overshoot = write(
        dir.path(),
        "overshoot.json",
        &elbow("cubic", &[(0.0, 0.0, 60.0), (1.0, 0.0, 95.0), (2.0, 0.0, 96.0)]),
    );
    let out = run(&["check", &overshoot]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert!(stdout(&out).contains("97.953"), "{}", show(&out));
    let out = run(&["retime", &overshoot]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let said = stderr(&out);
    assert!(said.contains("the cubic overshoots its keys here: use monotone"), "{said}");
}
