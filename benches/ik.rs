//! Inverse kinematics on the SO-101: solve time per key of keypose's closed form and of its
//! damped least squares (DLS), and of the `k` crate's `JacobianIkSolver`, on the same targets
//! from the same seeds with the same joint limits, in the same run; and the time of a 100-sample
//! tool line.
//!
//! Like for like:
//! - **Targets**: 200 reachable tool positions (and, for the pose rows, orientations), made from
//!   seeded random joint values inside 80 % of each range. Their positions are the official
//!   model's: MuJoCo's forward kinematics of the vendored MJCF (`sim/models/so101.xml`, through
//!   the project's harness `sim/sim_harness.py`), not keypose's.
//! - **Seeds**: every solver starts from the same joint values — a key 5° from the answer on
//!   every tool joint (clamped into the limits), the home pose, or an unrelated key (the next
//!   target's joints). `k` is given them too (it used to start from zero).
//! - **Limits**: `k`'s chain carries the robot's joint limits (it clamps every step into them),
//!   as keypose's solvers keep to them. `k` solves positions only: the arm has five joints to
//!   the tool, and `k` refuses six constraints with five joints.
//! - **Accuracy**: every answer, before anything is timed, is put through MuJoCo's forward
//!   kinematics of the official model: the tool within 0.1 mm of the target, the joints inside
//!   their limits, and for pose targets the gripper link's orientation (the wrist roll and gripper
//!   joint axes, two directions fixed in it) within 0.1° of the target's. A fast wrong answer is
//!   no answer, so the counts are printed beside the times.
//!
//! Time: each target is solved once per round, [`REPS`] rounds with every solver in each
//! (interleaved). Per round: the mean, median, 90th percentile and largest time per key over the
//! 200 targets; printed as the median and range of each over the rounds. Solvers with fallbacks
//! (the closed form's pitch search and roll scan, DLS's iterations) have long tails, so the mean
//! and the 90th percentile are given, not only the median.
//!
//! `cargo bench --bench ik` prints the load average and lines starting with `summary:`. It needs
//! keypose's Python environment (MuJoCo), built once in the target directory like the tests'.

mod common;

use glam::{DQuat, DVec3};
use k::InverseKinematicsSolver;
use keypose::kinematics::{solve_line, Dls, Solver, ToolTarget};
use keypose::python::{Harness, HarnessOptions, PyConfig};
use keypose::robot::Robot;
use serde_json::{json, Map, Value};
use std::hint::black_box;
use std::time::{Duration, Instant};

const TARGETS: usize = 200;
/// Rounds over all targets and solvers.
const REPS: usize = 5;
/// "A key 5° away": the seed's offset from the answer on every tool joint, degrees.
const NEAR_DEG: f64 = 5.0;
/// An answer is right when the official model puts the tool this close to the target, metres.
const POSITION_OK_M: f64 = 1e-4;
/// … and, for a pose, the gripper link this close to the target's orientation, degrees.
const ORIENTATION_OK_DEG: f64 = 0.1;

/// Reachable poses: joint values from a fixed linear congruential sequence inside 80 % of each
/// range, kept when the tool is above the floor and 2 cm above it.
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

// ---------------------------------------------------------------------------------------------
// The official model, through MuJoCo.

/// What MuJoCo's forward kinematics of the official model says of one pose.
struct Official {
    tcp: DVec3,
    /// The wrist roll and gripper joint axes (world): two directions fixed in the gripper link.
    axes: [DVec3; 2],
}

struct MuJoCo {
    harness: Harness,
}

impl MuJoCo {
    fn start(robot: &Robot) -> Result<MuJoCo, String> {
        let config = PyConfig::from_env().map_err(|e| e.to_string())?;
        let options = HarnessOptions {
            request_timeout: Duration::from_secs(300),
            ..HarnessOptions::default()
        };
        let mut harness =
            Harness::start_in(&config, "sim_harness.py", options).map_err(|e| e.to_string())?;
        let mjcf = format!(
            "{}/sim/models/{}.xml",
            env!("CARGO_MANIFEST_DIR"),
            robot.name
        );
        harness
            .request(&json!({"op": "load", "mjcf": mjcf}))
            .map_err(|e| e.to_string())?;
        Ok(MuJoCo { harness })
    }

