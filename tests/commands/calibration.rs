//! LeRobot calibration files that do not fit the robot: partial, other servo ids, the old
//! format; and the cause of a calibrated limit in the message about a key outside it.

use crate::common::{keypose, repo, run, show, stderr, stdout, SO101_JOINTS};
use keypose::plan::Trajectory;
use keypose::robot::{import_lerobot_calibration, Robot};
use keypose::sequence::Sequence;
use std::path::Path;

/// One SO-101 motor entry as LeRobot writes it; the whole turn recorded unless `range` given.
fn motor(name: &str, id: u8, range: (i64, i64)) -> String {
    format!(
        r#""{name}": {{"id": {id}, "drive_mode": 0, "homing_offset": 0, "range_min": {}, "range_max": {}}}"#,
        range.0, range.1
    )
}

/// A calibration for the built-in SO-101 (servo ids 1–6 in joint order), with `id_of` and
/// `range_of` overriding single entries and only the joints in `joints`.
fn calibration(
    joints: &[&str],
    id_of: &dyn Fn(&str, u8) -> u8,
    range_of: &dyn Fn(&str) -> (i64, i64),
) -> String {
    let entries: Vec<String> = SO101_JOINTS
        .iter()
        .enumerate()
        .filter(|(_, name)| joints.contains(name))
        .map(|(i, name)| motor(name, id_of(name, i as u8 + 1), range_of(name)))
        .collect();
    format!("{{{}}}", entries.join(",\n"))
}

fn import(text: &str) -> Result<Robot, String> {
    let mut robot = Robot::builtin("so101").unwrap();
    import_lerobot_calibration(&mut robot, "cal.json", text)
        .map(|_| robot)
        .map_err(|e| e.to_string())
}

const WHOLE_TURN: (i64, i64) = (0, 4095);

#[test]
fn a_calibration_for_every_joint_with_the_robots_ids_is_accepted() {
    let text = calibration(&SO101_JOINTS, &|_, id| id, &|_| WHOLE_TURN);
    assert!(import(&text).is_ok());
}

#[test]
fn a_partial_calibration_names_the_missing_joints() {
    let text = calibration(&["shoulder_pan", "elbow_flex"], &|_, id| id, &|_| {
        WHOLE_TURN
    });
    let message = import(&text).unwrap_err();
    assert!(message.starts_with("cal.json: "), "{message}");
    assert!(
        message.contains(
            "does not name joint(s) shoulder_lift, wrist_flex, wrist_roll, gripper of so101"
        ),
        "{message}"
    );
}

#[test]
fn a_calibration_with_other_servo_ids_names_the_joints() {
    // elbow_flex is servo 3 and gripper servo 6 on the built-in SO-101.
    let swap = |name: &str, id: u8| match name {
        "elbow_flex" => 7,
        "gripper" => 9,
        _ => id,
    };
    let text = calibration(&SO101_JOINTS, &swap, &|_| WHOLE_TURN);
    let message = import(&text).unwrap_err();
    assert!(
        message.contains("elbow_flex has id 7 in the calibration, 3 in the robot"),
        "{message}"
    );
    assert!(
        message.contains("gripper has id 9 in the calibration, 6 in the robot"),
        "{message}"
    );
    assert!(!message.contains("shoulder_pan"), "{message}");
}

#[test]
fn the_old_lerobot_format_is_recognised_and_the_fix_named() {
    let text = r#"{"homing_offset": [2048, 3072, 3072, -1024, -2048, 0],
                   "drive_mode": [0, 0, 0, 0, 0, 0],
                   "start_pos": [2048, 3072, 3072, 1024, 2048, 0],
                   "end_pos": [3072, 2048, 2048, 2048, 3072, 1024],
                   "calib_mode": ["DEGREE", "DEGREE", "DEGREE", "DEGREE", "DEGREE", "LINEAR"],
                   "motor_names": ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"]}"#;
    let message = import(text).unwrap_err();
    for expected in [
        "cal.json",
        "old calibration format",
        "homing_offset",
        "motor_names",
        "recalibrate",
    ] {
        assert!(message.contains(expected), "{expected:?} in {message}");
    }
}

