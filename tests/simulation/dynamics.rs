//! keypose's inverse dynamics (`keypose::dynamics`) against MuJoCo's `mj_inverse` on
//! the same built-in models (the oracle; the harness's `inverse` op leaves out damping,
//! friction and constraints, as keypose does): every joint's force within 1 % of its peak,
//! over every example's motion and seeded random states of every built-in robot. The worst
//! difference is printed.

use crate::common::Seeded;
use keypose::dynamics::Dynamics;
use keypose::plan::{Side, States, Trajectory};
use keypose::robot::Robot;
use keypose::sim::Simulation;

/// Agreement asked, as a share of the joint's largest force over the states compared.
const AGREEMENT: f64 = 0.01;
const RANDOM_STATES: usize = 60;

/// (values, velocities, accelerations): seeded random states within each joint's position,
/// velocity and twice its acceleration limit, then the states of every example of `robot`
/// at 25 Hz.
fn states_of(robot: &Robot, seed: u64) -> Vec<[Vec<f64>; 3]> {
    let mut random = Seeded(seed);
    let mut states: Vec<[Vec<f64>; 3]> = (0..RANDOM_STATES)
        .map(|_| {
            let mut pick = |f: &dyn Fn(&keypose::robot::Joint) -> (f64, f64)| -> Vec<f64> {
                robot
                    .joints
                    .iter()
                    .map(|j| {
                        let (low, high) = f(j);
                        random.between(low, high)
                    })
                    .collect()
            };
            [
                pick(&|j| (j.limits.min, j.limits.max)),
                pick(&|j| (-j.limits.velocity, j.limits.velocity)),
                pick(&|j| (-2.0 * j.limits.acceleration, 2.0 * j.limits.acceleration)),
            ]
        })
        .collect();
    for path in crate::common::examples() {
        let sequence = keypose::sequence::Sequence::load(&path).unwrap();
        if sequence.is_cell()
            || keypose::plan::builtin_robot_of(&sequence).map(|r| r.name)
                != Some(robot.name.clone())
        {
            continue;
        }
        let trajectory = Trajectory::build(&sequence, robot).unwrap();
        let motion = States::of(&trajectory);
        for t in trajectory.grid(25.0) {
            let s = motion.at(t, Side::After);
            states.push([s.values, s.velocities, s.accelerations]);
        }
    }
    states
}

#[test]
fn our_inverse_dynamics_is_mujocos_within_one_percent_of_the_peak() {
    for (i, name) in keypose::robot::BUILTIN_NAMES.iter().enumerate() {
        let robot = Robot::builtin(name).unwrap();
        let dynamics = Dynamics::for_robot(&robot).expect("the built-in model's masses");
        let mut sim = Simulation::start(&robot, None, None).expect("MuJoCo");
        let states = states_of(&robot, 0x9E37_79B9_7F4A_7C15 + i as u64);
        let mut pairs: Vec<(Vec<f64>, Vec<f64>)> = Vec::with_capacity(states.len());
        for [q, qd, qdd] in &states {
            let ours = dynamics.joint_forces(q, qd, qdd);
            let force = sim.pose_inverse(&robot, q, qd, qdd).expect("mj_inverse");
            let theirs: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| {
                    // The OMX's right finger follows the left one by the same value (its
                    // equality's coefficient 1): by virtual work its force adds to the left's.
                    let mimic = match j.name.as_str() {
                        "gripper_left_joint" => force["gripper_right_joint"],
                        _ => 0.0,
                    };
                    force[&j.name] + mimic
                })
                .collect();
            pairs.push((ours, theirs));
        }
        for (j, joint) in robot.joints.iter().enumerate() {
            let peak = pairs.iter().map(|(_, t)| t[j].abs()).fold(0.0, f64::max);
            let worst = pairs
                .iter()
                .map(|(o, t)| (o[j] - t[j]).abs())
                .fold(0.0, f64::max);
            eprintln!(
                "{name} {}: peak {peak:.4}, worst difference {worst:.2e} ({:.3} % of the peak) over {} states",
                joint.name,
                100.0 * worst / peak,
                pairs.len()
            );
            assert!(peak > 0.0, "{name} {}: some load", joint.name);
            assert!(
                worst <= AGREEMENT * peak,
                "{name} {}: ours and MuJoCo's differ by {worst} (peak {peak})",
                joint.name
            );
        }
    }
}
