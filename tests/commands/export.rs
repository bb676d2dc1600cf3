//! `keypose export ros2` and `export play_motion2`, judged by independent evaluation: the
//! JointTrajectory is interpolated here the way ros2_control's joint_trajectory_controller does
//! with positions and velocities (the cubic Hermite through each pair of consecutive points),
//! and compared with `keypose sample` at 100 Hz; play_motion2's flat positions are compared
//! sample by sample.

use crate::common::{repo, run, show, stdout};
use std::path::Path;

/// The controller's agreement with keypose's own curve: 0.01° (revolute), 0.01 mm (prismatic).
const TOLERANCE_RAD: f64 = 0.01 * std::f64::consts::PI / 180.0;
const TOLERANCE_M: f64 = 1e-5;

#[derive(Debug)]
struct Point {
    time: f64,
    positions: Vec<f64>,
    velocities: Vec<f64>,
}

fn list(line: &str, key: &str) -> Option<Vec<f64>> {
    let rest = line.trim_start_matches("- ").trim().strip_prefix(key)?;
    let inner = rest.trim().strip_prefix('[')?.strip_suffix(']')?;
    Some(
        inner
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(|s| s.trim().parse().unwrap())
            .collect(),
    )
}

/// The points of a JointTrajectory YAML as `export ros2` writes it (one list per line).
fn parse_points(text: &str) -> Vec<Point> {
    let mut points: Vec<Point> = Vec::new();
    let mut sec = 0.0;
    for line in text.lines() {
        if let Some(p) = list(line, "positions:") {
            points.push(Point {
                time: 0.0,
                positions: p,
                velocities: Vec::new(),
            });
        } else if let Some(v) = list(line, "velocities:") {
            points.last_mut().unwrap().velocities = v;
        } else if let Some(s) = line.strip_prefix("    sec: ") {
            sec = s.parse::<f64>().unwrap();
        } else if let Some(n) = line.strip_prefix("    nanosec: ") {
            if let Some(p) = points.last_mut() {
                p.time = sec + n.parse::<f64>().unwrap() * 1e-9;
            }
        }
    }
    points
}

/// The controller's cubic Hermite between consecutive points (positions, velocities): each
/// joint's position, velocity and acceleration at time `t` (per second, per second squared).
fn controller_at(points: &[Point], t: f64) -> Vec<[f64; 3]> {
    let k = points
        .partition_point(|p| p.time <= t)
        .clamp(1, points.len() - 1)
        - 1;
    let (a, b) = (&points[k], &points[k + 1]);
    let h = b.time - a.time;
    let s = ((t - a.time) / h).clamp(0.0, 1.0);
    (0..a.positions.len())
        .map(|j| {
            // p(s) = p0 + m0·s + c2·s² + c3·s³ with the Hermite's c2, c3 (m = h·v).
            let delta = b.positions[j] - a.positions[j];
            let (m0, m1) = (h * a.velocities[j], h * b.velocities[j]);
            let c2 = 3.0 * delta - 2.0 * m0 - m1;
            let c3 = -2.0 * delta + m0 + m1;
            let position = a.positions[j] + s * (m0 + s * (c2 + s * c3));
            let velocity = (m0 + 2.0 * c2 * s + 3.0 * c3 * s * s) / h;
            let acceleration = (2.0 * c2 + 6.0 * c3 * s) / (h * h);
            [position, velocity, acceleration]
        })
        .collect()
}

