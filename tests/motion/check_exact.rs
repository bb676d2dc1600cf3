//! The limit check is exact and covers what leaves keypose: through the binary, a motion
//! shorter than a control period fails at every rate with its closed-form peaks; `play` at
//! another speed or from a later key, and every `export`, refuse what fails; a straight tool
//! line is checked as solved. A property test holds the check's peaks against what the player
//! asks for at every phase of its control period (tests/common/player_differences.rs, shared with
//! the `check_exact` fuzz target).

#[path = "../common/player_differences.rs"]
mod player_differences;

use crate::common::{run, show, stderr, stdout};
use keypose::plan::{check, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

/// wrist_flex 0 → 60 → 0° over `ms` milliseconds, cubic: two smoothsteps of h = ms/2, each
/// peaking at 1.5·60/h °/s and (at its ends) 6·60/h² °/s².
fn spike(ms: f64) -> String {
    let h = ms / 2000.0;
    format!(
        r#"{{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic","keyframes":[
          {{"time":0,"joints":{{"wrist_flex":0}}}},{{"time":{h},"joints":{{"wrist_flex":60}}}},
          {{"time":{},"joints":{{"wrist_flex":0}}}}]}}"#,
        2.0 * h
    )
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn wrist_json(report: &serde_json::Value) -> &serde_json::Value {
    report["joints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["joint"] == "wrist_flex")
        .unwrap()
}

#[test]
fn a_spike_of_a_few_milliseconds_fails_at_every_rate_with_the_same_peaks() {
    let dir = tempfile::tempdir().unwrap();
    for ms in [2.0, 3.0, 4.0] {
        let path = write(dir.path(), "spike.json", &spike(ms));
        let h = ms / 2000.0;
        let (velocity, acceleration) = (1.5 * 60.0 / h, 6.0 * 60.0 / (h * h));
        let mut reports = Vec::new();
        for rate in ["10", "50", "100", "500", "1000"] {
            let out = run(&[
                "check",
                path.to_str().unwrap(),
                "--rate",
                rate,
                "--format",
                "json",
            ]);
            assert_eq!(
                out.status.code(),
                Some(1),
                "{ms} ms, {rate} Hz: {}",
                show(&out)
            );
            let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
            assert_eq!(report["passed"], false);
            let wrist = wrist_json(&report);
            let close = |field: &str, expected: f64| {
                let got = wrist[field].as_f64().unwrap();
                assert!(
                    (got - expected).abs() <= 1e-9 * expected,
                    "{ms} ms, {rate} Hz: {field} {got}, expected {expected}"
                );
            };
            close("max_position", 60.0);
            close("peak_velocity", velocity);
            close("peak_acceleration", acceleration);
            reports.push(report);
        }
        assert!(
            reports.windows(2).all(|w| w[0] == w[1]),
            "{ms} ms: the report changed with --rate"
        );
    }
}

#[test]
fn play_refuses_the_spike_at_any_speed_and_a_start_in_motion() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "spike.json", &spike(4.0));
    let path = path.to_str().unwrap();
    // The refusal comes before the port is opened; a sequence that passes fails on the port.
    for speed in ["0.7", "1", "0.1"] {
        let out = run(&[
            "play",
            path,
            "--speed",
            speed,
            "--port",
            "/dev/keypose-no-such-port",
        ]);
        assert_eq!(
            out.status.code(),
            Some(1),
            "--speed {speed}: {}",
            show(&out)
        );
        let err = stderr(&out);
        assert!(err.contains("refusing to play"), "{err}");
        assert!(err.contains("wrist_flex     velocity"), "{err}");
    }
    // A cubic 0 → 30 → 60° at 0, 1, 2 s passes from its start (at rest) but not from key 1,
    // where it moves at the central difference 60/2 = 30 °/s. From there it is the Hermite
    // 30 + 30s + 30s² − 30s³ (slopes 30 and 0 over 1 s), so the first goal after the start,
    // 10 ms later, is 0.30297° on: from rest, 0.30297/0.01² = 3029.7 °/s².
    let ramp = write(
        dir.path(),
        "ramp.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"wrist_flex":0}},{"time":1,"joints":{"wrist_flex":30}},
          {"time":2,"joints":{"wrist_flex":60}}]}"#,
    );
    let ramp = ramp.to_str().unwrap();
    let out = run(&["play", ramp, "--port", "/dev/keypose-no-such-port"]);
    assert_eq!(out.status.code(), Some(3), "{}", show(&out));
    let out = run(&[
        "play",
        ramp,
        "--from",
        "1",
        "--port",
        "/dev/keypose-no-such-port",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let err = stderr(&out);
    assert!(
        err.contains("acceleration segment 1 (#1 → #2), t = 1.000 s")
            && err.contains(": 3029.700 deg/s²"),
        "{err}"
    );
    assert!(err.contains("from key \"1\""), "{err}");
}

#[test]
fn every_export_refuses_the_spike_listing_its_violations() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "spike.json", &spike(4.0));
    let path = path.to_str().unwrap();
    for (format, file) in [
        ("c", "seq.h"),
        ("ros2", "t.yaml"),
        ("play_motion2", "m.yaml"),
    ] {
        let out_file = dir.path().join(file);
        let out = run(&["export", format, path, "-o", out_file.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(1), "{format}: {}", show(&out));
        let err = stderr(&out);
        assert!(
            err.contains("FAILED: 6 limit violation(s)"),
            "{format}: {err}"
        );
        assert!(
            err.contains("45000.000 deg/s > limit 115.000 deg/s"),
            "{format}: {err}"
        );
        assert!(err.contains("refusing to export"), "{format}: {err}");
        assert!(!out_file.exists(), "{format}: wrote {file}");
    }
}

