//! The JSON lines of the MuJoCo harness, typed: the requests [`Simulation`](super::Simulation)
//! sends and the replies it reads (sim/PROTOCOL.md is the wire format; the harness adds and
//! echoes `seq`). Everything here is in the model's units: radians or metres, seconds, newtons.

use crate::python::HarnessError;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

use super::SimError;

/// A request line, by its `op`.
#[derive(Debug, Serialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub(super) enum Request<'a> {
    /// One arm's model (`mjcf`), or a cell's scene of every arm's model at its base (`arms`).
    Load(Load),
    /// The contacts of one pose, with no dynamics.
    Contacts {
        /// Model joint name → position.
        qpos: BTreeMap<&'a str, f64>,
    },
    /// The distances of pairs of bodies (a body and the floor for `None`) at one pose, with no
    /// dynamics, up to `distmax` metres.
    Distances {
        /// Model joint name → position.
        qpos: BTreeMap<&'a str, f64>,
        pairs: Vec<[Option<&'a str>; 2]>,
        distmax: f64,
    },
    /// The loaded model's joints and their position actuators made the robot's servos as
    /// built: model joint name → what drives it.
    Drive {
        joints: BTreeMap<&'a str, JointDrive>,
    },
    /// Each joint's generalized force for one state of motion (`mj_inverse`), gravity,
    /// inertia and armature only.
    Inverse {
        /// Model joint name → position.
        qpos: BTreeMap<&'a str, f64>,
        /// Model joint name → velocity.
        qvel: BTreeMap<&'a str, f64>,
        /// Model joint name → acceleration.
        qacc: BTreeMap<&'a str, f64>,
    },
    /// Commands held one control period each, the trace recorded after each.
    Run {
        joints: &'a [String],
        control_hz: f64,
        initial: Vec<f64>,
        /// `false` continues the previous run's state.
        reset: bool,
        commands: Vec<Vec<f64>>,
        #[serde(skip_serializing_if = "Option::is_none")]
        profile: Option<&'a ProfileLimits>,
        /// How the trace comes back.
        trace: TraceForm,
    },
    /// The listed joints made the shafts of emulated servos, at rest at `qpos`.
    ServosStart {
        joints: &'a [String],
        qpos: Vec<f64>,
        /// Seconds the limp arm first falls to rest (0: it starts at `qpos`).
        settle: f64,
    },
    /// The emulated servos' arm stepped to `until` seconds with each joint's motor as given.
    ServosStep { until: f64, drives: Vec<ServoDrive> },
    /// Frames drawn to an image or an animation.
    Render {
        joints: &'a [String],
        frames: Vec<Vec<f64>>,
        labels: &'a [String],
        path: String,
        width: u32,
        height: u32,
        fps: u32,
        columns: u32,
        /// Degrees, MuJoCo's free camera.
        azimuth: f64,
        /// Degrees, negative from above.
        elevation: f64,
    },
}

/// How a run's trace comes back: keypose always asks for the binary form (`trace_bytes`); the
/// JSON form (the harness's default) is for people and tests speaking to the harness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum TraceForm {
    /// Raw little-endian f64 after the reply line (sim/PROTOCOL.md, run).
    Binary,
}

/// What a `load` request loads.
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub(super) enum Load {
    /// One model file.
    Model {
        mjcf: String,
        /// An MJCF file of objects added to the scene (`--scene`).
        #[serde(skip_serializing_if = "Option::is_none")]
        scene: Option<String>,
    },
    /// A cell's scene.
    Cell {
        arms: Vec<SceneArm>,
        /// An MJCF file of objects added to the scene (`--scene`).
        #[serde(skip_serializing_if = "Option::is_none")]
        scene: Option<String>,
    },
}

impl Load {
    /// The same load with the objects of `scene` added.
    pub fn with_scene(self, scene: Option<String>) -> Load {
        match self {
            Load::Model { mjcf, .. } => Load::Model { mjcf, scene },
            Load::Cell { arms, .. } => Load::Cell { arms, scene },
        }
    }
}

/// One emulated servo's motor for a step of `servos_step`, in the model's units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(super) struct ServoDrive {
    pub on: bool,
    pub goal: f64,
    pub kp: f64,
    pub force: f64,
    pub damping: f64,
    /// The firmware's profile: `None` none.
    pub acceleration: Option<f64>,
    pub velocity: Option<f64>,
    /// Where a hand pulls the joint: `None` no hand.
    pub hand: Option<f64>,
}

