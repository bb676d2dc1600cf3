//! Jerk limits (`"jerk"` in a robot file's joint limits): the loader's checks, the exact
//! check's jerk and acceleration jumps against hand-derived values, a robot without them
//! checked exactly as before, and S-curve moves against Ruckig (the `ruckig` package in
//! keypose's Python environment, which these tests need: without it they fail).

use crate::common::{run, show, stdout};
use keypose::curve::Interp;
use keypose::plan::{check, Cause, LimitKind, Trajectory};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use serde_json::Value;

use crate::ruckig;

/// The SO-101's robot file with `jerk` set on every joint (None: as it is).
fn so101_text(jerk: Option<&str>) -> String {
    let text = std::fs::read_to_string(crate::common::repo("robots/so101.json")).unwrap();
    let mut robot: Value = serde_json::from_str(&text).unwrap();
    robot["name"] = "so101-jerk".into();
    if let Some(jerk) = jerk {
        for joint in robot["joints"].as_array_mut().unwrap() {
            joint["limits"]["jerk"] = serde_json::from_str(jerk).unwrap();
        }
    }
    serde_json::to_string_pretty(&robot).unwrap()
}

fn so101_with_jerk(jerk: f64) -> Robot {
    Robot::from_json("so101-jerk.json", &so101_text(Some(&jerk.to_string()))).unwrap()
}

/// wrist_flex keys `(time, value)` in `mode`, for the robot file `robot`.
fn wrist(robot: &str, mode: &str, keys: &[(f64, f64)]) -> String {
    let keys: Vec<String> = keys
        .iter()
        .map(|(t, v)| format!(r#"{{"time": {t}, "joints": {{"wrist_flex": {v}}}}}"#))
        .collect();
    format!(
        r#"{{"format": "keypose-sequence/1", "robot": "{robot}", "interpolation": "{mode}",
            "keyframes": [{}]}}"#,
        keys.join(",")
    )
}

fn trajectory(text: &str, robot: &Robot) -> Trajectory {
    let sequence = Sequence::from_json("wrist.json", text).unwrap();
    Trajectory::build(&sequence, robot).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

#[test]
fn a_jerk_limit_is_optional_positive_and_named_in_errors() {
    let robot = Robot::from_json("r.json", &so101_text(None)).unwrap();
    assert!(robot.joints.iter().all(|j| j.limits.jerk.is_none()));
    assert_eq!(so101_with_jerk(2500.0).joints[3].limits.jerk, Some(2500.0));
    for bad in ["0", "-5", "\"fast\"", "1e9"] {
        let err = Robot::from_json("r.json", &so101_text(Some(bad)))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("r.json") && err.contains("limits.jerk"),
            "{bad}: {err}"
        );
    }
}

#[test]
fn a_smoothstep_has_its_constant_jerk_and_jumps_at_both_ends() {
    // 0 → 30° in 2 s, cubic between two keys at rest: 30·(3f² − 2f³), f = t/2. Its
    // acceleration 30·(6 − 12f)/4 goes from 45 to −45 °/s², its jerk is −30·12/8 = −45 °/s³
    // throughout, and the acceleration jumps by +45 °/s² from rest at 0 s and back at 2 s.
    let text = wrist("so101", "cubic", &[(0.0, 0.0), (2.0, 30.0)]);
    for (limit, curve_violations) in [(1000.0, 0), (40.0, 1)] {
        let robot = so101_with_jerk(limit);
        let report = check(&trajectory(&text, &robot), &robot, 50.0);
        let wrist = report
            .joints
            .iter()
            .find(|j| j.joint == "wrist_flex")
            .unwrap();
        assert!(close(wrist.peak_jerk, 45.0), "{wrist:?}");
        assert!(close(wrist.acceleration_jump, 45.0), "{wrist:?}");
        assert_eq!(wrist.jerk_limit, Some(limit));
        let jumps: Vec<_> = report
            .violations
            .iter()
            .filter(|v| v.cause == Cause::AccelerationJump)
            .collect();
        assert_eq!(jumps.len(), 2, "{:?}", report.violations);
        for (v, t) in jumps.iter().zip([0.0, 2.0]) {
            assert_eq!((v.kind, v.joint.as_str()), (LimitKind::Jerk, "wrist_flex"));
            assert!(close(v.peak_time, t), "{v:?}");
            assert!(close(v.acceleration_jump.unwrap(), 45.0), "{v:?}");
            assert!(v.peak.is_infinite() && !v.mendable_by_timing());
        }
        let curve: Vec<_> = report
            .violations
            .iter()
            .filter(|v| v.kind == LimitKind::Jerk && v.cause == Cause::Curve)
            .collect();
        assert_eq!(curve.len(), curve_violations, "{:?}", report.violations);
        if let Some(v) = curve.first() {
            assert!(close(v.peak, -45.0) && close(v.excess, 5.0), "{v:?}");
            assert!(close(v.from, 0.0) && close(v.to, 2.0), "{v:?}");
        }
    }
}

#[test]
fn a_key_of_a_cubic_jumps_by_the_change_of_its_second_derivative() {
    // 0 → 10 → 30° at 0, 1, 2 s with zero end slopes and the central slope (30 − 0)/2 = 15 °/s
    // at the middle key. First segment: 0 + 0·t + c2·t² + c3·t³ with c2 + c3 = 10,
    // 2c2 + 3c3 = 15 → c2 = 15, c3 = −5, so its acceleration at 1 s is 30 − 30 = 0. Second
    // (s = t − 1): 10 + 15s + c2·s² + c3·s³ with 15 + c2 + c3 = 20, 15 + 2c2 + 3c3 = 0 →
    // c2 = 30, c3 = −25, acceleration 60 at the key: a jump of +60 °/s² at 1 s.
    let robot = so101_with_jerk(1e6);
    let text = wrist("so101", "cubic", &[(0.0, 0.0), (1.0, 10.0), (2.0, 30.0)]);
    let report = check(&trajectory(&text, &robot), &robot, 50.0);
    let at_key = report
        .violations
        .iter()
        .find(|v| close(v.peak_time, 1.0))
        .unwrap_or_else(|| panic!("{:?}", report.violations));
    assert_eq!(at_key.cause, Cause::AccelerationJump);
    assert!(close(at_key.acceleration_jump.unwrap(), 60.0), "{at_key:?}");
}

