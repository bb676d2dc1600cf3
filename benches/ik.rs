//! Inverse kinematics: solve time per key (closed form and damped least squares), line solving
//! per control sample, and the `k` crate's Jacobian IK on the same SO-101 targets in the same
//! run. Before timing, every solver's answers are checked against the forward kinematics and
//! the limits, and the counts printed: a fast wrong answer is no answer.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use k::InverseKinematicsSolver;
use keypose::kinematics::{solve_line, Dls, Solver, ToolTarget};
use keypose::robot::Robot;
use std::hint::black_box;

const TARGETS: usize = 200;

/// Reachable poses: joint values from a fixed linear congruential sequence inside 80 % of each
/// range, kept when the tool is above the floor and 5 cm from the pan axis.
fn poses(robot: &Robot) -> Vec<Vec<f64>> {
    let mut state: u64 = 12345;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let tool = keypose::kinematics::tool_joints(robot);
    let mut out = Vec::new();
    while out.len() < TARGETS {
        let values: Vec<f64> = robot
            .joints
            .iter()
            .zip(&tool)
            .map(|(j, &t)| {
                let (lo, hi) = (j.limits.min, j.limits.max);
                let middle = (lo + hi) / 2.0;
                if t {
                    middle + (next() - 0.5) * 0.8 * (hi - lo)
                } else {
                    0.0f64.clamp(lo, hi)
                }
            })
            .collect();
        if keypose::kinematics::lowest_below_floor(robot, &values).is_none()
            && robot.tcp_position(&values).z > 0.02
        {
            out.push(values);
        }
    }
    out
}

/// The SO-101 chain up to the tcp as a `k` serial chain.
fn k_chain(robot: &Robot) -> k::SerialChain<f64> {
    let tcp = robot.tcp.as_ref().expect("so101 has a tcp");
    let node = |name: &str, t: DVec3, r: glam::DQuat, joint: k::JointType<f64>| -> k::Node<f64> {
        k::NodeBuilder::new()
            .name(name)
            .translation(k::Translation3::new(t.x, t.y, t.z))
            .rotation(k::UnitQuaternion::from_quaternion(
                k::nalgebra::Quaternion::new(r.w, r.x, r.y, r.z),
            ))
            .joint_type(joint)
            .finalize()
            .into()
    };
    let mut nodes: Vec<k::Node<f64>> = robot.joints[..=tcp.parent]
        .iter()
        .map(|j| {
            let axis = k::Vector3::new(j.axis.x, j.axis.y, j.axis.z);
            node(
                &j.name,
                j.origin.t,
                j.origin.r,
                k::JointType::Rotational {
                    axis: k::nalgebra::Unit::new_normalize(axis),
                },
            )
        })
        .collect();
    nodes.push(node("tcp", tcp.origin.t, tcp.origin.r, k::JointType::Fixed));
    for pair in nodes.windows(2) {
        pair[1].set_parent(&pair[0]);
    }
    let end = nodes.last().expect("nodes").clone();
    let _chain = k::Chain::from_root(nodes[0].clone());
    k::SerialChain::from_end(&end)
}

fn k_solve(
    arm: &k::SerialChain<f64>,
    solver: &k::JacobianIkSolver<f64>,
    target: DVec3,
) -> Option<Vec<f64>> {
    arm.set_joint_positions_unchecked(&vec![0.0; arm.dof()]);
    let goal = k::Isometry3::translation(target.x, target.y, target.z);
    let constraints = k::Constraints {
        rotation_x: false,
        rotation_y: false,
        rotation_z: false,
        ..Default::default()
    };
    solver
        .solve_with_constraints(arm, &goal, &constraints)
        .ok()?;
    Some(
        arm.joint_positions()
            .iter()
            .map(|r| r.to_degrees())
            .collect(),
    )
}

/// How many of `answers` put the tool within 0.1 mm of the target and inside the limits.
fn correct(robot: &Robot, targets: &[DVec3], answers: &[Option<Vec<f64>>]) -> usize {
    targets
        .iter()
        .zip(answers)
        .filter(|(t, a)| {
            a.as_ref().is_some_and(|v| {
                let mut full = robot.home.clone();
                full[..v.len()].copy_from_slice(v);
                robot.tcp_position(&full).distance(**t) < 1e-4
                    && robot
                        .joints
                        .iter()
                        .zip(&full)
                        .all(|(j, &x)| j.limits.contains(x))
            })
        })
        .count()
}

