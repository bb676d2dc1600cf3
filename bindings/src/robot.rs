//! `keypose.Robot`: an arm's joints and limits, where its tool is at a pose (forward
//! kinematics) and the joints for a tool pose (inverse kinematics, as a sequence's tool key is
//! solved).

use crate::cli::commands::pose::{solve_target, tool, tool_target};
use crate::cli::commands::{load_robot, CalibrationArgs};
use crate::errors::{argument_error, command_error};
use crate::sequence::array;
use glam::DVec3;
use keypose::robot::{names_a_file, Robot as LibRobot};
use keypose::sequence::ToolApproach;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// An arm: a built-in (so101, so100, koch, omx), a LeRobot robot type (so101_follower,
/// koch_leader, …) or a robot file, with a LeRobot calibration applied when given.
#[pyclass(module = "keypose", name = "Robot", frozen)]
#[derive(Clone)]
pub struct Robot {
    /// The description, calibration applied.
    pub robot: LibRobot,
    /// How it was named (a sequence built in code names its robot so).
    pub spec: String,
}

impl Robot {
    /// `robot` as it was named.
    pub fn new(robot: LibRobot, spec: String) -> Robot {
        Robot { robot, spec }
    }

    /// The robot `spec` names, as `--robot SPEC` takes it, with the calibration of
    /// `calibration` (a file) or `robot_id` (LeRobot's id) applied.
    pub fn named(
        py: Python<'_>,
        spec: &str,
        calibration: Option<PathBuf>,
        robot_id: Option<String>,
    ) -> PyResult<Robot> {
        let calibration = CalibrationArgs {
            calibration: calibration
                .into_iter()
                .map(|p| p.to_string_lossy().into_owned())
                .collect(),
            robot_id: robot_id.into_iter().collect(),
        };
        Robot::with_calibration(py, spec, &calibration)
    }

    /// The robot `spec` names with the calibrations `calibration` says (`--calibration` and
    /// `--robot-id` as the command line takes them, `ARM=…` for an arm of several).
    pub fn with_calibration(
        py: Python<'_>,
        spec: &str,
        calibration: &CalibrationArgs,
    ) -> PyResult<Robot> {
        let robot = load_robot(spec, calibration).map_err(|e| command_error(py, e))?;
        // A sequence built in code names its robot by this; a file's relative path in a saved
        // sequence would be read relative to the sequence's folder, so it is made absolute.
        let spec = match names_a_file(spec) {
            true => std::path::absolute(spec).map_or(spec.into(), |p| p.display().to_string()),
            false => spec.to_string(),
        };
        Ok(Robot::new(robot, spec))
    }

    /// A pose from `q`: a value per joint in joint order, or a mapping of joint names to
    /// values (the others at home); each finite. `what` names the argument in errors.
    fn pose(&self, py: Python<'_>, q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
        let robot = &self.robot;
        let values = if let Ok(map) = q.cast::<PyDict>() {
            let mut values = robot.home.clone();
            for (name, value) in map.iter() {
                let name: String = name.extract()?;
                let index = robot.joint_index(&name).ok_or_else(|| {
                    argument_error(
                        py,
                        format!(
                            "{what}: robot {} has no joint {name:?}; its joints are: {}",
                            robot.name,
                            robot.joint_names().join(", ")
                        ),
                    )
                })?;
                values[index] = value.extract()?;
            }
            values
        } else {
            let values: Vec<f64> = q
                .try_iter()?
                .map(|v| v?.extract())
                .collect::<PyResult<_>>()?;
            if values.len() != robot.joints.len() {
                return Err(argument_error(
                    py,
                    format!(
                        "{what}: expected {} values (one per joint: {}), found {}",
                        robot.joints.len(),
                        robot.joint_names().join(", "),
                        values.len()
                    ),
                ));
            }
            values
        };
        if let Some((joint, value)) = robot
            .joints
            .iter()
            .zip(&values)
            .find(|(_, v)| !v.is_finite())
        {
            return Err(argument_error(
                py,
                format!(
                    "{what}: {} is {value}; expected a finite number",
                    joint.name
                ),
            ));
        }
        Ok(values)
    }