#[test]
fn without_jerk_limits_the_report_is_as_before() {
    // The same sequence on the built-in (no jerk limits): no jerk violation, no jerk column.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wrist.json");
    std::fs::write(&path, wrist("so101", "cubic", &[(0.0, 0.0), (2.0, 30.0)])).unwrap();
    let out = run(&["check", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(!stdout(&out).contains("jerk"), "{}", show(&out));
}

#[test]
fn check_names_each_acceleration_jump_with_its_time_and_size() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("robot.json"), so101_text(Some("500"))).unwrap();
    let path = dir.path().join("wrist.json");
    let text = wrist("./robot.json", "cubic", &[(0.0, 0.0), (2.0, 30.0)]);
    std::fs::write(&path, text).unwrap();
    let out = run(&["check", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let text = stdout(&out);
    assert!(
        text.contains("t = 0.000 s: the acceleration jumps by 45.000 deg/s², an infinite jerk (limit 500.000 deg/s³)"),
        "{}",
        show(&out)
    );
    assert!(text.contains("peak jerk"), "{text}");
    let out = run(&["check", path.to_str().unwrap(), "--format", "json"]);
    let report: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let wrist = report["joints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["joint"] == "wrist_flex")
        .unwrap();
    assert_eq!(wrist["jerk_limit"], 500.0);
    assert!(close(wrist["peak_jerk"].as_f64().unwrap(), 45.0));
    let jumps: Vec<&Value> = report["violations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|v| v["cause"] == "jump")
        .collect();
    assert_eq!(jumps.len(), 2, "{report}");
    assert_eq!(jumps[0]["kind"], "jerk");
    assert!(close(jumps[0]["acceleration_jump"].as_f64().unwrap(), 45.0));
}

/// keypose's Python environment (with ruckig): these tests fail without it.
fn python() -> std::path::PathBuf {
    keypose::python::PyConfig::with_cache_dir(crate::common::python_cache())
        .ensure_python()
        .unwrap_or_else(|e| panic!("keypose's Python environment (with ruckig) is needed: {e}"))
        .python
}

/// `robot` moving every joint from `from` to `to` on a linear segment of `seconds`.
fn point_to_point_sequence(robot: &Robot, from: &[f64], to: &[f64], seconds: f64) -> Sequence {
    let key = |time: f64, values: &[f64]| {
        let joints: Vec<String> = robot
            .joints
            .iter()
            .zip(values)
            .map(|(j, v)| format!("\"{}\": {v}", j.name))
            .collect();
        format!(r#"{{"time": {time}, "joints": {{{}}}}}"#, joints.join(", "))
    };
    let text = format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "linear",
            "keyframes": [{}, {}]}}"#,
        key(0.0, from),
        key(seconds, to)
    );
    Sequence::from_json("p2p.json", &text).unwrap()
}

/// Rest-to-rest moves of the SO-101: one joint far, one joint a little (it never reaches its
/// acceleration limit), several joints by different amounts, all of them.
fn so101_moves() -> Vec<(Vec<f64>, Vec<f64>)> {
    let zero = vec![0.0; 6];
    let with = |changes: &[(usize, f64)]| {
        let mut pose = zero.clone();
        for &(j, v) in changes {
            pose[j] = v;
        }
        pose
    };
    vec![
        (zero.clone(), with(&[(3, 90.0)])),
        (zero.clone(), with(&[(3, 2.0)])),
        (zero.clone(), with(&[(3, 25.0)])),
        (
            with(&[(0, -60.0)]),
            with(&[(0, 45.0), (1, 30.0), (2, -10.0)]),
        ),
        (
            with(&[
                (0, 10.0),
                (1, -20.0),
                (2, 30.0),
                (3, -40.0),
                (4, 50.0),
                (5, 5.0),
            ]),
            with(&[
                (0, -80.0),
                (1, 60.0),
                (2, -50.0),
                (3, 30.0),
                (4, -90.0),
                (5, 60.0),
            ]),
        ),
    ]
}

#[test]
fn the_s_curve_of_one_joint_takes_ruckigs_time() {
    // One axis from rest to rest: the closed form against Ruckig's time-optimal profile, in
    // each of its cases (a cruise at the velocity limit, the acceleration limit reached or not).
    let cases: Vec<(f64, f64, f64, f64)> = vec![
        (200.0, 100.0, 400.0, 4000.0),
        (30.0, 100.0, 400.0, 4000.0),
        (1.0, 100.0, 400.0, 4000.0),
        (90.0, 115.0, 344.0, 3440.0),
        (0.05, 0.0333, 0.103, 1.03),
        (500.0, 370.0, 1146.0, 500.0),
    ];
    let moves: Vec<Value> = cases
        .iter()
        .map(|&(d, v, a, j)| {
            serde_json::json!({"from": [0.0], "to": [d], "vlim": [v], "alim": [a], "jlim": [j],
                               "sync": "time"})
        })
        .collect();
    let (theirs, _) = ruckig::ruckig_durations(&python(), &moves).unwrap();
    for (&(d, v, a, j), theirs) in cases.iter().zip(theirs) {
        let limits = keypose::plan::scurve::JerkLimits {
            velocity: v,
            acceleration: a,
            jerk: j,
        };
        let ours = keypose::plan::scurve::SCurve::fastest(d, limits).duration();
        assert!(
            (ours / theirs - 1.0).abs() < 1e-6,
            "{d} under {limits:?}: {ours} s against Ruckig's {theirs} s"
        );
    }
}

#[test]
fn a_point_to_point_move_under_jerk_limits_is_within_five_percent_of_ruckig() {
    // `retime --fastest` of a linear segment between two poses at rest, for the SO-101 with a
    // jerk limit of ten times its acceleration limit per second: the move passes the exact
    // check with jerk, and lasts no less than Ruckig's time-optimal move under the same limits
    // and at most 5 % more (Ruckig's default synchronisation: each joint its own profile,
    // ending together). Along the straight line (Ruckig's phase synchronisation), it is the
    // same move: the same time to the planning share and key-time rounding.
    let robot = so101_with_jerk(3440.0);
    let moves = so101_moves();
    let request = |sync| -> Vec<Value> {
        moves
            .iter()
            .map(|(from, to)| ruckig::move_request(&robot, from, to, sync))
            .collect()
    };
    let python = python();
    let (time_sync, _) = ruckig::ruckig_durations(&python, &request(ruckig::Sync::Time)).unwrap();
    let (phase_sync, _) = ruckig::ruckig_durations(&python, &request(ruckig::Sync::Phase)).unwrap();
    for (k, (from, to)) in moves.iter().enumerate() {
        let sequence = point_to_point_sequence(&robot, from, to, 5.0);
        let outcome = keypose::plan::fastest(&sequence, &robot, 50.0).unwrap();
        assert!(
            outcome.report.passed(),
            "{k}: {:?}",
            outcome.report.violations
        );
        let times = outcome.sequence.key_times();
        let ours = times[1] - times[0];
        assert!(
            ours >= time_sync[k] && ours <= 1.05 * time_sync[k],
            "move {k}: {ours} s against Ruckig's {} s",
            time_sync[k]
        );
        assert!(
            ours >= phase_sync[k] && ours <= 1.002 * phase_sync[k],
            "move {k}: {ours} s against Ruckig's {} s along the line",
            phase_sync[k]
        );
        // The library's point-to-point move (the approach ramp's) is the same S-curve.
        let direct = keypose::plan::scurve::point_to_point(&robot, from, to, 1.0).unwrap();
        assert!((direct.duration() / phase_sync[k] - 1.0).abs() < 1e-6);
    }
}

/// The commanded positions of joint `joint` every `dt` seconds until the timeline ends; a stop
/// is requested once it has run `stop_at` seconds.
fn play(timeline: &mut keypose::plan::Timeline, joint: usize, dt: f64, stop_at: f64) -> Vec<f64> {
    let mut out = vec![0.0; 6];
    let mut positions = Vec::new();
    let mut t = 0.0;
    while timeline.sample_into(&mut out).is_some() {
        positions.push(out[joint]);
        if t >= stop_at && t - dt < stop_at {
            timeline.request_stop();
        }
        timeline.advance(dt);
        t += dt;
    }
    positions
}

/// The largest |second| and |third| differences of `p` over `dt`: a piecewise-cubic curve's
/// are averages of its acceleration and jerk, so they never exceed the curve's peaks.
fn peak_differences(p: &[f64], dt: f64) -> (f64, f64) {
    let second = p
        .windows(3)
        .map(|w| ((w[2] - 2.0 * w[1] + w[0]) / (dt * dt)).abs())
        .fold(0.0, f64::max);
    let third = p
        .windows(4)
        .map(|w| ((w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]) / (dt * dt * dt)).abs())
        .fold(0.0, f64::max);
    (second, third)
}

#[test]
fn the_approach_ramp_under_jerk_limits_is_ruckigs_straight_line_at_half_the_limits() {
    let robot = so101_with_jerk(3440.0);
    let (from, to) = so101_moves().swap_remove(4);
    let sequence = point_to_point_sequence(&robot, &to, &to, 1.0);
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    let options = keypose::plan::TimelineOptions::default();
    let timeline = keypose::plan::Timeline::new(&robot, &trajectory, &options, &from);
    let mut halved = robot.clone();
    for joint in &mut halved.joints {
        joint.limits.velocity *= 0.5;
        joint.limits.acceleration *= 0.5;
        joint.limits.jerk = joint.limits.jerk.map(|j| 0.5 * j);
    }
    let request = [ruckig::move_request(
        &halved,
        &from,
        &to,
        ruckig::Sync::Phase,
    )];
    let (theirs, _) = ruckig::ruckig_durations(&python(), &request).unwrap();
    assert!(
        (timeline.approach_seconds() / theirs[0] - 1.0).abs() < 1e-9,
        "{} s against Ruckig's {} s",
        timeline.approach_seconds(),
        theirs[0]
    );
    // Sampled at 1 kHz: within half of every limit, and it arrives.
    for (j, &end) in to.iter().enumerate() {
        let mut timeline = keypose::plan::Timeline::new(&robot, &trajectory, &options, &from);
        let p = play(&mut timeline, j, 1e-3, f64::INFINITY);
        let (acceleration, jerk) = peak_differences(&p, 1e-3);
        assert!(acceleration <= 172.0 * (1.0 + 1e-6), "{j}: {acceleration}");
        assert!(jerk <= 1720.0 * (1.0 + 1e-6), "{j}: {jerk}");
        assert!((p[p.len() - 1] - end).abs() < 1e-9);
    }
}

#[test]
fn a_soft_stop_under_jerk_limits_brakes_along_the_path_without_an_acceleration_jump() {
    // The wrist's S-curve from −90 to 90° (its cruise at 115 °/s from 0.43 to 1.57 s), stopped
    // at 0.5 s and sampled at 1 kHz: braking lowers the rate along the first half of an S-curve
    // whose rate of change is within 172/115 /s and its change within 1720/115 /s², which
    // lasts 0.1 + 0.567 + 0.1 s (before the path's own deceleration). It keeps within half the
    // acceleration and jerk limits (the path's own are 0 in the cruise), and stays on the path.
    // The same stop without jerk limits lowers the rate linearly: the acceleration jumps where
    // it starts, which the third difference shows.
    let (from, to) = (
        [0.0, 0.0, 0.0, -90.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 90.0, 0.0, 0.0],
    );
    for (robot, jerk_limited) in [
        (so101_with_jerk(3440.0), true),
        (so101_with_jerk(1e7), false),
    ] {
        let robot = if jerk_limited {
            robot
        } else {
            let mut plain = robot;
            plain.joints.iter_mut().for_each(|j| j.limits.jerk = None);
            plain
        };
        let planner = so101_with_jerk(3440.0);
        let sequence = point_to_point_sequence(&planner, &from, &to, 5.0);
        let timed = keypose::plan::fastest(&sequence, &planner, 50.0).unwrap();
        let trajectory = Trajectory::build(&timed.sequence, &robot).unwrap();
        let options = keypose::plan::TimelineOptions {
            approach: false,
            ..Default::default()
        };
        let mut timeline = keypose::plan::Timeline::new(&robot, &trajectory, &options, &from);
        let p = play(&mut timeline, 3, 1e-3, 0.5);
        assert!(timeline.stopped());
        let end = p[p.len() - 1];
        assert!(end < 90.0, "{end}");
        assert!(p.windows(2).all(|w| w[1] >= w[0]), "it never turns back");
        let (acceleration, jerk) = peak_differences(&p[490..], 1e-3);
        if jerk_limited {
            // Cruising at 0.999 · 115 °/s (the planning share): tj = 0.1 s and
            // ta = 114.885/172 − 0.1 = 0.5679 s.
            let braking = (p.len() - 501) as f64 * 1e-3;
            assert!((braking - 0.7679).abs() < 2e-3, "{braking}");
            assert!(acceleration <= 172.0 * (1.0 + 1e-6), "{acceleration}");
            assert!(jerk <= 1720.0 * (1.0 + 1e-6), "{jerk}");
        } else {
            assert!(jerk > 50_000.0, "{jerk}");
        }
    }
}

#[test]
fn fastest_with_jerk_limits_writes_s_curves_that_pass_the_check_with_jerk() {
    // The SO-101 wave (cubic keys) for an SO-101 with jerk limits: through the binary, every
    // moving segment gets an S-curve profile, the file checks clean (jerk and acceleration
    // jumps included), and the stretch-only retime cannot mend the jumps at its keys.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("robot.json"), so101_text(Some("3440"))).unwrap();
    let wave = std::fs::read_to_string(crate::common::repo("sequences/so101_wave.json")).unwrap();
    let mut wave: Value = serde_json::from_str(&wave).unwrap();
    wave["robot"] = "./robot.json".into();
    // The wave as the key-time cubic it was first written in: its acceleration jumps at keys.
    wave["interpolation"] = "cubic".into();
    let path = dir.path().join("wave.json");
    std::fs::write(&path, wave.to_string()).unwrap();
    let out_path = dir.path().join("fast.json");
    let (input, output) = (path.to_str().unwrap(), out_path.to_str().unwrap());
    let out = run(&["retime", "--fastest", input, "-o", output]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let out = run(&["check", output]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let timed = Sequence::load(&out_path).unwrap();
    let profiled = timed
        .keyframes
        .iter()
        .filter(|k| {
            matches!(
                k.timing.as_ref().map(|t| &t.profile),
                Some(keypose::sequence::TimeProfile::SCurve(_))
            )
        })
        .count();
    assert_eq!(profiled, timed.keyframes.len() - 1);
    let out = run(&["check", input]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let out = run(&["retime", input, "-o", output]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert!(
        crate::common::stderr(&out).contains("use smooth interpolation")
            && crate::common::stderr(&out).contains("or retime --fastest"),
        "{}",
        show(&out)
    );
    // play and export refuse it with the same advice, not a plain retime that cannot mend it
    // (nothing is sent: the refusal comes before the port is opened).
    let yaml = dir.path().join("wave.yaml");
    for args in [
        vec!["play", input, "--port", "/dev/null/no-such-port"],
        vec!["export", "ros2", input, "-o", yaml.to_str().unwrap()],
    ] {
        let out = run(&args);
        let err = crate::common::stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{}", show(&out));
        assert!(
            err.contains("use smooth interpolation") && err.contains("or retime --fastest"),
            "{}",
            show(&out)
        );
        assert!(!err.contains("try `keypose retime`"), "{}", show(&out));
    }
}

#[test]
fn an_s_curve_profile_in_a_file_is_checked_for_its_shape() {
    let with_timing = |timing: &str| {
        format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
              {{"time": 0, "timing": {timing}, "joints": {{"wrist_flex": 0}}}},
              {{"time": 1, "joints": {{"wrist_flex": 9}}}}]}}"#
        )
    };
    let ok = Sequence::from_json(
        "s.json",
        &with_timing(r#"{"path_time": 1, "scurve": [0.1, 0, 0.2]}"#),
    );
    assert!(ok.is_ok(), "{ok:?}");
    for (timing, expected) in [
        (
            r#"{"path_time": 1, "scurve": [0, 0.1, 0.2]}"#,
            "seconds above 0",
        ),
        (
            r#"{"path_time": 1, "scurve": [0.1, -1, 0.2]}"#,
            "seconds 0 or more",
        ),
        (
            r#"{"path_time": 1, "scurve": [0.1, 0.2]}"#,
            "three numbers; found 2",
        ),
        (
            r#"{"path_time": 1, "scurve": [0.1, 0, 0], "speeds": [1, 1]}"#,
            "expected one profile",
        ),
    ] {
        let err = Sequence::from_json("s.json", &with_timing(timing))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("$.keyframes[0].timing") && err.contains(expected),
            "{timing}: {err}"
        );
    }
}

/// Cubic keys on wrist_flex and elbow_flex, `(seconds to the next key, wrist, elbow, S-curve
/// shape of the segment after it)`.
fn s_curve_keys(keys: &[(f64, f64, f64, [f64; 3])]) -> Sequence {
    let mut time = 0.0;
    let mut text = Vec::new();
    for (i, &(gap, wrist, elbow, shape)) in keys.iter().enumerate() {
        let timing = if i + 1 < keys.len() {
            format!(r#""timing": {{"path_time": {gap}, "scurve": {shape:?}}},"#)
        } else {
            String::new()
        };
        text.push(format!(
            r#"{{"time": {time}, {timing} "joints": {{"wrist_flex": {wrist}, "elbow_flex": {elbow}}}}}"#
        ));
        time += gap;
    }
    let json = format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{}]}}"#,
        text.join(",")
    );
    Sequence::from_json("scurve.json", &json).unwrap()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

    /// Cubic keys run along S-curves: the check's peak velocity, acceleration and jerk are the
    /// curve's, sampled every 0.1 ms by finite differences of `Trajectory::sample` (which knows
    /// nothing of the check's polynomials of degree nine), from above and from below; and the
    /// acceleration never jumps, since each S-curve is at rest at its keys.
    #[test]
    fn the_checks_jerk_is_the_sampled_curves(
        keys in proptest::collection::vec(
            (0.2f64..1.0, -90.0f64..90.0, -90.0f64..90.0,
             (0.05f64..1.0, 0.0f64..1.0, 0.0f64..1.0)),
            2..5,
        ),
    ) {
        let keys: Vec<_> = keys.into_iter().map(|(g, w, e, (a, b, c))| (g, w, e, [a, b, c])).collect();
        let robot = so101_with_jerk(1e7);
        let trajectory = Trajectory::build(&s_curve_keys(&keys), &robot).unwrap();
        let report = check(&trajectory, &robot, 100.0);
        let h = 1e-4;
        let n = ((trajectory.end - trajectory.start) / h).ceil() as usize;
        let samples: Vec<Vec<f64>> = (0..=n + 3)
            .map(|k| trajectory.sample(trajectory.start + (k as f64 - 1.0) * h))
            .collect();
        for name in ["wrist_flex", "elbow_flex"] {
            let j = robot.joint_index(name).unwrap();
            let p: Vec<f64> = samples.iter().map(|s| s[j]).collect();
            let velocity = p
                .windows(2)
                .map(|w| ((w[1] - w[0]) / h).abs())
                .fold(0.0, f64::max);
            let (acceleration, jerk) = peak_differences(&p, h);
            let summary = report.joints.iter().find(|s| s.joint == name).unwrap();
            // A k-th difference of samples is off by up to 2^k times a sample's own error, over
            // h^k. A sample is a polynomial evaluated in a few steps, not one rounding: up to
            // a few units in the last place of the largest value (a failing case measured 1.5;
            // 4 are allowed: 0.24 °/s³ on a jerk of 3575 at h = 0.1 ms).
            let largest = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let rounding = |k: i32| 2f64.powi(k) * 4.0 * f64::EPSILON * largest / h.powi(k);
            for (what, sampled, reported, below, k) in [
                ("velocity", velocity, summary.peak_velocity, 1e-3, 1),
                ("acceleration", acceleration, summary.peak_acceleration, 1e-2, 2),
                ("jerk", jerk, summary.peak_jerk, 3e-2, 3),
            ] {
                proptest::prop_assert!(
                    sampled <= reported * (1.0 + 1e-6) + 1e-6 + rounding(k)
                        && sampled >= reported * (1.0 - below) - 1e-6 - rounding(k),
                    "{name} {what}: sampled {sampled}, reported {reported}"
                );
            }
            proptest::prop_assert!(
                summary.acceleration_jump <= 1e-6 * (1.0 + summary.peak_acceleration),
                "{summary:?}"
            );
        }
    }
}

