//! The MuJoCo models of the built-in robots (`sim/models/<name>.xml`) against keypose's own robot
//! descriptions (`robots/<name>.json`), through the MuJoCo harness (`sim/sim_harness.py`, protocol
//! in sim/PROTOCOL.md):
//! - every joint of the description is in its model, of the same kind, limited to the same range
//!   (radians for revolute joints, metres for prismatic ones), with a position actuator of its
//!   own name;
//! - MuJoCo's joint anchors and axes and the model's `tcp` site equal keypose's forward kinematics
//!   to 1e-6 at q = 0, at home and at 50 seeded random poses within the limits;
//! - at q = 0 the TCP is where docs/robots.md measured it on the official models;
//! - holding home or q = 0 touches nothing and sags less than 3 degrees;
//! - pushing each arm into the floor, or folding it into itself, does make floor and self
//!   contacts, so that a contact-free run means something.
//!
//! The environment is built on first use in `target/tmp/python_cache` and reused by later runs
//! (a changed `sim/requirements.txt` builds a new one beside it). Without python3 (3.10+, with venv)
//! or without PyPI these tests fail and say so: they never skip.

use keypose::python::{Harness, PyConfig};
use keypose::robot::{JointKind, Robot};
use serde_json::{json, Map, Value};
use std::sync::OnceLock;

/// Forward-kinematics agreement, metres (and unitless for axes).
const TOLERANCE: f64 = 1e-6;
/// Random poses per robot, besides q = 0 and home.
const RANDOM_POSES: usize = 50;
/// Largest static error allowed while a model holds home or q = 0 (gravity sag of the servos).
const MAX_SAG_DEG: f64 = 3.0;
const MAX_SAG_M: f64 = 0.001;

struct Case {
    robot: &'static str,
    /// TCP at q = 0 as docs/robots.md (§1.3, §11.3, §2.3, §3.3) measured it on the official models, metres;
    /// given there to 0.01 mm (SO-101), 0.1 mm (Koch) and 0.1 mm (OpenMANIPULATOR-X).
    measured_tcp: [f64; 3],
    /// A pose (joint, value in the description's unit) that puts the arm through the floor.
    into_floor: &'static [(&'static str, f64)],
    /// A pose that folds the arm into itself (two links that are not neighbours touch).
    into_itself: &'static [(&'static str, f64)],
}

const CASES: [Case; 4] = [
    Case {
        robot: "so101",
        measured_tcp: [0.39136, -0.00001, 0.22647],
        into_floor: &[("shoulder_lift", 99.0), ("elbow_flex", 30.0)],
        into_itself: &[("elbow_flex", 96.0), ("wrist_flex", 90.0)],
    },
    Case {
        robot: "so100",
        measured_tcp: [0.0, -0.39276, 0.26558],
        into_floor: &[("shoulder_lift", 100.0)],
        into_itself: &[("elbow_flex", 89.0), ("wrist_flex", 105.0)],
    },
    Case {
        robot: "koch",
        measured_tcp: [-0.2150, 0.0059, 0.1678],
        into_floor: &[
            ("shoulder_lift", -89.0),
            ("elbow_flex", -30.0),
            ("wrist_flex", -100.0),
        ],
        into_itself: &[
            ("shoulder_lift", 20.0),
            ("elbow_flex", 80.0),
            ("wrist_flex", -90.0),
        ],
    },
    Case {
        robot: "omx",
        measured_tcp: [0.2860, 0.0, 0.2045],
        into_floor: &[("joint2", 85.0)],
        into_itself: &[("joint2", -60.0), ("joint3", 80.0), ("joint4", 112.0)],
    },
];

