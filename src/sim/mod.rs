//! Simulation in MuJoCo through the Python harness `sim/sim_harness.py`.
//!
//! The arm is commanded exactly as the player would command servos: the same [`Timeline`]
//! (approach ramp from the pose the arm rests in, the control rate, loops, speed), the same
//! joint values. The harness only measures; [`verdict`] decides. A cell of several arms is one
//! scene of every arm's model at its base, its joints named `ARM/JOINT` as the cell's are, so
//! that everything here treats it as one robot.

mod joint_map;
mod models;
mod servo_arm;
mod trace_bytes;
pub mod verdict;
mod warm;
mod wire;

pub use joint_map::{JointMap, MjcfModel};
pub use models::{check_mjcf_file, model_path};
pub use servo_arm::{MujocoArm, SETTLE_S};
pub use trace_bytes::TraceBytesError;
pub use warm::WarmSimulation;

use crate::plan::Trajectory;
use crate::plan::{Phase, Timeline, TimelineOptions};
use crate::python::{Harness, HarnessError, HarnessOptions, PyConfig, PyEnvError};
use crate::robot::{JointKind, Robot};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;
use verdict::{Contact, ContactKind, Trace};
use wire::{
    ContactKindReply, ContactReply, Load, ProfileLimits, RefusalKind, Request, SceneArm, TraceForm,
};

/// The harness script's file name among keypose's embedded Python scripts.
pub const HARNESS_SCRIPT: &str = "sim_harness.py";

/// MUJOCO_GL of a harness that only simulates: MuJoCo imports none of its rendering, which
/// takes a fifth of its start-up (sim/PROTOCOL.md).
const PHYSICS_ONLY: &str = "disable";