    fn kinematics(&mut self, robot: &Robot, values: &[f64]) -> Official {
        let mut qpos = Map::new();
        for (joint, &value) in robot.joints.iter().zip(values) {
            qpos.insert(joint.name.clone(), json!(value.to_radians()));
        }
        let reply = self
            .harness
            .request(&json!({"op": "kinematics", "qpos": qpos, "sites": ["tcp"]}))
            .unwrap_or_else(|e| panic!("MuJoCo's kinematics failed: {e}"));
        let vec3 = |v: &Value| {
            let a: Vec<f64> = v
                .as_array()
                .unwrap_or_else(|| panic!("not a vector: {v}"))
                .iter()
                .map(|x| x.as_f64().expect("a number"))
                .collect();
            DVec3::new(a[0], a[1], a[2])
        };
        Official {
            tcp: vec3(&reply["sites"]["tcp"]),
            axes: [
                vec3(&reply["axes"]["wrist_roll"]),
                vec3(&reply["axes"]["gripper"]),
            ],
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The solvers.

/// The SO-101 chain up to the tcp as a `k` serial chain, with the robot's joint limits.
fn k_chain(robot: &Robot) -> k::SerialChain<f64> {
    let tcp = robot.tcp.as_ref().expect("so101 has a tcp");
    let node = |name: &str,
                t: DVec3,
                r: DQuat,
                joint: k::JointType<f64>,
                limits: Option<k::joint::Range<f64>>|
     -> k::Node<f64> {
        k::NodeBuilder::new()
            .name(name)
            .translation(k::Translation3::new(t.x, t.y, t.z))
            .rotation(k::UnitQuaternion::from_quaternion(
                k::nalgebra::Quaternion::new(r.w, r.x, r.y, r.z),
            ))
            .joint_type(joint)
            .limits(limits)
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
                Some(k::joint::Range::new(
                    j.limits.min.to_radians(),
                    j.limits.max.to_radians(),
                )),
            )
        })
        .collect();
    nodes.push(node(
        "tcp",
        tcp.origin.t,
        tcp.origin.r,
        k::JointType::Fixed,
        None,
    ));
    for pair in nodes.windows(2) {
        pair[1].set_parent(&pair[0]);
    }
    let end = nodes.last().expect("nodes").clone();
    let _chain = k::Chain::from_root(nodes[0].clone());
    k::SerialChain::from_end(&end)
}

#[derive(Clone, Copy, PartialEq)]
enum Contender {
    ClosedForm,
    Dls,
    K,
}

#[derive(Clone, Copy, PartialEq)]
enum Seed {
    /// The answer's joints, 5° off on every tool joint (clamped into the limits).
    Near,
    /// The robot's home pose.
    Home,
    /// The next target's joints.
    Unrelated,
}

/// One row of the comparison: who solves what from where.
struct Case {
    contender: Contender,
    pose: bool,
    seed: Seed,
}

impl Case {
    fn label(&self) -> String {
        let who = match self.contender {
            Contender::ClosedForm => "keypose closed form",
            Contender::Dls => "keypose DLS",
            Contender::K => "k JacobianIkSolver",
        };
        let what = if self.pose { "pose" } else { "position" };
        let from = match self.seed {
            Seed::Near => "from a key 5° away",
            Seed::Home => "from home",
            Seed::Unrelated => "from an unrelated key",
        };
        format!("{who}, {what}, {from}")
    }
}

fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for seed in [Seed::Near, Seed::Home, Seed::Unrelated] {
        for contender in [Contender::ClosedForm, Contender::Dls, Contender::K] {
            cases.push(Case {
                contender,
                pose: false,
                seed,
            });
        }
        for contender in [Contender::ClosedForm, Contender::Dls] {
            cases.push(Case {
                contender,
                pose: true,
                seed,
            });
        }
    }
    cases
}

/// Everything the solvers share.
struct Bench {
    robot: Robot,
    poses: Vec<Vec<f64>>,
    /// The official model's tool position of each pose (the targets).
    official: Vec<Official>,
    /// keypose's tool orientation of each pose (the pose targets' orientation).
    orientations: Vec<DQuat>,
    closed: Solver,
    dls: Solver,
    held: Vec<bool>,
    arm: k::SerialChain<f64>,
    k_solver: k::JacobianIkSolver<f64>,
    /// How many leading joints `k`'s chain has.
    k_dof: usize,
}

impl Bench {
    fn seed(&self, seed: Seed, i: usize) -> Vec<f64> {
        match seed {
            Seed::Near => {
                let tool = keypose::kinematics::tool_joints(&self.robot);
                self.poses[i]
                    .iter()
                    .zip(&self.robot.joints)
                    .zip(tool)
                    .map(|((&v, j), t)| {
                        if t {
                            (v + NEAR_DEG).clamp(j.limits.min, j.limits.max)
                        } else {
                            v
                        }
                    })
                    .collect()
            }
            Seed::Home => self.robot.home.clone(),
            Seed::Unrelated => self.poses[(i + 1) % TARGETS].clone(),
        }
    }