/// keypose's Python environment, built on first use by whichever test gets here first.
pub(crate) fn config() -> &'static PyConfig {
    static SHARED: OnceLock<Result<PyConfig, String>> = OnceLock::new();
    let built = SHARED.get_or_init(|| {
        let cache = crate::common::python_cache();
        let config = PyConfig::with_cache_dir(&cache);
        config.ensure_python().map_err(|e| {
            format!(
                "building keypose's Python environment in {} failed; these tests need python3 \
                 {}.{}+ with its venv module and access to PyPI: {e}",
                cache.display(),
                keypose::python::MIN_PYTHON.0,
                keypose::python::MIN_PYTHON.1
            )
        })?;
        Ok(config)
    });
    match built {
        Ok(config) => config,
        Err(reason) => panic!("{reason}"),
    }
}

pub(crate) fn harness() -> Harness {
    Harness::start_in(config(), "sim_harness.py", crate::common::patient_harness())
        .unwrap_or_else(|e| panic!("the MuJoCo harness did not start: {e}"))
}

pub(crate) fn robot(name: &str) -> Robot {
    Robot::builtin(name).unwrap_or_else(|| panic!("no built-in robot {name:?}"))
}

fn model_path(name: &str) -> String {
    format!("{}/sim/models/{name}.xml", env!("CARGO_MANIFEST_DIR"))
}

pub(crate) fn request(harness: &mut Harness, robot: &str, request: Value) -> Value {
    harness
        .request(&request)
        .unwrap_or_else(|e| panic!("{robot}: {request} failed: {e}"))
}

/// Loads a robot's model and returns the harness's description of it.
pub(crate) fn load(harness: &mut Harness, robot: &str) -> Value {
    let path = model_path(robot);
    request(harness, robot, json!({"op": "load", "mjcf": path}))
}

/// A joint value in MuJoCo's unit: keypose's revolute joints are in degrees, MuJoCo's hinges in
/// radians; prismatic joints are in metres on both sides.
pub(crate) fn to_sim(kind: JointKind, value: f64) -> f64 {
    match kind {
        JointKind::Revolute => value.to_radians(),
        JointKind::Prismatic => value,
    }
}

/// SplitMix64: a fixed seed gives the same poses on every platform.
pub(crate) struct Prng(pub(crate) u64);

impl Prng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi].
    pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let unit = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * unit
    }
}

pub(crate) fn vec3(value: &Value, what: &str) -> [f64; 3] {
    let items = value
        .as_array()
        .filter(|items| items.len() == 3)
        .unwrap_or_else(|| panic!("{what}: expected [x, y, z], got {value}"));
    let mut out = [0.0; 3];
    for (slot, item) in out.iter_mut().zip(items) {
        *slot = item
            .as_f64()
            .unwrap_or_else(|| panic!("{what}: expected numbers, got {value}"));
    }
    out
}

