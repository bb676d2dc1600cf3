//! Sequence file text, loaded against the built-in robot it names (the SO-101 when it names
//! none; the cell of the built-ins its arms name for several arms), then through everything `check`, `retime` and `play` do before a servo is involved.
//! Property: no panic; what loads saves and loads back to the same sequence; a trajectory that
//! builds checks; what `retime` returns builds, its report is the check of what it returns, and
//! it never shortens a segment (beyond the millisecond its key times are rounded to).
#![no_main]

use keypose::plan::{check, retime, Trajectory};
use keypose::sequence::Sequence;
use keypose_fuzz::sequence_robot;
use libfuzzer_sys::fuzz_target;

/// Longer trajectories are valid but make an execution take seconds at the control rate.
const MAX_CHECKED_SECONDS: f64 = 120.0;

/// The sequence without where its keys stood in the file (a saved file lists them in time
/// order, so their places change when the file had them out of order).
fn content(sequence: &Sequence) -> Sequence {
    let mut sequence = sequence.clone();
    for key in &mut sequence.keyframes {
        key.source_index = None;
    }
    sequence
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(sequence) = Sequence::from_json("fuzz.json", text) else {
        return;
    };
    let again = Sequence::from_json("fuzz.json", &sequence.to_json())
        .unwrap_or_else(|e| panic!("a loaded sequence does not load once saved: {e}"));
    assert_eq!(
        content(&again),
        content(&sequence),
        "save and load changed the sequence"
    );

    let Some(robot) = sequence_robot(&sequence) else {
        return;
    };
    let robot = robot.as_ref();
    let Ok(trajectory) = Trajectory::build(&sequence, robot) else {
        return;
    };
    let duration = trajectory.duration();
    if duration.is_nan() || duration > MAX_CHECKED_SECONDS {
        return;
    }
    let rate = robot.control_hz;
    let report = check(&trajectory, robot, rate);
    assert!(report.joints.iter().all(|j| !j.peak_velocity.is_nan()));

    let outcome = match retime(&sequence, robot, rate) {
        Ok(outcome) => outcome,
        Err(e) => panic!("a sequence that builds does not retime: {e}"),
    };
    let retimed = Trajectory::build(&outcome.sequence, robot)
        .unwrap_or_else(|e| panic!("the retimed sequence does not build: {e}"));
    assert_eq!(check(&retimed, robot, rate), outcome.report);
    let (before, after) = (sequence.key_times(), outcome.sequence.key_times());
    for (i, (b, a)) in before.windows(2).zip(after.windows(2)).enumerate() {
        assert!(
            a[1] - a[0] >= b[1] - b[0] - 1e-3,
            "retime shortened segment {i}: {b:?} -> {a:?}"
        );
    }
});
