//! `keypose.Sequence` and `keypose.load`: a sequence on its robot, its samples, its check,
//! retiming and saving, each through the library (and the verbs' loading, for the same
//! messages as `keypose check FILE`).

use crate::cli::commands::{
    check_sample_budget, limit_check_rate, sample, CalibrationArgs, SequenceOptions,
};
use crate::errors::{argument_error, command_error, input_error, LimitError};
use crate::report::Report;
use crate::robot::{OneOrMany, Robot};
use keypose::curve::Interp;
use keypose::plan::{self, retime, Trajectory};
use keypose::sequence::Sequence as LibSequence;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;

/// What a sequence built from keys in code is called in messages.
const KEYS_FILE: &str = "<keys>";

/// A sequence on its robot (calibration applied), and the trajectory they make.
#[pyclass(module = "keypose", name = "Sequence", frozen)]
pub struct Sequence {
    sequence: LibSequence,
    robot: Robot,
    trajectory: Trajectory,
}

impl Sequence {
    /// The sequence on `robot`, its trajectory built (which checks its keys against the
    /// robot's joints).
    fn on(py: Python<'_>, sequence: LibSequence, robot: Robot) -> PyResult<Sequence> {
        let trajectory =
            Trajectory::build(&sequence, &robot.robot).map_err(|e| input_error(py, &e))?;
        Ok(Sequence {
            sequence,
            robot,
            trajectory,
        })
    }

    /// The robot it plays on.
    pub fn robot_ref(&self) -> &Robot {
        &self.robot
    }

    /// The trajectory its keys make on that robot.
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }
}

/// Reads a sequence file (keypose-sequence/1) and its robot, as `keypose check FILE` does:
/// the robot the file names (a built-in, a LeRobot type, or a robot file relative to the
/// sequence) or `robot`, with a LeRobot calibration from `calibration` (a file) or `robot_id`
/// (the id LeRobot calibrated the arm with); on a sequence of several arms a list of them,
/// `"ARM=FILE"` each.
#[pyfunction]
#[pyo3(signature = (path, *, robot = None, calibration = None, robot_id = None, interpolation = None, payload = None, robot_variant = None))]
#[allow(clippy::too_many_arguments)]
pub fn load(
    py: Python<'_>,
    path: PathBuf,
    robot: Option<String>,
    calibration: Option<OneOrMany>,
    robot_id: Option<OneOrMany>,
    interpolation: Option<String>,
    payload: Option<f64>,
    robot_variant: Option<String>,
) -> PyResult<Sequence> {
    let options = SequenceOptions {
        robot,
        calibration: CalibrationArgs {
            calibration: OneOrMany::strings(calibration),
            robot_id: OneOrMany::strings(robot_id),
        },
        interpolation: interpolation.map(|m| parse_interp(py, &m)).transpose()?,
        clearance: None,
        payload: match payload {
            Some(kg) if !(0.0..=keypose::robot::MAX_PAYLOAD_KG).contains(&kg) => {
                return Err(argument_error(
                    py,
                    format!(
                        "payload: expected a mass from 0 to {} kg, found {kg}",
                        keypose::robot::MAX_PAYLOAD_KG
                    ),
                ))
            }
            other => other,
        },
        robot_variant,
    };
    let (sequence, robot) = options.load(&path).map_err(|e| command_error(py, e))?;
    let spec = sequence.robot.clone();
    Sequence::on(py, sequence, Robot::new(robot, spec))
}

/// An interpolation mode by name, as the sequence format and `--interpolation` spell it.
fn parse_interp(py: Python<'_>, name: &str) -> PyResult<Interp> {
    Interp::parse(name).ok_or_else(|| {
        argument_error(
            py,
            format!(
                "interpolation: expected one of {}, found {name:?}",
                Interp::names()
            ),
        )
    })
}

#[pymethods]
impl Sequence {
    /// A sequence built from keys in code: each key a dict as a sequence file writes a
    /// keyframe (`{"time": 1.0, "joints": {"elbow_flex": 30}}`, with `"name"`, `"hold"`,
    /// `"interp"`, `"tool"` …; `"joints"` may be a list in the robot's joint order, and numbers
    /// may be numpy's), checked as a file's keys are; errors name `<keys>` and the key's path
    /// (`$.keyframes[1].joints.elbow_flex`).
    #[new]
    #[pyo3(signature = (robot, keys, *, interpolation = "cubic", description = None))]
    fn new(
        py: Python<'_>,
        robot: &Bound<'_, PyAny>,
        keys: &Bound<'_, PyAny>,
        interpolation: &str,
        description: Option<String>,
    ) -> PyResult<Sequence> {
        let robot = match robot.cast::<Robot>() {
            Ok(given) => given.get().clone(),
            Err(_) => Robot::named(py, &robot.extract::<String>()?, None, None)?,
        };
        let joints: Vec<String> = robot.robot.joints.iter().map(|j| j.name.clone()).collect();
        let keys =
            crate::keys::keys_json(keys, &joints, KEYS_FILE).map_err(|e| input_error(py, &e))?;
        let mut file = serde_json::json!({
            "format": "keypose-sequence/1",
            "robot": robot.spec,
            "interpolation": interpolation,
        });
        if let Some(text) = description {
            file["description"] = text.into();
        }
        file["keyframes"] = keys;
        let sequence = LibSequence::from_json(KEYS_FILE, &file.to_string())
            .map_err(|e| input_error(py, &e))?;
        Sequence::on(py, sequence, robot)
    }

