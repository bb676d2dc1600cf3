//! Robot descriptions: the joint chain, limits, servo mapping and forward kinematics.
//!
//! A [`Robot`] is read from a robot file ([`Robot::load`], keypose-robot/1), taken from the
//! built-ins ([`Robot::builtin`], [`BUILTINS`]) or resolved from what the user typed
//! ([`Robot::resolve`]: a built-in, a LeRobot type name, or a path). A LeRobot calibration
//! moves its servo mapping and limits onto one physical arm ([`import_lerobot_calibration`]);
//! several arms make one cell ([`Robot::cell`]), its joints named `ARM/JOINT`.

mod build;
pub(crate) mod builtin;
mod cell;
mod gravity;
mod lerobot;
mod lerobot_names;
mod load;
pub use load::MAX_CLEARANCE_MM;
pub(crate) mod mjcf;
pub(crate) mod profile;
mod servo;

use crate::json::InputError;
use crate::pose::RigidTransform;
use glam::{DQuat, DVec3};
use std::fmt;
use std::path::{Path, PathBuf};

pub use crate::servo::Protocol;
pub use build::{Build, BuildError, BUILDS};
pub use builtin::{
    builtin_like, builtin_mjcf, named_like_hint, BuiltinRobot, BUILTINS, BUILTIN_NAMES,
};
pub use cell::{cell_joint_name, split_joint_name, Arm, CellError, MAX_CELL_JOINTS};
pub use lerobot::{
    import_lerobot_calibration, is_lerobot_gripper, CalibrationMismatch, CalibrationReport,
    IdMismatch, NotThisJoint, OutsideTheTurn, LEROBOT_GRIPPER, WIDEST_RECORDED_RANGE,
};
pub use lerobot_names::{
    calibration_candidates, calibration_root, BadRobotId, CalibrationRoot, LeRobotRole,
    LeRobotType, NoCalibrationRoot, NotBuiltIn, CALIBRATION_ENV_VARS,
};
pub use profile::ProfileError;
pub use servo::{PositionEncoding, Servo, ServoModel, TickError, Vendor};

/// The `format` a robot file declares.
pub const ROBOT_FORMAT: &str = "keypose-robot/1";

/// How a joint moves: it turns about its axis or slides along it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Values in degrees.
    Revolute,
    /// Values in metres.
    Prismatic,
}

impl JointKind {
    /// The unit of its values in messages and files: "deg" or "m".
    pub fn unit(self) -> &'static str {
        match self {
            JointKind::Revolute => "deg",
            JointKind::Prismatic => "m",
        }
    }

    /// How far a measured joint may be from where it should be and still count as there, in
    /// its unit: how far outside its limits it may start and still be ramped from or held (at
    /// the limit; calibration and backlash put a resting arm a little outside now and then,
    /// anything further is a real problem to solve by hand), and how close it must come to a
    /// final pose before it counts as arrived.
    pub fn position_slack(self) -> f64 {
        match self {
            JointKind::Revolute => 2.0,
            // A gripper's travel is a few centimetres: 2 mm is as coarse as 2° on a joint.
            JointKind::Prismatic => 0.002,
        }
    }
}

/// Limits in the joint's unit (degrees or metres) and per second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Lowest position.
    pub min: f64,
    /// Highest position.
    pub max: f64,
    /// Highest speed, per second.
    pub velocity: f64,
    /// Highest acceleration, per second squared.
    pub acceleration: f64,
    /// Highest jerk (rate of change of acceleration), per second cubed; None (the default)
    /// leaves jerk unlimited, and then nothing about jerk is checked or planned for.
    pub jerk: Option<f64>,
}

impl Limits {
    /// Whether `value` is within `min` … `max`, both included.
    pub fn contains(&self, value: f64) -> bool {
        value >= self.min && value <= self.max
    }
}

/// What set a joint's position limits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LimitsOrigin {
    /// The robot description.
    Robot,
    /// The range a LeRobot calibration recorded for the joint, which replaces the robot's
    /// limits (src/robot/lerobot.rs).
    RecordedRange {
        /// The calibration file.
        file: String,
    },
    /// The robot's limits moved into a LeRobot calibration's frame, for a joint it recorded no
    /// range for (a whole-turn joint), kept within that turn.
    Rebased {
        /// The calibration file.
        file: String,
    },
}

impl LimitsOrigin {
    /// Why the limits are what they are, for a message about a value outside them ("" when
    /// they are the robot's own).
    pub fn note(&self) -> String {
        match self {
            LimitsOrigin::Robot => String::new(),
            LimitsOrigin::RecordedRange { file } => {
                format!(" (the range recorded for it in the calibration {file})")
            }
            LimitsOrigin::Rebased { file } => format!(
                " (the robot's limits, moved to the zero of the calibration {file}, which \
                 recorded no range for this joint)"
            ),
        }
    }
}

