//! Tool keys chosen as a person would (`Solver::solve_key`), against MuJoCo on every built-in:
//! the solved joints set in the arm's MuJoCo model put its `tcp` site on the target, MuJoCo
//! finds no contact at all there (the key keeps 1 mm of clearance in keypose's own collision
//! model), and a gripper-down key has the approach axis MuJoCo measures pointing down. The
//! approach axis is measured as docs/robots.md §12.1 defines it, on MuJoCo's joint axes and
//! anchors: the axis of the joint carrying the tcp, turned towards the tcp, where the tcp lies
//! within 30° of it; else the direction from that joint's anchor to the tcp.

use crate::models::{harness, load, request, robot, to_sim, vec3, Prng};
use glam::DVec3;
use keypose::collision::CollisionModel;
use keypose::kinematics::{
    lowest_below_floor, smallest_margin, tool_joints, Approach, KeyOrientation, KeyTarget,
    Preference, Solver, COMFORT,
};
use keypose::python::Harness;
use keypose::robot::Robot;
use serde_json::{json, Map, Value};

const ROBOTS: [&str; 4] = ["so101", "so100", "koch", "omx"];
/// Random targets per robot.
const TARGETS: usize = 25;
/// How far MuJoCo's tcp may be from the target, metres.
const WITHIN_M: f64 = 0.0005;

/// MuJoCo's forward kinematics at `values`: the reply with joint anchors, axes and the tcp.
fn mujoco_at(harness: &mut Harness, robot: &Robot, values: &[f64]) -> Value {
    let mut qpos = Map::new();
    for (joint, &value) in robot.joints.iter().zip(values) {
        qpos.insert(joint.name.clone(), json!(to_sim(joint.kind, value)));
    }
    let kinematics = request(
        harness,
        &robot.name,
        json!({"op": "kinematics", "qpos": qpos.clone(), "sites": ["tcp"]}),
    );
    let contacts = request(
        harness,
        &robot.name,
        json!({"op": "contacts", "qpos": qpos}),
    );
    json!({"kinematics": kinematics, "contacts": contacts["contacts"]})
}

/// The approach axis MuJoCo's frames give (module doc), base frame.
fn mujoco_approach(robot: &Robot, reply: &Value) -> DVec3 {
    let carrier = &robot.joints[robot.tcp.as_ref().unwrap().parent].name;
    let k = &reply["kinematics"];
    let tcp = DVec3::from_array(vec3(&k["sites"]["tcp"], "tcp"));
    let anchor = DVec3::from_array(vec3(&k["anchors"][carrier], "anchor"));
    let axis = DVec3::from_array(vec3(&k["axes"][carrier], "axis")).normalize();
    let to_tcp = (tcp - anchor).normalize();
    let along = axis.dot(to_tcp);
    if along.abs() >= 30f64.to_radians().cos() {
        axis * along.signum()
    } else {
        to_tcp
    }
}

/// Checks one solved key in MuJoCo: on the target, touching nothing. Returns the reply.
fn assert_on_target_and_clear(
    harness: &mut Harness,
    robot: &Robot,
    values: &[f64],
    target: DVec3,
) -> Value {
    let reply = mujoco_at(harness, robot, values);
    let tcp = DVec3::from_array(vec3(&reply["kinematics"]["sites"]["tcp"], "tcp"));
    assert!(
        tcp.distance(target) <= WITHIN_M,
        "{}: target {target}, joints {values:?}: MuJoCo's tcp {tcp} is {:.2} mm off",
        robot.name,
        tcp.distance(target) * 1000.0
    );
    assert_eq!(
        reply["contacts"],
        json!([]),
        "{}: joints {values:?} for {target}",
        robot.name
    );
    reply
}

