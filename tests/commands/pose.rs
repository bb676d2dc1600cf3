//! `keypose pose` through the binary, with the real harness and MuJoCo. Expectations are
//! MuJoCo-measured positions from docs/robots.md (§1.3, §3.3) and hand geometry from them,
//! never keypose's own output.

use crate::common::{png_size, python_cache as cache, run_sim as keypose, show};
use serde_json::Value;
use std::path::PathBuf;

/// `keypose pose ARGS --format json`: exit code and report.
fn pose_json(args: &[&str]) -> (Option<i32>, Value) {
    let mut all = vec!["pose", "--format", "json"];
    all.extend_from_slice(args);
    let out = keypose(&all);
    let report = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", show(&out)));
    (out.status.code(), report)
}

fn assert_tool_at(report: &Value, want: [f64; 3], tolerance: f64) {
    let got: Vec<f64> = report["tool"]["position_m"]
        .as_array()
        .expect("tool.position_m")
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for axis in 0..3 {
        assert!(
            (got[axis] - want[axis]).abs() <= tolerance,
            "tool axis {axis}: got {got:?}, want {want:?} ± {tolerance}: {report:#}"
        );
    }
}

/// SO-101 at home (q = 0): the TCP where docs/robots.md §1.3 measured MuJoCo's site
/// `gripperframe`, (0.39136, −0.00001, 0.22647) m, and nothing touching.
#[test]
fn so101_at_home_has_the_tool_where_mujoco_measured_it() {
    let (code, report) = pose_json(&[]);
    assert_eq!(code, Some(0), "{report:#}");
    assert_eq!(report["tool"]["frame"], "tcp");
    assert_tool_at(&report, [0.39136, -0.00001, 0.22647], 0.0002);
    assert_eq!(report["clear"], true);
    assert_eq!(report["contacts"], serde_json::json!([]));
    let joints = report["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 6);
    assert!(joints
        .iter()
        .all(|j| j["given"] == false && j["unit"] == "deg"));
    // The elbow's limits as docs/robots.md §1.2 gives them: ±96.83°.
    let elbow = joints.iter().find(|j| j["name"] == "elbow_flex").unwrap();
    assert_eq!(
        (elbow["min"].as_f64(), elbow["max"].as_f64()),
        (Some(-96.83), Some(96.83))
    );
}

/// elbow_flex +90° folds the forearm straight down (axis world +y, §1.3: +y turns +x towards
/// −z). The TCP turns about the elbow axis through (0.09723, −0.01828, 0.22917): from
/// Δ = TCP − elbow = (0.29413, ·, −0.0027) to (Δz, ·, −Δx) = (−0.0027, ·, −0.29413), so it
/// lands at (0.09453, −0.00001, −0.06496): 65 mm below the floor, which must be named.
#[test]
fn the_forearm_folded_down_into_the_floor_fails_naming_the_floor() {
    let (code, report) = pose_json(&["elbow_flex=90"]);
    assert_eq!(code, Some(1), "{report:#}");
    assert_tool_at(&report, [0.09453, -0.00001, -0.06496], 0.0003);
    assert_eq!(report["clear"], false);
    let contacts = report["contacts"].as_array().unwrap();
    assert!(
        contacts.iter().any(|c| c["kind"] == "floor"
            && c["depth_m"].as_f64().unwrap() > 0.03
            && c["message"].as_str().unwrap().contains("touches the floor")),
        "{report:#}"
    );
    let out = keypose(&["pose", "elbow_flex=90"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let text = crate::common::stdout(&out);
    assert!(text.contains("TOUCHES"), "{text}");
    assert!(text.contains("touches the floor"), "{text}");
    assert!(
        text.contains("elbow_flex") && text.contains("90.00 deg"),
        "{text}"
    );
}

/// elbow_flex +96° and wrist_flex +95° fold the forearm down and the gripper on back under it,
/// 191° from +x about +y (§1.3 axes): the wrist_flex axis lands at
/// (0.09723 + 0.1349·cos 96° + 0.0052·sin 96°, ·, 0.22917 − 0.1349·sin 96° + 0.0052·cos 96°)
/// = (0.0883, ·, 0.0945) and the TCP, (0.15923, −0.0079) from it turned by 191°, at
/// (0.0883 − 0.1548, ·, 0.0945 + 0.0381) = (−0.0665, ·, 0.1326): behind the pan axis
/// (x = 0.0388), through the shoulder, 13 cm above the floor. Only self-collisions, then.
#[test]
fn the_gripper_folded_back_into_the_shoulder_is_a_self_collision() {
    let (code, report) = pose_json(&["elbow_flex=96", "wrist_flex=95"]);
    assert_eq!(code, Some(1), "{report:#}");
    assert_tool_at(&report, [-0.0665, -0.00001, 0.1326], 0.0005);
    let contacts = report["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty(), "{report:#}");
    assert!(contacts.iter().all(|c| c["kind"] == "self"), "{report:#}");
    assert!(
        contacts
            .iter()
            .any(|c| c["body1"] == "shoulder" || c["body2"] == "shoulder"),
        "{report:#}"
    );
}

/// OMX with joint1 at +90° (axis world +z through (0.012, 0, 0.017), §3.3) and the arm
/// straightened (joint2 = joint3 = 0; joint4 and the gripper stay at home, 0): the q = 0 TCP
/// (0.2860, 0, 0.2045) turns a quarter about that axis to (0.012, 0.274, 0.2045), the tool
/// yawed by 90° and level.
#[test]
fn omx_turned_a_quarter_has_the_tool_turned_with_it() {
    let (code, report) = pose_json(&["--robot", "omx", "joint1=90", "joint2=0", "joint3=0"]);
    assert_eq!(code, Some(0), "{report:#}");
    assert_tool_at(&report, [0.012, 0.274, 0.2045], 0.0002);
    let rpy: Vec<f64> = report["tool"]["rpy_deg"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(rpy[0].abs() < 0.01 && rpy[1].abs() < 0.01, "{rpy:?}");
    assert!((rpy[2] - 90.0).abs() < 0.01, "{rpy:?}");
    let joint4 = &report["joints"][3];
    assert_eq!(
        (joint4["name"].as_str(), joint4["given"].as_bool()),
        (Some("joint4"), Some(false))
    );
}

/// The tool frame's z axis in the base frame from the report's roll-pitch-yaw (URDF:
/// R = Rz(yaw)·Ry(pitch)·Rx(roll), so R·ẑ is its third column, worked by hand): on the SO-101
/// the approach axis, wrist to fingertips (docs/robots.md §12.1).
fn tool_z(report: &Value) -> [f64; 3] {
    let rpy: Vec<f64> = report["tool"]["rpy_deg"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap().to_radians())
        .collect();
    let (r, p, y) = (rpy[0], rpy[1], rpy[2]);
    [
        y.cos() * p.sin() * r.cos() + y.sin() * r.sin(),
        y.sin() * p.sin() * r.cos() - y.cos() * r.sin(),
        p.cos() * r.cos(),
    ]
}

/// Each joint's distance to its nearer limit, degrees, from the report's values and limits
/// (the limits as robots/so101.json gives them: the report prints the robot's own).
fn margins(report: &Value) -> Vec<(String, f64)> {
    report["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            let v = j["value"].as_f64().unwrap();
            let (min, max) = (j["min"].as_f64().unwrap(), j["max"].as_f64().unwrap());
            (
                j["name"].as_str().unwrap().to_string(),
                (v - min).min(max - v),
            )
        })
        .collect()
}

/// Issue 25's two targets: the nearest solutions put shoulder_lift on its −100° stop
/// (0.22, −0.08, 0.10) and folded the gripper into the shoulder (0.22, 0.08, 0.04, exit 1).
/// Solved as keys, every joint that moves the tool is at least 18° inside its limits (the
/// issue found such tilted-tool solutions), the tool is on the target, and MuJoCo finds
/// nothing touching (exit 0).
#[test]
fn the_issues_tool_targets_are_solved_clear_and_well_inside_the_limits() {
    for target in [[0.22, -0.08, 0.10], [0.22, 0.08, 0.04]] {
        let text = format!("{},{},{}", target[0], target[1], target[2]);
        let (code, report) = pose_json(&["--tool", &text]);
        assert_eq!(code, Some(0), "{text}: {report:#}");
        assert_eq!(report["clear"], true, "{report:#}");
        assert_tool_at(&report, target, 1e-4);
        for (joint, margin) in margins(&report).into_iter().take(5) {
            assert!(
                margin >= 18.0,
                "{text}: {joint} {margin:.2}° inside: {report:#}"
            );
        }
        let smallest = &report["solved"]["smallest_margin"];
        assert!(smallest["margin"].as_f64().unwrap() >= 18.0, "{report:#}");
    }
}

/// `--approach down` points the tool straight down (its z axis along −z, by the rpy printed)
/// where the arm can; where it cannot, exit 2 saying so and the least tilt that works, and
/// `down-or-tilted` takes that tilt, clear of the floor and the arm (MuJoCo's contacts).
#[test]
fn approach_down_points_the_tool_down_or_says_it_cannot() {
    let (code, report) = pose_json(&["--tool", "0.25,0.05,0.06", "--approach", "down"]);
    assert_eq!(code, Some(0), "{report:#}");
    assert_eq!(report["clear"], true, "{report:#}");
    assert_tool_at(&report, [0.25, 0.05, 0.06], 1e-4);
    let z = tool_z(&report);
    assert!(z[2] < -(0.01f64.to_radians().cos()), "{z:?}: {report:#}");

    let out = keypose(&["pose", "--tool", "0.22,-0.08,0.10", "--approach", "down"]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let said = crate::common::stderr(&out);
    assert!(said.contains("not pointing down"), "{said}");
    assert!(said.contains("least tilt"), "{said}");

    let (code, report) = pose_json(&["--tool", "0.22,-0.08,0.10", "--approach", "down-or-tilted"]);
    assert_eq!(code, Some(0), "{report:#}");
    assert_eq!(report["clear"], true, "{report:#}");
    let z = tool_z(&report);
    let tilt = (-z[2]).acos().to_degrees();
    assert!((1.0..=20.0).contains(&tilt), "{tilt}: {report:#}");
    let reported = report["solved"]["tilt_deg"].as_f64().unwrap();
    assert!((reported - tilt).abs() < 0.01, "{reported} vs {tilt}");
}

/// `--tool` with `--port` stays near the arm's present pose, not home: emulated STS3215s at
/// zero whose Homing_Offset registers hold −500 (shoulder_lift) and 800 (elbow_flex) report
/// actual − offset (docs/protocols.md §2), so 500 · 360/4096 = 43.945° and −800 · 360/4096 =
/// −70.3125° (by hand); the solution from there is nearer that
/// pose (in the sum of squared joint differences) than the one from home is, and both are on
/// the target and clear.
#[test]
fn tool_with_a_port_stays_near_the_arms_present_pose() {
    let bus = crate::common::VirtualBusProcess::start(&[
        "--robot",
        "so101",
        "--homing-offset",
        "2:-500",
        "--homing-offset",
        "3:800",
    ]);
    let target = [0.25, 0.05, 0.12];
    let (code, from_arm) = pose_json(&["--tool", "0.25,0.05,0.12", "--port", &bus.path]);
    assert_eq!(code, Some(0), "{from_arm:#}");
    let present: Vec<f64> = from_arm["solved"]["seed"]["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!((present[1] - 43.9453125).abs() < 1e-9, "{present:?}");
    assert!((present[2] + 70.3125).abs() < 1e-9, "{present:?}");
    let (code, from_home) = pose_json(&["--tool", "0.25,0.05,0.12"]);
    assert_eq!(code, Some(0), "{from_home:#}");
    let distance = |report: &Value| -> f64 {
        report["joints"]
            .as_array()
            .unwrap()
            .iter()
            .zip(&present)
            .map(|(j, p)| (j["value"].as_f64().unwrap() - p).powi(2))
            .sum()
    };
    assert!(
        distance(&from_arm) < distance(&from_home),
        "{from_arm:#} {from_home:#}"
    );
    for report in [&from_arm, &from_home] {
        assert_tool_at(report, target, 1e-4);
        assert_eq!(report["clear"], true, "{report:#}");
    }
}

/// Millimetres typed for metres get a hint with the metres; angles past a turn in --tool are
/// refused as not degrees; --approach with an orientation is refused. All exit 2.
#[test]
fn tool_units_typed_wrong_get_a_hint() {
    for (args, says) in [
        (vec!["--tool", "220,-80,100"], "0.2200, -0.0800, 0.1000"),
        (vec!["--tool", "0.2,0,0.1,0,900,0"], "degrees"),
        (
            vec!["--tool", "0.2,0,0.1,0,90,0", "--approach", "down"],
            "give one",
        ),
    ] {
        let mut all = vec!["pose"];
        all.extend(args);
        let out = keypose(&all);
        assert_eq!(out.status.code(), Some(2), "{}", show(&out));
        assert!(crate::common::stderr(&out).contains(says), "{}", show(&out));
    }
}

#[test]
fn bad_assignments_are_bad_input() {
    for (args, says) in [
        (
            vec!["elbow=30"],
            "has no joint \"elbow\"; its joints are: shoulder_pan",
        ),
        (
            vec!["elbow_flex=97"],
            "outside its limits -96.83 … 96.83 deg",
        ),
        (vec!["gripper=-11"], "outside its limits -10 … 100 deg"),
        (vec!["elbow_flex"], "expected JOINT=VALUE"),
        (vec!["elbow_flex=far"], "expected a number (deg)"),
        (vec!["elbow_flex=nan"], "expected a number (deg)"),
        (vec!["elbow_flex=10", "elbow_flex=20"], "given twice"),
        (
            vec!["--robot", "omx", "joint1=10", "elbow_flex=0"],
            "robot omx has no joint",
        ),
    ] {
        let mut all = vec!["pose"];
        all.extend(&args);
        let out = keypose(&all);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", show(&out));
        assert!(
            crate::common::stderr(&out).contains(says),
            "{args:?}: {}",
            show(&out)
        );
        assert!(out.stdout.is_empty(), "{args:?}: {}", show(&out));
    }
}

/// The joint-directions sheet: the zero pose and one tile per joint, 320 × 240 tiles in four
/// columns: 7 tiles for the six-joint SO-101 make 2 rows (1280 × 480).
#[test]
fn directions_draw_the_zero_pose_and_each_joint() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("so101.png");
    let out = keypose(&["pose", "--directions", png.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert_eq!(png_size(&png), (1280, 480));
    assert!(
        crate::common::stderr(&out).contains("7 frames"),
        "{}",
        show(&out)
    );
    let wrong = dir.path().join("so101.gif");
    let out = keypose(&["pose", "--directions", wrong.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(!wrong.exists());
    let nowhere = dir.path().join("missing/so101.png");
    let out = keypose(&["pose", "--directions", nowhere.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        crate::common::stderr(&out).contains("does not exist"),
        "{}",
        show(&out)
    );
}

/// The committed pictures exist for every built-in robot and stay small.
#[test]
fn the_committed_joint_direction_pictures_are_small_pngs() {
    for robot in ["so101", "so100", "koch", "omx"] {
        let path = PathBuf::from(crate::common::repo(&format!(
            "docs/joint-directions-{robot}.png"
        )));
        let size = std::fs::metadata(&path).unwrap().len();
        assert!(size < 200_000, "{}: {size} bytes", path.display());
        assert_eq!(png_size(&path).0, 1280, "{}", path.display());
    }
}

/// docs/commands.md's `keypose pose` sample is what the command prints, the model's path (which
/// depends on the machine's cache) shown as `…/so101.xml`.
#[test]
fn the_readme_pose_sample_prints_what_the_command_prints() {
    let readme = std::fs::read_to_string(crate::common::repo("docs/commands.md")).unwrap();
    let (_, after) = readme
        .split_once("$ keypose pose elbow_flex=90")
        .expect("docs/commands.md shows keypose pose elbow_flex=90");
    let (_, sample) = after.split_once('\n').unwrap();
    let (sample, _) = sample.split_once("```").unwrap();
    let out = keypose(&["pose", "elbow_flex=90"]);
    let printed = crate::common::stdout(&out);
    let model = cache().join("sim/models/so101.xml");
    let printed = printed.replace(&model.display().to_string(), "…/so101.xml");
    let lines =
        |text: &str| -> Vec<String> { text.lines().map(|l| l.trim_end().to_string()).collect() };
    assert_eq!(lines(&printed), lines(sample), "{}", show(&out));
}
