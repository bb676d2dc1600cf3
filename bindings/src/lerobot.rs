//! `keypose.lerobot`'s native half: keypose's player driving a LeRobot robot object.
//!
//! The player is the library's own (`keypose::player::play`): ramp from the measured pose,
//! pacing by absolute deadlines, the step limiter and the position guard on every goal, stall
//! handling, a first stop request braking along the path and a second holding at once. Only
//! its bus is new here: [`LeRobotBus`] reads the arm through the robot's `get_observation()` and
//! writes goals through its `send_action()`, converting each tick to the normalised value that
//! LeRobot's own bus turns back into that very tick (`keypose::interop::lerobot::motor_norm`).
//! So what reaches the servos is exactly what the guard let through.

use crate::errors::{argument_error, kind_error};
use crate::sequence::Sequence;
use keypose::bus::{BusError, Health, PingInfo, ServoBus};
use keypose::dynamics::Compensation;
use keypose::error::Report;
use keypose::interop::lerobot::motor_norm::{MotorNorm, NormMode};
use keypose::player::{play, Outcome, PlayOptions, StopSignal, DEFAULT_MAX_STALL};
use keypose::robot::Robot as LibRobot;
use keypose::servo::ServoModel;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Who refuses in a [`BusError::Sdk`] raised by the robot object.
const BY: &str = "lerobot";
/// The message of a call broken off by Ctrl-C (Python's KeyboardInterrupt).
const INTERRUPTED: &str = "interrupted by Ctrl-C";

/// Stop requests for a playback, shared with whoever asks (a Ctrl-C handler): the first
/// brakes along the path to rest, the second holds where the arm is.
#[pyclass(module = "keypose", name = "StopRequests", frozen)]
#[derive(Default)]
pub struct StopRequests {
    signal: StopSignal,
}

#[pymethods]
impl StopRequests {
    #[new]
    fn new() -> Self {
        Self::default()
    }

    /// Asks for a stop: the first brakes to rest along the path, a second holds at once.
    fn request(&self) {
        self.signal.request();
    }

    /// How many stops were requested so far.
    #[getter]
    fn count(&self) -> u32 {
        self.signal.count()
    }
}

/// One motor of the LeRobot robot: its name on its arm's bus, its key in actions and
/// observations, the arm it is on (`left`, `right` of a bimanual robot; `None` on one arm), the
/// servo id keypose's player addresses it by (a cell's ids are the cell's) and how LeRobot's bus
/// normalises it.
struct Motor {
    name: String,
    key: String,
    arm: Option<String>,
    id: u8,
    norm: MotorNorm,
}

/// An arm's motors by their names on its bus (`None`: the robot's own bus, one arm).
type ArmMotors = (Option<String>, Vec<String>);

/// A LeRobot robot object as a servo bus: positions through `get_observation()`, goals through
/// `send_action()`, torque through its motor bus (`robot.bus`).
struct LeRobotBus {
    robot: Py<PyAny>,
    motors: Vec<Motor>,
    stop: StopSignal,
    name: String,
}

impl LeRobotBus {
    fn motor(&self, id: u8) -> Result<&Motor, BusError> {
        self.motors
            .iter()
            .find(|m| m.id == id)
            .ok_or(BusError::Sdk {
                by: BY,
                message: format!("the robot has no motor of id {id}"),
            })
    }

    /// Runs `f` with the interpreter held. Signal handlers run first (a Ctrl-C that came while
    /// the player slept is seen here); a KeyboardInterrupt, from Python's own handler, is a
    /// stop request like keypose's handler makes, not a failure of the bus.
    fn with_python<T>(
        &self,
        f: impl FnOnce(Python<'_>, &Bound<'_, PyAny>) -> PyResult<T>,
    ) -> Result<T, BusError> {
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                let error = self.bus_error(py, e);
                if !self.interrupted(&error) {
                    return Err(error);
                }
            }
            f(py, self.robot.bind(py)).map_err(|e| self.bus_error(py, e))
        })
    }

    /// The robot's exception as the bus's error, with LeRobot's message; a KeyboardInterrupt
    /// also counts as a stop request (the call it broke off failed all the same).
    fn bus_error(&self, py: Python<'_>, error: PyErr) -> BusError {
        if error.is_instance_of::<PyKeyboardInterrupt>(py) {
            self.stop.request();
            return BusError::Sdk {
                by: BY,
                message: INTERRUPTED.into(),
            };
        }
        BusError::Sdk {
            by: BY,
            message: error.to_string(),
        }
    }

    fn interrupted(&self, error: &BusError) -> bool {
        matches!(error, BusError::Sdk { message, .. } if message == INTERRUPTED)
    }

    /// The motors of `ids` by arm, as each arm's bus names them: (arm, names).
    fn names_by_arm(&self, ids: &[u8]) -> Result<Vec<ArmMotors>, BusError> {
        let mut by_arm: Vec<ArmMotors> = Vec::new();
        for &id in ids {
            let motor = self.motor(id)?;
            match by_arm.iter_mut().find(|(arm, _)| *arm == motor.arm) {
                Some((_, names)) => names.push(motor.name.clone()),
                None => by_arm.push((motor.arm.clone(), vec![motor.name.clone()])),
            }
        }
        Ok(by_arm)
    }
}