fn max_deviation(a: [f64; 3], b: [f64; 3]) -> f64 {
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// A pose in the description's units: the listed joints set, the others at 0.
fn pose(robot: &Robot, values: &[(&str, f64)]) -> Vec<f64> {
    let mut pose = vec![0.0; robot.joints.len()];
    for (name, value) in values {
        let index = robot
            .joint_index(name)
            .unwrap_or_else(|| panic!("{}: no joint {name:?}", robot.name));
        pose[index] = *value;
    }
    pose
}

fn sim_pose(robot: &Robot, values: &[f64]) -> Vec<f64> {
    robot
        .joints
        .iter()
        .zip(values)
        .map(|(joint, &value)| to_sim(joint.kind, value))
        .collect()
}

/// Holds `values` (the description's units) with every actuated joint of the description for
/// `rows` control periods; returns the harness's reply.
fn hold(harness: &mut Harness, robot: &Robot, values: &[f64], rows: usize) -> Value {
    let sim = sim_pose(robot, values);
    let reply = request(
        harness,
        &robot.name,
        json!({
            "op": "run",
            "joints": robot.joint_names(),
            "control_hz": robot.control_hz,
            "initial": sim,
            "commands": vec![sim.clone(); rows],
        }),
    );
    let divergence = reply["divergence"].as_array().map_or(0, Vec::len);
    assert_eq!(
        divergence, 0,
        "{}: holding {values:?} diverged or warned: {}",
        robot.name, reply["divergence"]
    );
    reply
}

fn contact_kinds(reply: &Value) -> Vec<String> {
    reply["contacts"]
        .as_array()
        .unwrap_or_else(|| panic!("a run reply without contacts: {reply}"))
        .iter()
        .map(|contact| contact["kind"].as_str().unwrap_or("?").to_string())
        .collect()
}

#[test]
fn every_joint_of_the_description_is_in_its_model_with_the_same_range_and_a_servo() {
    let mut harness = harness();
    for case in &CASES {
        let robot = robot(case.robot);
        let model = load(&mut harness, case.robot);
        assert_eq!(model["timestep"], json!(0.002), "{}: {model}", case.robot);
        let joints = model["joints"]
            .as_array()
            .unwrap_or_else(|| panic!("{}: no joints in {model}", case.robot));
        let actuators = model["actuators"]
            .as_array()
            .unwrap_or_else(|| panic!("{}: no actuators in {model}", case.robot));
        for joint in &robot.joints {
            let found = joints
                .iter()
                .find(|j| j["name"] == json!(joint.name))
                .unwrap_or_else(|| {
                    panic!(
                        "{}: joint {:?} of robots/{}.json is not in {}: {model}",
                        case.robot,
                        joint.name,
                        case.robot,
                        model_path(case.robot)
                    )
                });
            let kind = match joint.kind {
                JointKind::Revolute => "hinge",
                JointKind::Prismatic => "slide",
            };
            assert_eq!(found["type"], json!(kind), "{}: {found}", case.robot);
            assert_eq!(found["limited"], json!(true), "{}: {found}", case.robot);
            let range = found["range"]
                .as_array()
                .filter(|r| r.len() == 2)
                .unwrap_or_else(|| panic!("{}: {found}", case.robot));
            let expected = [
                to_sim(joint.kind, joint.limits.min),
                to_sim(joint.kind, joint.limits.max),
            ];
            for (bound, want) in range.iter().zip(expected) {
                let got = bound.as_f64().expect("a number");
                assert!(
                    (got - want).abs() <= 1e-9,
                    "{}: joint {:?} range {range:?}, expected {expected:?} (the json limits {} … {} {})",
                    case.robot,
                    joint.name,
                    joint.limits.min,
                    joint.limits.max,
                    joint.kind.unit()
                );
            }

            let servo = actuators
                .iter()
                .find(|a| a["joint"] == json!(joint.name))
                .unwrap_or_else(|| {
                    panic!(
                        "{}: joint {:?} has no position actuator: {model}",
                        case.robot, joint.name
                    )
                });
            assert_eq!(servo["name"], json!(joint.name), "{}: {servo}", case.robot);
            assert!(
                servo["kp"].as_f64().is_some_and(|kp| kp > 0.0),
                "{}: {servo}",
                case.robot
            );
            assert_eq!(
                servo["forcelimited"],
                json!(true),
                "{}: {servo}",
                case.robot
            );
            let [lo, hi] = [0, 1].map(|i| servo["forcerange"][i].as_f64().unwrap_or(f64::NAN));
            assert!(lo < 0.0 && hi > 0.0, "{}: {servo}", case.robot);
        }
        let sites = model["sites"].as_array().expect("sites");
        assert!(
            sites.contains(&json!("tcp")),
            "{}: no tcp site: {model}",
            case.robot
        );
    }
}

#[test]
fn mujoco_kinematics_equal_keypose_forward_kinematics() {
    let mut harness = harness();
    let mut rng = Prng(0x6b65_7970_6f73_6531);
    for case in &CASES {
        let robot = robot(case.robot);
        load(&mut harness, case.robot);
        let mut poses = vec![vec![0.0; robot.joints.len()], robot.home.clone()];
        for _ in 0..RANDOM_POSES {
            poses.push(
                robot
                    .joints
                    .iter()
                    .map(|j| rng.uniform(j.limits.min, j.limits.max))
                    .collect(),
            );
        }
        let (mut worst_anchor, mut worst_axis, mut worst_tcp) = (0.0_f64, 0.0_f64, 0.0_f64);
        for values in &poses {
            let mut qpos = Map::new();
            for (joint, &value) in robot.joints.iter().zip(values) {
                qpos.insert(joint.name.clone(), json!(to_sim(joint.kind, value)));
            }
            let reply = request(
                &mut harness,
                case.robot,
                json!({"op": "kinematics", "qpos": qpos, "sites": ["tcp"]}),
            );
            let expected = robot.joint_axes(values);
            for ((joint, &value), (anchor, axis)) in robot.joints.iter().zip(values).zip(&expected)
            {
                let what = format!("{} {values:?}: joint {:?}", case.robot, joint.name);
                let mut mj_anchor = vec3(&reply["anchors"][&joint.name], &what);
                let mj_axis = vec3(&reply["axes"][&joint.name], &what);
                if joint.kind == JointKind::Prismatic {
                    // MuJoCo anchors a slide joint where it starts; keypose's joint frame is the
                    // moving one, value × axis further on.
                    for (a, x) in mj_anchor.iter_mut().zip(mj_axis) {
                        *a += value * x;
                    }
                }
                let anchor_dev = max_deviation(mj_anchor, anchor.to_array());
                let axis_dev = max_deviation(mj_axis, axis.to_array());
                assert!(
                    anchor_dev <= TOLERANCE,
                    "{what}: MuJoCo anchor {mj_anchor:?}, keypose {anchor}"
                );
                assert!(
                    axis_dev <= TOLERANCE,
                    "{what}: MuJoCo axis {mj_axis:?}, keypose {axis}"
                );
                worst_anchor = worst_anchor.max(anchor_dev);
                worst_axis = worst_axis.max(axis_dev);
            }
            let tcp = vec3(&reply["sites"]["tcp"], &format!("{} tcp", case.robot));
            let want = robot.tcp_position(values);
            let tcp_dev = max_deviation(tcp, want.to_array());
            assert!(
                tcp_dev <= TOLERANCE,
                "{} {values:?}: MuJoCo tcp {tcp:?}, keypose {want}",
                case.robot
            );
            worst_tcp = worst_tcp.max(tcp_dev);
        }
        eprintln!(
            "{}: {} poses, largest deviation: anchors {worst_anchor:.1e} m, axes {worst_axis:.1e}, \
             tcp {worst_tcp:.1e} m",
            case.robot,
            poses.len()
        );
    }
}

#[test]
fn the_tcp_at_zero_is_where_the_data_sheet_measured_it() {
    let mut harness = harness();
    for case in &CASES {
        load(&mut harness, case.robot);
        let reply = request(
            &mut harness,
            case.robot,
            json!({"op": "kinematics", "qpos": {}, "sites": ["tcp"]}),
        );
        let tcp = vec3(&reply["sites"]["tcp"], case.robot);
        // The sheet rounds to 0.1 mm at worst.
        assert!(
            max_deviation(tcp, case.measured_tcp) <= 1e-4,
            "{}: tcp at q = 0 is {tcp:?}, docs/robots.md measured {:?}",
            case.robot,
            case.measured_tcp
        );
    }
}

#[test]
fn holding_home_or_zero_touches_nothing_and_barely_sags() {
    let mut harness = harness();
    for case in &CASES {
        let robot = robot(case.robot);
        load(&mut harness, case.robot);
        let rows = (2.0 * robot.control_hz).round() as usize;
        for (label, values) in [
            ("q = 0", vec![0.0; robot.joints.len()]),
            ("home", robot.home.clone()),
        ] {
            let reply = hold(&mut harness, &robot, &values, rows);
            let contacts = reply["contacts"].as_array().expect("contacts");
            assert!(
                contacts.is_empty(),
                "{}: holding {label} touches: {}",
                case.robot,
                reply["contacts"]
            );
            let last = reply["trace"]["qpos"]
                .as_array()
                .and_then(|rows| rows.last())
                .unwrap_or_else(|| panic!("{}: an empty trace: {reply}", case.robot));
            for ((joint, &value), got) in robot.joints.iter().zip(&values).zip(
                last.as_array()
                    .expect("a row of qpos")
                    .iter()
                    .map(|q| q.as_f64().expect("a number")),
            ) {
                let error = got - to_sim(joint.kind, value);
                let (error, bound) = match joint.kind {
                    JointKind::Revolute => (error.to_degrees(), MAX_SAG_DEG),
                    JointKind::Prismatic => (error, MAX_SAG_M),
                };
                assert!(
                    error.abs() <= bound,
                    "{}: holding {label}, joint {:?} sags {error} {} (more than {bound})",
                    case.robot,
                    joint.name,
                    joint.kind.unit()
                );
            }
        }
    }
}

#[test]
fn pushing_an_arm_into_the_floor_or_into_itself_makes_contacts() {
    let mut harness = harness();
    for case in &CASES {
        let robot = robot(case.robot);
        load(&mut harness, case.robot);
        for (label, values, kind) in [
            ("into the floor", case.into_floor, "floor"),
            ("into itself", case.into_itself, "self"),
        ] {
            let reply = hold(&mut harness, &robot, &pose(&robot, values), 1);
            let kinds = contact_kinds(&reply);
            assert!(
                kinds.iter().any(|k| k == kind),
                "{}: {label} {values:?} gives no {kind} contact: {}",
                case.robot,
                reply["contacts"]
            );
        }
    }
}

/// Inverse kinematics against MuJoCo: tool targets (positions of random poses above the floor,
/// half with their orientation) solved from home by keypose, the solved joints set in each
/// arm's MuJoCo model, and MuJoCo's `tcp` site measured within 0.5 mm of the target.
#[test]
fn mujoco_puts_the_tool_of_solved_joints_on_the_target() {
    use keypose::kinematics::{lowest_below_floor, Solver, ToolTarget};
    const TARGETS: usize = 20;
    const WITHIN_M: f64 = 0.0005;
    let mut harness = harness();
    let mut rng = Prng(0x696b_5f74_6f6f_6c73);
    for case in &CASES {
        let robot = robot(case.robot);
        load(&mut harness, case.robot);
        let solver = Solver::for_robot(&robot);
        let held = vec![false; robot.joints.len()];
        let mut solved = 0;
        while solved < TARGETS {
            let truth: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| rng.uniform(j.limits.min, j.limits.max))
                .collect();
            if lowest_below_floor(&robot, &truth).is_some() {
                continue;
            }
            let frame = robot.tcp_frame(&truth);
            let target = if solved % 2 == 0 {
                ToolTarget::position(frame.t)
            } else {
                ToolTarget::pose(frame.t, frame.r)
            };
            let Ok(solution) = solver.solve(&robot, &target, &robot.home, &held) else {
                // Only near the pan axis can an oriented target be missed (docs/robots.md §12.2).
                assert!(
                    target.orientation.is_some(),
                    "{}: {frame:?} unsolved",
                    case.robot
                );
                continue;
            };
            let mut qpos = Map::new();
            for (joint, &value) in robot.joints.iter().zip(&solution.values) {
                qpos.insert(joint.name.clone(), json!(to_sim(joint.kind, value)));
            }
            let reply = request(
                &mut harness,
                case.robot,
                json!({"op": "kinematics", "qpos": qpos, "sites": ["tcp"]}),
            );
            let tcp = vec3(&reply["sites"]["tcp"], &format!("{} tcp", case.robot));
            let miss = max_deviation(tcp, frame.t.to_array());
            assert!(
                miss <= WITHIN_M,
                "{}: target {:?}, joints {:?}: MuJoCo's tcp {tcp:?} is {:.2} mm off",
                case.robot,
                frame.t,
                solution.values,
                miss * 1000.0
            );
            solved += 1;
        }
    }
}