/// One joint of the chain: how it moves, where it sits, its limits and its servo.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Unique within the robot (`ARM/JOINT` in a cell).
    pub name: String,
    /// Revolute (degrees) or prismatic (metres).
    pub kind: JointKind,
    /// Unit axis in the joint's own frame.
    pub axis: DVec3,
    /// Pose of the joint frame in its parent's frame (the previous joint's moving frame).
    pub origin: RigidTransform,
    /// Position, velocity and acceleration limits, in the joint's unit.
    pub limits: Limits,
    /// What set the position limits: the robot, or a calibration.
    pub limits_origin: LimitsOrigin,
    /// The servo that drives it, and how its ticks map to joint values.
    pub servo: Servo,
    /// The range a LeRobot calibration recorded, in the joint's unit; None without one.
    pub calibrated_range: Option<CalibratedRange>,
}

/// A calibration's recorded range as LeRobot's 0…100 scale (`MotorNormMode.RANGE_0_100`) sees
/// it, in the joint's unit: the value at 0 % and the value at 100 %. LeRobot puts 0 at
/// range_min and 100 at range_max, mirrored (`100 − x`) when it applies `drive_mode` 1 (on
/// Feetech only): keeping the two ends rather than low and high carries that mirroring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibratedRange {
    /// The joint value at 0 %.
    pub at_0: f64,
    /// The joint value at 100 %.
    pub at_100: f64,
}

impl CalibratedRange {
    /// The joint value at `percent` of the range (0 … 100, not checked here).
    pub fn value(&self, percent: f64) -> f64 {
        self.at_0 + percent / 100.0 * (self.at_100 - self.at_0)
    }

    /// Where `value` is on the range, in percent; outside 0 … 100 past its ends (LeRobot
    /// clamps there, keypose shows how far past they are).
    pub fn percent(&self, value: f64) -> f64 {
        (value - self.at_0) / (self.at_100 - self.at_0) * 100.0
    }
}

impl Joint {
    /// Where to hold this joint, measured at `present`, when its torque comes on: where it is,
    /// or at the limit it is a little past (within [`JointKind::position_slack`]). None when it
    /// is further past: a goal there is forbidden, and pulling it to the limit at once would be
    /// a jump, so it must be moved inside by hand first.
    pub fn hold_value(&self, present: f64) -> Option<f64> {
        let excess = (self.limits.min - present).max(present - self.limits.max);
        (excess <= self.kind.position_slack())
            .then(|| present.clamp(self.limits.min, self.limits.max))
    }

    /// [`Joint::hold_value`] for the servo measured at `present` ticks, as the goal tick.
    pub fn hold_tick(&self, present: i64) -> Option<i64> {
        self.hold_value(self.servo.value(present))
            .and_then(|value| self.goal_tick(value).ok())
    }

    /// The tick to command for `value`: the nearest tick whose value is inside the limits too.
    /// Plain rounding can land up to half a tick past a limit that `value` sits on.
    pub fn goal_tick(&self, value: f64) -> Result<i64, TickError> {
        let outside = TickError::OutsideLimits {
            value,
            min: self.limits.min,
            max: self.limits.max,
        };
        if !self.limits.contains(value) {
            return Err(outside);
        }
        let tick = self.servo.tick(value)?;
        [tick, tick - 1, tick + 1]
            .into_iter()
            .find(|&t| self.limits.contains(self.servo.value(t)))
            .ok_or(outside)
    }
    /// The joint's motion for a joint value (degrees or metres).
    pub fn motion(&self, value: f64) -> RigidTransform {
        match self.kind {
            JointKind::Revolute => RigidTransform::new(
                DVec3::ZERO,
                DQuat::from_axis_angle(self.axis, value.to_radians()),
            ),
            JointKind::Prismatic => RigidTransform::new(self.axis * value, DQuat::IDENTITY),
        }
    }
}

/// A fixed frame on the chain, such as the tool centre point.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedFrame {
    /// Index of the joint whose moving frame carries this frame.
    pub parent: usize,
    /// Its pose in that moving frame.
    pub origin: RigidTransform,
}

/// How the robot's servos are spoken to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusSettings {
    /// The wire protocol every servo of the robot speaks.
    pub protocol: Protocol,
    /// Bits per second.
    pub baud: u32,
}

/// Where a robot description came from, for the user to see which one is in use.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RobotSource {
    /// Compiled into the binary, by name.
    Builtin(String),
    /// Read from a file (or parsed from text named like one).
    File(PathBuf),
    /// Several arms made into one ([`Robot::cell`]).
    Cell,
}