#[test]
fn at_another_speed_jerk_scales_with_its_cube_and_a_jump_with_its_square() {
    // The smoothstep above (jerk −45 °/s³, jumps of 45 °/s²) played at half and at double
    // speed: what the servos see is S³ times the jerk and S² times each jump, against the
    // robot's own limit of 100 °/s³.
    let robot = so101_with_jerk(100.0);
    let trajectory = trajectory(&wrist("so101", "cubic", &[(0.0, 0.0), (2.0, 30.0)]), &robot);
    for (speed, curve_violations) in [(0.5, 0), (2.0, 1)] {
        let report = keypose::plan::check_at_speed(&trajectory, &robot, 50.0, speed);
        let wrist = report
            .joints
            .iter()
            .find(|j| j.joint == "wrist_flex")
            .unwrap();
        assert!(
            close(wrist.peak_jerk, 45.0 * speed * speed * speed),
            "{wrist:?}"
        );
        assert!(
            close(wrist.acceleration_jump, 45.0 * speed * speed),
            "{wrist:?}"
        );
        assert_eq!(wrist.jerk_limit, Some(100.0));
        let jerks: Vec<_> = report
            .violations
            .iter()
            .filter(|v| v.kind == LimitKind::Jerk)
            .collect();
        assert_eq!(jerks.len(), 2 + curve_violations, "{jerks:?}");
        for v in jerks {
            match v.acceleration_jump {
                Some(jump) => assert!(close(jump, 45.0 * speed * speed), "{v:?}"),
                None => assert!(close(v.peak, -360.0) && close(v.limit, -100.0), "{v:?}"),
            }
        }
    }
}