#[test]
fn a_key_outside_the_range_the_calibration_recorded_says_so() {
    let dir = tempfile::tempdir().unwrap();
    // elbow_flex recorded over 1048 … 3048: ±1000 ticks = ±87.890625°, inside the robot's
    // ±96.83°. A key at 90° is inside the robot's limits and outside the calibration's.
    let text = calibration(&SO101_JOINTS, &|_, id| id, &|name| {
        if name == "elbow_flex" {
            (1048, 3048)
        } else {
            WHOLE_TURN
        }
    });
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, text).unwrap();
    let seq = dir.path().join("elbow.json");
    std::fs::write(
        &seq,
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":10,"joints":{"elbow_flex":90}}]}"#,
    )
    .unwrap();
    let (seq, cal) = (seq.display().to_string(), cal.display().to_string());
    let out = run(&["check", &seq]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let out = run(&["check", &seq, "--calibration", &cal]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    assert!(err.contains("expected -87.890625 … 87.890625 deg"), "{err}");
    assert!(
        err.contains(&format!(
            "the range recorded for it in the calibration {cal}"
        )),
        "{err}"
    );
    // The same pose given to `keypose pose` is refused against the recorded range, before
    // any simulation starts.
    let out = run(&["pose", "elbow_flex=90", "--calibration", &cal]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    assert!(
        err.contains("elbow_flex 90 deg is outside its limits -87.890625 … 87.890625 deg"),
        "{err}"
    );
}

#[test]
fn a_partial_calibration_on_the_command_line_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("partial.json");
    std::fs::write(
        &cal,
        calibration(&["gripper"], &|_, id| id, &|_| WHOLE_TURN),
    )
    .unwrap();
    let cal = cal.display().to_string();
    let out = read_so101("virtual", &cal);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        stderr(&out).contains(&cal) && stderr(&out).contains("shoulder_pan"),
        "{}",
        show(&out)
    );
    assert!(out.stdout.is_empty(), "{}", show(&out));
}

/// `keypose read` of the SO-101 on `port` with the calibration file `cal`.
fn read_so101(port: &str, cal: &str) -> std::process::Output {
    run(&[
        "read",
        "--robot",
        "so101",
        "--port",
        port,
        "--calibration",
        cal,
    ])
}

/// A whole calibration for the built-in `robot` (servo ids 1–6 in joint order, the whole turn
/// recorded) with `joint` given `drive_mode` 1 and the recorded `range`.
fn with_drive_mode_one(robot: &str, joint: &str, range: (i64, i64)) -> Robot {
    let mut robot = Robot::builtin(robot).unwrap();
    let entries: Vec<String> = robot
        .joints
        .iter()
        .map(|j| {
            let (drive_mode, (min, max)) = if j.name == joint {
                (1, range)
            } else {
                (0, WHOLE_TURN)
            };
            format!(
                r#""{}": {{"id": {}, "drive_mode": {drive_mode}, "homing_offset": 0, "range_min": {min}, "range_max": {max}}}"#,
                j.name, j.servo.id
            )
        })
        .collect();
    let text = format!("{{{}}}", entries.join(","));
    import_lerobot_calibration(&mut robot, "cal.json", &text).unwrap();
    robot
}

/// LeRobot's degrees for `tick` and keypose's must agree in sign and differ by the 4096/4095
/// scale only: keypose = LeRobot · 4095/4096, so by exactly 1/4096 of the angle.
fn assert_agrees(robot: &Robot, joint: &str, cases: &[(i64, f64, f64)]) {
    let joint = &robot.joints[robot.joint_index(joint).unwrap()];
    for &(tick, lerobot, keypose) in cases {
        let value = joint.servo.value(tick);
        assert!(
            (value - keypose).abs() < 1e-9,
            "{} tick {tick}: {value} deg, expected {keypose}",
            joint.name
        );
        assert!(
            (value - lerobot).abs() <= lerobot.abs() / 4096.0 + 1e-12,
            "{} tick {tick}: {value} deg is more than 1/4096 from LeRobot's {lerobot}",
            joint.name
        );
    }
}