impl ServoBus for LeRobotBus {
    fn describe(&self) -> String {
        format!("LeRobot robot {}", self.name)
    }

    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        Err(BusError::Sdk {
            by: BY,
            message: format!("servo {id}: a LeRobot robot object does not ping its servos"),
        })
    }

    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        let values = self.with_python(|_, robot| {
            let observation = robot.call_method0("get_observation")?;
            ids.iter()
                .map(|&id| {
                    let motor = self
                        .motor(id)
                        .map_err(|e| pyo3::exceptions::PyKeyError::new_err(e.to_string()))?;
                    observation.get_item(&motor.key)?.extract::<f64>()
                })
                .collect::<PyResult<Vec<f64>>>()
        })?;
        ids.iter()
            .zip(values)
            .map(|(&id, value)| Ok(self.motor(id)?.norm.tick_of_value(value)))
            .collect()
    }

    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        let action: Vec<(String, f64)> = goals
            .iter()
            .map(|&(id, tick)| {
                let motor = self.motor(id)?;
                Ok((motor.key.clone(), motor.norm.value_for_tick(tick)))
            })
            .collect::<Result<_, BusError>>()?;
        self.with_python(|py, robot| {
            let dict = PyDict::new(py);
            for (key, value) in &action {
                dict.set_item(key, value)?;
            }
            robot.call_method1("send_action", (dict,)).map(drop)
        })
    }

    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        let by_arm = self.names_by_arm(ids)?;
        let method = if on {
            "enable_torque"
        } else {
            "disable_torque"
        };
        self.with_python(|_, robot| {
            for (arm, names) in &by_arm {
                // A bimanual robot keeps each arm as `left_arm`, `right_arm`, with its own bus.
                let owner = match arm {
                    Some(arm) => robot.getattr(format!("{arm}_arm").as_str())?,
                    None => robot.clone(),
                };
                owner
                    .getattr("bus")?
                    .call_method1(method, (names.clone(),))?;
            }
            Ok(())
        })
    }

    fn read_health(&mut self, _ids: &[u8]) -> Result<Vec<Health>, BusError> {
        // Never asked for: the playback is set to read no health (LeRobot's robot API carries
        // no temperatures or alarms; a servo's fault reaches us as LeRobot's exception).
        Err(BusError::Sdk {
            by: BY,
            message: "a LeRobot robot object reports no servo health".into(),
        })
    }

    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        let id = servos.first().map_or(0, |s| s.0);
        Err(BusError::MissingRegister {
            id,
            register: "Homing_Offset (LeRobot's bus keeps it)",
        })
    }
}

/// One motor of LeRobot's bus as keypose/lerobot.py reads it (`motors_of`): a dict.
#[derive(FromPyObject, Clone)]
pub struct MotorSpec {
    /// keypose's joint name (`shoulder_pan`; `left/shoulder_pan` on a bimanual robot).
    #[pyo3(item)]
    joint: String,
    /// The motor's name on its arm's bus.
    #[pyo3(item)]
    name: String,
    /// Its key in actions and observations (`left_shoulder_pan.pos`).
    #[pyo3(item)]
    key: String,
    /// The arm of a bimanual robot it is on.
    #[pyo3(item)]
    arm: Option<String>,
    /// Its id on its arm's bus.
    #[pyo3(item)]
    id: u8,
    /// LeRobot's model name (`sts3215`, `xl430-w250`), as keypose's robot files spell them.
    #[pyo3(item)]
    model: String,
    /// `MotorNormMode.value`.
    #[pyo3(item)]
    norm_mode: String,
    #[pyo3(item)]
    range_min: i64,
    #[pyo3(item)]
    range_max: i64,
    /// `drive_mode` 1 on a bus that applies it.
    #[pyo3(item)]
    mirrored: bool,
    /// Ticks a turn (`model_resolution_table`).
    #[pyo3(item)]
    resolution: i64,
}