    /// Every joint's value in the answer, or None when the solver found none.
    fn solve(&self, case: &Case, i: usize, seed: &[f64]) -> Option<Vec<f64>> {
        let position = self.official[i].tcp;
        let target = if case.pose {
            ToolTarget::pose(position, self.orientations[i])
        } else {
            ToolTarget::position(position)
        };
        let robot = &self.robot;
        match case.contender {
            Contender::ClosedForm => self
                .closed
                .solve(robot, &target, seed, &self.held)
                .ok()
                .map(|s| s.values),
            Contender::Dls => self
                .dls
                .solve(robot, &target, seed, &self.held)
                .ok()
                .map(|s| s.values),
            Contender::K => {
                let start: Vec<f64> = seed[..self.k_dof].iter().map(|v| v.to_radians()).collect();
                self.arm.set_joint_positions_clamped(&start);
                let goal = k::Isometry3::translation(position.x, position.y, position.z);
                let constraints = k::Constraints {
                    rotation_x: false,
                    rotation_y: false,
                    rotation_z: false,
                    ..Default::default()
                };
                self.k_solver
                    .solve_with_constraints(&self.arm, &goal, &constraints)
                    .ok()?;
                let mut values = seed.to_vec();
                for (v, r) in values.iter_mut().zip(self.arm.joint_positions()) {
                    *v = r.to_degrees();
                }
                Some(values)
            }
        }
    }
}

/// How many answers of one case the official model finds right.
#[derive(Default)]
struct Accuracy {
    answered: usize,
    right: usize,
    /// The largest tool position error over the answers, metres, and orientation error, degrees.
    worst_position: f64,
    worst_orientation: f64,
    outside_limits: usize,
}

fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.normalize()
        .dot(b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

fn accuracy(bench: &Bench, mujoco: &mut MuJoCo, case: &Case) -> Accuracy {
    let mut acc = Accuracy::default();
    for i in 0..TARGETS {
        let seed = bench.seed(case.seed, i);
        let Some(values) = bench.solve(case, i, &seed) else {
            continue;
        };
        acc.answered += 1;
        let reached = mujoco.kinematics(&bench.robot, &values);
        let wanted = &bench.official[i];
        let position = reached.tcp.distance(wanted.tcp);
        let orientation = if case.pose {
            angle_deg(reached.axes[0], wanted.axes[0])
                .max(angle_deg(reached.axes[1], wanted.axes[1]))
        } else {
            0.0
        };
        let inside = bench
            .robot
            .joints
            .iter()
            .zip(&values)
            .all(|(j, &x)| j.limits.contains(x));
        acc.worst_position = acc.worst_position.max(position);
        acc.worst_orientation = acc.worst_orientation.max(orientation);
        acc.outside_limits += usize::from(!inside);
        if position < POSITION_OK_M && orientation < ORIENTATION_OK_DEG && inside {
            acc.right += 1;
        }
    }
    acc
}

/// One round's figures of a case, microseconds per key.
struct Round {
    mean: f64,
    median: f64,
    p90: f64,
    max: f64,
}

fn round(bench: &Bench, case: &Case, seeds: &[Vec<f64>]) -> Round {
    let mut times: Vec<f64> = (0..TARGETS)
        .map(|i| {
            let start = Instant::now();
            black_box(bench.solve(case, i, black_box(&seeds[i])));
            start.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    let mean = common::mean(&times);
    times.sort_by(f64::total_cmp);
    Round {
        mean,
        median: common::quantile(&times, 0.5),
        p90: common::quantile(&times, 0.9),
        max: times[TARGETS - 1],
    }
}

fn main() {
    let session = common::Session::start("ik");
    common::use_shared_python_cache();
    let reps = if common::is_bench_run() { REPS } else { 1 };
    let robot = Robot::builtin("so101").expect("so101");
    let mut mujoco = MuJoCo::start(&robot).unwrap_or_else(|e| {
        panic!("the official model's kinematics (MuJoCo through sim/sim_harness.py) are needed to check the answers: {e}")
    });
    let poses = poses(&robot);
    let official: Vec<Official> = poses.iter().map(|p| mujoco.kinematics(&robot, p)).collect();
    let orientations = poses.iter().map(|p| robot.tcp_frame(p).r).collect();
    let fk_gap = poses
        .iter()
        .zip(&official)
        .map(|(p, o)| robot.tcp_position(p).distance(o.tcp))
        .fold(0.0, f64::max);
    println!(
        "targets: {TARGETS} tool positions by MuJoCo's forward kinematics of sim/models/so101.xml \
         (keypose's own forward kinematics is within {:.1e} m of them)",
        fk_gap
    );
    let arm = k_chain(&robot);
    let bench = Bench {
        closed: Solver::for_robot(&robot),
        dls: Solver::General(Dls::new(&robot)),
        held: vec![false; robot.joints.len()],
        k_dof: arm.dof(),
        arm,
        k_solver: k::JacobianIkSolver::new(1e-5, 0.01, 0.5, 100),
        poses,
        official,
        orientations,
        robot,
    };
    assert!(bench.closed.is_closed_form(), "so101 gets the closed form");

    let cases = cases();
    let accuracies: Vec<Accuracy> = cases
        .iter()
        .map(|case| accuracy(&bench, &mut mujoco, case))
        .collect();
    drop(mujoco);

    let seeds: Vec<Vec<Vec<f64>>> = cases
        .iter()
        .map(|case| (0..TARGETS).map(|i| bench.seed(case.seed, i)).collect())
        .collect();
    for (case, seeds) in cases.iter().zip(&seeds) {
        round(&bench, case, seeds); // warm-up
    }
    let mut rounds: Vec<Vec<Round>> = cases.iter().map(|_| Vec::new()).collect();
    for _ in 0..reps {
        for ((case, seeds), out) in cases.iter().zip(&seeds).zip(&mut rounds) {
            out.push(round(&bench, case, seeds));
        }
    }

    // A 10 cm line at 100 Hz over 1 s: 100 samples, from home.
    let start = bench.robot.home.clone();
    let from = bench.robot.tcp_position(&start);
    let end = ToolTarget::position(from + DVec3::new(-0.1, 0.0, -0.05));
    let params: Vec<f64> = (1..=100).map(|k| k as f64 / 100.0).collect();
    let line: Vec<f64> = (0..reps)
        .map(|_| {
            let started = Instant::now();
            for _ in 0..10 {
                black_box(solve_line(&bench.robot, &start, &end, &start, &params).ok());
            }
            started.elapsed().as_secs_f64() / 10.0 * 1e6
        })
        .collect();

    println!();
    println!(
        "summary: SO-101, {TARGETS} targets, every solver from the same seed with the same joint \
         limits; µs per key, median (range) over {reps} rounds; right = the official model \
         (MuJoCo) puts the tool within {} mm (pose: and the gripper within {ORIENTATION_OK_DEG}°) \
         inside the limits",
        POSITION_OK_M * 1e3
    );
    println!(
        "summary: | solver, target, seed | mean | median | 90th pct. | max | mean vs k (same seed) \
         | answers right (answered) of {TARGETS} | worst error (MuJoCo) |"
    );
    println!("summary: |---|---|---|---|---|---|---|---|");
    for (k, case) in cases.iter().enumerate() {
        let r = &rounds[k];
        let peer = cases
            .iter()
            .position(|c| c.contender == Contender::K && c.seed == case.seed)
            .expect("k has a row for every seed");
        let means: Vec<f64> = r.iter().map(|x| x.mean).collect();
        let peer_means: Vec<f64> = rounds[peer].iter().map(|x| x.mean).collect();
        let a = &accuracies[k];
        println!(
            "summary: | {} | {} | {} | {} | {} | {} | {} ({}){} | {:.4} mm{} |",
            case.label(),
            common::Spread::of(&means).show(1),
            common::Spread::over(r, |x| x.median).show(1),
            common::Spread::over(r, |x| x.p90).show(1),
            common::Spread::over(r, |x| x.max).show(0),
            common::Spread::ratio(&means, &peer_means).show(2),
            a.right,
            a.answered,
            if a.outside_limits > 0 {
                format!(" ({} outside the limits)", a.outside_limits)
            } else {
                String::new()
            },
            a.worst_position * 1e3,
            if case.pose {
                format!(", {:.4}°", a.worst_orientation)
            } else {
                String::new()
            },
        );
    }
    println!(
        "summary: | line of 100 samples (keypose `solve_line`, from home) | {} µs | | | | | | |",
        common::Spread::of(&line).show(0)
    );
    println!(
        "summary: `mean vs k` is the mean time per key over k's, round by round (below 1: faster \
         than k); {}",
        session.load()
    );
    session.end();
}