#[test]
fn drive_mode_one_leaves_the_degrees_as_lerobot_computes_them_on_feetech_and_dynamixel() {
    // LeRobot's MotorNormMode.DEGREES (motors_bus.py::_normalize): deg = (raw − mid) · 360/4095,
    // with no drive_mode term on either vendor; keypose: (raw − mid) · 360/4096. Worked by hand.
    // Feetech (SO-101 elbow_flex, an STS3215), recorded 1000 … 3000: mid 2000.
    let so101 = with_drive_mode_one("so101", "elbow_flex", (1000, 3000));
    assert_agrees(
        &so101,
        "elbow_flex",
        &[
            // −1000 · 360/4095 = −87.912087…; −1000 · 360/4096 = −87.890625.
            (1000, -87.912_087_912_087_91, -87.890_625),
            // −500 ticks: −43.956043…; −43.9453125.
            (1500, -43.956_043_956_043_96, -43.945_312_5),
            (2000, 0.0, 0.0),
            (2500, 43.956_043_956_043_96, 43.945_312_5),
        ],
    );
    // Dynamixel (Koch elbow_flex, an XL330-M288), recorded 1024 … 3072: mid 2048. The servo's
    // Drive Mode register has already mirrored what it reports (LeRobot's leader calibration
    // writes it), so the ticks read are LeRobot's raw values as they are.
    let koch = with_drive_mode_one("koch", "elbow_flex", (1024, 3072));
    assert_agrees(
        &koch,
        "elbow_flex",
        &[
            // −548 · 360/4095 = −48.175824…; −548 · 360/4096 = −48.1640625.
            (1500, -48.175_824_175_824_18, -48.164_062_5),
            // +552 ticks: 48.527472…; 48.515625.
            (2600, 48.527_472_527_472_53, 48.515_625),
        ],
    );
}

#[test]
fn keypose_degrees_are_lerobots_within_one_4096th_of_the_angle() {
    // A whole turn recorded (0 … 4095): LeRobot's mid is 2047.5, and its ends are exactly
    // ±2047.5 · 360/4095 = ±180°; keypose's ±2047.5 · 360/4096 = ±179.9560546875°, 0.0439° less.
    let robot = with_drive_mode_one("so101", "elbow_flex", (1000, 3000));
    assert_agrees(
        &robot,
        "wrist_roll",
        &[
            (0, -180.0, -179.956_054_687_5),
            // 952.5 ticks: 83.736263…; 83.7158203125.
            (3000, 83.736_263_736_263_74, 83.715_820_312_5),
            (4095, 180.0, 179.956_054_687_5),
        ],
    );
}

/// `keypose ARGS` with LeRobot's calibration variables cleared and then `vars` set.
fn run_with_env(args: &[&str], vars: &[(&str, &Path)]) -> std::process::Output {
    let mut command = keypose();
    for var in keypose::robot::CALIBRATION_ENV_VARS {
        command.env_remove(var);
    }
    command
        .envs(vars.iter().copied())
        .args(args)
        .output()
        .unwrap()
}

/// A calibration of the built-in SO-101 whose shoulder_lift and elbow_flex midpoints are not
/// the built-in's 2047, so it changes the ticks.
fn so101_calibration() -> String {
    calibration(&SO101_JOINTS, &|_, id| id, &|name| match name {
        "shoulder_lift" => (900, 3300),
        "elbow_flex" => (1100, 3000),
        _ => WHOLE_TURN,
    })
}