#[test]
fn a_tool_line_out_and_back_between_two_samples_is_checked_as_solved() {
    // The tool goes 2 cm down a straight line and back up in 4 ms, from 3 to 7 ms: between the
    // 100 Hz samples at 0 and 10 ms, where the arm is at the same pose.
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "dip.json",
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"monotone","keyframes":[
          {"name":"a","time":0,"tool":{"xyz":[0.25,0.05,0.12]}},
          {"name":"b","time":0.003,"interp":"line","tool":{"xyz":[0.25,0.05,0.12]}},
          {"name":"c","time":0.005,"interp":"line","tool":{"xyz":[0.25,0.05,0.10]}},
          {"name":"d","time":0.007,"tool":{"xyz":[0.25,0.05,0.12]}},
          {"name":"e","time":0.010,"tool":{"xyz":[0.25,0.05,0.12]}}]}"#,
    );
    let path = path.to_str().unwrap();
    let out = run(&["check", path, "--format", "json"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    // The solved joints, sampled every 10 µs by `keypose sample`: their fastest finite
    // difference is the check's peak velocity, to the sampling's precision.
    let sampled = run(&["sample", path, "--rate", "100000"]);
    assert_eq!(sampled.status.code(), Some(0), "{}", show(&sampled));
    let text = stdout(&sampled);
    let mut lines = text.lines();
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let mut moved = 0;
    for (j, name) in names.iter().enumerate().skip(1) {
        let fastest = rows
            .windows(2)
            .map(|w| ((w[1][j] - w[0][j]) / (w[1][0] - w[0][0])).abs())
            .fold(0.0, f64::max);
        let summary = report["joints"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["joint"] == name.as_str())
            .unwrap();
        let peak = summary["peak_velocity"].as_f64().unwrap();
        assert!(
            fastest <= peak * (1.0 + 1e-9) && fastest >= 0.99 * peak,
            "{name}: sampled {fastest} °/s, checked {peak} °/s"
        );
        if fastest > 115.0 {
            moved += 1;
        }
    }
    assert!(moved > 0, "the dip breaks the velocity limit of some joint");
    let violations = report["violations"].as_array().unwrap();
    assert!(
        violations
            .iter()
            .any(|v| v["kind"] == "velocity" && v["segment_label"] == "b → c"),
        "{report}"
    );
}

#[test]
fn the_fuzz_targets_seeds_hold_the_property() {
    // fuzz/seeds/check_exact (written by fuzz/make-seeds): the repository's sequences and the
    // steps, corners and spikes the check treats apart, each decoded as the target decodes it.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/check_exact");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).expect("the check_exact seeds") {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        let (rate, offset, text) = player_differences::decode(&data).unwrap();
        let sequence = Sequence::from_json("seed.json", text)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let robot = keypose::plan::builtin_robot_of(&sequence).unwrap();
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, rate);
        let sampled = player_differences::player_extremes(
            &trajectory,
            rate,
            player_differences::PHASES,
            offset,
        );
        player_differences::assert_within_report(&report, &robot, &sampled);
        checked += 1;
    }
    assert!(checked >= 20, "{checked} seeds in {}", dir.display());
}

