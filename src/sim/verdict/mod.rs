//! Verdicts on a simulated run. Python measures; Rust decides (DESIGN.md): every threshold is
//! in [`Thresholds`], applied to a [`Trace`] in joint units (degrees, metres, seconds).
//!
//! One check per [`FindingKind`], each in the module named for what it looks at:
//! `tracking` (in motion, settling at keys), `speed`, `limits` (joint stops),
//! `saturation`, `contacts` (collisions, divergence). This module only runs them, joint by
//! joint, and knows nothing about any threshold's meaning.

mod column;
mod contacts;
mod finding;
mod limits;
mod saturation;
mod speed;
mod tolerances;
mod tracking;

pub use crate::report::units::{force_unit, shown, Shown};
pub use contacts::collisions;
pub use finding::{Finding, FindingKind};
pub use tolerances::Thresholds;

use crate::robot::{JointKind, Robot};
use column::Column;

/// One simulated run, in joint units, one row per control cycle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    /// Seconds since the start of the run.
    pub time: Vec<f64>,
    /// The sequence time each row belongs to, or `None` during the approach ramp.
    pub sequence_time: Vec<Option<f64>>,
    /// The goal sent, `commanded[row][joint]`.
    pub commanded: Vec<Vec<f64>>,
    /// Where the arm should be, `intended[row][joint]`: the goal itself, or the path the goal
    /// leads with droop compensation. Tracking is judged against it.
    pub intended: Vec<Vec<f64>>,
    /// `position[row][joint]`, measured at the end of the row.
    pub position: Vec<Vec<f64>>,
    /// Joint units per second.
    pub velocity: Vec<Vec<f64>>,
    /// Actuator force or torque (N·m, N).
    pub force: Vec<Vec<f64>>,
    /// A joint-limit constraint was active.
    pub at_limit: Vec<Vec<bool>>,
    /// Every penetrating contact, row by row.
    pub contacts: Vec<Contact>,
    /// (simulation time, MuJoCo's message) where the run diverged; it ends there.
    pub divergence: Vec<(f64, String)>,
    /// Actuator force limits per joint (None: unlimited).
    pub force_limits: Vec<Option<f64>>,
}

/// A penetrating contact between two bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Simulation time, seconds (0 for a pose held still).
    pub time: f64,
    /// One body's name ("flex" for a flex).
    pub body1: String,
    /// The other's.
    pub body2: String,
    /// What touches what.
    pub kind: ContactKind,
    /// Penetration, metres (positive).
    pub depth: f64,
    /// Normal force, newtons.
    pub force: f64,
    /// In a cell, the arms `body1` and `body2` belong to (None: not an arm's, the floor say).
    pub arms: [Option<String>; 2],
}

impl Contact {
    /// The two bodies, and for a collision between arms the two arms first:
    /// "arms left and right: left/gripper touches right/moving_jaw".
    pub fn bodies(&self) -> String {
        let touch = format!("{} touches {}", self.body1, self.body2);
        match (self.kind, &self.arms) {
            (ContactKind::BetweenArms, [Some(a), Some(b)]) => format!("arms {a} and {b}: {touch}"),
            _ => touch,
        }
    }

    /// Whether `other` is between the same two bodies, named in either order.
    pub fn same_bodies(&self, other: &Contact) -> bool {
        (self.body1 == other.body1 && self.body2 == other.body2)
            || (self.body1 == other.body2 && self.body2 == other.body1)
    }
}

/// What a contact touches, as the harness classifies it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactKind {
    /// One body is the floor.
    Floor,
    /// Two bodies of the same arm.
    SelfCollision,
    /// Bodies of two different arms of a cell.
    BetweenArms,
    /// Anything else the arm touched.
    Environment,
}

impl ContactKind {
    /// Lower-case name, as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            ContactKind::Floor => "floor",
            ContactKind::SelfCollision => "self",
            ContactKind::BetweenArms => "arms",
            ContactKind::Environment => "environment",
        }
    }
}

/// Per-joint tracking figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracking {
    /// The joint's name.
    pub joint: String,
    /// The arm of a cell the joint belongs to.
    pub arm: Option<String>,
    /// Revolute (degrees) or prismatic (metres): what [`shown`] needs to show its figures.
    pub kind: JointKind,
    /// "deg" or "m".
    pub unit: &'static str,
    /// Largest tracking error (measured − commanded, absolute), in the joint's unit.
    pub max_error: f64,
    /// When it happened, in the sequence's time (negative during the approach).
    pub max_error_time: f64,
    /// Root mean square of the tracking error over the run.
    pub rms_error: f64,
    /// (key label, sequence time, error) after settling at each key.
    pub settled: Vec<(String, f64, f64)>,
    /// Fastest the servo's output shaft turned, °/s.
    pub peak_speed_servo_deg_s: f64,
    /// The servo's no-load speed, °/s.
    pub servo_speed_limit_deg_s: f64,
}