/// The reply to `servos_step`: each joint's state in the request's order.
#[derive(Debug, Deserialize)]
pub(super) struct ServosStepReply {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    /// The position loop's output, N·m or N.
    #[serde(rename = "loop")]
    pub output: Vec<f64>,
    /// The motor's torque after its torque-speed line, N·m or N.
    pub torque: Vec<f64>,
    /// Seconds of wall time stepping took so far.
    pub wall: f64,
    /// Seconds simulated so far.
    pub simulated: f64,
}

/// One arm of a cell's scene: its model placed at its base.
#[derive(Debug, Serialize)]
pub(super) struct SceneArm {
    pub name: String,
    pub mjcf: String,
    /// The base's position in the scene, metres.
    pub pos: [f64; 3],
    /// The base's rotation, MuJoCo's order: w first.
    pub quat: [f64; 4],
}

/// The servos' own motion profile modelled in a `run` (`--servo-profile`), per joint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(super) struct ProfileLimits {
    /// Per second squared.
    pub acceleration: Vec<f64>,
    /// Per second; `None`: no velocity limit.
    pub velocity: Vec<Option<f64>>,
}

/// The reply to `load`.
#[derive(Debug, Deserialize)]
pub(super) struct LoadReply {
    /// Seconds of physics per step.
    pub timestep: f64,
    /// The model's named hinge and slide joints.
    pub joints: Vec<ModelJoint>,
    /// The position actuators on those joints.
    pub actuators: Vec<Actuator>,
}

/// The `drive` reply: the position servos as they are now.
#[derive(Debug, Deserialize)]
pub(super) struct DriveReply {
    pub actuators: Vec<Actuator>,
}

/// A joint of the loaded model.
#[derive(Debug, Deserialize)]
pub(super) struct ModelJoint {
    pub name: String,
}

/// A position actuator of the loaded model.
#[derive(Debug, Deserialize)]
pub(super) struct Actuator {
    /// The joint it drives (`None`: an unnamed joint).
    pub joint: Option<String>,
    /// Lowest and highest force, N·m or N, applied only when `forcelimited`.
    pub forcerange: [f64; 2],
    pub forcelimited: bool,
}

/// The reply to `run`; its trace follows it as bytes ([`super::trace_bytes`]).
#[derive(Debug, Deserialize)]
pub(super) struct RunReply {
    pub contacts: Vec<ContactReply>,
    pub divergence: Vec<Divergence>,
}

/// One value per recorded row, or per row and joint in the request's `joints` order.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct TraceReply {
    pub time: Vec<f64>,
    pub qpos: Vec<Vec<f64>>,
    pub qvel: Vec<Vec<f64>>,
    /// The position actuator's force.
    pub force: Vec<Vec<f64>>,
    /// 1 where a joint-limit constraint is active, else 0.
    pub limit: Vec<Vec<f64>>,
}

impl TraceReply {
    /// At most the `commanded` rows sent, every matrix as many rows as `time` of one value per
    /// joint: anything else would misalign the verdict's columns.
    pub fn check_rows(&self, commanded: usize, joints: usize) -> Result<(), SimError> {
        let reply_error = |detail: String| SimError::Reply { op: "run", detail };
        let n = self.time.len();
        if n > commanded {
            return Err(reply_error(format!(
                "trace.time has {n} rows; expected at most the {commanded} commanded"
            )));
        }
        let matrices = [
            ("qpos", &self.qpos),
            ("qvel", &self.qvel),
            ("force", &self.force),
            ("limit", &self.limit),
        ];
        for (name, matrix) in matrices {
            if matrix.len() != n {
                return Err(reply_error(format!(
                    "trace.{name} has {} rows; expected {n}, as trace.time",
                    matrix.len()
                )));
            }
            if let Some(row) = matrix.iter().position(|r| r.len() != joints) {
                return Err(reply_error(format!(
                    "trace.{name} row {row} has {} values; expected one per joint ({joints})",
                    matrix[row].len()
                )));
            }
        }
        Ok(())
    }
}

/// A MuJoCo warning or a non-finite state met during a run.
#[derive(Debug, Deserialize)]
pub(super) struct Divergence {
    pub time: f64,
    pub message: String,
    /// `Some(false)`: a warning the run went on after (a full contact buffer).
    pub fatal: Option<bool>,
}

