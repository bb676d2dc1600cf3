//! `keypose.Report`: what the exact check found, as `keypose check` reports it.

use crate::cli::commands::check::{tool_text, tools_pass};
use keypose::plan::Contact as LibContact;
use keypose::plan::Violation as LibViolation;
use keypose::plan::{check, CheckReport, JointSummary as LibJointSummary, Trajectory};
use keypose::robot::Robot;
use pyo3::prelude::*;

/// The largest orientation a tool key may miss by, degrees: `keypose check`'s default.
const ORIENTATION_TOLERANCE_DEG: f64 = 2.0;

/// The check of a sequence: every violation, each joint's peaks, and whether it passed (as
/// `keypose check`'s exit code says: limits kept, and every tool key oriented and every tool
/// line followed).
#[pyclass(module = "keypose", name = "Report", frozen)]
pub struct Report {
    report: CheckReport,
    passed: bool,
    text: String,
}

impl Report {
    /// The check of `trajectory` on `robot` at the robot's control rate, as `keypose check`
    /// makes it; `file` names the sequence in the text.
    pub fn of(trajectory: &Trajectory, file: &str, robot: &Robot) -> Report {
        let report = check(trajectory, robot, robot.control_hz);
        let tools = &trajectory.tools;
        let passed = report.passed() && tools_pass(tools, ORIENTATION_TOLERANCE_DEG);
        let text = keypose::report::check_text(&report, file, robot)
            + &tool_text(tools, ORIENTATION_TOLERANCE_DEG, robot, &report);
        Report {
            report,
            passed,
            text,
        }
    }

    /// How many violations there are.
    pub fn violation_count(&self) -> usize {
        self.report.violations.len()
    }

    /// One line per violation, then one per contact no key declares, then one per servo
    /// overload.
    pub fn violation_lines(&self) -> Vec<String> {
        let contacts = self.report.undeclared_contacts().map(describe_contact);
        let overloads = self
            .report
            .overloads()
            .map(|o| format!("{}: {}", o.describe(), o.advice));
        self.report
            .violations
            .iter()
            .map(describe)
            .chain(contacts)
            .chain(overloads)
            .collect()
    }
}

#[pymethods]
impl Report {
    /// Whether the sequence keeps every limit (and its tool keys and lines hold).
    #[getter]
    pub fn passed(&self) -> bool {
        self.passed
    }

    /// Every stretch of time where a joint exceeds a limit, joint by joint.
    #[getter]
    fn violations(&self) -> Vec<Violation> {
        let to = |v: &LibViolation| Violation(v.clone());
        self.report.violations.iter().map(to).collect()
    }

    /// Every stretch of time where the arm comes closer than its clearance to the floor,
    /// itself or another arm, in order of time; declared ones too (`declared_by_key`).
    #[getter]
    fn contacts(&self) -> Vec<Contact> {
        self.report.contacts.iter().cloned().map(Contact).collect()
    }

    /// Each servo's load against its drive, as `keypose check --format json` gives it under
    /// "torque": the build, per joint the peak torque and its share of the torque-speed line,
    /// RMS against the continuous rating and droop, the overloads and droops; `None` when it
    /// was not checked.
    #[getter]
    fn torque<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = keypose::report::torque_json(&self.report).to_string();
        py.import("json")?.call_method1("loads", (text,))
    }

    /// How close each joint comes to its limits, in joint order.
    #[getter]
    fn joints(&self) -> Vec<JointSummary> {
        self.report
            .joints
            .iter()
            .cloned()
            .map(JointSummary)
            .collect()
    }

    /// The control rate steps and corners were judged at, Hz.
    #[getter]
    fn rate(&self) -> f64 {
        self.report.rate
    }

    /// The report as `keypose check` prints it.
    #[getter]
    fn text(&self) -> String {
        self.text.clone()
    }

    fn __str__(&self) -> String {
        self.text.clone()
    }

    fn __repr__(&self) -> String {
        let verdict = if self.passed { "passed" } else { "failed" };
        format!(
            "<keypose.Report {verdict}: {} violation(s), {} contact(s)>",
            self.report.violations.len(),
            self.report.undeclared_contacts().count()
        )
    }
}

/// A violation in one line: joint, limit, how far past, where and what from.
fn describe(v: &LibViolation) -> String {
    let per = match v.kind {
        keypose::plan::LimitKind::Position => "",
        keypose::plan::LimitKind::Velocity => "/s",
        keypose::plan::LimitKind::Acceleration => "/s²",
        keypose::plan::LimitKind::Jerk => "/s³",
    };
    format!(
        "{} {} {:.3} {}{per} vs limit {:.3} {}{per} in segment {} ({}) at t = {:.3} s ({})",
        v.joint,
        v.kind.name(),
        v.peak,
        v.unit,
        v.limit,
        v.unit,
        v.segment,
        v.segment_label,
        v.peak_time,
        v.cause.name()
    )
}

/// A contact in one line: the bodies, how close, when, and the fix.
fn describe_contact(c: &LibContact) -> String {
    format!(
        "{} {:.1} mm from {} at t = {:.3} s in segment {} ({}): {}",
        c.bodies.0,
        c.distance * 1000.0,
        c.bodies.1.as_deref().unwrap_or("the floor"),
        c.deepest_time,
        c.segment,
        c.segment_label,
        c.advice
    )
}

/// One stretch of time where the arm comes closer than its clearance to something.
#[pyclass(module = "keypose", name = "Contact", frozen)]
pub struct Contact(LibContact);