impl fmt::Display for RobotSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RobotSource::Builtin(_) => f.write_str("built-in"),
            RobotSource::File(path) => write!(f, "file {}", path.display()),
            RobotSource::Cell => f.write_str("cell"),
        }
    }
}

/// A robot named as a built-in that does not exist.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown robot {spec:?}: expected a built-in robot ({}), a LeRobot robot type ({}) or a robot file given as a path (containing a '/' or ending in .json, e.g. ./{spec})", BUILTIN_NAMES.join(", "), lerobot_names::builtin_type_names().join(", "))]
pub struct UnknownRobot {
    /// What was given.
    pub spec: String,
}

/// Why a robot could not be resolved.
#[derive(Debug, thiserror::Error)]
pub enum ResolveError {
    /// No built-in, LeRobot type or file by that name.
    #[error(transparent)]
    Unknown(#[from] UnknownRobot),
    /// A LeRobot type whose arm keypose has not built in.
    #[error(transparent)]
    NotBuiltIn(#[from] NotBuiltIn),
    /// The robot file could not be read or is not a valid description.
    #[error(transparent)]
    Input(#[from] InputError),
}

/// Whether a robot given by the user names a file: it contains a '/' or ends in ".json".
/// Anything else is a built-in name, and never a file: a file called `so101` in the working
/// directory or beside a sequence must not stand in for the built-in robot.
pub fn names_a_file(spec: &str) -> bool {
    spec.contains('/') || spec.ends_with(".json")
}

/// An arm (or a cell of arms): its joint chain, limits, servos, bus and home pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// The built-in's name or the robot file's `name`; sequences name their robot by it.
    pub name: String,
    /// The built-in or the file this description was read from.
    pub source: RobotSource,
    /// One line saying what arm it is, for people.
    pub description: String,
    /// Protocol and baud rate of its servos.
    pub bus: BusSettings,
    /// Default streaming rate of the player, Hz.
    pub control_hz: f64,
    /// In chain order: each joint's parent frame is the previous joint's moving frame.
    pub joints: Vec<Joint>,
    /// The tool centre point, when the description defines one.
    pub tcp: Option<FixedFrame>,
    /// Home value of every joint, in joint order.
    pub home: Vec<f64>,
    /// The LeRobot type this robot is (a built-in named the keypose way is its follower type),
    /// which says where LeRobot keeps its calibrations; None for a robot file.
    pub lerobot: Option<&'static LeRobotType>,
    /// The arms of a cell ([`Robot::cell`]); empty for a robot of one arm.
    pub arms: Vec<Arm>,
    /// How close the arm may come to the floor, itself or another arm before the check
    /// reports it, metres: the robot file's `clearance_mm` (default
    /// [`DEFAULT_CLEARANCE_MM`]), or `--clearance`.
    pub clearance: f64,
    /// What the tool carries: the robot file's `payload`, or `--payload`.
    pub payload: Option<Payload>,
}

/// A load the tool carries, as a point mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Payload {
    /// Kilograms.
    pub mass: f64,
    /// Its centre of mass in the TCP's frame (the last joint's frame where the robot has no
    /// TCP), metres.
    pub com: glam::DVec3,
}

/// The heaviest payload a robot file or `--payload` may give, kilograms: ten times what any
/// supported arm lifts, so a typo in grams is caught.
pub const MAX_PAYLOAD_KG: f64 = 10.0;

/// The clearance the check keeps when the robot file gives none, millimetres: room for the
/// collision model's shapes against the real parts and for a few tenths of a degree of
/// calibration, not for the arm's lag behind its goals, which the check bounds apart.
pub const DEFAULT_CLEARANCE_MM: f64 = 3.0;

impl Robot {
    /// Loads a robot description from a file.
    pub fn load(path: &Path) -> Result<Robot, InputError> {
        let text = crate::json::read_text(path)?;
        load::parse_robot(&path.display().to_string(), &text)
    }

    /// Parses a robot description; `file` names the source in errors.
    pub fn from_json(file: &str, text: &str) -> Result<Robot, InputError> {
        load::parse_robot(file, text)
    }

    /// A robot compiled into the binary, by name.
    pub fn builtin(name: &str) -> Option<Robot> {
        builtin::get(name)
    }