/// The motors of `robot`, matched to its joints by name, id and model: a sequence of another
/// arm (another id or servo model behind a joint's name) is refused, not played. On a cell, a
/// joint's id and model are those of its own arm's robot (the cell numbers its servos anew).
fn matched_motors(py: Python<'_>, robot: &LibRobot, motors: &[MotorSpec]) -> PyResult<Vec<Motor>> {
    let refuse = |message: String| argument_error(py, format!("robot: {message}"));
    let mut matched = Vec::with_capacity(robot.joints.len());
    for (index, joint) in robot.joints.iter().enumerate() {
        let Some(m) = motors.iter().find(|m| m.joint == joint.name) else {
            let names: Vec<&str> = motors.iter().map(|m| m.joint.as_str()).collect();
            return Err(refuse(format!(
                "the LeRobot robot has no motor for joint {:?} of {}; its motors are: {}",
                joint.name,
                robot.name,
                names.join(", ")
            )));
        };
        let own = own_servo(robot, index);
        if m.id != own.id {
            return Err(refuse(format!(
                "motor {} has id {} on the LeRobot robot, {} in {}: the sequence is for another arm",
                m.key, m.id, own.id, robot.name
            )));
        }
        if ServoModel::parse(&m.model) != Some(own.model) {
            return Err(refuse(format!(
                "motor {} is an {} on the LeRobot robot, an {} in {}: the sequence is for another arm",
                m.name,
                m.model,
                own.model.name(),
                robot.name
            )));
        }
        let mode = NormMode::from_lerobot(&m.norm_mode).ok_or_else(|| {
            refuse(format!(
                "motor {}: unknown LeRobot norm mode {:?}; expected degrees, range_m100_100 or range_0_100",
                m.key, m.norm_mode
            ))
        })?;
        if m.range_max <= m.range_min || m.resolution < 2 {
            return Err(refuse(format!(
                "motor {}: calibration range {} … {} at {} ticks a turn is not a range",
                m.key, m.range_min, m.range_max, m.resolution
            )));
        }
        matched.push(Motor {
            key: m.key.clone(),
            name: m.name.clone(),
            arm: m.arm.clone(),
            id: joint.servo.id,
            norm: MotorNorm {
                mode,
                range_min: m.range_min,
                range_max: m.range_max,
                mirrored: m.mirrored,
                resolution: m.resolution,
            },
        });
    }
    Ok(matched)
}

/// The servo of joint `index` as its own arm's bus knows it (the robot's own on one arm).
fn own_servo(robot: &LibRobot, index: usize) -> &keypose::robot::Servo {
    match robot.arm_of_joint(index) {
        Some(arm) => &arm.robot.joints[index - arm.joints.start].servo,
        None => &robot.joints[index].servo,
    }
}

// The signature's default is the player's (a literal there, for the stub's checker).
const _: () = assert!(DEFAULT_MAX_STALL == 0.25);

/// Plays `sequence` on the LeRobot robot object `robot` (connected, calibrated) through
/// keypose's player; `motors` describes its motor bus (keypose/lerobot.py reads it). Returns
/// what the playback did.
#[pyfunction]
#[pyo3(signature = (sequence, robot, motors, *, stop, rate = None, speed = 1.0, max_stall = 0.25, judge_pace = true, compensate_droop = false))]
#[allow(clippy::too_many_arguments)]
pub fn play_lerobot<'py>(
    py: Python<'py>,
    sequence: &Sequence,
    robot: Py<PyAny>,
    motors: Vec<MotorSpec>,
    stop: &StopRequests,
    rate: Option<f64>,
    speed: f64,
    max_stall: f64,
    judge_pace: bool,
    compensate_droop: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let lib_robot = &sequence.robot_ref().robot;
    let rate = rate.unwrap_or(lib_robot.control_hz);
    if !(rate.is_finite() && rate > 0.0) {
        return Err(argument_error(
            py,
            format!("rate: expected a positive number of Hz, found {rate}"),
        ));
    }
    if !(speed.is_finite() && speed > 0.0) {
        return Err(argument_error(
            py,
            format!("speed: expected a positive factor, found {speed}"),
        ));
    }
    if !(max_stall.is_finite() && max_stall > 0.0) {
        return Err(argument_error(
            py,
            format!("max_stall: expected a positive number of seconds, found {max_stall}"),
        ));
    }
    let name: String = robot.bind(py).str()?.extract()?;
    let mut bus = LeRobotBus {
        robot,
        motors: matched_motors(py, lib_robot, &motors)?,
        stop: stop.signal.clone(),
        name,
    };
    let mut options = PlayOptions::new(rate);
    options.timeline.speed = speed;
    options.max_stall = max_stall;
    options.health_every = u32::MAX;
    if !judge_pace {
        options.max_stalls_per_second = None;
    }
    if compensate_droop {
        let compensation = Compensation::for_robot(lib_robot)
            .map_err(|e| argument_error(py, format!("compensate_droop: {e}")))?;
        options.timeline.compensation = Some(std::sync::Arc::new(compensation));
    }
    let trajectory = sequence.trajectory();
    let signal = stop.signal.clone();
    let played = py.detach(|| play(&mut bus, lib_robot, trajectory, &options, &signal));
    let (outcome, stats) = played.map_err(|e| kind_error(py, e.kind(), Report(&e).to_string()))?;
    let result = PyDict::new(py);
    let outcome = match outcome {
        Outcome::Finished => "finished",
        Outcome::Stopped => "stopped",
        Outcome::Held => "held",
    };
    result.set_item("outcome", outcome)?;
    result.set_item("rate", rate)?;
    result.set_item("cycles", stats.cycles)?;
    result.set_item("approach_seconds", stats.approach_seconds)?;
    result.set_item("max_tracking_error", stats.max_tracking_error)?;
    result.set_item(
        "tracking_error_joint",
        stats
            .tracking_error_joint
            .map(|j| lib_robot.joints[j].name.clone()),
    )?;
    result.set_item("limited_goals", stats.limited_goals)?;
    result.set_item("late", stats.late)?;
    result.set_item("stalls", stats.pacing.stalls)?;
    Ok(result)
}