/// `keypose sample --units rad` rows: time, then every joint.
fn samples(sequence: &str, rate: &str) -> Vec<Vec<f64>> {
    let out = run(&["sample", sequence, "--units", "rad", "--rate", rate]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    stdout(&out)
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn export_ros2(sequence: &str, out: &Path) -> Vec<Point> {
    let result = run(&["export", "ros2", sequence, "-o", out.to_str().unwrap()]);
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    parse_points(&std::fs::read_to_string(out).unwrap())
}

fn assert_follows(sequence: &str, prismatic: &[usize], rate: &str) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let points = export_ros2(sequence, &dir.path().join("t.yaml"));
    let rows = samples(sequence, rate);
    let start = rows[0][0];
    for row in &rows {
        let got = controller_at(&points, row[0] - start);
        for (j, (&want, &[have, _, _])) in row[1..].iter().zip(&got).enumerate() {
            let tol = if prismatic.contains(&j) {
                TOLERANCE_M
            } else {
                TOLERANCE_RAD
            };
            assert!(
                (want - have).abs() <= tol,
                "{sequence}: joint {j} at t = {}: keypose {want}, controller {have}",
                row[0]
            );
        }
    }
    points.len()
}

/// A copy of the example `name` in `dir` with its interpolation `mode`.
pub(crate) fn example_in_mode(dir: &Path, name: &str, mode: &str) -> String {
    let text = std::fs::read_to_string(repo(&format!("sequences/{name}"))).unwrap();
    let mut sequence: serde_json::Value = serde_json::from_str(&text).unwrap();
    sequence["interpolation"] = mode.into();
    let path = dir.join(name);
    std::fs::write(&path, sequence.to_string()).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn the_controllers_hermite_through_the_points_follows_keyposes_curve() {
    // Monotone with holds and keys that name only some joints (tracks of their own key times).
    let dir = tempfile::tempdir().unwrap();
    let monotone = example_in_mode(dir.path(), "so101_pick_place.json", "monotone");
    let points = assert_follows(&monotone, &[], "100");
    // A point per key and a second one at the end of each of the three holds, nothing more.
    assert_eq!(points, 10 + 3);
    // Smooth, as shipped: quintics no one cubic follows, so more points, until they do.
    let smooth = assert_follows(&repo("sequences/so101_pick_place.json"), &[], "100");
    assert!(smooth > points, "{smooth}");
    // Rigid transforms, a prismatic gripper in metres.
    assert_follows(&repo("sequences/omx_reach.json"), &[4], "100");
}

#[test]
fn corners_get_a_point_one_period_before_and_are_followed_between_samples() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mixed.json");
    // Cubic, then a slow linear stretch (3°/s: a linear start stays within the SO-101's
    // 344 °/s² at 100 Hz), then cubic back to rest.
    std::fs::write(
        &path,
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [
              {"time": 0, "joints": {"elbow_flex": 0, "wrist_flex": 0}},
              {"time": 1, "interp": "linear", "hold": 0.2, "joints": {"elbow_flex": 1, "wrist_flex": 0}},
              {"time": 2.2, "interp": "linear", "joints": {"elbow_flex": 4, "wrist_flex": 1}},
              {"time": 3.2, "joints": {"elbow_flex": 5, "wrist_flex": 2}},
              {"time": 5, "joints": {"elbow_flex": 0, "wrist_flex": 0}}]}"#,
    )
    .unwrap();
    let sequence = path.to_str().unwrap();
    // At 1000 Hz, between the 100 Hz points: a corner's last period is judged too. Each point
    // carries the slope after it, so over the period before a corner (h = 10 ms) the Hermite
    // strays from the line by at most |Δv|·h·4/27: for the largest change here, 3°/s at the
    // end of the hold, 0.0044°.
    let points = assert_follows(sequence, &[], "1000");
    // Keys (5), the hold's end, and a point before each corner: the hold's end (linear
    // starts) and the key at 2.2 s (linear meets linear). Key 3 at 3.2 s joins linear to cubic
    // with the same slope: no corner.
    assert_eq!(points, 5 + 1 + 2);
}

#[test]
fn play_motion2_positions_are_keyposes_samples() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.yaml");
    let sequence = repo("sequences/so101_nod.json");
    let result = run(&[
        "export",
        "play_motion2",
        &sequence,
        "--rate",
        "10",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(result.status.code(), Some(0), "{}", show(&result));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with(
            "/play_motion2:\n  ros__parameters:\n    motions:\n      \"so101_nod\":\n"
        ),
        "{text}"
    );
    let positions = text.lines().find_map(|l| list(l, "positions:")).unwrap();
    let times = text
        .lines()
        .find_map(|l| list(l, "times_from_start:"))
        .unwrap();
    let rows = samples(&sequence, "10");
    assert_eq!(times.len(), rows.len());
    for (k, row) in rows.iter().enumerate() {
        assert!((times[k] - (row[0] - rows[0][0])).abs() < 1e-9);
        for j in 0..6 {
            assert!(
                (positions[k * 6 + j] - row[1 + j]).abs() < 1e-9,
                "sample {k}, joint {j}"
            );
        }
    }
}