#[pymethods]
impl Contact {
    /// What the first body touches: "floor", "self" or "between_arms".
    #[getter]
    fn kind(&self) -> &'static str {
        self.0.kind.name()
    }
    /// The two bodies as the model names them; the second is None for the floor.
    #[getter]
    fn bodies(&self) -> (String, Option<String>) {
        self.0.bodies.clone()
    }
    /// Sequence time the contact starts, seconds.
    #[getter]
    fn start(&self) -> f64 {
        self.0.from
    }
    /// Sequence time it ends, seconds.
    #[getter]
    fn end(&self) -> f64 {
        self.0.to
    }
    /// Sequence time of its deepest point, seconds.
    #[getter]
    fn deepest_time(&self) -> f64 {
        self.0.deepest_time
    }
    /// The distance there, millimetres (negative: that deep).
    #[getter]
    fn distance_mm(&self) -> f64 {
        self.0.distance * 1000.0
    }
    /// "path" (measured on the goals) or "unresolved" (a step's jump could not be ruled out).
    #[getter]
    fn cause(&self) -> &'static str {
        self.0.cause.name()
    }
    /// The key whose pose is in it, if any: the key to move.
    #[getter]
    fn key(&self) -> Option<usize> {
        self.0.key
    }
    /// The key whose "contact" declares it (then it passes), or None.
    #[getter]
    fn declared_by_key(&self) -> Option<usize> {
        self.0.declared
    }
    /// What to do about it.
    #[getter]
    fn advice(&self) -> String {
        self.0.advice.clone()
    }
    fn __repr__(&self) -> String {
        format!("<keypose.Contact {}>", describe_contact(&self.0))
    }
    fn __str__(&self) -> String {
        describe_contact(&self.0)
    }
}

/// One stretch of time where a joint exceeds a limit.
#[pyclass(module = "keypose", name = "Violation", frozen)]
pub struct Violation(LibViolation);

#[pymethods]
impl Violation {
    /// The joint's name.
    #[getter]
    fn joint(&self) -> String {
        self.0.joint.clone()
    }
    /// "position", "velocity" or "acceleration".
    #[getter]
    fn kind(&self) -> &'static str {
        self.0.kind.name()
    }
    /// What the worst value comes from: "curve", "step" or "corner".
    #[getter]
    fn cause(&self) -> &'static str {
        self.0.cause.name()
    }
    /// "deg" or "m" (velocities per s, accelerations per s²).
    #[getter]
    fn unit(&self) -> &'static str {
        self.0.unit
    }
    /// The segment, from key `segment` to key `segment + 1`.
    #[getter]
    fn segment(&self) -> usize {
        self.0.segment
    }
    /// "from → to": the names of the segment's keys.
    #[getter]
    fn segment_label(&self) -> String {
        self.0.segment_label.clone()
    }
    /// Sequence time the violation starts, seconds.
    #[getter]
    fn start(&self) -> f64 {
        self.0.from
    }
    /// Sequence time it ends, seconds.
    #[getter]
    fn end(&self) -> f64 {
        self.0.to
    }
    /// Sequence time of the worst point, seconds.
    #[getter]
    fn peak_time(&self) -> f64 {
        self.0.peak_time
    }
    /// The worst value (signed).
    #[getter]
    fn peak(&self) -> f64 {
        self.0.peak
    }
    /// The limit it crosses (signed).
    #[getter]
    fn limit(&self) -> f64 {
        self.0.limit
    }
    /// How far past the limit the worst value is (positive).
    #[getter]
    fn excess(&self) -> f64 {
        self.0.excess
    }
    fn __repr__(&self) -> String {
        format!("<keypose.Violation {}>", describe(&self.0))
    }
    fn __str__(&self) -> String {
        describe(&self.0)
    }
}

/// How close one joint comes to its limits.
#[pyclass(module = "keypose", name = "JointSummary", frozen)]
pub struct JointSummary(LibJointSummary);

#[pymethods]
impl JointSummary {
    /// The joint's name.
    #[getter]
    fn joint(&self) -> String {
        self.0.joint.clone()
    }
    /// "deg" or "m".
    #[getter]
    fn unit(&self) -> &'static str {
        self.0.unit
    }
    /// Lowest position over the played window.
    #[getter]
    fn min_position(&self) -> f64 {
        self.0.min_position
    }
    /// Highest position over the played window.
    #[getter]
    fn max_position(&self) -> f64 {
        self.0.max_position
    }
    /// Largest speed, per second.
    #[getter]
    fn peak_velocity(&self) -> f64 {
        self.0.peak_velocity
    }
    /// The joint's velocity limit, per second.
    #[getter]
    fn velocity_limit(&self) -> f64 {
        self.0.velocity_limit
    }
    /// Largest acceleration, per second squared.
    #[getter]
    fn peak_acceleration(&self) -> f64 {
        self.0.peak_acceleration
    }
    /// The joint's acceleration limit, per second squared.
    #[getter]
    fn acceleration_limit(&self) -> f64 {
        self.0.acceleration_limit
    }
    fn __repr__(&self) -> String {
        let s = &self.0;
        format!(
            "<keypose.JointSummary {}: {:.2} … {:.2} {u}, peak {:.1} {u}/s, {:.1} {u}/s²>",
            s.joint,
            s.min_position,
            s.max_position,
            s.peak_velocity,
            s.peak_acceleration,
            u = s.unit
        )
    }
}