fn write_at(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

const NOD: &str = "sequences/so101_nod.json";

#[test]
fn robot_id_applies_exactly_what_the_same_file_given_by_path_does() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("cal");
    let file = root.join("robots/so_follower/blue.json");
    write_at(&file, &so101_calibration());
    let nod = repo(NOD);
    let ticks = |extra: &[&str]| {
        let mut args = vec!["sample", nod.as_str(), "--units", "ticks"];
        args.extend_from_slice(extra);
        let out = run_with_env(&args, &[("HF_LEROBOT_CALIBRATION", &root)]);
        assert_eq!(out.status.code(), Some(0), "{}", show(&out));
        out
    };
    let by_path = ticks(&["--calibration", file.to_str().unwrap()]);
    let by_id = ticks(&["--robot-id", "blue"]);
    let uncalibrated = ticks(&[]);
    assert_eq!(stdout(&by_id), stdout(&by_path));
    assert_ne!(
        stdout(&by_id),
        stdout(&uncalibrated),
        "the calibration changes the ticks"
    );
    // The stderr line says which file was used, and from which LeRobot type and id.
    let said = format!(
        "calibration: {} (LeRobot so101_follower id \"blue\")",
        file.display()
    );
    assert!(stderr(&by_id).contains(&said), "{}", show(&by_id));
}

#[test]
fn robot_id_finds_the_root_as_lerobot_does_from_each_variable() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let below = "robots/so_follower/blue.json";
    // Each variable alone, with where LeRobot's defaults put the file under it.
    let cases: [(&str, String); 5] = [
        ("HF_LEROBOT_CALIBRATION", format!("c/{below}")),
        ("HF_LEROBOT_HOME", format!("lr/calibration/{below}")),
        ("HF_HOME", format!("hf/lerobot/calibration/{below}")),
        (
            "XDG_CACHE_HOME",
            format!("xdg/huggingface/lerobot/calibration/{below}"),
        ),
        (
            "HOME",
            format!("home/.cache/huggingface/lerobot/calibration/{below}"),
        ),
    ];
    let value_of = |var: &str| {
        d.join(match var {
            "HF_LEROBOT_CALIBRATION" => "c",
            "HF_LEROBOT_HOME" => "lr",
            "HF_HOME" => "hf",
            "XDG_CACHE_HOME" => "xdg",
            _ => "home",
        })
    };
    for (var, file) in &cases {
        write_at(&d.join(file), &so101_calibration());
        let value = value_of(var);
        let out = run_with_env(
            &["check", &repo(NOD), "--robot-id", "blue"],
            &[(var, &value)],
        );
        assert_eq!(out.status.code(), Some(0), "{var}: {}", show(&out));
        let used = d.join(file).display().to_string();
        assert!(stderr(&out).contains(&used), "{var}: {}", show(&out));
        std::fs::remove_file(d.join(file)).unwrap();
    }
    // HF_LEROBOT_CALIBRATION wins over the others when several are set.
    write_at(&d.join(&cases[0].1), &so101_calibration());
    write_at(&d.join(&cases[2].1), "not json");
    let (c, hf) = (value_of("HF_LEROBOT_CALIBRATION"), value_of("HF_HOME"));
    let out = run_with_env(
        &["check", &repo(NOD), "--robot-id", "blue"],
        &[("HF_HOME", &hf), ("HF_LEROBOT_CALIBRATION", &c)],
    );
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

#[test]
fn robot_id_looks_where_lerobot_keeps_each_type() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let check = |robot: &str| {
        run_with_env(
            &["check", &repo(NOD), "--robot", robot, "--robot-id", "arm"],
            &[("HF_LEROBOT_CALIBRATION", &root)],
        )
    };
    // A leader's calibration is a teleoperator's (LeRobot's teleoperator.py).
    let leader = root.join("teleoperators/so_leader/arm.json");
    write_at(&leader, &so101_calibration());
    let out = check("so101_leader");
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        stderr(&out).contains(&leader.display().to_string()),
        "{}",
        show(&out)
    );
    assert!(stderr(&out).contains("leader arm"), "{}", show(&out));
    // Before LeRobot merged its SO classes (2026-01), the directory was the type's name; the
    // current place wins when both exist.
    let legacy = root.join("robots/so101_follower/arm.json");
    write_at(&legacy, &so101_calibration());
    let out = check("so101");
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(
        stderr(&out).contains(&legacy.display().to_string()),
        "{}",
        show(&out)
    );
    let current = root.join("robots/so_follower/arm.json");
    write_at(&current, &so101_calibration());
    let out = check("so101_follower");
    assert!(
        stderr(&out).contains(&current.display().to_string()),
        "{}",
        show(&out)
    );
}