#[test]
fn a_sequence_that_breaks_the_limits_is_not_exported() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fast.json");
    std::fs::write(
        &path,
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "linear",
            "keyframes": [{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 0.5, "joints": {"elbow_flex": 80}}]}"#,
    )
    .unwrap();
    let out = dir.path().join("t.yaml");
    let result = run(&[
        "export",
        "ros2",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(result.status.code(), Some(1), "{}", show(&result));
    assert!(!out.exists());
}

/// Joint names YAML would read as something else if they were written plain or single-quoted
/// carelessly: quotes, a comment, a mapping, a list item, flow collections, an anchor, an
/// alias, a tag, a boolean and a number in YAML 1.1, a backslash, spaces at the ends, letters
/// beyond ASCII.
const YAML_NAMES: [&str; 6] = [
    "it's \"q\" # not a comment",
    "key: value",
    "- [a, b] {x: 1} &anchor *alias !tag",
    "on",
    "12",
    " back\\slash épaule 🦾 ",
];

/// A parsed YAML document (libyaml's parser, as ROS 2's parameter files and PyYAML use).
fn yaml(path: &Path) -> serde_norway::Value {
    serde_norway::from_str(&std::fs::read_to_string(path).unwrap())
        .unwrap_or_else(|e| panic!("{}: not YAML: {e}", path.display()))
}

fn strings(value: &serde_norway::Value) -> Vec<&str> {
    let items = value.as_sequence().expect("a list");
    items
        .iter()
        .map(|v| v.as_str().expect("a string"))
        .collect()
}

fn numbers(value: &serde_norway::Value) -> Vec<f64> {
    let items = value.as_sequence().expect("a list");
    items.iter().map(|v| v.as_f64().expect("a float")).collect()
}

#[test]
fn names_descriptions_and_motion_names_of_any_length_read_back_from_the_yaml() {
    let dir = tempfile::tempdir().unwrap();
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot.as_object_mut().unwrap().remove("home");
    robot["tcp"]["parent"] = YAML_NAMES[4].into();
    for (joint, name) in robot["joints"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .zip(YAML_NAMES)
    {
        joint["name"] = name.into();
    }
    let robot_path = dir.path().join("robot.json");
    std::fs::write(&robot_path, robot.to_string()).unwrap();
    let description = "two\nlines,\ta 'single' and a \"double\" quote # : - \\";
    let sequence = serde_json::json!({"format": "keypose-sequence/1",
        "robot": robot_path.to_str().unwrap(), "description": description,
        "keyframes": [{"time": 0, "joints": {YAML_NAMES[1]: 0, YAML_NAMES[3]: 0}},
                      {"time": 2, "joints": {YAML_NAMES[1]: 20, YAML_NAMES[3]: -30}}]});
    let sequence_path = dir.path().join("seq.json");
    std::fs::write(&sequence_path, sequence.to_string()).unwrap();
    let seq = sequence_path.to_str().unwrap();
    let rows = samples(seq, "10");

    let out = dir.path().join("t.yaml");
    export_ros2(seq, &out);
    let message = yaml(&out);
    assert_eq!(strings(&message["joint_names"]), YAML_NAMES);
    // The first and the last point are at the first and the last key (20° and −30° there).
    let points = message["points"].as_sequence().unwrap();
    for (point, row) in [
        (&points[0], &rows[0]),
        (points.last().unwrap(), rows.last().unwrap()),
    ] {
        let positions = numbers(&point["positions"]);
        assert_eq!(positions.len(), 6);
        for (have, want) in positions.iter().zip(&row[1..]) {
            assert!((have - want).abs() < 1e-9, "{have} against {want}");
        }
    }
    assert!((rows.last().unwrap()[2] - 20f64.to_radians()).abs() < 1e-9);

    // Names as long as anyone types them: YAML readers look 1024 characters ahead for a
    // plain key's colon. "on" is a boolean to YAML 1.1 unless quoted.
    for name in ["x".repeat(3000), "on".to_string()] {
        let out = dir.path().join("m.yaml");
        let result = run(&[
            "export",
            "play_motion2",
            seq,
            "--rate",
            "10",
            "--name",
            &name,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_eq!(result.status.code(), Some(0), "{}", show(&result));
        let file = yaml(&out);
        let motions = file["/play_motion2"]["ros__parameters"]["motions"]
            .as_mapping()
            .unwrap();
        assert_eq!(motions.len(), 1);
        let (key, motion) = motions.iter().next().unwrap();
        assert_eq!(key.as_str(), Some(name.as_str()), "the motion's key");
        assert_eq!(motion["meta"]["name"].as_str(), Some(name.as_str()));
        assert_eq!(motion["meta"]["description"].as_str(), Some(description));
        assert_eq!(strings(&motion["joints"]), YAML_NAMES);
        let positions = numbers(&motion["positions"]);
        let times = numbers(&motion["times_from_start"]);
        assert_eq!(times.len(), rows.len());
        for (k, row) in rows.iter().enumerate() {
            assert!((times[k] - (row[0] - rows[0][0])).abs() < 1e-9);
            for j in 0..6 {
                assert!((positions[k * 6 + j] - row[1 + j]).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn sampled_csv_columns_named_with_commas_or_quotes_stay_one_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot.as_object_mut().unwrap().remove("home");
    robot["joints"][0]["name"] = "pan, base".into();
    robot["joints"][1]["name"] = "lift \"1\"".into();
    let robot_path = dir.path().join("robot.json");
    std::fs::write(&robot_path, robot.to_string()).unwrap();
    let sequence = serde_json::json!({"format": "keypose-sequence/1",
        "robot": robot_path.to_str().unwrap(),
        "keyframes": [{"time": 0, "joints": {"pan, base": 0}}, {"time": 1, "joints": {"pan, base": 10}}]});
    let path = dir.path().join("seq.json");
    std::fs::write(&path, sequence.to_string()).unwrap();
    let out = run(&["sample", path.to_str().unwrap(), "--rate", "1"]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // RFC 4180: a field holding a comma or a quote is quoted, a quote in it doubled.
    let text = stdout(&out);
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(r#"time,"pan, base","lift ""1""",elbow_flex,wrist_flex,wrist_roll,gripper"#)
    );
    assert_eq!(lines.last(), Some("1,10,0,0,0,0,0"));
}

/// Where some joint's velocity jumps along `sequence` on `robot` (its curve's corners).
fn corners_of(sequence: &str, robot: &keypose::robot::Robot) -> Vec<f64> {
    use keypose::plan::{Side, States, Trajectory};
    let sequence = keypose::sequence::Sequence::load(std::path::Path::new(sequence)).unwrap();
    let states = States::of(&Trajectory::build(&sequence, robot).unwrap());
    states
        .breaks()
        .into_iter()
        .filter(|&t| {
            let (before, after) = (states.at(t, Side::Before), states.at(t, Side::After));
            before
                .velocities
                .iter()
                .zip(&after.velocities)
                .any(|(a, b)| (a - b).abs() > 1e-6)
        })
        .collect()
}

#[test]
fn timing_profiles_are_followed_by_the_controllers_cubics_within_the_limits() {
    // Before, these were refused ("cannot carry a timing profile"). An eased straight segment
    // plays a quadratic of time on each piece of its trapezoid, which the cubic through a point
    // at each end of the piece is: a point per key (3), at the hold's end, and at the
    // trapezoid's 19 inner points of 20, nothing more.
    let dir = tempfile::tempdir().unwrap();
    let eased = crate::export_c::eased_sequence(dir.path());
    let eased = eased.to_str().unwrap();
    assert_eq!(assert_follows(eased, &[], "1000"), 3 + 1 + 19);
    // A cubic run by three long pieces of a profile: the cubics through the keys (3), the
    // profile's inner points (2) and the corner's point (1) alone stray 0.11° from keypose's
    // curve; the export adds points until they follow it (within 0.01°, at 1 kHz).
    let curved = crate::export_c::curved_sequence(dir.path());
    let curved = curved.to_str().unwrap();
    assert!(assert_follows(curved, &[], "1000") > 6);
    // A time-optimal profile along smooth quintics: degree ten in time.
    let fastest = crate::export_c::fastest_sequence(dir.path());
    let fastest = fastest.to_str().unwrap();
    assert_follows(fastest, &[], "1000");
    // The cubics the controller plays keep the SO-101's limits (115 °/s, 344 °/s² on every
    // joint), sampled at 1 kHz and at every point from either side: all of them, but for each
    // corner (a velocity that jumps: the curved sequence's at 2 s, the fastest one's where a
    // linear gripper segment meets the next), turned over the control period before it (judged
    // by the limit check at the control rate, as for any corner), and the curved sequence's
    // unprofiled cubic after its corner.
    let robot = keypose::robot::Robot::builtin("so101").unwrap();
    let period = 1.0 / robot.control_hz;
    for (sequence, until) in [
        (eased, f64::INFINITY),
        (fastest, f64::INFINITY),
        (curved, 1.99),
    ] {
        let corners = corners_of(sequence, &robot);
        let points = export_ros2(sequence, &dir.path().join("t.yaml"));
        let end = points.last().unwrap().time.min(until);
        let mut times: Vec<f64> = (0..=(end * 1000.0) as usize)
            .map(|k| k as f64 / 1000.0)
            .collect();
        times.extend(points.iter().flat_map(|p| [p.time - 1e-7, p.time + 1e-7]));
        let turning = |t: f64| corners.iter().any(|&c| t > c - period - 1e-6 && t <= c);
        for t in times
            .into_iter()
            .filter(|t| (0.0..=end).contains(t) && !turning(*t))
        {
            for (j, [_, v, a]) in controller_at(&points, t).into_iter().enumerate() {
                let limits = robot.joints[j].limits;
                let (v, a) = (v.to_degrees(), a.to_degrees());
                assert!(
                    v.abs() <= limits.velocity * (1.0 + 1e-9),
                    "{sequence}: joint {j} at {t} s: {v} °/s"
                );
                assert!(
                    a.abs() <= limits.acceleration * (1.0 + 1e-9),
                    "{sequence}: joint {j} at {t} s: {a} °/s²"
                );
            }
        }
    }
}