/// The wrist from −90° to 90° on a linear segment, retimed `--fastest` (an S-curve with a
/// cruise of more than a second), and the pose it starts from.
fn wrist_across(robot: &Robot) -> (Trajectory, [f64; 6]) {
    let (from, to) = (
        [0.0, 0.0, 0.0, -90.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 90.0, 0.0, 0.0],
    );
    let sequence = point_to_point_sequence(robot, &from, &to, 5.0);
    let timed = keypose::plan::fastest(&sequence, robot, 50.0).unwrap();
    (Trajectory::build(&timed.sequence, robot).unwrap(), from)
}

/// Playback from the first pose, without the approach ramp.
fn no_approach() -> keypose::plan::TimelineOptions {
    keypose::plan::TimelineOptions {
        approach: false,
        ..Default::default()
    }
}

/// A stall while the path itself accelerates harder than the wrist's (here lowered) limit
/// leaves room for: no climb fits, so the factor holds at the stall's 0.5 until the path's
/// acceleration eases, and never jumps. Before, a climb planned at a rate of 0 came out as
/// NaN and the factor went straight back to 1 in one cycle.
#[test]
fn a_stall_with_no_room_to_climb_holds_the_rate_until_there_is_room() {
    let robot = so101_with_jerk(3440.0);
    let (trajectory, from) = wrist_across(&robot);
    // The wrist accelerates at up to 344 deg/s² at the full rate; at half the rate the path
    // asks a quarter of that, over the 43 deg/s² this robot allows it.
    let mut tight = robot.clone();
    tight.joints[3].limits.acceleration = 344.0 / 8.0;
    let mut timeline = keypose::plan::Timeline::new(&tight, &trajectory, &no_approach(), &from);
    let (dt, stall) = (1e-3, 150);
    let mut taus = Vec::new();
    let mut out = vec![0.0; 6];
    for k in 0..400 {
        timeline.sample_into(&mut out).unwrap();
        taus.push(timeline.sequence_time());
        if k == stall {
            timeline.after_stall(0.5);
        }
        timeline.advance(dt);
    }
    let factors: Vec<f64> = taus.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
    assert!((factors[stall] - 0.5).abs() < 1e-9, "{}", factors[stall]);
    assert!(
        (factors[stall + 1] - 0.5).abs() < 1e-9,
        "no room: the factor holds, {}",
        factors[stall + 1]
    );
    let largest = factors[stall..]
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0f64, f64::max);
    assert!(largest < 0.05, "the factor rose by {largest} in one cycle");
}