/// Why a simulation could not be started, run or rendered.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The Python environment could not be found or built.
    #[error(transparent)]
    Env(#[from] PyEnvError),
    /// The harness process failed, timed out or refused a request.
    #[error(transparent)]
    Harness(#[from] HarnessError),
    /// A model MuJoCo refuses, or that does not fit the robot (bad input).
    #[error("model {model}: {message}")]
    Model {
        /// The model's path, or the robot's name when keypose has no model of it.
        model: String,
        /// What is wrong with it.
        message: String,
    },
    /// A reply that lacks a member sim/PROTOCOL.md promises, or whose shape is wrong.
    #[error("the simulation's reply to {op} is not what the protocol says: {detail}")]
    Reply {
        /// The request's `op`.
        op: &'static str,
        /// What is missing or wrong.
        detail: String,
    },
    /// The binary trace after a run's reply is not what sim/PROTOCOL.md describes.
    #[error("the trace the simulation sent after its reply to run is malformed")]
    TraceBytes(#[source] TraceBytesError),
    /// The harness died, was started again, and died again.
    #[error("the simulation's harness died ({first}); started again, it died again")]
    DiedAgain {
        /// How it died the first time.
        first: String,
        /// How it died the second time.
        #[source]
        second: HarnessError,
    },
    /// A joint whose servo profile (`--servo-profile`) cannot be modelled.
    #[error(transparent)]
    ServoProfile(#[from] crate::robot::ProfileError),
    /// No GL context could be made (each backend's failure, `; `-separated).
    #[error("rendering failed with both EGL and OSMesa: {0}")]
    Render(String),
}

impl SimError {
    /// What kind of failure this is: a model MuJoCo refuses is the user's to mend; anything
    /// else is the simulation's (its process, its environment).
    pub fn kind(&self) -> crate::error::ErrorKind {
        match self {
            SimError::Model { .. } | SimError::ServoProfile(_) => crate::error::ErrorKind::BadInput,
            _ => crate::error::ErrorKind::Hardware,
        }
    }
}

/// A model MuJoCo cannot load is bad input (exit 2), not a failure of the simulation.
fn model_error(error: HarnessError, model: &str) -> SimError {
    match wire::refusal(&error) {
        Some(refusal) if refusal.kind == RefusalKind::Model => SimError::Model {
            model: model.to_string(),
            message: refusal.error.unwrap_or_else(|| "does not load".to_string()),
        },
        _ => SimError::Harness(error),
    }
}

/// The `load` request of `robot`'s model, and the model's name in reports: `mjcf` or the
/// robot's built-in model; for a cell, the scene of every arm's built-in model, each at its
/// base, its joints prefixed with the arm's name as the cell's are (sim/PROTOCOL.md, load).
fn load_request(
    config: &PyConfig,
    robot: &Robot,
    mjcf: Option<&MjcfModel>,
) -> Result<(Load, String), SimError> {
    if !robot.is_cell() {
        let path: PathBuf = match mjcf {
            Some(m) => m.path.clone(),
            None => model_path(config, robot)?,
        };
        let model = path.display().to_string();
        return Ok((
            Load::Model {
                mjcf: model.clone(),
                scene: None,
            },
            model,
        ));
    }
    if let Some(m) = mjcf {
        return Err(SimError::Model {
            model: m.path.display().to_string(),
            message: format!(
                "is one arm's model; {} is simulated with each arm's built-in model",
                robot.description
            ),
        });
    }
    cell_load_request(config, robot)
}

/// The `load` request of a cell's scene and its name in reports: `ARM=MODEL, …`.
fn cell_load_request(config: &PyConfig, robot: &Robot) -> Result<(Load, String), SimError> {
    let mut arms = Vec::with_capacity(robot.arms.len());
    let mut names = Vec::with_capacity(robot.arms.len());
    for arm in &robot.arms {
        let path = model_path(config, &arm.robot).map_err(|e| match e {
            SimError::Model { model, .. } => SimError::Model {
                model,
                message: format!(
                    "arm {}: keypose has no built-in model of this robot, and a cell is simulated with its arms' built-in models",
                    arm.name
                ),
            },
            e => e,
        })?;
        let r = arm.base.r;
        arms.push(SceneArm {
            name: arm.name.clone(),
            mjcf: path.display().to_string(),
            pos: arm.base.t.to_array(),
            // MuJoCo's order: w first.
            quat: [r.w, r.x, r.y, r.z],
        });
        names.push(format!("{}={}", arm.name, path.display()));
    }
    Ok((Load::Cell { arms, scene: None }, names.join(", ")))
}

/// What the player would send, cycle by cycle, in joint units.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandStream {
    /// Control rate, Hz: one row per period.
    pub rate: f64,
    /// The pose the arm rests in before the first cycle.
    pub initial: Vec<f64>,
    /// The goals sent in each cycle, in joint order.
    pub rows: Vec<Vec<f64>>,
    /// Where the arm should be in each cycle: the timeline's pose, which the goals lead with
    /// droop compensation and equal without it.
    pub intended: Vec<Vec<f64>>,
    /// Sequence time of each row; `None` during ramps.
    pub sequence_time: Vec<Option<f64>>,
    /// The timeline's own sequence time of each row (during a ramp, where the ramp leads), as
    /// the player logs it.
    pub timeline_time: Vec<f64>,
    /// What the timeline was doing in each row.
    pub phase: Vec<Phase>,
    /// Which loop each row belongs to, as the player's progress line shows it ("2/3").
    pub loop_label: Vec<String>,
    /// Rows the player would send; any after them hold the final pose to judge settling.
    pub played: usize,
}

/// The commands of playing `trajectory` from the robot's home pose with `options` at `rate` Hz.
pub fn command_stream(
    robot: &Robot,
    trajectory: &Trajectory,
    options: &TimelineOptions,
    rate: f64,
) -> CommandStream {
    let initial = robot.home.clone();
    let mut timeline = Timeline::new(robot, trajectory, options, &initial);
    let mut stream = CommandStream {
        rate,
        initial: initial.clone(),
        rows: Vec::new(),
        intended: Vec::new(),
        sequence_time: Vec::new(),
        timeline_time: Vec::new(),
        phase: Vec::new(),
        loop_label: Vec::new(),
        played: 0,
    };
    let mut pose = vec![0.0; robot.joints.len()];
    let dt = 1.0 / rate;
    while let Some(phase) = timeline.sample_into(&mut pose) {
        let tau = timeline.sequence_time();
        let mut goals = pose.clone();
        timeline.goals_into(&mut goals, dt);
        stream.push(goals, pose.clone(), phase, tau, timeline.loop_label());
        timeline.advance(dt);
    }
    stream.played = stream.rows.len();
    stream
}

impl CommandStream {
    fn push(
        &mut self,
        goals: Vec<f64>,
        pose: Vec<f64>,
        phase: Phase,
        tau: f64,
        loop_label: String,
    ) {
        self.rows.push(goals);
        self.intended.push(pose);
        self.sequence_time.push(match phase {
            Phase::Approach | Phase::Return => None,
            Phase::Play | Phase::Stopping | Phase::Resuming => Some(tau),
        });
        self.timeline_time.push(tau);
        self.phase.push(phase);
        self.loop_label.push(loop_label);
    }

    /// Holds the final pose `seconds` longer (sequence time running on at `speed`), as the
    /// servos hold it after the player's last cycle, so that the last key is judged settled
    /// too.
    pub fn hold_at_end(&mut self, seconds: f64, speed: f64) {
        let (Some(goals), Some(pose), Some(&tau), Some(label)) = (
            self.rows.last().cloned(),
            self.intended.last().cloned(),
            self.timeline_time.last(),
            self.loop_label.last().cloned(),
        ) else {
            return;
        };
        // The player sends the final pose twice (its last cycle and once more): sequence time
        // runs on from the first of them, one cycle per row.
        let at_end = self
            .timeline_time
            .iter()
            .rev()
            .take_while(|&&t| (t - tau).abs() < 1e-9)
            .count();
        let cycles = (seconds * self.rate).ceil() as usize;
        for k in 1..=cycles {
            let t = tau + (at_end - 1 + k) as f64 * speed / self.rate;
            self.push(goals.clone(), pose.clone(), Phase::Play, t, label.clone());
        }
    }
}

/// Joint value (degrees / metres) to MuJoCo's (radians / metres).
fn to_model(robot: &Robot, values: &[f64]) -> Vec<f64> {
    robot
        .joints
        .iter()
        .zip(values)
        .map(|(j, &v)| to_model_one(j, v))
        .collect()
}

/// One joint's value (or rate) in the model's units: radians or metres.
fn to_model_one(joint: &crate::robot::Joint, value: f64) -> f64 {
    match joint.kind {
        JointKind::Revolute => value.to_radians(),
        JointKind::Prismatic => value,
    }
}

fn from_model(robot: &Robot, values: &[f64]) -> Vec<f64> {
    robot
        .joints
        .iter()
        .zip(values)
        .map(|(j, v)| match j.kind {
            JointKind::Revolute => v.to_degrees(),
            JointKind::Prismatic => *v,
        })
        .collect()
}

/// A loaded model in a running harness.
pub struct Simulation {
    harness: Harness,
    model: String,
    joints: Vec<String>,
    force_limits: Vec<Option<f64>>,
    /// Seconds of physics per MuJoCo step, the model's.
    pub timestep: f64,
    /// The servos' own profile to model (`--servo-profile`): the "profile" of every run.
    servo_profile: Option<ProfileLimits>,
    /// The build the model's servos were made ([`Simulation::build`]).
    build: Option<String>,
}

impl Simulation {
    /// Starts the harness (building the Python environment on first use) and loads the robot's
    /// model, or `mjcf` when given (its joints named as the robot's, through its joint map).
    /// `gl` is the OpenGL backend of a harness that renders; without one the harness simulates
    /// only, and starts faster.
    pub fn start(
        robot: &Robot,
        mjcf: Option<&MjcfModel>,
        gl: Option<&str>,
    ) -> Result<Simulation, SimError> {
        Simulation::start_in_scene(robot, mjcf, gl, None)
    }

    /// Like [`Simulation::start`], with the objects of the MJCF file `scene` (a block to
    /// pick, a fixture) in the scene beside the arm.
    pub fn start_in_scene(
        robot: &Robot,
        mjcf: Option<&MjcfModel>,
        gl: Option<&str>,
        scene: Option<&Path>,
    ) -> Result<Simulation, SimError> {
        let config = PyConfig::from_env()?;
        let mut options = HarnessOptions {
            // A long run is one request: allow minutes.
            request_timeout: Duration::from_secs(600),
            ..HarnessOptions::default()
        };
        options
            .env
            .push(("MUJOCO_GL".into(), gl.unwrap_or(PHYSICS_ONLY).into()));
        // The model's request first: a robot keypose has no model of is refused before Python
        // starts.
        let (load, model) = load_request(&config, robot, mjcf)?;
        let load = load.with_scene(scene.map(|p| p.display().to_string()));
        let harness = Harness::start_in(&config, HARNESS_SCRIPT, options)?;
        let mut sim = Simulation {
            harness,
            model: String::new(),
            joints: Vec::new(),
            force_limits: Vec::new(),
            timestep: 0.0,
            servo_profile: None,
            build: None,
        };
        sim.load_model(robot, mjcf, load, model)?;
        Ok(sim)
    }

    /// Loads `robot`'s model (or `mjcf`) in place of the one loaded, in the same harness: a
    /// session that simulates again pays for Python and MuJoCo once. The servos' profile is
    /// no longer modelled until [`Simulation::model_servo_profile`] is called again.
    pub fn load(&mut self, robot: &Robot, mjcf: Option<&MjcfModel>) -> Result<(), SimError> {
        let (load, model) = load_request(&PyConfig::from_env()?, robot, mjcf)?;
        self.load_model(robot, mjcf, load, model)
    }

    fn load_model(
        &mut self,
        robot: &Robot,
        mjcf: Option<&MjcfModel>,
        load: Load,
        model: String,
    ) -> Result<(), SimError> {
        let no_map = JointMap::default();
        let map = mjcf.map_or(&no_map, |m| &m.joint_map);
        self.model = model.clone();
        self.joints = robot
            .joints
            .iter()
            .map(|j| map.model_name(&j.name).to_string())
            .collect();
        self.servo_profile = None;
        let reply = self
            .harness
            .request(&Request::Load(load))
            .map_err(|e| model_error(e, &model))?;
        let reply: wire::LoadReply = wire::parse(reply, "load")?;
        self.timestep = reply.timestep;
        let model_joints: Vec<&str> = reply.joints.iter().map(|j| j.name.as_str()).collect();
        let missing: Vec<&str> = self
            .joints
            .iter()
            .map(String::as_str)
            .filter(|j| !model_joints.contains(j))
            .collect();
        if !missing.is_empty() {
            return Err(SimError::Model {
                model,
                message: format!(
                    "has no joint(s) {} of robot {}; its joints are: {}",
                    missing.join(", "),
                    robot.name,
                    model_joints.join(", ")
                ),
            });
        }
        let mut actuators = reply.actuators;
        self.build = None;
        // The model's servos are the robot's as it says it is built, whoever wrote the model:
        // an official model's actuators are a modeller's choice (the SO-101's kp of 998 turns
        // each control step into a force spike), the robot file's servos are what the arm has.
        let names = self.joints.clone();
        let joints = drives(robot, &names);
        if !joints.is_empty() {
            let reply = self.harness.request(&Request::Drive { joints })?;
            actuators = wire::parse::<wire::DriveReply>(reply, "drive")?.actuators;
            self.build = Some(crate::plan::build_name(robot));
        }
        self.force_limits = self
            .joints
            .iter()
            .map(|joint| {
                let a = actuators
                    .iter()
                    .find(|a| a.joint.as_deref() == Some(joint.as_str()))?;
                let [low, high] = a.forcerange;
                a.forcelimited.then(|| high.abs().min(low.abs()))
            })
            .collect();
        Ok(())
    }

    /// The build the model was made, as the check names it ("sts3215 c001 @ 5 V"); `None`
    /// where no servo of the robot has drive data, and the model keeps its own actuators.
    pub fn build(&self) -> Option<&str> {
        self.build.as_deref()
    }

    /// The model's name in reports: its path, or for a cell `ARM=PATH, …`.
    pub fn model(&self) -> &str {
        &self.model
    }

    /// Models the servos' own profile from now on, as `play --servo-profile` sets it (each
    /// joint's limits in its servo's register units, rounded down): each servo follows its goal
    /// within these acceleration and velocity limits.
    pub fn model_servo_profile(&mut self, robot: &Robot) -> Result<(), SimError> {
        let limits = robot
            .joints
            .iter()
            .map(crate::robot::profile::applied_limits)
            .collect::<Result<Vec<_>, _>>()?;
        let accelerations: Vec<f64> = limits.iter().map(|(a, _)| *a).collect();
        // Rates convert like positions: to_model only scales.
        let velocities: Vec<Option<f64>> = limits
            .iter()
            .zip(&robot.joints)
            .map(|((_, v), joint)| v.map(|v| to_model_one(joint, v)))
            .collect();
        self.servo_profile = Some(ProfileLimits {
            acceleration: to_model(robot, &accelerations),
            velocity: velocities,
        });
        Ok(())
    }

    /// Runs rows of `stream`, continuing from the current state unless `reset`. Times in the
    /// trace are the simulation clock, which goes on across continued runs.
    pub fn run(
        &mut self,
        robot: &Robot,
        stream: &CommandStream,
        rows: std::ops::Range<usize>,
        reset: bool,
    ) -> Result<Trace, SimError> {
        let commands: Vec<Vec<f64>> = stream.rows[rows.clone()]
            .iter()
            .map(|r| to_model(robot, r))
            .collect();
        let request = Request::Run {
            joints: &self.joints,
            control_hz: stream.rate,
            initial: to_model(robot, &stream.initial),
            reset,
            commands,
            profile: self.servo_profile.as_ref(),
            trace: TraceForm::Binary,
        };
        let answer = self.harness.request_with_payload(&request)?;
        let reply: wire::RunReply = wire::parse(answer.reply, "run")?;
        let Some(payload) = answer.payload else {
            return Err(SimError::Reply {
                op: "run",
                detail: "no binary trace followed it (no \"payload\" member)".to_string(),
            });
        };
        let trace = trace_bytes::decode(&payload).map_err(SimError::TraceBytes)?;
        let n = trace.time.len();
        trace.check_rows(rows.len(), self.joints.len())?;
        Ok(Trace {
            time: trace.time,
            sequence_time: stream.sequence_time[rows.clone()][..n].to_vec(),
            commanded: stream.rows[rows.clone()][..n].to_vec(),
            intended: stream.intended[rows][..n].to_vec(),
            position: trace.qpos.iter().map(|r| from_model(robot, r)).collect(),
            velocity: trace.qvel.iter().map(|r| from_model(robot, r)).collect(),
            force: trace.force,
            at_limit: trace
                .limit
                .iter()
                .map(|r| r.iter().map(|x| *x != 0.0).collect())
                .collect(),
            contacts: reply.contacts.into_iter().map(contact).collect(),
            divergence: reply
                .divergence
                .into_iter()
                // Non-fatal warnings (a full contact buffer) do not end the run.
                .filter(|d| d.fatal != Some(false))
                .map(|d| (d.time, d.message))
                .collect(),
            force_limits: self.force_limits.clone(),
        })
    }
}

impl Simulation {
    /// The contacts of the arm held still at `values` (joint units, joint order): MuJoCo's
    /// collision check at that pose with no dynamics, every penetration however shallow
    /// (which depth is a collision is the verdict's to say, [`verdict::Thresholds`]).
    pub fn pose_contacts(
        &mut self,
        robot: &Robot,
        values: &[f64],
    ) -> Result<Vec<Contact>, SimError> {
        let model = to_model(robot, values);
        let qpos = self.joints.iter().map(String::as_str).zip(model).collect();
        let reply = self.harness.request(&Request::Contacts { qpos })?;
        let reply: wire::ContactsReply = wire::parse(reply, "contacts")?;
        Ok(reply.contacts.into_iter().map(contact).collect())
    }
}

impl Simulation {
    /// The signed distance, metres, of each pair of bodies (`None` for the second: the body
    /// and the floor) with the arm held still at `values` (joint units, joint order), as
    /// MuJoCo measures it between the same shapes; `None` at `distmax` or farther. The oracle
    /// of `collision::CollisionModel`'s distances.
    pub fn pose_distances(
        &mut self,
        robot: &Robot,
        values: &[f64],
        pairs: &[(&str, Option<&str>)],
        distmax: f64,
    ) -> Result<Vec<Option<f64>>, SimError> {
        let model = to_model(robot, values);
        let qpos = self.joints.iter().map(String::as_str).zip(model).collect();
        let pairs = pairs.iter().map(|&(a, b)| [Some(a), b]).collect();
        let request = Request::Distances {
            qpos,
            pairs,
            distmax,
        };
        let reply = self.harness.request(&request)?;
        let reply: wire::DistancesReply = wire::parse(reply, "distances")?;
        Ok(reply.distances)
    }
}

impl Simulation {
    /// MuJoCo's inverse dynamics of one state of motion (joint units and their rates, joint
    /// order): every model joint's generalized force (N·m for a hinge, N for a slide), from
    /// gravity, inertia and armature alone. The oracle of `dynamics`; joints the robot
    /// does not have (a mimic finger) are in the reply too.
    pub fn pose_inverse(
        &mut self,
        robot: &Robot,
        values: &[f64],
        velocities: &[f64],
        accelerations: &[f64],
    ) -> Result<BTreeMap<String, f64>, SimError> {
        let named = |v: &[f64]| -> BTreeMap<&str, f64> {
            self.joints
                .iter()
                .map(String::as_str)
                .zip(to_model(robot, v))
                .collect()
        };
        let request = Request::Inverse {
            qpos: named(values),
            qvel: named(velocities),
            qacc: named(accelerations),
        };
        let reply = self.harness.request(&request)?;
        let reply: wire::InverseReply = wire::parse(reply, "inverse")?;
        Ok(reply.force)
    }
}

/// Each rated servo's drive in its model joint's (`names`) units: the position loop's
/// stiffness at the firmware gain, its stall torque as the force bound and the line's slope as
/// the joint's damping (a saturated servo then runs along its torque-speed line, to the
/// no-load speed), its rotor as armature, its friction.
fn drives<'a>(robot: &Robot, names: &'a [String]) -> BTreeMap<&'a str, wire::JointDrive> {
    robot
        .joints
        .iter()
        .zip(names)
        .filter_map(|(joint, name)| {
            let d = joint.servo.drive()?;
            let n = joint.servo.transmission(joint.kind);
            let stall = d.stall_torque.value;
            Some((
                name.as_str(),
                wire::JointDrive {
                    kp: d.stiffness.value / (n * n),
                    force: stall / n,
                    damping: stall / d.no_load_speed.value / (n * n),
                    armature: d.rotor_inertia.value / (n * n),
                    frictionloss: d.friction.value / n,
                },
            ))
        })
        .collect()
}