/// Targets reachable in comfort: the tool positions of random poses that keep every joint that
/// moves the tool at least 30 % of its half range from its limits, the tool 3 cm above the
/// floor and 5 cm from the pan axis, and that MuJoCo finds touching nothing. Each is a witness
/// that a comfortable, clear solution exists, so the key chosen must be comfortable (at least
/// the 25 % a key keeps where it can): every target solved, every key comfortable, on target
/// and clear in MuJoCo.
#[test]
fn keys_at_comfortable_targets_are_comfortable_on_target_and_clear_in_mujoco() {
    let mut harness = harness();
    let mut rng = Prng(0x746f_6f6c_6b65_7973);
    for name in ROBOTS {
        let robot = robot(name);
        load(&mut harness, name);
        let solver = Solver::for_robot(&robot);
        let collision = CollisionModel::for_robot(&robot);
        let tool = tool_joints(&robot);
        let held = vec![false; robot.joints.len()];
        let mut solved = 0;
        while solved < TARGETS {
            let truth: Vec<f64> = robot
                .joints
                .iter()
                .zip(&tool)
                .map(|(j, &moves)| {
                    let (lo, hi) = (j.limits.min, j.limits.max);
                    let middle = 0.5 * (lo + hi);
                    if moves {
                        rng.uniform(middle - 0.35 * (hi - lo), middle + 0.35 * (hi - lo))
                    } else {
                        0f64.clamp(lo, hi)
                    }
                })
                .collect();
            let position = robot.tcp_position(&truth);
            let comfortable = smallest_margin(&robot, &truth, &tool).unwrap().share >= 0.3;
            let pan_axis = (robot.tcp_position(&truth) - robot.joint_frames(&truth)[0].t)
                .truncate()
                .length();
            if !comfortable
                || position.z < 0.03
                || pan_axis < 0.05
                || lowest_below_floor(&robot, &truth).is_some()
                || mujoco_at(&mut harness, &robot, &truth)["contacts"] != json!([])
            {
                continue;
            }
            let preference = Preference {
                seed: &robot.home,
                held: &held,
                collision: collision.as_ref(),
            };
            let target = KeyTarget {
                position,
                orientation: KeyOrientation::Free,
            };
            let chosen = solver
                .solve_key(&robot, &target, &preference)
                .unwrap_or_else(|e| panic!("{name}: {position} from {truth:?}: {e}"));
            let margin = chosen.margin.unwrap().share;
            assert!(
                margin >= COMFORT - 1e-9,
                "{name}: {position}: margin {margin:.3} though {truth:?} keeps 0.3"
            );
            assert_on_target_and_clear(&mut harness, &robot, &chosen.solution.values, position);
            solved += 1;
        }
    }
}

/// Gripper-down keys at random targets in front of each arm (40–80 % of the way to where its
/// tool is at home, ±30 % of that across, 2–15 cm above the floor), `down-or-tilted`: wherever a
/// key is solved, MuJoCo's approach axis is tilted from down by what the key reports (within
/// 0.05°), pointing straight down when it reports no tilt, and the pose is on target and
/// clear. Some targets on each arm must be reached straight down.
#[test]
fn down_keys_point_down_in_mujoco() {
    let mut harness = harness();
    let mut rng = Prng(0x646f_776e);
    for name in ROBOTS {
        let robot = robot(name);
        load(&mut harness, name);
        let solver = Solver::for_robot(&robot);
        let collision = CollisionModel::for_robot(&robot);
        let held = vec![false; robot.joints.len()];
        // Forward is where the tool is at home (the Koch's faces −x).
        let home = robot.tcp_position(&robot.home);
        let forward = home.with_z(0.0);
        let across = DVec3::Z.cross(forward);
        let mut straight = 0;
        for _ in 0..TARGETS {
            let position = forward * rng.uniform(0.4, 0.8)
                + across * rng.uniform(-0.3, 0.3)
                + DVec3::Z * rng.uniform(0.02, 0.15);
            let target = KeyTarget {
                position,
                orientation: KeyOrientation::Approach(Approach::down(true)),
            };
            let preference = Preference {
                seed: &robot.home,
                held: &held,
                collision: collision.as_ref(),
            };
            let Ok(chosen) = solver.solve_key(&robot, &target, &preference) else {
                continue;
            };
            let reply =
                assert_on_target_and_clear(&mut harness, &robot, &chosen.solution.values, position);
            let axis = mujoco_approach(&robot, &reply);
            let tilt = axis.angle_between(DVec3::NEG_Z).to_degrees();
            let reported = chosen.tilt_deg.unwrap();
            assert!(
                (tilt - reported).abs() < 0.05,
                "{name}: {position}: MuJoCo's tilt {tilt:.3}°, reported {reported:.3}°"
            );
            if reported < 0.05 {
                straight += 1;
            }
        }
        assert!(straight > 0, "{name}: no target reached straight down");
    }
}