/// The reply to `contacts`.
#[derive(Debug, Deserialize)]
pub(super) struct ContactsReply {
    pub contacts: Vec<ContactReply>,
}

/// The `distances` reply: one per pair asked, `None` at `distmax` or beyond.
#[derive(Debug, Deserialize)]
pub(super) struct DistancesReply {
    pub distances: Vec<Option<f64>>,
}

/// One joint's servo in the model's units (N·m and rad, or N and m for a slide): its position
/// loop's stiffness, the force it is bounded by, the joint's damping (the slope of the
/// torque-speed line: a saturated actuator then runs along it), armature and friction.
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct JointDrive {
    pub kp: f64,
    pub force: f64,
    pub damping: f64,
    pub armature: f64,
    pub frictionloss: f64,
}

/// The `inverse` reply: every model joint's generalized force, N·m or N.
#[derive(Debug, Deserialize)]
pub(super) struct InverseReply {
    pub force: BTreeMap<String, f64>,
}

/// A penetrating contact.
#[derive(Debug, Deserialize)]
pub(super) struct ContactReply {
    /// Absent in a pose's contacts.
    #[serde(default)]
    pub time: f64,
    pub body1: String,
    pub body2: String,
    pub kind: ContactKindReply,
    /// In a cell's scene, the arms of `body1` and `body2` (`None`: the world's).
    #[serde(default)]
    pub arm1: Option<String>,
    #[serde(default)]
    pub arm2: Option<String>,
    /// −dist, metres.
    pub depth: f64,
    /// Normal force, newtons.
    pub force: f64,
}

/// What a contact touches, as the harness classifies it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum ContactKindReply {
    Floor,
    #[serde(rename = "self")]
    SelfCollision,
    Arms,
    #[serde(other)]
    Environment,
}

/// The reply to `render`.
#[derive(Debug, Deserialize)]
pub(super) struct RenderReply {
    /// The GL backend that drew it.
    pub gl: Option<String>,
}

/// A reply with `"ok": false`, as far as keypose tells refusals apart.
#[derive(Debug, Deserialize)]
pub(super) struct Refusal {
    pub kind: RefusalKind,
    pub error: Option<String>,
}

/// Which refusals keypose tells apart: a model MuJoCo cannot load, no GL context for a render.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(super) enum RefusalKind {
    Model,
    Render,
    #[serde(other)]
    Other,
}

/// The harness's refusal behind `error`; `None` when it did not answer with one.
pub(super) fn refusal(error: &HarnessError) -> Option<Refusal> {
    Refusal::deserialize(error.reply()?).ok()
}