fn bench(c: &mut Criterion) {
    let robot = Robot::builtin("so101").expect("so101");
    let poses = poses(&robot);
    let frames: Vec<_> = poses.iter().map(|p| robot.tcp_frame(p)).collect();
    let positions: Vec<DVec3> = frames.iter().map(|f| f.t).collect();
    let closed = Solver::for_robot(&robot);
    let general = Solver::General(Dls::new(&robot));
    let held = vec![false; robot.joints.len()];
    let arm = k_chain(&robot);
    let k_solver = k::JacobianIkSolver::new(1e-5, 0.01, 0.5, 100);

    let ours: Vec<_> = positions
        .iter()
        .map(|&p| {
            closed
                .solve(&robot, &ToolTarget::position(p), &robot.home, &held)
                .ok()
                .map(|s| s.values)
        })
        .collect();
    let theirs: Vec<_> = positions
        .iter()
        .map(|&p| k_solve(&arm, &k_solver, p))
        .collect();
    println!(
        "correct (tool within 0.1 mm, inside the limits) of {TARGETS}: closed form {}, k {}",
        correct(&robot, &positions, &ours),
        correct(&robot, &positions, &theirs)
    );

    // Criterion reports means; the closed form's fallbacks (pitch search, roll scan, the general
    // solver) make a few targets far slower than the rest, so the median is printed too.
    let median = |f: &dyn Fn(usize)| {
        let mut times: Vec<f64> = (0..TARGETS)
            .map(|i| {
                let start = std::time::Instant::now();
                for _ in 0..20 {
                    f(i);
                }
                start.elapsed().as_secs_f64() / 20.0 * 1e6
            })
            .collect();
        times.sort_by(f64::total_cmp);
        (times[TARGETS / 2], times[TARGETS * 9 / 10])
    };
    let (m, p90) = median(&|i| {
        let target = ToolTarget::pose(frames[i].t, frames[i].r);
        black_box(closed.solve(&robot, &target, &robot.home, &held).ok());
    });
    println!("closed form, pose, from home: median {m:.2} µs, 90th percentile {p90:.2} µs");
    let (m, p90) = median(&|i| {
        let seed: Vec<f64> = poses[i].iter().map(|v| v + 5.0).collect();
        black_box(
            closed
                .solve(&robot, &ToolTarget::position(positions[i]), &seed, &held)
                .ok(),
        );
    });
    println!("closed form, position, from a key 5 deg away: median {m:.2} µs, 90th percentile {p90:.2} µs");
    let (m, p90) = median(&|i| {
        black_box(k_solve(&arm, &k_solver, positions[i]));
    });
    println!("k, position, from zero: median {m:.2} µs, 90th percentile {p90:.2} µs");

    let mut group = c.benchmark_group("ik so101 per key");
    let mut i = 0;
    group.bench_function("closed form, pose (xyz + r)", |b| {
        b.iter(|| {
            i = (i + 1) % TARGETS;
            let target = ToolTarget::pose(frames[i].t, frames[i].r);
            black_box(closed.solve(&robot, &target, &robot.home, &held).ok())
        })
    });
    group.bench_function("closed form, position, from a key 5 deg away", |b| {
        b.iter(|| {
            i = (i + 1) % TARGETS;
            let seed: Vec<f64> = poses[i].iter().map(|v| v + 5.0).collect();
            black_box(
                closed
                    .solve(&robot, &ToolTarget::position(positions[i]), &seed, &held)
                    .ok(),
            )
        })
    });
    group.bench_function("closed form, position, from an unrelated key", |b| {
        b.iter(|| {
            i = (i + 1) % TARGETS;
            let seed = &poses[(i + 1) % TARGETS];
            black_box(
                closed
                    .solve(&robot, &ToolTarget::position(positions[i]), seed, &held)
                    .ok(),
            )
        })
    });
    group.bench_function("damped least squares, pose, from a key 5 deg away", |b| {
        b.iter(|| {
            i = (i + 1) % TARGETS;
            let seed: Vec<f64> = poses[i].iter().map(|v| v + 5.0).collect();
            let target = ToolTarget::pose(frames[i].t, frames[i].r);
            black_box(general.solve(&robot, &target, &seed, &held).ok())
        })
    });
    group.bench_function("k JacobianIkSolver, position, from zero", |b| {
        b.iter(|| {
            i = (i + 1) % TARGETS;
            black_box(k_solve(&arm, &k_solver, positions[i]))
        })
    });
    group.finish();

    // A 10 cm line at 100 Hz over 1 s: 100 samples.
    let start = robot.home.clone();
    let from = robot.tcp_position(&start);
    let end = ToolTarget::position(from + DVec3::new(-0.1, 0.0, -0.05));
    let params: Vec<f64> = (1..=100).map(|k| k as f64 / 100.0).collect();
    c.bench_function("ik so101 line of 100 samples", |b| {
        b.iter(|| black_box(solve_line(&robot, &start, &end, &start, &params).ok()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