/// A contact of a `run` or `contacts` reply (a pose's contacts have no time: 0).
fn contact(c: ContactReply) -> Contact {
    Contact {
        time: c.time,
        body1: c.body1,
        body2: c.body2,
        kind: match c.kind {
            ContactKindReply::Floor => ContactKind::Floor,
            ContactKindReply::SelfCollision => ContactKind::SelfCollision,
            ContactKindReply::Arms => ContactKind::BetweenArms,
            ContactKindReply::Environment => ContactKind::Environment,
        },
        arms: [c.arm1, c.arm2],
        depth: c.depth.abs(),
        force: c.force,
    }
}

impl Trace {
    /// Appends a later part of the same run.
    pub fn extend(&mut self, more: Trace) {
        self.time.extend(more.time);
        self.sequence_time.extend(more.sequence_time);
        self.commanded.extend(more.commanded);
        self.intended.extend(more.intended);
        self.position.extend(more.position);
        self.velocity.extend(more.velocity);
        self.force.extend(more.force);
        self.at_limit.extend(more.at_limit);
        self.contacts.extend(more.contacts);
        self.divergence.extend(more.divergence);
        self.force_limits = more.force_limits;
    }
}

/// Where a render's camera looks from, degrees (MuJoCo's free camera: azimuth about +z,
/// elevation negative from above); it always looks at the middle of every frame's arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Degrees about +z.
    pub azimuth: f64,
    /// Degrees, negative looking from above (within ±90).
    pub elevation: f64,
}

