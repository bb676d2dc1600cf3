//! A rate byte, a phase byte, then sequence file text, loaded against the built-in robot it
//! names (as `sequence_loader` does) and checked exactly at that control rate; the same
//! trajectory then sampled by brute force at 16 phases of every control period
//! (tests/common/player_differences.rs, which the test suite's property test shares).
//! Property: no panic; the check's peaks bound every sampled position, goal velocity and goal
//! acceleration, so the exact verdict never says "ok" where dense sampling finds a violation.
#![no_main]

#[path = "../../tests/common/player_differences.rs"]
mod player_differences;

use keypose::plan::{check, Trajectory};
use keypose::sequence::Sequence;
use keypose_fuzz::sequence_robot;
use libfuzzer_sys::fuzz_target;
use player_differences::PHASES;

/// Longer samplings are valid but make an execution take seconds.
const MAX_SAMPLES: f64 = 200_000.0;

fuzz_target!(|data: &[u8]| {
    let Some((rate, offset, text)) = player_differences::decode(data) else {
        return;
    };
    let Ok(sequence) = Sequence::from_json("fuzz.json", text) else {
        return;
    };
    let Some(robot) = sequence_robot(&sequence) else {
        return;
    };
    let robot = robot.as_ref();
    let Ok(trajectory) = Trajectory::build(&sequence, robot) else {
        return;
    };
    let samples = (trajectory.duration() * rate + 2.0) * PHASES as f64;
    // NaN (an infinite duration times zero) is too many as well.
    if samples.partial_cmp(&MAX_SAMPLES) != Some(std::cmp::Ordering::Less) {
        return;
    }
    let report = check(&trajectory, robot, rate);
    let sampled = player_differences::player_extremes(&trajectory, rate, PHASES, offset);
    player_differences::assert_within_report(&report, robot, &sampled);
});
