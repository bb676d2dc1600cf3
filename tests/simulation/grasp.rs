//! A grasp that holds without overloading (`"effort"` on a key), on the physics bus: the
//! SO-101's gripper closes on a block standing on the table, lifts it, puts it back and lets
//! go. Physics is the oracle: a block between the jaws keeps them from closing to their goal.
//! (That a gripper squeezing what cannot give trips the servo's own overload protection after
//! its protection time is `physics_bus`'s test.)

use crate::push_guard::{alarms, play, text, Log};
use glam::DVec3;
use keypose::robot::Robot;
use std::path::Path;

/// Pick-and-place of a block in front of the SO-101: open above it, straight down (the tool
/// point 3 cm over the table), close to 5° (at
/// `effort`, if any), lift, put down, open (at full effort again), up.
fn sequence(dir: &Path, effort: bool, lift: bool) -> String {
    let (close, open) = match effort {
        true => (
            r#", "effort": {"gripper": 30}"#,
            r#", "effort": {"gripper": 100}"#,
        ),
        false => ("", ""),
    };
    // Straight down to the block and up from it (tool lines, the jaws pointing down).
    let tool = |z: f64| {
        format!(r#""tool": {{"xyz": [0.3032, 0.0, {z}], "rpy": [3.1348, 0.1395, 3.0924]}}"#)
    };
    // Put down 4 mm over where it was picked up: the block is not pressed into the table.
    let (high, low, set_down) = (tool(0.06), tool(0.0304), tool(0.0344));
    // Lifted and put down again, or held where it was grasped until the release.
    let (grasp_hold, carry) = match lift {
        true => (
            0.5,
            format!(
                r#"  {{"name": "lift", "time": 6.0, "hold": 0.5, "interp": "line", "joints": {{"gripper": -5}}, {high}}},
  {{"name": "place", "time": 7.4, "hold": 0.3, "joints": {{"gripper": -5}}, {set_down}}},
"#
            ),
        ),
        false => (3.0, String::new()),
    };
    let text = format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone", "keyframes": [
  {{"name": "up", "time": 0.0, "hold": 0.3, "joints": {{"shoulder_pan": 0, "shoulder_lift": -30, "elbow_flex": -45, "wrist_flex": 10, "wrist_roll": 0, "gripper": 40}}}},
  {{"name": "above", "time": 2.0, "interp": "line", "joints": {{"gripper": 40}}, {high}}},
  {{"name": "down", "time": 3.2, "hold": 0.4, "joints": {{"gripper": 40}}, {low}}},
  {{"name": "grasp", "time": 4.6, "hold": {grasp_hold}, "interp": "line", "joints": {{"gripper": -5}}, {low}{close}}},
{carry}  {{"name": "release", "time": 8.6, "hold": 0.3, "interp": "line", "joints": {{"gripper": 40}}, {set_down}{open}}},
  {{"name": "away", "time": 10.0, "joints": {{"gripper": 40}}, {high}}}]}}"#
    );
    let path = dir.join(format!("grasp-{effort}-{lift}.json"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// Where the jaws hold: 85 % of the way along the moving jaw's blade, in its own frame, and the
/// static jaw's inner face as far down, in the gripper's (wrist roll's) frame, about 1 cm
/// over the jaws' tips (sim/models/so101.xml: the blade capsule's ends; the static jaw box's
/// centre and its 3 mm half-thickness).
const BLADE_POINT: DVec3 = DVec3::new(-0.0143, -0.0733, 0.0183);
const STATIC_FACE: DVec3 = DVec3::new(-0.0159, -0.00074, -0.088);
/// The blade's capsule radius, metres.
const BLADE_RADIUS: f64 = 0.004;
/// The gripper angle at which the closing blade meets the block, degrees.
const MEETS_AT: f64 = 20.0;

/// A block standing on the table between the jaws of the arm at `pose` (as measured where the
/// sequence holds "down"), as wide as the gap at [`MEETS_AT`]°.
fn block_between_the_jaws(robot: &Robot, pose: &[f64], dir: &Path) -> String {
    let roll = robot.joint_index("wrist_roll").unwrap();
    let gripper = robot.joint_index("gripper").unwrap();
    let mut meeting = pose.to_vec();
    meeting[gripper] = MEETS_AT;
    let frames = robot.joint_frames(&meeting);
    let face = frames[roll].apply(STATIC_FACE);
    let blade = frames[gripper].apply(BLADE_POINT);
    let across = DVec3::new(blade.x - face.x, blade.y - face.y, 0.0);
    let half_width = across.length() / 2.0 - BLADE_RADIUS / 2.0;
    let centre = (face + blade) / 2.0;
    // Its top 1 cm over the blade's point wherever the blade swings through from open
    // (the blade comes down and in as it closes: it must meet the block's side, not its top).
    let mut open = pose.to_vec();
    open[gripper] = 40.0;
    let opened = robot.joint_frames(&open)[gripper].apply(BLADE_POINT);
    let half_height = (opened.z.max(blade.z).max(face.z) + 0.01) / 2.0;
    let angle = across.y.atan2(across.x);
    let scene = dir.join("block.xml");
    std::fs::write(
        &scene,
        format!(
            r#"<mujoco><worldbody><body name="block" pos="{} {} {half_height}" quat="{} 0 0 {}"><freejoint/><geom type="box" size="{half_width} 0.012 {half_height}" mass="0.03" friction="1.2"/></body></worldbody></mujoco>"#,
            centre.x,
            centre.y,
            (angle / 2.0).cos(),
            (angle / 2.0).sin()
        ),
    )
    .unwrap();
    println!(
        "block {:.1} mm wide, {:.1} mm tall, at ({:.1}, {:.1}) mm",
        half_width * 2e3,
        half_height * 2e3,
        centre.x * 1e3,
        centre.y * 1e3
    );
    scene.display().to_string()
}

/// The measured pose at the first reading within `from..to` of sequence time.
fn measured_within(log: &Log, robot: &Robot, from: f64, to: f64) -> Vec<f64> {
    log.rows
        .iter()
        .filter(|r| log.cell(r, "phase") != "approach")
        .filter(|r| (from..to).contains(&log.number(r, "sequence_time").unwrap()))
        .find_map(|r| {
            robot
                .joints
                .iter()
                .map(|j| log.number(r, &format!("{}_meas", j.name)))
                .collect::<Option<Vec<f64>>>()
        })
        .expect("a reading there")
}

/// The gripper's (smallest measured angle, hardest load) over `from..to` of sequence time.
fn gripper_over(log: &Log, from: f64, to: f64) -> (f64, f64) {
    let mut least = f64::INFINITY;
    let mut hardest: f64 = 0.0;
    for r in &log.rows {
        let t = log.number(r, "sequence_time").unwrap();
        if log.cell(r, "phase") == "approach" || !(from..to).contains(&t) {
            continue;
        }
        if let Some(angle) = log.number(r, "gripper_meas") {
            least = least.min(angle);
        }
        if let Some(load) = log.number(r, "gripper_load_pct") {
            hardest = hardest.max(load.abs());
        }
    }
    (least, hardest)
}

#[test]
fn a_grasp_at_30_percent_effort_lifts_and_places_a_block_that_full_effort_squeezes_out() {
    let robot = Robot::builtin("so101").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let limited = sequence(dir.path(), true, true);
    let droop = ["--compensate-droop"];
    // Where the arm really is at "down" (its droop is the servos'): the free run says.
    let (out, free) = play(dir.path(), &limited, "free", &droop);
    assert!(out.status.success(), "{}", text(&out));
    let down = measured_within(&free, &robot, 3.5, 3.6);
    let scene = block_between_the_jaws(&robot, &down, dir.path());
    let mut args = droop.to_vec();
    args.extend(["--scene", &scene]);

    let (out, held) = play(dir.path(), &limited, "held", &args);
    assert!(out.status.success(), "{}", text(&out));
    // Closing, holding, lifting, putting down: the block keeps the jaws open.
    let (closed, hardest) = gripper_over(&held, 5.1, 8.6);
    let (lifted, _) = gripper_over(&held, 6.0, 6.5);
    let (free_closed, _) = gripper_over(&free, 5.1, 8.6);
    println!(
        "30 % effort: the jaws stayed at {closed:.1}° or more (lifted: {lifted:.1}°; \
         {free_closed:.1}° without the block), the gripper's load at most {hardest:.1} %"
    );
    assert!(
        free_closed < -3.0,
        "without the block the jaws close: {free_closed:.1}°"
    );
    assert!(
        lifted > MEETS_AT - 8.0,
        "the block slipped out on the lift: {lifted:.1}°"
    );
    assert!(hardest <= 31.0, "the gripper pushed at {hardest:.1} %");
    assert!(
        alarms(&held, &robot).is_empty(),
        "{:?}",
        alarms(&held, &robot)
    );

    // At full effort the push guard stops the squeeze (no protection trips)…
    let full = sequence(dir.path(), false, true);
    let (out, caught) = play(dir.path(), &full, "caught", &args);
    let said = text(&out);
    println!("full effort: {}", said.lines().last().unwrap_or_default());
    assert_eq!(out.status.code(), Some(3), "{said}");
    assert!(said.contains("gripper pushing"), "{said}");
    assert!(
        alarms(&caught, &robot).is_empty(),
        "{:?}",
        alarms(&caught, &robot)
    );
    // …and without the guard, the closing jaw shoves the block out from between the jaws.
    let mut unguarded = args.clone();
    unguarded.push("--no-push-guard");
    let (out, squeezed) = play(dir.path(), &full, "squeezed", &unguarded);
    let (lifted, hardest) = gripper_over(&squeezed, 6.0, 6.5);
    println!(
        "full effort, no push guard: {:?}, the jaws at {lifted:.1}° on the lift, the gripper's load up to {hardest:.1} %",
        out.status.code()
    );
    assert!(
        lifted < 0.0,
        "the block stayed in the jaws at full effort: {lifted:.1}°"
    );
}