#[test]
fn a_stall_while_braking_under_jerk_limits_never_speeds_the_arm_up_again() {
    // Braking from the wrist's cruise as above; 0.2 s into it the process stalls and the path
    // was followed at half the rate meanwhile (`after_stall(0.5)`): the next step is half the
    // one before, every later step is no longer than the one before it, and the arm still
    // comes to rest.
    let robot = so101_with_jerk(3440.0);
    let (trajectory, from) = wrist_across(&robot);
    let mut timeline = keypose::plan::Timeline::new(&robot, &trajectory, &no_approach(), &from);
    let (dt, mut out, mut p) = (1e-3, vec![0.0; 6], Vec::new());
    let mut k = 0;
    while timeline.sample_into(&mut out).is_some() {
        p.push(out[3]);
        match k {
            500 => timeline.request_stop(),
            700 => timeline.after_stall(0.5),
            _ => {}
        }
        timeline.advance(dt);
        k += 1;
    }
    assert!(timeline.stopped() && p.len() > 702);
    let steps: Vec<f64> = p.windows(2).map(|w| w[1] - w[0]).collect();
    // The stall halves the rate braking had reached, and it never climbs back.
    assert!(
        steps[700] <= 0.5 * steps[699] * (1.0 + 1e-9) && steps[700] > 0.4 * steps[699],
        "{} after {}",
        steps[700],
        steps[699]
    );
    assert!(
        steps[505..].windows(2).all(|w| w[1] <= w[0] + 1e-12),
        "a step grew while braking"
    );
}

