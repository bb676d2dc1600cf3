//! `plot --log`'s reader of playback logs, two ways by the first byte: any text read as a log
//! of a built-in robot's joints; or rows the player's own log writer wrote (any phase, times
//! and measured values, joints renamed with any name a robot file may hold: commas and quotes
//! included, control characters not) read back.
//! The servo columns (loads read, load needed) are written beside the measured ones.
//! Property: no panic; bad text is an error naming the file and a line of it; every point
//! read is finite; what the writer wrote reads back: each joint's measured values in the
//! phases on the sequence's time axis (play, stopping, resuming), at their sequence times, to
//! the writer's 6 decimals.
#![no_main]

use keypose::json::Location;
use keypose::plan::Phase;
use keypose::player::{LogRow, PlaybackLog};
use keypose::report::log::{measured_traces, parse_traces, Trace};
use keypose::robot::Robot;
use keypose::terminal_text::is_layout_control;
use keypose_fuzz::exports::{names, renamed};
use keypose_fuzz::{builtin_robot, Choices};
use libfuzzer_sys::fuzz_target;

const PHASES: [Phase; 5] = [
    Phase::Approach,
    Phase::Play,
    Phase::Return,
    Phase::Stopping,
    Phase::Resuming,
];
/// Rows per written log: enough for every phase between measured and unmeasured rows.
const MAX_ROWS: usize = 48;

fn joint_names(robot: &Robot) -> Vec<String> {
    robot.joint_names().iter().map(|n| n.to_string()).collect()
}

/// A finite value from four bytes: ±2³¹ in steps of 2⁻¹⁰, and some far larger.
fn value(choices: &mut Choices) -> f64 {
    let bits = u32::from_le_bytes([
        choices.byte(),
        choices.byte(),
        choices.byte(),
        choices.byte(),
    ]);
    let x = f64::from(bits as i32) / 1024.0;
    if choices.byte() == 0xff {
        x * 1e12
    } else {
        x
    }
}

fn any_text(robot: &Robot, data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    match parse_traces("fuzz.csv", &text, &joint_names(robot)) {
        Ok(traces) => {
            let points = traces.iter().flatten().flatten();
            assert!(points.clone().all(|(t, v)| t.is_finite() && v.is_finite()));
        }
        Err(e) => {
            assert_eq!(e.file, "fuzz.csv");
            if let Location::Syntax { line, .. } = e.location {
                assert!(line >= 1 && line <= text.lines().count().max(1), "{e}");
            }
        }
    }
}

fn written_and_read(robot: &Robot, choices: &mut Choices) {
    // What a robot file may hold: non-empty names, each once, no control characters.
    let mut list = joint_names(robot);
    for (i, name) in names(choices, list.len()).into_iter().enumerate() {
        if !name.is_empty() && !name.chars().any(is_layout_control) && !list.contains(&name) {
            list[i] = name;
        }
    }
    let robot = renamed(robot, &list);
    let joints = robot.joints.len();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("log.csv");
    let mut log = PlaybackLog::create(&path, &robot).unwrap();
    let mut expected: Vec<Trace> = vec![Vec::new(); joints];
    let commanded = vec![0.0; joints];
    for k in 0..MAX_ROWS {
        if choices.is_empty() {
            break;
        }
        let phase = choices.pick(&PHASES);
        let sequence_time = value(choices);
        let measured: Option<Vec<f64>> = choices
            .byte()
            .is_multiple_of(2)
            .then(|| (0..joints).map(|_| value(choices)).collect());
        // The servo columns beside them: a load read (or not) and the load the guard judged,
        // written on the same rows; they must not shift the measured columns.
        let loads: Vec<Option<f64>> = if choices.byte().is_multiple_of(2) {
            (0..joints)
                .map(|_| choices.byte().is_multiple_of(2).then(|| value(choices)))
                .collect()
        } else {
            Vec::new()
        };
        let needed: Vec<f64> = if choices.byte().is_multiple_of(2) {
            (0..joints).map(|_| value(choices)).collect()
        } else {
            Vec::new()
        };
        log.row(&LogRow {
            time: k as f64 * 0.01,
            phase,
            sequence_time,
            commanded: &commanded,
            measured: measured.as_deref(),
            lateness: 0.0,
            stall: None,
            loads: &loads,
            health: &[],
            needed: &needed,
        })
        .unwrap();
        if let (Some(measured), Phase::Play | Phase::Stopping | Phase::Resuming) =
            (&measured, phase)
        {
            for (trace, &m) in expected.iter_mut().zip(measured) {
                trace.push((sequence_time, m));
            }
        }
    }
    log.finish().unwrap();
    let traces = measured_traces(&path, &joint_names(&robot))
        .unwrap_or_else(|e| panic!("the log the player wrote does not read back: {e}"));
    for (j, (read, written)) in traces.iter().zip(&expected).enumerate() {
        let read = read
            .as_ref()
            .unwrap_or_else(|| panic!("joint {j}'s column is missing"));
        assert_eq!(read.len(), written.len(), "joint {j}");
        for ((t, v), (wt, wv)) in read.iter().zip(written) {
            // Six decimals: half of the last, and f64's own rounding of large values.
            let close = |a: f64, b: f64| (a - b).abs() <= 0.5e-6 + 1e-15 * b.abs();
            assert!(
                close(*t, *wt) && close(*v, *wv),
                "joint {j}: read ({t}, {v}), wrote ({wt}, {wv})"
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let mode = choices.byte();
    let robot = builtin_robot(mode >> 1);
    if mode & 1 == 0 {
        any_text(robot, choices.rest());
    } else {
        written_and_read(robot, &mut choices);
    }
});