/// What the simulation says of a run: each joint's figures and everything caught.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// One per joint, in joint order.
    pub tracking: Vec<Tracking>,
    /// In time order.
    pub findings: Vec<Finding>,
}

impl Verdict {
    /// Nothing was caught.
    pub fn passed(&self) -> bool {
        self.findings.is_empty()
    }
}

/// A key for the settling check, in sequence time.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyMark {
    /// The key's name, or "#index".
    pub label: String,
    /// When the command reaches the key.
    pub time: f64,
    /// How long the sequence holds it, seconds.
    pub hold: f64,
}

/// The verdict on `trace`: every check of every joint, then the run's contacts and divergence,
/// findings in time order.
pub fn judge(robot: &Robot, trace: &Trace, keys: &[KeyMark], t: &Thresholds) -> Verdict {
    let mut findings = Vec::new();
    let mut tracking = Vec::new();
    for (index, joint) in robot.joints.iter().enumerate() {
        let column = Column {
            trace,
            index,
            joint,
            arm: robot.arm_of_joint(index).map(|a| a.name.as_str()),
        };
        tracking.push(judge_joint(&column, keys, t, &mut findings));
    }
    findings.extend(contacts::check_contacts(trace, t));
    findings.extend(contacts::check_divergence(trace));
    // Stable: findings at the same time keep the order of the checks.
    findings.sort_by(|a, b| a.time.total_cmp(&b.time));
    // The checks work on the simulation clock; a person reads the file's times.
    for f in &mut findings {
        f.time = trace.shown_time(f.time);
    }
    for figures in &mut tracking {
        figures.max_error_time = trace.shown_time(figures.max_error_time);
    }
    Verdict { tracking, findings }
}

impl Trace {
    /// Simulation time `time` as the sequence file counts it: the sequence time of its row, or
    /// during a ramp, the (negative) time left until the sequence starts or resumes.
    pub fn shown_time(&self, time: f64) -> f64 {
        if self.time.is_empty() {
            return time;
        }
        let row = self
            .time
            .partition_point(|&t| t < time - 1e-9)
            .min(self.time.len() - 1);
        if let Some(s) = self.sequence_time[row] {
            return s;
        }
        match (row..self.time.len()).find_map(|r| self.sequence_time[r].map(|s| (r, s))) {
            Some((next, s)) => s - (self.time[next] - time),
            // A ramp nothing follows: after the last sequence time.
            None => (0..row)
                .rev()
                .find_map(|r| self.sequence_time[r].map(|s| s + (time - self.time[r])))
                .unwrap_or(time),
        }
    }
}