impl Default for Camera {
    /// From the front-left and a little above (sim/PROTOCOL.md, render).
    fn default() -> Self {
        Camera {
            azimuth: 135.0,
            elevation: -20.0,
        }
    }
}

/// Renders `frames` (joint values) to `path` (.png contact sheet, .gif or .mp4), headless: EGL
/// first, OSMesa if EGL cannot make a context.
pub fn render(
    robot: &Robot,
    mjcf: Option<&MjcfModel>,
    frames: &[Vec<f64>],
    labels: &[String],
    path: &Path,
    camera: &Camera,
) -> Result<String, SimError> {
    let mut failures = Vec::new();
    for gl in ["egl", "osmesa"] {
        let mut sim = match Simulation::start(robot, mjcf, Some(gl)) {
            Ok(sim) => sim,
            Err(e) => {
                failures.push(format!("{gl}: {e}"));
                continue;
            }
        };
        let request = Request::Render {
            joints: &sim.joints,
            frames: frames.iter().map(|f| to_model(robot, f)).collect(),
            labels,
            path: path.display().to_string(),
            width: 320,
            height: 240,
            fps: 25,
            columns: 4,
            azimuth: camera.azimuth,
            elevation: camera.elevation,
        };
        let refused = match sim.harness.request(&request) {
            Ok(reply) => {
                let reply: wire::RenderReply = wire::parse(reply, "render")?;
                return Ok(reply.gl.unwrap_or_else(|| gl.to_string()));
            }
            Err(e) => e,
        };
        match wire::refusal(&refused) {
            Some(refusal) if refusal.kind == RefusalKind::Render => {
                failures.push(format!("{gl}: {refused}"));
            }
            _ => return Err(SimError::Harness(refused)),
        }
    }
    Err(SimError::Render(failures.join("; ")))
}