/// The largest `|Δⁿp| / hⁿ` of `p` sampled every `h` seconds, for n = 1, 2, 3: by the mean
/// value theorem no more than the curve's peak velocity, acceleration and jerk where the
/// derivative below is continuous, and an acceleration jump J shows in the third as up to
/// 0.75·J/h (the quadratic B-spline's peak, over which a third difference averages the jerk).
fn difference_peaks(p: &[f64], h: f64) -> [f64; 3] {
    let mut d = p.to_vec();
    let mut out = [0.0; 3];
    for peak in &mut out {
        d = d.windows(2).map(|w| (w[1] - w[0]) / h).collect();
        *peak = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    }
    out
}

/// Every example of sequences/, retimed `--fastest` for its robot with the bench's jerk limits
/// (each joint's acceleration limit reached in 0.1 s, docs/robots.md §5a), passes the exact
/// check with jerk, as written to a file and read back; keeps its keys (names, poses,
/// interpolation, tool keys and lines) and its holds (each as long, or longer where the outcome
/// says it had to be), and reaches the same pose at every key and hold end; and, sampled at
/// 1 kHz, no finite difference of any order is above its limit. On main at
/// 7fb3f6d six of the nine kept violations (bimanual_wave 12, koch_wave 8, omx_reach 25,
/// so100_wave 14, so101-tool-line 745, so101_pick_place 40): holds through which a joint
/// without a key there moved at pace 1 between S-curves at rest, and the tool line's samples
/// joined with an acceleration jump at each.
#[test]
fn fastest_with_jerk_limits_passes_the_check_with_jerk_on_every_example() {
    let examples = crate::common::examples();
    assert!(examples.len() >= 9, "{examples:?}");
    for example in &examples {
        let name = example.file_name().unwrap().to_string_lossy();
        let sequence = Sequence::load(example).unwrap();
        let robot = ruckig::with_jerk(
            &keypose::plan::builtin_robot_of(&sequence).unwrap(),
            ruckig::RISE_SECONDS,
        );
        let outcome = keypose::plan::fastest(&sequence, &robot, robot.control_hz).unwrap();
        let timed = Sequence::from_json("timed.json", &outcome.sequence.to_json()).unwrap();
        let after = Trajectory::build(&timed, &robot).unwrap();
        let report = check(&after, &robot, robot.control_hz);
        assert!(report.passed(), "{name}: {:#?}", report.violations);

        assert_eq!(timed.keyframes.len(), sequence.keyframes.len(), "{name}");
        for (k, (x, y)) in sequence.keyframes.iter().zip(&timed.keyframes).enumerate() {
            assert_eq!(
                (&x.name, &x.values, x.interp, x.line),
                (&y.name, &y.values, y.interp, y.line),
                "{name}"
            );
            // A hold lasts as long, or longer where the outcome says so.
            let longer = outcome.holds.iter().find(|h| h.0 == k);
            match longer {
                None => assert_eq!(x.hold, y.hold, "{name}: key {k}"),
                Some(&(_, before, after)) => {
                    assert!(
                        before == x.hold && after == y.hold && after > before,
                        "{name}"
                    )
                }
            }
            assert_eq!(
                (format!("{:?}", x.tool), format!("{:?}", x.arm_tools)),
                (format!("{:?}", y.tool), format!("{:?}", y.arm_tools)),
                "{name}"
            );
        }
        let before = Trajectory::build(&sequence, &robot).unwrap();
        let (b, a) = (sequence.key_times(), timed.key_times());
        for (k, (x, y)) in sequence.keyframes.iter().zip(&timed.keyframes).enumerate() {
            for (tb, ta) in [(b[k], a[k]), (b[k] + x.hold, a[k] + y.hold)] {
                let (p, q) = (before.sample(tb), after.sample(ta));
                for (x, y) in p.iter().zip(&q) {
                    assert!((x - y).abs() < 1e-6, "{name}: key {k}: {p:?} vs {q:?}");
                }
            }
        }
        for line in &after.tools.lines {
            assert!(line.problem.is_none(), "{name}: {line:?}");
        }

        assert_differences_within_limits(&name, &after, &robot);
    }
}

/// Sampled at 1 kHz, no finite difference of `trajectory` of any order (velocity,
/// acceleration, jerk: [`difference_peaks`]) is above `robot`'s limit.
fn assert_differences_within_limits(name: &str, trajectory: &Trajectory, robot: &Robot) {
    let h = 1e-3;
    let samples: Vec<Vec<f64>> = trajectory
        .grid(1.0 / h)
        .map(|t| trajectory.sample(t))
        .collect();
    for (j, joint) in robot.joints.iter().enumerate() {
        let p: Vec<f64> = samples.iter().map(|s| s[j]).collect();
        let [v, acc, jerk] = difference_peaks(&p, h);
        let l = &joint.limits;
        let within = |peak: f64, limit: f64| peak <= limit * (1.0 + 1e-6) + 1e-6;
        assert!(within(v, l.velocity), "{name} {}: {v} deg/s", joint.name);
        assert!(within(acc, l.acceleration), "{name} {}: {acc}", joint.name);
        assert!(
            within(jerk, l.jerk.unwrap()),
            "{name} {}: {jerk}",
            joint.name
        );
    }
}

