//! The studio's and the teaching rules' own collision check (`keypose::collision`) against
//! MuJoCo's contacts of the same pose (`keypose pose`'s check, the oracle): the same models,
//! so every pair MuJoCo finds more than 1 mm deep is found, and every pair found more than
//! 1 mm deep is one MuJoCo finds, over seeded random poses within the limits of every
//! built-in robot and of a cell of two SO-101 arms 0.25 m apart. The check's time per pose
//! is printed (not asserted).

use crate::common::Seeded;
use keypose::collision::CollisionModel;
use keypose::pose::RigidTransform;
use keypose::robot::Robot;
use keypose::sim::Simulation;
use std::collections::BTreeSet;

/// Deeper than this, both checks must agree; shallower, either may call it (the two round
/// box-capsule contacts differently at the surface).
const SURE: f64 = 0.001;
const POSES: usize = 120;

/// A body that MuJoCo's held pose leaves out of place: the OpenMANIPULATOR-X's right finger
/// follows the left through an equality constraint, which the held pose (`mj_forward` on the
/// joint values) does not solve, so MuJoCo has it at 0 while our check has it where it follows
/// the left finger. Pairs with it are not compared.
const MIMIC: &str = "gripper_right";

fn pair(a: &str, b: Option<&str>) -> (String, String) {
    let b = b.unwrap_or("world");
    if a <= b {
        (a.to_string(), b.to_string())
    } else {
        (b.to_string(), a.to_string())
    }
}

fn compare(robot: &Robot, seed: u64) {
    let model = CollisionModel::for_robot(robot).expect("a collision model");
    let mut sim = Simulation::start(robot, None, None).expect("MuJoCo");
    let mut random = Seeded(seed);
    let mut touching = 0;
    let mut checked = std::time::Duration::ZERO;
    for pose in 0..POSES {
        let values: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| j.limits.min + random.unit() * (j.limits.max - j.limits.min))
            .collect();
        let contacts = sim.pose_contacts(robot, &values).expect("contacts");
        let oracle_sure: BTreeSet<_> = contacts
            .iter()
            .filter(|c| c.depth > SURE)
            .map(|c| pair(&c.body1, Some(&c.body2)))
            .collect();
        let oracle_any: BTreeSet<_> = contacts
            .iter()
            .map(|c| pair(&c.body1, Some(&c.body2)))
            .collect();
        let started = std::time::Instant::now();
        let touches = model.touches(&values, 0.0);
        checked += started.elapsed();
        let ours_any: BTreeSet<_> = touches
            .iter()
            .map(|t| pair(&t.bodies.0, t.bodies.1.as_deref()))
            .collect();
        let ours_sure: BTreeSet<_> = touches
            .iter()
            .filter(|t| t.distance < -SURE)
            .map(|t| pair(&t.bodies.0, t.bodies.1.as_deref()))
            .collect();
        let compared = |p: &(String, String)| p.0 != MIMIC && p.1 != MIMIC;
        let oracle_sure: BTreeSet<_> = oracle_sure.into_iter().filter(compared).collect();
        let ours_sure: BTreeSet<_> = ours_sure.into_iter().filter(compared).collect();
        touching += usize::from(!oracle_sure.is_empty());
        assert!(
            oracle_sure.is_subset(&ours_any),
            "{} pose {pose} {values:?}: MuJoCo {contacts:?}, ours {touches:?}",
            robot.name
        );
        assert!(
            ours_sure.is_subset(&oracle_any),
            "{} pose {pose} {values:?}: ours {touches:?}, MuJoCo {contacts:?}",
            robot.name
        );
    }
    eprintln!(
        "{}: {POSES} poses, {touching} in contact; our check {:.1} µs per pose",
        robot.name,
        checked.as_secs_f64() * 1e6 / POSES as f64
    );
    assert!(touching > 0, "{}: some poses touch", robot.name);
}

#[test]
fn our_collision_check_agrees_with_mujoco_on_every_built_in_robot() {
    for (i, name) in keypose::robot::BUILTIN_NAMES.iter().enumerate() {
        compare(
            &Robot::builtin(name).unwrap(),
            0x9E37_79B9_7F4A_7C15 + i as u64,
        );
    }
}