    /// The joints' names, in the order of the columns of `sample`'s q (`ARM/JOINT` on a
    /// sequence of several arms).
    #[getter]
    fn joints(&self) -> Vec<String> {
        self.trajectory.joint_names.clone()
    }

    /// The robot the sequence plays on, its calibration applied.
    #[getter]
    fn robot(&self) -> Robot {
        self.robot.clone()
    }

    /// The file it was read from (`<keys>` when built in code).
    #[getter]
    fn file(&self) -> String {
        self.sequence.file.clone()
    }

    /// The interpolation of segments that do not set their own.
    #[getter]
    fn interpolation(&self) -> &'static str {
        self.sequence.interpolation.name()
    }

    /// Sequence time of the first played key, seconds.
    #[getter]
    fn start(&self) -> f64 {
        self.trajectory.start()
    }

    /// Sequence time of the last played key, seconds.
    #[getter]
    fn end(&self) -> f64 {
        self.trajectory.end
    }

    /// Every key's time, seconds.
    #[getter]
    fn key_times(&self) -> Vec<f64> {
        self.sequence.key_times()
    }

    /// The keys as a sequence file writes them (a list of dicts).
    #[getter]
    fn keys<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let file = py
            .import("json")?
            .call_method1("loads", (self.sequence.to_json(),))?;
        file.get_item("keyframes")
    }

    /// The trajectory at `rate` Hz from the first to the last played key: `(t, q)`, t of shape
    /// (n,) in seconds, q of shape (n, len(joints)) in the joints' units (degrees; metres for
    /// a prismatic joint), as `keypose sample --rate RATE` writes them.
    #[pyo3(signature = (rate = 100.0))]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        rate: f64,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        // The command line's rule for --rate, given the number's exact text.
        let rate = crate::cli::commands::parse_rate(&rate.to_string())
            .map_err(|e| argument_error(py, format!("rate: {e}")))?;
        check_sample_budget(&self.sequence.file, &self.trajectory, rate)
            .map_err(|e| command_error(py, e))?;
        // Long sequences take a while: other Python threads run meanwhile.
        let rows = py
            .detach(|| {
                sample::sample_rows(
                    &self.trajectory,
                    &self.robot.robot,
                    rate,
                    sample::Units::Deg,
                )
            })
            .map_err(|e| command_error(py, e))?;
        let columns = self.trajectory.joint_names.len();
        let times: Vec<f64> = rows.iter().map(|row| row[0]).collect();
        let values: Vec<f64> = rows
            .iter()
            .flat_map(|row| row[1..].iter().copied())
            .collect();
        let t = array(py, &times, (times.len(), None))?;
        let q = array(py, &values, (rows.len(), Some(columns)))?;
        Ok((t, q))
    }

    /// The same keys on the same robot with the LeRobot calibration `calibration` (a file; a
    /// list of `"ARM=FILE"` on a sequence of several arms) applied instead, checked against
    /// its joints as a file's keys are.
    fn with_calibration(&self, py: Python<'_>, calibration: OneOrMany) -> PyResult<Sequence> {
        let args = CalibrationArgs {
            calibration: OneOrMany::strings(Some(calibration)),
            robot_id: Vec::new(),
        };
        let robot = Robot::with_calibration(py, &self.robot.spec, &args)?;
        Sequence::on(py, self.sequence.clone(), robot)
    }

    /// The trajectory as LeRobot's frames at `fps`, as `keypose export lerobot` writes its
    /// `action`: `(names, values)`, names `shoulder_pan.pos` … in joint order, values of shape
    /// (frames, joints) in LeRobot's units — body joints in `units` (`degrees`, or `range`:
    /// −100…100 of the calibrated range, which needs a calibration), the gripper in 0…100 % of
    /// its calibrated range (of its limits without a calibration, said in a warning).
    #[pyo3(signature = (fps = 30, units = "degrees"))]
    fn lerobot_frames<'py>(
        &self,
        py: Python<'py>,
        fps: u32,
        units: &str,
    ) -> PyResult<(Vec<String>, Bound<'py, PyAny>)> {
        use keypose::interop::lerobot::{export, BodyUnits};
        let units = match units {
            "degrees" => BodyUnits::Degrees,
            "range" => BodyUnits::Range,
            other => {
                return Err(argument_error(
                    py,
                    format!("units: expected degrees or range, found {other:?}"),
                ))
            }
        };
        if fps == 0 {
            return Err(argument_error(
                py,
                "fps: expected a positive integer, found 0".into(),
            ));
        }
        check_sample_budget(&self.sequence.file, &self.trajectory, f64::from(fps))
            .map_err(|e| command_error(py, e))?;
        let frames = export::lerobot_frames(&self.trajectory, &self.robot.robot, fps, units)
            .map_err(|e| {
                crate::errors::kind_error(py, e.kind(), keypose::error::Report(&e).to_string())
            })?;
        let warnings = py.import("warnings")?;
        for notice in &frames.notices {
            warnings.call_method1("warn", (notice.as_str(),))?;
        }
        let values: Vec<f64> = frames.rows.iter().flatten().copied().collect();
        let q = array(py, &values, (frames.rows.len(), Some(frames.names.len())))?;
        Ok((frames.names, q))
    }

    /// The exact check against the joints' limits, as `keypose check` makes it.
    fn check(&self, py: Python<'_>) -> PyResult<Report> {
        let robot = &self.robot.robot;
        check_sample_budget(&self.sequence.file, &self.trajectory, robot.control_hz)
            .map_err(|e| command_error(py, e))?;
        let file = &self.sequence.file;
        Ok(py.detach(|| Report::of(&self.trajectory, file, robot)))
    }

    /// The sequence with its key times stretched, segment by segment, until the velocity and
    /// acceleration limits hold, as `keypose retime` writes it; with `fastest`, timed as fast as
    /// those limits allow along its path (`keypose retime --fastest`: a timing profile per
    /// segment). Raises `LimitError` (its
    /// `report` the retimed sequence's check) where timing cannot mend the motion: positions
    /// outside the limits, steps.
    #[pyo3(signature = (fastest = false))]
    fn retime(&self, py: Python<'_>, fastest: bool) -> PyResult<Sequence> {
        let robot = &self.robot.robot;
        let rate = limit_check_rate(None, robot);
        check_sample_budget(&self.sequence.file, &self.trajectory, rate)
            .map_err(|e| command_error(py, e))?;
        let timed = py.detach(|| match fastest {
            true => plan::fastest(&self.sequence, robot, rate).map(|o| o.sequence),
            false => retime(&self.sequence, robot, rate).map(|o| o.sequence),
        });
        let timed = timed.map_err(|e| input_error(py, &e))?;
        let retimed = Sequence::on(py, timed, self.robot.clone())?;
        let report = retimed.check(py)?;
        if !report.passed() {
            let err = LimitError::new_err(format!(
                "{}: {} finding(s) cannot be fixed by retiming (positions outside limits, step \
                 jumps, contacts): {}",
                self.sequence.file,
                report.violation_count(),
                report.violation_lines().join("; ")
            ));
            let _ = err.value(py).setattr("report", Py::new(py, report)?);
            return Err(err);
        }
        Ok(retimed)
    }

    /// Writes the sequence to `path` atomically, in the layout of the file it was read from
    /// (every value nobody changed as it was written).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        self.sequence.save(&path).map_err(|e| input_error(py, &e))
    }

    /// The sequence as keypose-sequence/1 JSON text, in the canonical layout.
    fn to_json(&self) -> String {
        self.sequence.to_json()
    }

    fn __repr__(&self) -> String {
        format!(
            "<keypose.Sequence {:?}: robot {}, {} keys, {:.3} s … {:.3} s>",
            self.sequence.file,
            self.robot.robot.name,
            self.sequence.keyframes.len(),
            self.trajectory.start(),
            self.trajectory.end
        )
    }
}

/// A numpy float64 array of `values` in the shape `(rows,)` or `(rows, columns)`, writable.
pub fn array<'py>(
    py: Python<'py>,
    values: &[f64],
    shape: (usize, Option<usize>),
) -> PyResult<Bound<'py, PyAny>> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let numpy = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", numpy.getattr("float64")?)?;
    let flat = numpy.call_method("frombuffer", (PyBytes::new(py, &bytes),), Some(&kwargs))?;
    let shaped = match shape {
        (rows, None) => flat.call_method1("reshape", ((rows,),))?,
        (rows, Some(columns)) => flat.call_method1("reshape", ((rows, columns),))?,
    };
    // frombuffer's array is a read-only view of the bytes: hand out a copy of its own.
    shaped.call_method0("copy")
}