    /// A robot given as a built-in name, a LeRobot type name for a built-in
    /// ([`LeRobotType`]: the built-in, marked as that type) or a path to a robot file
    /// ([`names_a_file`]); a relative path is taken relative to `base` when given (a sequence's
    /// directory).
    pub fn resolve(spec: &str, base: Option<&Path>) -> Result<Robot, ResolveError> {
        if names_a_file(spec) {
            let path = match base {
                Some(dir) if Path::new(spec).is_relative() => dir.join(spec),
                _ => PathBuf::from(spec),
            };
            return Ok(Robot::load(&path)?);
        }
        if let Some(robot) = Robot::builtin(spec) {
            return Ok(robot);
        }
        let unknown = || UnknownRobot {
            spec: spec.to_string(),
        };
        let (builtin, lerobot) = lerobot_names::lerobot_type(spec).ok_or_else(unknown)??;
        // The registry holds built-ins that load (its tests say so); refuse rather than panic.
        let mut robot = Robot::builtin(builtin.name).ok_or_else(unknown)?;
        robot.lerobot = Some(lerobot);
        Ok(robot)
    }

    /// The index of joint `name` in joint order.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// The id and model of every joint's servo, in joint order.
    pub fn servos(&self) -> Vec<(u8, ServoModel)> {
        self.joints
            .iter()
            .map(|j| (j.servo.id, j.servo.model))
            .collect()
    }

    /// These joints alone (indices in joint order), as a robot of their own for joint-space
    /// motion: a teach jog is played by the player on the jogged joints only, so the others —
    /// limp ones too — are neither written nor switched on. Each joint keeps its limits, servo
    /// and calibration; the chain is not kept (no forward kinematics on the result), nor a
    /// cell's arms.
    pub fn only(&self, joints: &[usize]) -> Robot {
        Robot {
            name: self.name.clone(),
            source: self.source.clone(),
            description: self.description.clone(),
            bus: self.bus,
            control_hz: self.control_hz,
            joints: joints.iter().map(|&j| self.joints[j].clone()).collect(),
            tcp: None,
            home: joints.iter().map(|&j| self.home[j]).collect(),
            lerobot: self.lerobot,
            arms: Vec::new(),
            clearance: self.clearance,
            payload: self.payload,
        }
    }

    /// Joint values (degrees or metres) of servo positions read in joint order.
    pub fn values_of(&self, ticks: &[i64]) -> Vec<f64> {
        self.joints
            .iter()
            .zip(ticks)
            .map(|(j, &t)| j.servo.value(t))
            .collect()
    }

    /// The name of the joint driven by servo `id`.
    pub fn joint_of_servo(&self, id: u8) -> Option<&str> {
        self.joints
            .iter()
            .find(|j| j.servo.id == id)
            .map(|j| j.name.as_str())
    }

    /// Every joint's name, in joint order.
    pub fn joint_names(&self) -> Vec<&str> {
        self.joints.iter().map(|j| j.name.as_str()).collect()
    }

    /// World pose of every joint's moving frame for joint values in joint order.
    pub fn joint_frames(&self, values: &[f64]) -> Vec<RigidTransform> {
        self.frames(values).collect()
    }

    /// World position of the tool centre point (or of the last joint's frame when the robot
    /// defines no TCP).
    pub fn tcp_position(&self, values: &[f64]) -> DVec3 {
        self.tcp_frame(values).t
    }

    /// World pose of the tool centre point frame (or of the last joint's frame when the robot
    /// defines no TCP).
    pub fn tcp_frame(&self, values: &[f64]) -> RigidTransform {
        // Walked without collecting the frames: inverse kinematics calls this per candidate.
        let carried = match &self.tcp {
            Some(tcp) => tcp.parent + 1,
            None => self.joints.len(),
        };
        let last = self.frames(values).take(carried).last();
        let last = last.unwrap_or(RigidTransform::IDENTITY);
        match &self.tcp {
            Some(tcp) => last.compose(&tcp.origin),
            None => last,
        }
    }

    /// Every joint's moving frame in the base frame, in joint order, computed lazily.
    pub fn frames<'a>(&'a self, values: &'a [f64]) -> impl Iterator<Item = RigidTransform> + 'a {
        self.joints.iter().zip(values).enumerate().scan(
            RigidTransform::IDENTITY,
            |current, (index, (joint, &value))| {
                if self.starts_chain(index) {
                    *current = RigidTransform::IDENTITY;
                }
                *current = current.compose(&joint.origin).compose(&joint.motion(value));
                Some(*current)
            },
        )
    }

    /// World position of every joint's anchor (its frame origin) and its world axis.
    pub fn joint_axes(&self, values: &[f64]) -> Vec<(DVec3, DVec3)> {
        self.joint_frames(values)
            .iter()
            .zip(&self.joints)
            .map(|(frame, joint)| (frame.t, frame.r * joint.axis))
            .collect()
    }
}