#[test]
fn a_missing_calibration_names_the_path_and_the_variables() {
    let dir = tempfile::tempdir().unwrap();
    let home = dir.path().to_path_buf();
    let out = run_with_env(
        &["check", &repo(NOD), "--robot-id", "blue"],
        &[("HOME", &home)],
    );
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    let looked_at =
        home.join(".cache/huggingface/lerobot/calibration/robots/so_follower/blue.json");
    for expected in [
        looked_at.display().to_string().as_str(),
        "robots/so101_follower/blue.json",
        "HF_LEROBOT_CALIBRATION",
        "HF_HOME",
        "comes from HOME",
        "lerobot-calibrate --robot.type=so101_follower --robot.id=blue",
        "--calibration FILE",
    ] {
        assert!(err.contains(expected), "{expected:?} in {err}");
    }
    assert!(out.stdout.is_empty(), "{}", show(&out));
}

#[test]
fn robot_id_misuse_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let cal = root.join("cal.json");
    write_at(&cal, &so101_calibration());
    let robot_file = root.join("so101.json");
    std::fs::copy(repo("robots/so101.json"), &robot_file).unwrap();
    let nod = repo(NOD);
    let (cal, robot_file) = (cal.display().to_string(), robot_file.display().to_string());
    let cases: [(Vec<&str>, &[&str]); 4] = [
        (
            vec!["--robot-id", "blue", "--calibration", &cal],
            &[
                "--robot-id",
                "--calibration",
                "expected one calibration for the arm",
            ],
        ),
        (
            vec!["--robot", &robot_file, "--robot-id", "blue"],
            &["--robot-id", "no LeRobot robot type", "--calibration FILE"],
        ),
        (
            vec!["--robot", "omx", "--robot-id", "blue"],
            &["omx", "--calibration FILE"],
        ),
        (
            vec!["--robot-id", "../blue"],
            &["--robot-id", "without '/'"],
        ),
    ];
    for (extra, expected) in cases {
        let mut args = vec!["check", nod.as_str()];
        args.extend(extra.iter().copied());
        let out = run_with_env(&args, &[("HF_LEROBOT_CALIBRATION", &root)]);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {}", show(&out));
        for text in expected {
            assert!(stderr(&out).contains(text), "{text:?} in {}", show(&out));
        }
    }
    // Every command that takes --calibration takes --robot-id.
    write_at(
        &root.join("robots/so_follower/blue.json"),
        &so101_calibration(),
    );
    for verb in [
        vec!["read", "--robot", "so101", "--port", "virtual"],
        vec!["torque", "off", "--robot", "so101", "--port", "virtual"],
    ] {
        let mut args = verb.clone();
        args.extend(["--robot-id", "blue"]);
        let out = run_with_env(&args, &[("HF_LEROBOT_CALIBRATION", &root)]);
        assert_eq!(out.status.code(), Some(0), "{verb:?}: {}", show(&out));
        assert!(
            stderr(&out).contains("LeRobot so101_follower id"),
            "{verb:?}: {}",
            show(&out)
        );
    }
}

/// The SO-101 with the gripper recorded over ticks 2000 … 3000 (drive_mode 0), the other
/// joints over the whole turn.
fn gripper_2000_3000() -> String {
    calibration(&SO101_JOINTS, &|_, id| id, &|name| {
        if name == "gripper" {
            (2000, 3000)
        } else {
            WHOLE_TURN
        }
    })
}

/// The gripper's value in a one-key sequence giving it as `percent`.
fn gripper_at(robot: &Robot, percent: &str) -> Result<f64, String> {
    let text = format!(
        r#"{{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {{"time":0,"joints":{{"gripper":"{percent}"}}}}]}}"#
    );
    let sequence = Sequence::from_json("grip.json", &text).map_err(|e| e.to_string())?;
    let trajectory = Trajectory::build(&sequence, robot).map_err(|e| e.to_string())?;
    let gripper = robot.joint_index("gripper").unwrap();
    Ok(trajectory.sample(0.0)[gripper])
}