/// Every example of sequences/ but two is smooth, and as written, with no retiming, passes the
/// exact check under the same jerk limits (docs/robots.md §5a): nothing in it changes an
/// acceleration at once. Sampled at 1 kHz, no finite difference of any order is above its
/// limit. And one peak by hand: the Koch gripper closes 60° from rest to rest in 0.8 s, the
/// minimum-jerk quintic, whose jerk peaks at its ends at 60·Δ/T³ = 7 031.25 °/s³.
/// The two: the sweep is a key-time cubic on purpose (its control keys' mirror gives zero slope
/// at the played ends; like a pendulum's swing it starts at full acceleration, which no jerk
/// limit passes); the tool line stays monotone until `retime --fastest` times a smooth line's
/// start as well as TOPP-RA does (smooth, 1.990 s against TOPP-RA's 1.743 s on the same path,
/// where monotone is 1.779 against 1.757). Their accelerations jump at their keys, and the
/// check says so there and only there.
#[test]
fn every_smooth_example_passes_the_check_with_jerk_as_written() {
    for example in &crate::common::examples() {
        let name = example.file_name().unwrap().to_string_lossy().to_string();
        let sequence = Sequence::load(example).unwrap();
        let robot = ruckig::with_jerk(
            &keypose::plan::builtin_robot_of(&sequence).unwrap(),
            ruckig::RISE_SECONDS,
        );
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, robot.control_hz);
        let not_smooth = [
            ("so101_sweep_control.json", Interp::Cubic),
            ("so101-tool-line.json", Interp::Monotone),
        ];
        if let Some(&(_, mode)) = not_smooth.iter().find(|(n, _)| *n == name) {
            assert_eq!(sequence.interpolation, mode, "{name}");
            assert!(!report.violations.is_empty());
            let keys = sequence.key_times();
            for v in &report.violations {
                let at_key = keys.iter().any(|&t| (v.peak_time - t).abs() < 1e-9);
                assert!(
                    v.kind == LimitKind::Jerk && v.acceleration_jump.is_some() && at_key,
                    "{name}: {v:?}"
                );
            }
            continue;
        }
        assert_eq!(sequence.interpolation, Interp::Smooth, "{name}");
        assert!(report.passed(), "{name}: {:#?}", report.violations);
        assert_differences_within_limits(&name, &trajectory, &robot);
        if name == "koch_wave.json" {
            let gripper = robot
                .joints
                .iter()
                .position(|j| j.name == "gripper")
                .unwrap();
            let peak = report.joints[gripper].peak_jerk;
            assert!((peak - 60.0 * 60.0 / 0.512).abs() < 1e-6, "{peak}");
        }
    }
}

/// A hold through which a joint without a key there keeps moving: wrist_flex rests at 30°
/// at key 1 while elbow_flex, keyed only at the ends, goes on along its cubic. The elbow's
/// track is the smoothstep 0 → 60° over the path's 3 s (plus the hold), 60·(3x² − 2x³) with
/// x = u/T, so where the hold starts (path time 1) and ends (path time 1 + hold) it is at
/// values worked out by hand. `--fastest` under jerk limits runs the hold on an S-curve of its
/// own from rest to rest, over the same path time: the wrist stays at 30° throughout, the elbow
/// is at rest at both ends of the hold and at its hand-worked values there, and everything
/// passes the exact check with jerk. A hold of 1 s keeps its seconds; one of 0.5 s is too short
/// for the elbow (at 27 deg/s or more along the path there) to stop and start again within
/// 3440 deg/s³ — a rest-to-rest move of T seconds needs a path jerk of 32/T² per path second
/// at least, 128 /s³ at 0.5 s, over 3440/27 — so it is lengthened, and said so. On main at
/// 7fb3f6d the hold ran at pace 1 between S-curves at rest: the elbow's velocity jumped at
/// both its ends.
#[test]
fn a_hold_through_which_an_unkeyed_joint_moves_runs_on_an_s_curve_of_its_own() {
    let robot = so101_with_jerk(3440.0);
    for (hold, kept) in [(1.0, true), (0.5, false)] {
        let text = format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [
              {{"time": 0, "joints": {{"shoulder_lift": -90, "elbow_flex": 0, "wrist_flex": 0}}}},
              {{"time": 1, "hold": {hold}, "joints": {{"wrist_flex": 30}}}},
              {{"time": {}, "joints": {{"elbow_flex": 60, "wrist_flex": 0}}}}]}}"#,
            3.0 + hold
        );
        let sequence = Sequence::from_json("hold.json", &text).unwrap();
        let outcome = keypose::plan::fastest(&sequence, &robot, 100.0).unwrap();
        assert!(outcome.report.passed(), "{:#?}", outcome.report.violations);
        let timed = Sequence::from_json("timed.json", &outcome.sequence.to_json()).unwrap();
        let timing = timed.keyframes[1].timing.as_ref().unwrap();
        assert_eq!(timing.hold.unwrap().path_time, hold, "{timing:?}");
        let seconds = timed.keyframes[1].hold;
        if kept {
            assert_eq!(seconds, hold);
            assert!(outcome.holds.is_empty(), "{:?}", outcome.holds);
        } else {
            assert!(seconds > hold, "{seconds}");
            assert_eq!(outcome.holds, vec![(1, hold, seconds)]);
        }
        let trajectory = Trajectory::build(&timed, &robot).unwrap();
        let (elbow, wrist) = (2, 3);
        let start = timed.key_times()[1];
        let at = |t: f64| trajectory.sample(t);
        let smoothstep = |u: f64| {
            let x = u / (3.0 + hold);
            60.0 * x * x * (3.0 - 2.0 * x)
        };
        assert!(
            (at(start)[elbow] - smoothstep(1.0)).abs() < 1e-9,
            "{:?}",
            at(start)
        );
        let end = start + seconds;
        assert!(
            (at(end)[elbow] - smoothstep(1.0 + hold)).abs() < 1e-9,
            "{:?}",
            at(end)
        );
        for k in 0..=100 {
            let t = start + seconds * k as f64 / 100.0;
            assert!((at(t)[wrist] - 30.0).abs() < 1e-12, "{t}: {:?}", at(t));
        }
        // At rest at both ends: a microsecond in, the elbow has moved by no more than the
        // rounding of its value (at 27 deg/s it would move 27 µdeg).
        let h = 1e-6;
        for (from, to) in [(start, start + h), (end - h, end)] {
            let moved = (at(to)[elbow] - at(from)[elbow]).abs();
            assert!(moved < 1e-12, "{moved}");
        }
        assert!(check(&trajectory, &robot, 100.0).passed());
        // Timed again for the SO-101 without jerk limits, the hold keeps its S-curve (and its
        // path time), and the speed profiles beside it stop at its ends: it passes in the
        // first round (planned for pace 1 there, it took 4 and 5 rounds of backing off).
        let plain = Robot::builtin("so101").unwrap();
        let again = keypose::plan::fastest(&timed, &plain, 100.0).unwrap();
        assert!(again.report.passed(), "{:#?}", again.report.violations);
        assert_eq!(again.rounds, 1);
        let kept = again.sequence.keyframes[1].timing.as_ref().unwrap().hold;
        assert_eq!(kept, timing.hold);
    }
}