    /// Refuses a cell of several arms where one tool is meant.
    fn one_arm(&self, py: Python<'_>, what: &str) -> PyResult<()> {
        if self.robot.is_cell() {
            let arms: Vec<&str> = self.robot.arms.iter().map(|a| a.name.as_str()).collect();
            return Err(argument_error(
                py,
                format!(
                    "{what}: robot {} is a cell of several arms ({}); expected one arm",
                    self.robot.name,
                    arms.join(", ")
                ),
            ));
        }
        Ok(())
    }
}

/// Three finite numbers, or an error naming `what`.
fn triple(py: Python<'_>, values: Vec<f64>, what: &str) -> PyResult<[f64; 3]> {
    match values[..] {
        [a, b, c] if values.iter().all(|v| v.is_finite()) => Ok([a, b, c]),
        _ => Err(argument_error(
            py,
            format!("{what}: expected three finite numbers, found {values:?}"),
        )),
    }
}

#[pymethods]
impl Robot {
    /// `Robot("so101")`, `Robot("so101_follower", robot_id="my_follower")`,
    /// `Robot("arm.json", calibration="my_follower.json")`.
    #[new]
    #[pyo3(signature = (name_or_path, *, calibration = None, robot_id = None))]
    fn py_new(
        py: Python<'_>,
        name_or_path: &str,
        calibration: Option<PathBuf>,
        robot_id: Option<String>,
    ) -> PyResult<Robot> {
        Robot::named(py, name_or_path, calibration, robot_id)
    }

    /// The robot's name (a built-in's, or the robot file's "name").
    #[getter]
    fn name(&self) -> String {
        self.robot.name.clone()
    }

    /// The joints' names, in joint order.
    #[getter]
    fn joints(&self) -> Vec<String> {
        self.robot.joints.iter().map(|j| j.name.clone()).collect()
    }

    /// Each joint's limits (calibration applied), by name in joint order, in its unit.
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let limits = PyDict::new(py);
        for j in &self.robot.joints {
            let of_joint = Limits {
                min: j.limits.min,
                max: j.limits.max,
                velocity: j.limits.velocity,
                acceleration: j.limits.acceleration,
                unit: j.kind.unit(),
            };
            limits.set_item(&j.name, of_joint)?;
        }
        Ok(limits)
    }

    /// Each joint's unit, by name in joint order: "deg", or "m" for a prismatic joint.
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let units = PyDict::new(py);
        for j in &self.robot.joints {
            units.set_item(&j.name, j.kind.unit())?;
        }
        Ok(units)
    }

    /// The home pose, in joint order.
    #[getter]
    fn home(&self) -> Vec<f64> {
        self.robot.home.clone()
    }

    /// The rate the player streams at, Hz.
    #[getter]
    fn control_hz(&self) -> f64 {
        self.robot.control_hz
    }

    /// Where the tool (the robot's tcp) is at pose `q` (joint order, or a dict of joint
    /// values with the others at home): position in metres and URDF roll, pitch, yaw in
    /// degrees, in the base frame, as `keypose pose` prints them.
    fn tool(&self, py: Python<'_>, q: &Bound<'_, PyAny>) -> PyResult<ToolPose> {
        self.one_arm(py, "tool")?;
        let values = self.pose(py, q, "q")?;
        let (xyz, rpy) = tool(&self.robot, &values);
        Ok(ToolPose {
            xyz: (xyz[0], xyz[1], xyz[2]),
            rpy: (rpy[0], rpy[1], rpy[2]),
        })
    }

    /// The joints (a numpy array, joint order) that put the tool at `xyz` (metres, base
    /// frame), solved as `keypose pose --tool` and a sequence's tool key are: clear of the
    /// floor and the arm itself, away from the limits, then nearest `seed` (home when None).
    /// `rpy` (degrees) asks for the whole orientation, met as closely as the arm allows;
    /// `approach="down"` (or "down-or-tilted") for a tool pointing down. Raises InputError
    /// when no pose inside the limits reaches it.
    #[pyo3(signature = (xyz, rpy = None, seed = None, *, approach = None))]
    fn solve<'py>(
        &self,
        py: Python<'py>,
        xyz: Vec<f64>,
        rpy: Option<Vec<f64>>,
        seed: Option<&Bound<'py, PyAny>>,
        approach: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.one_arm(py, "solve")?;
        let position = triple(py, xyz, "xyz")?;
        let rpy = rpy.map(|r| triple(py, r, "rpy")).transpose()?;
        let approach = approach
            .map(|text| {
                ToolApproach::parse(&text).ok_or_else(|| {
                    let spellings: Vec<&str> =
                        ToolApproach::ALL.iter().map(|a| a.spelling()).collect();
                    argument_error(
                        py,
                        format!(
                            "approach: expected one of: {}, found {text:?}",
                            spellings.join(", ")
                        ),
                    )
                })
            })
            .transpose()?;
        if rpy.is_some() && approach.is_some() {
            return Err(argument_error(
                py,
                "approach says which way the tool points, and so does rpy: give one".into(),
            ));
        }
        let seed = match seed {
            Some(q) => self.pose(py, q, "seed")?,
            None => self.robot.home.clone(),
        };
        let target = tool_target(DVec3::from_array(position), rpy, approach);
        let chosen = py.detach(|| solve_target(&self.robot, &target, &seed));
        let chosen = chosen.map_err(|e| {
            argument_error(
                py,
                format!(
                    "solve {position:?}: {}{}",
                    keypose::error::Report(&e),
                    radians_hint(rpy)
                ),
            )
        })?;
        let values = chosen.solution.values;
        array(py, &values, (values.len(), None))
    }

    fn __repr__(&self) -> String {
        format!(
            "<keypose.Robot {} ({}): {}>",
            self.robot.name,
            self.robot.source,
            self.robot.joint_names().join(", ")
        )
    }
}