#[test]
fn a_percent_of_the_grippers_recorded_range_is_the_degrees_worked_by_hand() {
    let robot = import(&gripper_2000_3000()).unwrap();
    // LeRobot's 0…100 (motors_bus.py::_normalize, RANGE_0_100): 40 % is tick
    // 2000 + 0.40 · 1000 = 2400. keypose's zero is the range's middle, 2500, at 360/4096° a tick:
    // (2400 − 2500) · 0.087890625 = −8.7890625°.
    assert_eq!(gripper_at(&robot, "40%").unwrap(), -8.7890625);
    // 100 %: tick 3000, 500 ticks above the middle = 43.9453125°; 0 %: tick 2000, −43.9453125°.
    // Both are the recorded range's ends, the gripper's limits now.
    assert_eq!(gripper_at(&robot, "100%").unwrap(), 43.9453125);
    assert_eq!(gripper_at(&robot, "0%").unwrap(), -43.9453125);
}

#[test]
fn drive_mode_one_mirrors_the_percent_on_feetech_only_as_lerobot_does() {
    // Feetech (SO-101 STS3215), drive_mode 1: LeRobot reads 100 − (raw − 2000)/1000 · 100, so
    // 40 % is raw 2600: (2600 − 2500) · 360/4096 = +8.7890625°.
    let so101 = with_drive_mode_one("so101", "gripper", (2000, 3000));
    assert_eq!(gripper_at(&so101, "40%").unwrap(), 8.7890625);
    // Dynamixel (Koch XL330, 4096 ticks): apply_drive_mode is False, no mirroring: raw 2400,
    // (2400 − 2500) · 360/4096 = −8.7890625° (inside the Koch gripper's −91.67 … 1.83°).
    let koch = with_drive_mode_one("koch", "gripper", (2000, 3000));
    let text = r#"{"format":"keypose-sequence/1","robot":"koch","keyframes":[
          {"time":0,"joints":{"gripper":"40%"}}]}"#;
    let sequence = Sequence::from_json("grip.json", text).unwrap();
    let trajectory = Trajectory::build(&sequence, &koch).unwrap();
    let gripper = koch.joint_index("gripper").unwrap();
    assert_eq!(trajectory.sample(0.0)[gripper], -8.7890625);
}

#[test]
fn a_percent_outside_0_to_100_or_malformed_is_bad_input() {
    let robot = import(&gripper_2000_3000()).unwrap();
    for bad in ["140%", "-5%", "40", "forty%", "NaN%"] {
        let err = gripper_at(&robot, bad).unwrap_err();
        assert!(
            err.contains("grip.json") && err.contains("$.keyframes[0].joints.gripper"),
            "{bad}: {err}"
        );
    }
    assert!(gripper_at(&robot, "140%")
        .unwrap_err()
        .contains("0% to 100%"));
}

#[test]
fn a_saved_sequence_keeps_the_percent_as_written() {
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"gripper":"40%","elbow_flex":10}}]}"#;
    let saved = Sequence::from_json("grip.json", text).unwrap().to_json();
    let saved: serde_json::Value = serde_json::from_str(&saved).unwrap();
    let joints = &saved["keyframes"][0]["joints"];
    assert_eq!(joints["gripper"], "40%", "{saved}");
    assert_eq!(joints["elbow_flex"], 10.0, "{saved}");
}

/// A sequence file giving the gripper as 40 % and then 60 %.
fn percent_sequence(dir: &Path) -> String {
    let seq = dir.join("grip.json");
    std::fs::write(
        &seq,
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"gripper":"40%"}},{"time":10,"joints":{"gripper":"60%"}}]}"#,
    )
    .unwrap();
    seq.display().to_string()
}