/// One joint's checks, their findings added to `findings`, and its tracking figures.
fn judge_joint(
    column: &Column,
    keys: &[KeyMark],
    t: &Thresholds,
    findings: &mut Vec<Finding>,
) -> Tracking {
    let errors = tracking::error_figures(column);
    findings.extend(tracking::check_tracking(column, &errors, t));
    let (settled, settling) = tracking::check_settling(column, keys, t);
    findings.extend(settling);
    let top_speed = speed::peak_servo_speed(column);
    findings.extend(speed::check_speed(column, top_speed));
    findings.extend(speed::check_commanded_speed(column));
    findings.extend(limits::check_joint_stop(column));
    findings.extend(saturation::check_saturation(column, t));
    Tracking {
        joint: column.joint.name.clone(),
        arm: column.arm.map(str::to_string),
        kind: column.joint.kind,
        unit: column.joint.kind.unit(),
        max_error: errors.max,
        max_error_time: errors.max_time,
        rms_error: errors.rms,
        settled,
        peak_speed_servo_deg_s: top_speed.0,
        servo_speed_limit_deg_s: column.servo_speed_limit(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic 2 s run at 100 Hz of the so101: every joint tracks perfectly unless a test
    /// changes it.
    fn perfect(robot: &Robot) -> Trace {
        let rows = 200;
        let n = robot.joints.len();
        Trace {
            time: (0..rows).map(|r| r as f64 / 100.0).collect(),
            sequence_time: (0..rows).map(|r| Some(r as f64 / 100.0)).collect(),
            commanded: vec![vec![0.0; n]; rows],
            intended: vec![vec![0.0; n]; rows],
            position: vec![vec![0.0; n]; rows],
            velocity: vec![vec![0.0; n]; rows],
            force: vec![vec![0.0; n]; rows],
            at_limit: vec![vec![false; n]; rows],
            contacts: Vec::new(),
            divergence: Vec::new(),
            force_limits: vec![Some(3.35); n],
        }
    }

    fn kinds(v: &Verdict) -> Vec<&'static str> {
        v.findings.iter().map(|f| f.kind.name()).collect()
    }

    #[test]
    fn a_perfect_run_passes_with_zero_error() {
        let robot = Robot::builtin("so101").unwrap();
        let v = judge(&robot, &perfect(&robot), &[], &Thresholds::default());
        assert!(v.passed(), "{:?}", v.findings);
        assert!(v
            .tracking
            .iter()
            .all(|t| t.max_error == 0.0 && t.rms_error == 0.0));
    }

    #[test]
    fn tracking_error_max_and_rms_are_computed_by_hand() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // Elbow lags 4° for the first half (100 rows) and 0 after: RMS = √(100·16/200) = √8.
        for row in 0..100 {
            trace.position[row][2] = 4.0;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(v.tracking[2].max_error, 4.0);
        assert!((v.tracking[2].rms_error - 8f64.sqrt()).abs() < 1e-12);
        assert!(v.passed(), "4° is within the 15° allowed in motion");
        trace.position[150][2] = 16.0;
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["tracking"]);
        assert_eq!(v.findings[0].time, 1.5);
    }

    fn key(label: &str, time: f64, hold: f64) -> KeyMark {
        KeyMark {
            label: label.into(),
            time,
            hold,
        }
    }

    #[test]
    fn an_arm_that_has_not_settled_at_a_held_key_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // The command holds still throughout. 5° off from t = 1.0 on: key a (0.4 s, no hold) is
        // judged 0.5 s after it, at 0.9 s (fine); key b (0.6 s, held 0.8 s) at the end of its
        // hold, 1.4 s (5° off: fails).
        for row in 100..200 {
            trace.position[row][1] = 5.0;
        }
        let keys = [key("a", 0.4, 0.0), key("b", 0.6, 0.8)];
        let v = judge(&robot, &trace, &keys, &Thresholds::default());
        assert_eq!(kinds(&v), ["settling"]);
        assert!(v.findings[0].message.contains("key b"));
        assert_eq!(v.findings[0].time, 1.4);
        assert_eq!(v.tracking[1].settled[0].2, 0.0);
        assert_eq!(v.tracking[1].settled[1].2, 5.0);
    }

    /// The so101 trace with the elbow commanded along a ramp of `rate` °/s from row `from` to
    /// row `to` (then held), and following it `lag` degrees behind.
    fn elbow_ramp(robot: &Robot, from: usize, to: usize, rate: f64, lag: f64) -> Trace {
        let mut trace = perfect(robot);
        for row in 0..trace.time.len() {
            let moved = rate * (row.clamp(from, to) - from) as f64 / 100.0;
            trace.commanded[row][2] = -moved;
            trace.intended[row][2] = -moved;
            trace.position[row][2] = -moved + lag;
        }
        trace
    }

    #[test]
    fn lag_behind_a_moving_command_is_tracking_not_settling() {
        let robot = Robot::builtin("so101").unwrap();
        // Key #0 at 0 s, the command moves at 100 °/s from 0 s to 1.5 s (through key #0's settle
        // point at 0.5 s) and the arm lags 5°: more than the 3° allowed once settled, less than
        // the 15° allowed while moving. The command never rests at key #0, so it is not judged.
        let trace = elbow_ramp(&robot, 0, 150, 100.0, 5.0);
        let v = judge(
            &robot,
            &trace,
            &[key("#0", 0.0, 0.0)],
            &Thresholds::default(),
        );
        assert!(v.passed(), "{:?}", v.findings);
        assert!(v.tracking[2].settled.is_empty());
        assert_eq!(v.tracking[2].max_error, 5.0);
    }

    #[test]
    fn an_arm_still_off_once_the_command_rests_fails_settling() {
        let robot = Robot::builtin("so101").unwrap();
        // The same move, ending at 1.0 s with the key #1 there; the arm stays 5° off after it.
        // Judged 0.5 s after the command came to rest: 1.5 s.
        let trace = elbow_ramp(&robot, 0, 100, 100.0, 5.0);
        let keys = [key("#0", 0.0, 0.0), key("#1", 1.0, 0.0)];
        let v = judge(&robot, &trace, &keys, &Thresholds::default());
        assert_eq!(kinds(&v), ["settling"]);
        assert!(
            v.findings[0].message.contains("key #1"),
            "{}",
            v.findings[0].message
        );
        assert_eq!(v.findings[0].time, 1.5);
    }

    #[test]
    fn times_are_sequence_times_and_the_approach_is_negative() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // The first 0.5 s (50 rows) are the approach ramp: sequence time 0 starts at row 50.
        for row in 0..200 {
            trace.sequence_time[row] = (row >= 50).then(|| (row - 50) as f64 / 100.0);
        }
        trace.position[20][0] = 16.0; // 0.3 s before the sequence starts
        trace.position[150][1] = 16.0; // sequence time 1.0 s
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        let times: Vec<f64> = v.findings.iter().map(|f| f.time).collect();
        assert_eq!(times.len(), 2);
        assert!((times[0] + 0.3).abs() < 1e-9, "{times:?}");
        assert!((times[1] - 1.0).abs() < 1e-9, "{times:?}");
    }

    #[test]
    fn momentary_saturation_passes_sustained_saturation_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // 20 rows = 0.19 s at the limit: momentary.
        for row in 10..30 {
            trace.force[row][1] = -3.35;
        }
        assert!(judge(&robot, &trace, &[], &Thresholds::default()).passed());
        // 40 rows = 0.39 s: sustained.
        for row in 50..90 {
            trace.force[row][1] = 3.34;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["saturation"]);
        assert_eq!(v.findings[0].time, 0.5);
    }

    #[test]
    fn speeds_beyond_the_servo_limits_fail() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // STS3215 on 5 V: 200 °/s no-load; 199 passes, 201 fails.
        trace.velocity[50][0] = 199.0;
        assert!(judge(&robot, &trace, &[], &Thresholds::default()).passed());
        trace.velocity[60][0] = -201.0;
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["speed"]);
        assert!((v.tracking[0].peak_speed_servo_deg_s - 201.0).abs() < 1e-9);
    }

    #[test]
    fn a_command_faster_than_the_servo_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // 2.5° in one 10 ms cycle is 250 °/s, beyond the STS3215's 200 °/s on 5 V.
        for row in 100..200 {
            trace.commanded[row][4] = 2.5;
            trace.intended[row][4] = 2.5;
            trace.position[row][4] = 2.5;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["speed"]);
        assert!(
            v.findings[0].message.contains("commanded 250 °/s"),
            "{}",
            v.findings[0].message
        );
        assert_eq!(v.findings[0].time, 1.0);
    }

    #[test]
    fn limits_contacts_and_divergence_are_reported_once_each() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        trace.at_limit[70][3] = true;
        trace.at_limit[71][3] = true;
        let contact = |time, depth, kind| Contact {
            time,
            body1: "gripper".into(),
            body2: "floor".into(),
            kind,
            depth,
            force: 2.0,
            arms: [None, None],
        };
        trace.contacts = vec![
            contact(0.8, 0.0001, ContactKind::Floor), // a resting touch: ignored
            contact(0.9, 0.003, ContactKind::Floor),
            contact(1.0, 0.004, ContactKind::Floor),
            contact(1.1, 0.002, ContactKind::SelfCollision),
        ];
        trace.divergence = vec![(1.5, "mjWARN_BADQACC".into())];
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(
            kinds(&v),
            [
                "joint limit",
                "floor collision",
                "self collision",
                "divergence"
            ]
        );
        assert!(v.findings[1].message.contains("4.0 mm deep"));
    }

    /// Two so101 arms, left and right, as one cell.
    fn cell() -> Robot {
        let so101 = Robot::builtin("so101").unwrap();
        let arm = |name: &str| {
            (
                name.to_string(),
                so101.clone(),
                crate::pose::RigidTransform::IDENTITY,
            )
        };
        Robot::cell(vec![arm("left"), arm("right")]).unwrap()
    }

    #[test]
    fn in_a_cell_findings_name_the_arm_and_arms_colliding_both() {
        let robot = cell();
        let mut trace = perfect(&robot);
        // Joint 8 is the right arm's elbow_flex (6 joints an arm).
        trace.position[150][8] = 16.0;
        trace.contacts = vec![Contact {
            time: 1.0,
            body1: "left/gripper".into(),
            body2: "right/moving_jaw".into(),
            kind: ContactKind::BetweenArms,
            depth: 0.003,
            force: 4.0,
            arms: [Some("left".into()), Some("right".into())],
        }];
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["arm collision", "tracking"]);
        assert_eq!(v.findings[0].arms, ["left", "right"]);
        assert_eq!(
            v.findings[0].message,
            "arms left and right: left/gripper touches right/moving_jaw: 3.0 mm deep, 4.0 N"
        );
        assert_eq!(v.findings[1].joint.as_deref(), Some("right/elbow_flex"));
        assert_eq!(v.findings[1].arms, ["right"]);
        assert_eq!(v.tracking[8].arm.as_deref(), Some("right"));
        assert_eq!(v.tracking[0].arm.as_deref(), Some("left"));
    }
}