/// A straight tool line under jerk limits: its samples are joined by a cubic spline, so the
/// exact check finds no acceleration jump between the line's two keys, where the key-time
/// cubic of a robot without jerk limits jumps at every sample (the 745 violations of
/// so101-tool-line on main at 7fb3f6d); the spline passes through every solved sample; and
/// `--fastest` times the line so that all of it passes.
#[test]
fn a_straight_tool_line_under_jerk_limits_has_no_acceleration_jump_between_its_keys() {
    let sequence = Sequence::load(std::path::Path::new(&crate::common::repo(
        "sequences/so101-tool-line.json",
    )))
    .unwrap();
    let robot = so101_with_jerk(3440.0);
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    let line = &trajectory.tools.lines[0];
    assert!(
        line.problem.is_none() && line.samples.len() > 100,
        "{line:?}"
    );
    let report = check(&trajectory, &robot, robot.control_hz);
    let (from, to) = line.span;
    let inside: Vec<_> = report
        .violations
        .iter()
        .filter(|v| v.acceleration_jump.is_some() && v.from > from + 1e-9 && v.to < to - 1e-9)
        .collect();
    assert!(inside.is_empty(), "{inside:#?}");
    // At each sample the second derivative along the path is the same from both sides; for
    // the robot without jerk limits (the key-time cubic) it is not.
    let plain = Robot::builtin("so101").unwrap();
    let plain = Trajectory::build(&sequence, &plain).unwrap();
    let mut largest_plain_jump: f64 = 0.0;
    // The five joints that move the tool (the gripper is keyed on its own, not along the line).
    for (k, &t) in line.times.iter().enumerate() {
        let pose = trajectory.sample(t);
        for j in 0..5 {
            assert!(
                (pose[j] - line.value(k, j).unwrap()).abs() < 1e-9,
                "{t}: {pose:?}"
            );
            let track = &trajectory.tracks()[j];
            let jump = track.second_rate_at(t) - track.second_rate_before(t);
            assert!(
                jump.abs() < 1e-6 * (1.0 + track.second_rate_at(t).abs()),
                "{t}: {jump}"
            );
            let track = &plain.tracks()[j];
            largest_plain_jump = largest_plain_jump
                .max((track.second_rate_at(t) - track.second_rate_before(t)).abs());
        }
    }
    assert!(largest_plain_jump > 1.0, "{largest_plain_jump} deg/s²");
    let outcome = keypose::plan::fastest(&sequence, &robot, robot.control_hz).unwrap();
    assert!(outcome.report.passed(), "{:#?}", outcome.report.violations);
}

/// Coming back to speed after a stall under jerk limits: the wrist cruises at v ≈ 115 deg/s
/// (measured before the stall) when the path is followed at half the rate for one cycle
/// (`after_stall(0.5)`). The factor then climbs from 0.5 to 1 along the first half of an
/// S-curve: its rate of change within 0.9·344/v per second (the acceleration headroom, the
/// path's own acceleration being zero in the cruise of a straight line), that rate's change
/// within half the jerk limit over v, 0.5·3440/v per second squared. By hand (docs/commands.md,
/// the S-curve's closed form): `tj = min(rate/jerk, √(0.5/jerk))`, `ta = 0.5/(jerk·tj) − tj`,
/// and it is back at 1 after `2·tj + ta` ≈ 0.366 s. Before (main at 7fb3f6d) the factor
/// climbed linearly: its rate of change jumped from 0 to 2.7 per second at once, a jump of
/// the wrist's acceleration of 310 deg/s².
#[test]
fn after_a_stall_under_jerk_limits_the_rate_climbs_back_along_an_s_curve() {
    let robot = so101_with_jerk(3440.0);
    let (trajectory, from) = wrist_across(&robot);
    let mut timeline = keypose::plan::Timeline::new(&robot, &trajectory, &no_approach(), &from);
    let (dt, stall) = (1e-3, 700);
    let mut taus = Vec::new();
    let mut out = vec![0.0; 6];
    let mut wrist = Vec::new();
    for k in 0..1400 {
        timeline.sample_into(&mut out).unwrap();
        taus.push(timeline.sequence_time());
        wrist.push(out[3]);
        if k == stall {
            timeline.after_stall(0.5);
        }
        timeline.advance(dt);
    }
    let v = (wrist[stall] - wrist[stall - 1]) / dt;
    assert!(v > 100.0 && v <= 115.0, "{v}: in the cruise");
    let (rate, jerk) = (0.9 * 344.0 / v, 0.5 * 3440.0 / v);
    let tj = (rate / jerk).min((0.5 / jerk).sqrt());
    let ta = 0.5 / (jerk * tj) - tj;
    let climb = 2.0 * tj + ta;
    // The factor each cycle followed the path at, from the stall on.
    let factors: Vec<f64> = taus.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
    assert!((factors[stall - 1] - 1.0).abs() < 1e-9);
    let back = factors[stall..]
        .iter()
        .position(|&f| f >= 1.0 - 1e-12)
        .unwrap();
    let steps = (climb / dt).ceil() as usize;
    assert!(
        back == steps || back + 1 == steps,
        "{back} cycles, by hand {climb} s"
    );
    let climbing = &factors[stall..=stall + back];
    let changes: Vec<f64> = climbing.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
    let largest = changes.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    assert!(
        largest <= rate * (1.0 + 1e-6),
        "{largest} per second, {rate} by hand"
    );
    assert!(
        largest >= rate * 0.98,
        "{largest} per second: it reaches the rate"
    );
    let second = climbing
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]) / (dt * dt))
        .fold(0.0f64, |m, c| m.max(c.abs()));
    assert!(
        second <= jerk * (1.0 + 1e-3) + 1e-6,
        "{second} per s², {jerk} by hand"
    );
    // The wrist's jerk from its samples (third differences): within half its limit, where the
    // linear climb's acceleration jump shows as 0.75·310/dt.
    let [_, _, wrist_jerk] = difference_peaks(&wrist[stall + 1..stall + back + 20], dt);
    assert!(wrist_jerk <= 0.5 * 3440.0 * 1.01, "{wrist_jerk} deg/s³");
}