/// A sequence of keys on the SO-101's wrist_flex and elbow_flex from `(time to the next key,
/// share of it held, mode, wrist, elbow)`, with control ends when asked (and there are 4 keys
/// or more).
fn random_sequence(keys: &[(f64, f64, usize, f64, f64)], control: bool) -> Sequence {
    const MODES: [&str; 5] = ["step", "linear", "smooth", "cubic", "monotone"];
    let mut time = 0.0;
    let mut text = Vec::new();
    for &(gap, hold, mode, wrist, elbow) in keys {
        text.push(format!(
            r#"{{"time":{time},"hold":{},"interp":"{}","joints":{{"wrist_flex":{wrist},"elbow_flex":{elbow}}}}}"#,
            // `gap` is the time to the next key; a hold leaves at least 1 ms of motion.
            ((gap - 0.001) * hold).max(0.0),
            MODES[mode]
        ));
        time += gap;
    }
    let ends = if control && keys.len() >= 4 {
        r#""ends":"control","#
    } else {
        ""
    };
    let json = format!(
        r#"{{"format":"keypose-sequence/1","robot":"so101",{ends}"keyframes":[{}]}}"#,
        text.join(",")
    );
    Sequence::from_json("random.json", &json).unwrap()
}

fn key() -> impl Strategy<Value = (f64, f64, usize, f64, f64)> {
    (
        prop_oneof![0.002f64..0.02, 0.02f64..0.6],
        prop_oneof![Just(0.0), 0.0f64..0.9],
        0usize..5,
        -90.0f64..90.0,
        -90.0f64..90.0,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The check's peaks bound what the player asks for at every phase of the control period,
    /// and an "ok" means no phase asks for more than the limits.
    #[test]
    fn the_exact_verdict_never_passes_what_the_player_would_break(
        keys in prop::collection::vec(key(), 2..7),
        control in any::<bool>(),
        rate in prop_oneof![Just(10.0), Just(37.0), Just(100.0), Just(250.0), Just(1000.0)],
        offset in 0.0f64..1.0,
        slow in any::<bool>(),
    ) {
        let mut robot = Robot::builtin("so101").unwrap();
        if slow {
            // Loose limits, so that passing reports are common too.
            for joint in &mut robot.joints {
                joint.limits.velocity = 5000.0;
                joint.limits.acceleration = 1e6;
            }
        }
        let sequence = random_sequence(&keys, control);
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, rate);
        let sampled = player_differences::player_extremes(&trajectory, rate, 16, offset);
        player_differences::assert_within_report(&report, &robot, &sampled);
    }

    /// Without steps or corners (smooth modes, from rest to rest), the rate changes nothing.
    #[test]
    fn a_smooth_curves_check_is_the_same_at_every_rate(
        keys in prop::collection::vec(key(), 2..7),
    ) {
        let keys: Vec<_> = keys.into_iter().map(|k| (k.0, k.1, 2 + k.2 % 2, k.3, k.4)).collect();
        let robot = Robot::builtin("so101").unwrap();
        let trajectory = Trajectory::build(&random_sequence(&keys, false), &robot).unwrap();
        let at = |rate: f64| check(&trajectory, &robot, rate);
        let (slow, fast) = (at(10.0), at(1000.0));
        prop_assert_eq!(slow.passed(), fast.passed());
        for (a, b) in slow.joints.iter().zip(&fast.joints) {
            for (x, y) in [
                (a.peak_velocity, b.peak_velocity),
                (a.peak_acceleration, b.peak_acceleration),
                (a.max_position, b.max_position),
            ] {
                prop_assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{:?} vs {:?}", a, b);
            }
        }
    }
}

/// A key of `random_sequence` with the path time and speeds of its segment's profile.
type ProfiledKey = ((f64, f64, usize, f64, f64), f64, Vec<f64>);