#[test]
fn a_percent_without_a_calibration_names_the_file_the_key_and_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let seq = percent_sequence(dir.path());
    let out = run(&["check", &seq]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let err = stderr(&out);
    for part in [
        seq.as_str(),
        "$.keyframes[0].joints.gripper",
        "no calibration",
        "--calibration",
        "--robot-id",
    ] {
        assert!(err.contains(part), "{part:?} missing: {err}");
    }
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, gripper_2000_3000()).unwrap();
    let out = run(&["check", &seq, "--calibration", &cal.display().to_string()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
}

#[test]
fn read_gives_each_calibrated_joint_in_percent_of_its_recorded_range() {
    // The emulated SO-101 rests at its uncalibrated home: tick 2047 on every servo.
    let server = crate::common::VirtualBusProcess::start(&["--robot", "so101"]);
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, gripper_2000_3000()).unwrap();
    let cal = cal.display().to_string();
    let out = read_so101(&server.path, &cal);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let pose: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(pose["ticks"][5], 2047);
    // (2047 − 2000) / (3000 − 2000) · 100 = 4.7 %; whole-turn joints: 2047 / 4095 · 100.
    let gripper = pose["percent"]["gripper"].as_f64().unwrap();
    assert!((gripper - 4.7).abs() < 1e-9, "{pose}");
    let pan = pose["percent"]["shoulder_pan"].as_f64().unwrap();
    assert!((pan - 2047.0 / 4095.0 * 100.0).abs() < 1e-9, "{pose}");
    // Without a calibration there is no range to count percent on.
    let out = run(&["read", "--robot", "so101", "--port", &server.path]);
    let pose: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(pose.get("percent").is_none(), "{pose}");
}

#[test]
fn an_so101_calibration_given_to_a_koch_is_bad_input_naming_the_joint_and_nothing_moves() {
    // The same motor names and ids 1–6: only the ranges tell the arms apart. The SO-101
    // follower's file records shoulder_lift over ticks 835 … 3198, 207.7° (2363 × 360/4096);
    // the Koch's shoulder_lift moves through −89.95 … 34.38°, 124.3°: 1.67× it.
    let cal = repo("tests/data/lerobot_so101_follower.json");
    let out = run(&[
        "play",
        &repo("sequences/koch_wave.json"),
        "--port",
        "virtual",
        "--calibration",
        &cal,
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    let message = stderr(&out);
    assert!(message.contains("$.shoulder_lift"), "{message}");
    assert!(
        message.contains("207.7 deg of travel, but koch's shoulder_lift moves through 124.3 deg"),
        "{message}"
    );
    assert!(message.contains("made on another arm"), "{message}");
    assert!(!message.contains("panicked"), "{message}");
    assert!(out.stdout.is_empty(), "{}", show(&out));
    // The same file on the SO-101 it was made on is accepted.
    let mut so101 = Robot::builtin("so101").unwrap();
    let text = std::fs::read_to_string(&cal).unwrap();
    import_lerobot_calibration(&mut so101, &cal, &text).unwrap();
}

#[test]
fn entries_no_servo_of_the_model_can_hold_are_refused() {
    // The STS3215's Homing_Offset is 11 bits of magnitude and a sign: ±2047.
    let offset = calibration(&SO101_JOINTS, &|_, id| id, &|_| WHOLE_TURN).replacen(
        "\"homing_offset\": 0",
        "\"homing_offset\": -3000",
        1,
    );
    let message = import(&offset).unwrap_err();
    assert!(
        message.contains(
            "homing_offset -3000 of shoulder_pan is outside what the sts3215's Homing_Offset holds (-2047 … 2047)"
        ),
        "{message}"
    );
    // A range over more than the 4096 ticks of one turn.
    let wide = calibration(&SO101_JOINTS, &|_, id| id, &|name| {
        if name == "elbow_flex" {
            (-100, 4200)
        } else {
            WHOLE_TURN
        }
    });
    let message = import(&wide).unwrap_err();
    assert!(
        message.contains("elbow_flex's range_min … range_max (-100 … 4200) spans 4300 ticks"),
        "{message}"
    );
}