/// For an `rpy` that failed: the Python API's angles are degrees (as its joint values), while a
/// file's `rpy` is radians; values all within ±π, not all zero, look like radians.
fn radians_hint(rpy: Option<[f64; 3]>) -> String {
    let Some(r) = rpy else {
        return String::new();
    };
    let small = r.iter().all(|x| x.abs() <= std::f64::consts::PI + 1e-9);
    if !small || r.iter().all(|x| x.abs() < 0.01) {
        return String::new();
    }
    let d = r.map(f64::to_degrees);
    format!(
        " (rpy here is in degrees, as the API's joint values are; {r:?} look like radians: \
         that is [{:.1}, {:.1}, {:.1}] degrees)",
        d[0], d[1], d[2]
    )
}

/// A joint's limits, in its unit ("deg" or "m") and per second.
#[pyclass(module = "keypose", name = "Limits", frozen, get_all)]
#[derive(Clone)]
pub struct Limits {
    /// Lowest position.
    min: f64,
    /// Highest position.
    max: f64,
    /// Highest speed, per second.
    velocity: f64,
    /// Highest acceleration, per second squared.
    acceleration: f64,
    /// "deg" or "m".
    unit: &'static str,
}

#[pymethods]
impl Limits {
    fn __repr__(&self) -> String {
        format!(
            "Limits(min={:?}, max={:?}, velocity={:?}, acceleration={:?}, unit={:?})",
            self.min, self.max, self.velocity, self.acceleration, self.unit
        )
    }
}

/// Where the tool is: position (metres) and URDF roll, pitch, yaw (degrees), base frame.
#[pyclass(module = "keypose", name = "ToolPose", frozen, get_all)]
pub struct ToolPose {
    /// x, y, z, metres.
    xyz: (f64, f64, f64),
    /// Roll, pitch, yaw, degrees (R = Rz(yaw)·Ry(pitch)·Rx(roll)).
    rpy: (f64, f64, f64),
}

#[pymethods]
impl ToolPose {
    fn __repr__(&self) -> String {
        let (x, y, z) = self.xyz;
        let (r, p, w) = self.rpy;
        format!("ToolPose(xyz=({x:.5}, {y:.5}, {z:.5}), rpy=({r:.3}, {p:.3}, {w:.3}))")
    }
}

/// A calibration argument from Python: one file (or id), or a list of them (`"left=FILE"` per
/// arm of a sequence of several).
#[derive(FromPyObject)]
pub enum OneOrMany {
    /// One file or id.
    One(PathBuf),
    /// One per arm.
    Many(Vec<PathBuf>),
}

impl OneOrMany {
    /// The values as the command line's options take them.
    pub fn strings(given: Option<OneOrMany>) -> Vec<String> {
        let paths = match given {
            None => Vec::new(),
            Some(OneOrMany::One(p)) => vec![p],
            Some(OneOrMany::Many(ps)) => ps,
        };
        paths
            .into_iter()
            .map(|p| p.to_string_lossy().into_owned())
            .collect()
    }
}