/// `random_sequence`'s keys, each segment that moves along a curve given a timing profile of
/// `path_time` and `speeds` (two zeros in a row made 0, 0.2).
fn profiled_sequence(keys: &[ProfiledKey]) -> Sequence {
    let plain: Vec<_> = keys.iter().map(|k| k.0).collect();
    let mut sequence = random_sequence(&plain, false);
    let last = sequence.keyframes.len() - 1;
    for (i, (_, path_time, speeds)) in keys.iter().enumerate() {
        let key = &mut sequence.keyframes[i];
        if i == last || key.interp == Some(keypose::curve::Interp::Step) {
            continue;
        }
        let mut speeds = speeds.clone();
        for k in 1..speeds.len() {
            if speeds[k] == 0.0 && speeds[k - 1] == 0.0 {
                speeds[k] = 0.2;
            }
        }
        key.timing = Some(keypose::sequence::SegmentTiming {
            path_time: *path_time,
            profile: keypose::sequence::TimeProfile::Speeds(speeds),
            hold: None,
        });
    }
    Sequence::from_json("profiled.json", &sequence.to_json()).unwrap()
}

fn profiled_key() -> impl Strategy<Value = ProfiledKey> {
    (
        key(),
        0.01f64..1.0,
        prop::collection::vec(prop_oneof![Just(0.0), 0.05f64..3.0], 2..7),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// With timing profiles (each segment's curve run at a changing path speed, a polynomial
    /// of degree six in time) the check's peaks still bound what the player asks for at every
    /// phase of the control period.
    #[test]
    fn the_exact_verdict_holds_for_timing_profiles(
        keys in prop::collection::vec(profiled_key(), 2..6),
        rate in prop_oneof![Just(10.0), Just(100.0), Just(1000.0)],
        offset in 0.0f64..1.0,
        slow in any::<bool>(),
    ) {
        let mut robot = Robot::builtin("so101").unwrap();
        if slow {
            for joint in &mut robot.joints {
                joint.limits.velocity = 5000.0;
                joint.limits.acceleration = 1e6;
            }
        }
        let sequence = profiled_sequence(&keys);
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, rate);
        let sampled = player_differences::player_extremes(&trajectory, rate, 16, offset);
        player_differences::assert_within_report(&report, &robot, &sampled);
    }
}

/// A key of `random_sequence` with the path time and S-curve shape of its segment's profile.
type SCurveKey = ((f64, f64, usize, f64, f64), f64, [f64; 3]);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// With S-curve profiles (path time a cubic of time on each phase, each joint's curve a
    /// polynomial of degree nine), on segments and on holds, the check's peaks still bound what
    /// the player asks for at every phase of the control period.
    #[test]
    fn the_exact_verdict_holds_for_s_curve_profiles(
        keys in prop::collection::vec(
            (key(), 0.01f64..1.0, (0.01f64..1.0, prop_oneof![Just(0.0), 0.01f64..1.0],
                                   prop_oneof![Just(0.0), 0.01f64..1.0])),
            2..6,
        ),
        rate in prop_oneof![Just(10.0), Just(100.0), Just(1000.0)],
        offset in 0.0f64..1.0,
    ) {
        let keys: Vec<SCurveKey> =
            keys.into_iter().map(|(k, path, (tj, ta, tv))| (k, path, [tj, ta, tv])).collect();
        let plain: Vec<_> = keys.iter().map(|k| k.0).collect();
        let mut sequence = random_sequence(&plain, false);
        let last = sequence.keyframes.len() - 1;
        for (i, (_, path_time, shape)) in keys.iter().enumerate() {
            let key = &mut sequence.keyframes[i];
            if i == last || key.interp == Some(keypose::curve::Interp::Step) {
                continue;
            }
            // A held key runs its hold on the same shape, over 1.5 times its seconds of path
            // time (as `retime --fastest` writes a hold it had to lengthen, the other way).
            let hold = (key.hold > 0.0).then_some(keypose::sequence::HoldTiming {
                path_time: (1.5 * key.hold).max(keypose::sequence::MIN_GAP),
                scurve: *shape,
            });
            key.timing = Some(keypose::sequence::SegmentTiming {
                path_time: *path_time,
                profile: keypose::sequence::TimeProfile::SCurve(*shape),
                hold,
            });
        }
        let sequence = Sequence::from_json("scurve.json", &sequence.to_json()).unwrap();
        let robot = Robot::builtin("so101").unwrap();
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, rate);
        let sampled = player_differences::player_extremes(&trajectory, rate, 16, offset);
        player_differences::assert_within_report(&report, &robot, &sampled);
    }
}