#[test]
fn our_collision_check_agrees_with_mujoco_on_a_cell_of_two_arms() {
    let so101 = Robot::builtin("so101").unwrap();
    let right = RigidTransform::new(glam::DVec3::new(0.0, -0.25, 0.0), glam::DQuat::IDENTITY);
    let cell = Robot::cell(vec![
        ("left".into(), so101.clone(), RigidTransform::IDENTITY),
        ("right".into(), so101, right),
    ])
    .unwrap();
    compare(&cell, 0xD1B5_4A32_D192_ED03);
}

/// Within this, metres, keypose's distance of a pair is MuJoCo's (issue: the check and MuJoCo
/// agree within 2 mm on the built-in models).
const DISTANCE_AGREEMENT: f64 = 0.002;
/// Pairs nearer than this, metres, are compared: what a clearance check ever looks at.
const NEAR: f64 = 0.05;

/// The poses compared on `robot`: seeded random ones within its limits, and every example
/// sequence's for it, sampled at 20 Hz along the motion.
fn poses_of(robot: &Robot, seed: u64) -> Vec<Vec<f64>> {
    let mut random = Seeded(seed);
    let mut poses: Vec<Vec<f64>> = (0..POSES)
        .map(|_| {
            robot
                .joints
                .iter()
                .map(|j| j.limits.min + random.unit() * (j.limits.max - j.limits.min))
                .collect()
        })
        .collect();
    let examples = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/sequences")).unwrap();
    for entry in examples {
        let path = entry.unwrap().path();
        let sequence = keypose::sequence::Sequence::load(&path).unwrap();
        if sequence.is_cell()
            || keypose::plan::builtin_robot_of(&sequence).map(|r| r.name)
                != Some(robot.name.clone())
        {
            continue;
        }
        let trajectory = keypose::plan::Trajectory::build(&sequence, robot).unwrap();
        poses.extend(trajectory.grid(20.0).map(|t| trajectory.sample(t)));
    }
    poses
}

/// keypose's distance of every pair of parts (and each part and the floor) against MuJoCo's
/// `mj_geomDistance` between the same shapes, wherever either is within 5 cm: every example's
/// motion and random poses of every built-in robot. Apart, they agree within 2 mm; inside each
/// other both say so (the depths are measured differently: ours the least overlap along the
/// separating axes). The worst difference is printed.
#[test]
fn our_distances_are_mujocos_within_two_millimetres() {
    for (i, name) in keypose::robot::BUILTIN_NAMES.iter().enumerate() {
        let robot = Robot::builtin(name).unwrap();
        let model = CollisionModel::for_robot(&robot).expect("a collision model");
        let mut sim = Simulation::start(&robot, None, None).expect("MuJoCo");
        let (mut worst, mut compared) = (0.0f64, 0usize);
        for values in poses_of(&robot, 0xA076_1D64_78BD_642F + i as u64) {
            let ours = model.touches(&values, f64::INFINITY);
            let pairs: Vec<(&str, Option<&str>)> = ours
                .iter()
                .map(|t| (t.bodies.0.as_str(), t.bodies.1.as_deref()))
                .filter(|&(a, b)| a != MIMIC && b != Some(MIMIC))
                .collect();
            let theirs = sim
                .pose_distances(&robot, &values, &pairs, 1.0)
                .expect("distances");
            for (pair, mujoco) in pairs.iter().zip(theirs) {
                let mine = ours
                    .iter()
                    .find(|t| (t.bodies.0.as_str(), t.bodies.1.as_deref()) == *pair)
                    .unwrap()
                    .distance;
                let mujoco = mujoco.unwrap_or(f64::INFINITY);
                if mine.min(mujoco) >= NEAR {
                    continue;
                }
                compared += 1;
                if mine < 0.0 || mujoco < 0.0 {
                    assert!(
                        mine < DISTANCE_AGREEMENT && mujoco < DISTANCE_AGREEMENT,
                        "{name} {pair:?} at {values:?}: ours {mine}, MuJoCo {mujoco}"
                    );
                    continue;
                }
                worst = worst.max((mine - mujoco).abs());
                assert!(
                    (mine - mujoco).abs() <= DISTANCE_AGREEMENT,
                    "{name} {pair:?} at {values:?}: ours {mine} m, MuJoCo {mujoco} m"
                );
            }
        }
        eprintln!(
            "{name}: {compared} pairs within {NEAR} m compared; worst difference {worst:.1e} m"
        );
        assert!(compared > 0, "{name}: some pairs come near");
    }
}