/// A successful reply to `op` as its type; a member missing or of the wrong type is
/// [`SimError::Reply`].
pub(super) fn parse<R: DeserializeOwned>(reply: Value, op: &'static str) -> Result<R, SimError> {
    R::deserialize(&reply).map_err(|error| SimError::Reply {
        op,
        detail: error.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn requests_are_the_lines_of_the_protocol() {
        let profile = ProfileLimits {
            acceleration: vec![6.0],
            velocity: vec![None],
        };
        let joints = ["elbow".to_string()];
        let run = Request::Run {
            joints: &joints,
            control_hz: 100.0,
            initial: vec![0.5],
            reset: false,
            commands: vec![vec![0.5], vec![0.6]],
            profile: Some(&profile),
            trace: TraceForm::Binary,
        };
        assert_eq!(
            serde_json::to_value(&run).unwrap(),
            json!({"op": "run", "joints": ["elbow"], "control_hz": 100.0, "initial": [0.5],
                   "reset": false, "commands": [[0.5], [0.6]],
                   "profile": {"acceleration": [6.0], "velocity": [null]},
                   "trace": "binary"})
        );
        let load = Request::Load(Load::Model {
            mjcf: "arm.xml".into(),
            scene: None,
        });
        assert_eq!(
            serde_json::to_value(&load).unwrap(),
            json!({"op": "load", "mjcf": "arm.xml"})
        );
        let cell = Request::Load(Load::Cell {
            arms: vec![SceneArm {
                name: "left".into(),
                mjcf: "so101.xml".into(),
                pos: [0.0, 0.2, 0.0],
                quat: [1.0, 0.0, 0.0, 0.0],
            }],
            scene: Some("block.xml".into()),
        });
        assert_eq!(
            serde_json::to_value(&cell).unwrap(),
            json!({"op": "load", "arms": [{"name": "left", "mjcf": "so101.xml",
                   "pos": [0.0, 0.2, 0.0], "quat": [1.0, 0.0, 0.0, 0.0]}],
                   "scene": "block.xml"})
        );
        let contacts = Request::Contacts {
            qpos: BTreeMap::from([("elbow", 0.25)]),
        };
        assert_eq!(
            serde_json::to_value(&contacts).unwrap(),
            json!({"op": "contacts", "qpos": {"elbow": 0.25}})
        );
    }

    #[test]
    fn a_reply_missing_a_member_is_a_reply_error_naming_it() {
        let reply = json!({"ok": true, "steps": 10, "payload": 16, "divergence": []});
        let error = parse::<RunReply>(reply, "run").unwrap_err();
        assert!(
            matches!(error, SimError::Reply { op: "run", .. }),
            "{error:?}"
        );
        let message = error.to_string();
        assert!(
            message.contains("reply to run") && message.contains("contacts"),
            "{message}"
        );
    }

    #[test]
    fn a_trace_whose_rows_do_not_match_is_refused() {
        let trace = |time: Vec<f64>, qpos: Vec<Vec<f64>>| TraceReply {
            time,
            qpos,
            qvel: vec![vec![0.0]],
            force: vec![vec![0.0]],
            limit: vec![vec![1.0]],
        };
        let fits = trace(vec![0.01], vec![vec![0.1]]);
        assert!(fits.check_rows(1, 1).is_ok());
        // More rows than were commanded: the stream's rows cannot be cut to them.
        let error = fits.check_rows(0, 1).unwrap_err().to_string();
        assert!(error.contains("1 rows; expected at most the 0"), "{error}");
        let short = trace(vec![0.01], vec![]);
        let error = short.check_rows(1, 1).unwrap_err().to_string();
        assert!(
            error.contains("trace.qpos has 0 rows; expected 1"),
            "{error}"
        );
        let error = fits.check_rows(1, 2).unwrap_err().to_string();
        assert!(error.contains("trace.qpos row 0 has 1 values"), "{error}");
    }

    #[test]
    fn contacts_read_with_and_without_time_and_arms() {
        let reply = json!({"ok": true, "contacts": [
            {"body1": "gripper", "body2": "world", "kind": "floor", "depth": 0.002, "force": 3.0},
            {"time": 0.5, "body1": "left/a", "body2": "right/b", "kind": "arms",
             "arm1": "left", "arm2": "right", "depth": 0.001, "force": 1.0},
            {"body1": "a", "body2": "b", "kind": "self", "arm1": null, "depth": 0.0,
             "force": 0.0},
            {"body1": "a", "body2": "box", "kind": "environment", "depth": 0.0, "force": 0.0}]});
        let contacts = parse::<ContactsReply>(reply, "contacts").unwrap().contacts;
        let kinds: Vec<_> = contacts.iter().map(|c| c.kind).collect();
        assert_eq!(
            kinds,
            [
                ContactKindReply::Floor,
                ContactKindReply::Arms,
                ContactKindReply::SelfCollision,
                ContactKindReply::Environment
            ]
        );
        assert_eq!(contacts[0].time, 0.0);
        assert_eq!(contacts[1].time, 0.5);
        assert_eq!(contacts[1].arm2.as_deref(), Some("right"));
        assert_eq!(contacts[2].arm1, None);
    }

    #[test]
    fn refusals_are_told_apart_by_kind() {
        let failed = |reply: Value| HarnessError::Failed {
            script: "sim_harness.py".into(),
            op: "load".into(),
            message: "no".into(),
            reply: Box::new(reply),
        };
        let model = refusal(&failed(
            json!({"ok": false, "kind": "model", "error": "bad xml"}),
        ));
        assert!(
            model.is_some_and(
                |r| r.kind == RefusalKind::Model && r.error.as_deref() == Some("bad xml")
            )
        );
        let state = refusal(&failed(
            json!({"ok": false, "kind": "state", "error": "no run"}),
        ));
        assert!(state.is_some_and(|r| r.kind == RefusalKind::Other));
    }
}
