//! Static checks of a trajectory against the robot's joint limits, exact at any sampling rate.
//!
//! The curve is checked, not only the keys: a cubic through keys that are all inside a limit can
//! overshoot it between them, and a motion of a few milliseconds fits between two samples of any
//! grid. Each joint's curve is split into polynomial spans (`spans`): position, velocity and
//! acceleration are polynomials there, whose extremes lie at the span's ends or at the roots of
//! their derivatives (`cubic`), so the peaks are found exactly, wherever they fall.
//!
//! Where the curve is smooth, those peaks bound what the player asks for at any control rate and
//! phase. A step (the value jumps) or a linear corner (the velocity jumps) is turned by the
//! player within one control period: there the velocity and acceleration of the goals it sends
//! at `rate` are checked, at their worst over every phase (`period`), as the step limiter
//! judges them. The arm is at rest before the window and after it, as it is after the approach
//! ramp and at the end of playback, so a sequence that starts or ends in motion is flagged.
//!
//! A joint with a jerk limit (`Limits::jerk`) is checked for jerk too (`jerk`): the curve's third
//! derivative on each span, exactly like the others, and every jump of its acceleration where
//! two spans meet, each a violation of its own (an infinite jerk at any control rate). Without
//! a jerk limit no jerk violation is reported: the verdict is what it was before.
//!
//! The check covers clearance too (`plan::clearance`): every contact of the arm with the floor,
//! itself or another arm along the whole trajectory, certified between any two instants.

mod jerk;
mod period;
mod units;

pub use units::radians_warning;
pub(crate) mod poly;
pub(crate) mod runs;
pub(crate) mod spans;

use super::clearance::{self, ClearanceScope, Contact};
use super::load::{check_loads, LoadScope, Overload};
use super::Trajectory;
use crate::robot::Robot;
use runs::Attributed;
use spans::{Discontinuity, JointCurve, Span};

/// Which of a joint's limits a violation exceeds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitKind {
    /// The range, `min` … `max`.
    Position,
    /// The speed, per second.
    Velocity,
    /// The acceleration, per second squared.
    Acceleration,
    /// The jerk, per second cubed: only for a joint with a jerk limit.
    Jerk,
}

impl LimitKind {
    /// Lower-case name, as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            LimitKind::Position => "position",
            LimitKind::Velocity => "velocity",
            LimitKind::Acceleration => "acceleration",
            LimitKind::Jerk => "jerk",
        }
    }
}

/// What a violation comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// The curve itself: an overshoot between keys, a segment too fast for its distance.
    Curve,
    /// A step: the value jumps, so the player's goals jump within one control period. No
    /// timing mends it.
    Step,
    /// A corner: the velocity jumps (linear segments meeting, a hold next to a linear segment, a
    /// start or an end in motion), so the player turns it within one control period.
    Corner,
    /// The acceleration jumps (a key of a key-time cubic, a change of a timing profile's path
    /// acceleration, a start or an end with the acceleration other than zero): an infinite
    /// jerk, reported for a joint with a jerk limit. Stretching time does not mend it.
    AccelerationJump,
}

impl Cause {
    /// Lower-case name, as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            Cause::Curve => "curve",
            Cause::Step => "step",
            Cause::Corner => "corner",
            Cause::AccelerationJump => "jump",
        }
    }
}

/// One stretch of time where a joint exceeds a limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// The joint's name.
    pub joint: String,
    /// "deg" or "m" (velocity and acceleration are per s and per s²).
    pub unit: &'static str,
    /// Which limit.
    pub kind: LimitKind,
    /// Keyframe segment index: from key `segment` to key `segment + 1`.
    pub segment: usize,
    /// "from → to" names of the segment's keys.
    pub segment_label: String,
    /// Sequence time the violation starts, seconds.
    pub from: f64,
    /// Sequence time it ends, seconds.
    pub to: f64,
    /// Sequence time of its worst point, seconds.
    pub peak_time: f64,
    /// The worst value (signed).
    pub peak: f64,
    /// The limit it crossed (signed: the min or max for positions, ±limit otherwise).
    pub limit: f64,
    /// How far past the limit the worst value is (positive).
    pub excess: f64,
    /// What the worst value comes from.
    pub cause: Cause,
    /// For a jerk violation where the acceleration jumps (`peak` is then infinite): how far it
    /// jumps, per second squared (after minus before). None for any other violation.
    pub acceleration_jump: Option<f64>,
}

impl Violation {
    /// Whether changing the timing can mend it: not a position, not a step's jump, not a jump
    /// of the acceleration (each is there however long the segment lasts).
    pub fn mendable_by_timing(&self) -> bool {
        self.kind != LimitKind::Position
            && self.cause != Cause::Step
            && self.acceleration_jump.is_none()
    }
}

/// How close each joint comes to its limits.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSummary {
    /// The joint's name.
    pub joint: String,
    /// "deg" or "m".
    pub unit: &'static str,
    /// Lowest position over the played window.
    pub min_position: f64,
    /// Highest position over the played window.
    pub max_position: f64,
    /// Largest speed, per second, at the checked playback speed.
    pub peak_velocity: f64,
    /// The joint's velocity limit, per second.
    pub velocity_limit: f64,
    /// Largest acceleration, per second squared, at the checked playback speed.
    pub peak_acceleration: f64,
    /// The joint's acceleration limit, per second squared.
    pub acceleration_limit: f64,
    /// Largest jerk of the curve between the places where its acceleration jumps, per second
    /// cubed, at the checked playback speed.
    pub peak_jerk: f64,
    /// Largest jump of the acceleration (the played window's ends included), per second
    /// squared, at the checked playback speed; 0 where the acceleration is continuous.
    pub acceleration_jump: f64,
    /// The joint's jerk limit, per second cubed; None without one (jerk is then not checked).
    pub jerk_limit: Option<f64>,
}

/// What [`check`] found: every violation, and how close each joint comes to its limits.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// Control rate in Hz at which steps and corners are judged: the player turns them within
    /// `speed / rate` seconds of sequence time.
    pub rate: f64,
    /// Playback speed: 1 for a plain check. Velocities, accelerations and their limits are what
    /// the servos see at this speed; times are the sequence's, so they point at its keys.
    pub speed: f64,
    /// Sequence time the checked window starts, seconds.
    pub start: f64,
    /// Sequence time it ends, seconds.
    pub end: f64,
    /// Every stretch of time where a joint exceeds a limit, joint by joint.
    pub violations: Vec<Violation>,
    /// One per joint, in robot joint order.
    pub joints: Vec<JointSummary>,
    /// Every stretch of time where the arm comes closer than its clearance to the floor,
    /// itself or another arm, in order of time; declared ones included (they pass).
    pub contacts: Vec<Contact>,
    /// What the clearance check covered; `None` when it was not run (the limits alone, as
    /// the retiming loops judge a candidate).
    pub clearance: Option<ClearanceScope>,
    /// Each servo's load against its drive; `None` when it was not run.
    pub loads: Option<LoadScope>,
}

impl CheckReport {
    /// No violation, no contact but declared ones, and no servo over its torque-speed line.
    pub fn passed(&self) -> bool {
        self.violations.is_empty()
            && self.undeclared_contacts().next().is_none()
            && self.overloads().next().is_none()
    }

    /// Every stretch where a servo is asked for more than its torque-speed line gives.
    pub fn overloads(&self) -> impl Iterator<Item = &Overload> {
        let report = match &self.loads {
            Some(LoadScope::Checked(report)) => Some(report),
            _ => None,
        };
        report.into_iter().flat_map(|r| r.overloads.iter())
    }

    /// The contacts no key declares: each fails the check.
    pub fn undeclared_contacts(&self) -> impl Iterator<Item = &Contact> {
        self.contacts.iter().filter(|c| c.declared.is_none())
    }

    /// The contacts a key declares: they pass, and `play` asks for `--allow-contact`.
    pub fn declared_contacts(&self) -> impl Iterator<Item = &Contact> {
        self.contacts.iter().filter(|c| c.declared.is_some())
    }
}

/// Checks `trajectory` against `robot`: each joint's limits (steps and corners as the player
/// turns them at a control rate of `rate` Hz), and the clearance to the floor, the arm itself
/// and the other arms along the whole motion.
pub fn check(trajectory: &Trajectory, robot: &Robot, rate: f64) -> CheckReport {
    let mut report = check_limits(trajectory, robot, rate);
    add_clearance(&mut report, trajectory, robot);
    report.loads = Some(check_loads(trajectory, robot, 1.0));
    report
}

/// Adds the clearance to a report of the limits alone (`check_limits`): the contacts along
/// the path, the same at any playback speed and timing.
pub(crate) fn add_clearance(report: &mut CheckReport, trajectory: &Trajectory, robot: &Robot) {
    let (contacts, scope) = clearance::contacts(trajectory, robot);
    report.contacts = contacts;
    report.clearance = Some(scope);
}

/// The joints' limits alone, without the clearance: what timing changes, for the loops that
/// judge one candidate timing after another.
pub(crate) fn check_limits(trajectory: &Trajectory, robot: &Robot, rate: f64) -> CheckReport {
    let period = 1.0 / rate;
    let mut violations = Vec::new();
    let mut joints = Vec::new();
    for (j, joint) in robot.joints.iter().enumerate() {
        let q = Quantities::of(trajectory, j, period);
        let limits = joint.limits;
        let unit = joint.kind.unit();
        let mut record =
            |spans: &[Attributed], kind: LimitKind, low: f64, high: f64| {
                violations.extend(runs::outside(spans, low, high).into_iter().map(|run| {
                    Violation {
                        joint: joint.name.clone(),
                        unit,
                        kind,
                        segment: run.segment,
                        segment_label: trajectory.segment_label(run.segment),
                        from: run.from,
                        to: run.to,
                        peak_time: run.peak_time,
                        peak: run.peak,
                        limit: run.limit,
                        excess: run.excess,
                        cause: run.cause,
                        acceleration_jump: None,
                    }
                }));
            };
        record(&q.position, LimitKind::Position, limits.min, limits.max);
        record(
            &q.velocity,
            LimitKind::Velocity,
            -limits.velocity,
            limits.velocity,
        );
        record(
            &q.acceleration,
            LimitKind::Acceleration,
            -limits.acceleration,
            limits.acceleration,
        );
        if let Some(jerk) = limits.jerk {
            record(&q.jerk, LimitKind::Jerk, -jerk, jerk);
            violations.extend(q.jumps.iter().map(|jump| {
                let segment = trajectory.segment_at(jump.time);
                Violation {
                    joint: joint.name.clone(),
                    unit,
                    kind: LimitKind::Jerk,
                    segment,
                    segment_label: trajectory.segment_label(segment),
                    from: jump.time,
                    to: jump.time,
                    peak_time: jump.time,
                    peak: f64::INFINITY.copysign(jump.jump),
                    limit: jerk.copysign(jump.jump),
                    excess: f64::INFINITY,
                    cause: jump.cause,
                    acceleration_jump: Some(jump.jump),
                }
            }));
        }
        let (low, high) = runs::range(&spans_of(&q.position));
        let (low, high) = q
            .rest
            .iter()
            .fold((low, high), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        joints.push(JointSummary {
            joint: joint.name.clone(),
            unit,
            min_position: low,
            max_position: high,
            peak_velocity: runs::peak(&spans_of(&q.velocity)),
            velocity_limit: limits.velocity,
            peak_acceleration: runs::peak(&spans_of(&q.acceleration)),
            acceleration_limit: limits.acceleration,
            peak_jerk: runs::peak(&spans_of(&q.jerk)),
            acceleration_jump: q.jumps.iter().fold(0.0, |m, j| m.max(j.jump.abs())),
            jerk_limit: limits.jerk,
        });
    }
    violations.sort_by(|a, b| a.from.total_cmp(&b.from));
    CheckReport {
        rate,
        speed: 1.0,
        start: trajectory.start,
        end: trajectory.end,
        violations,
        joints,
        contacts: Vec::new(),
        clearance: None,
        loads: None,
    }
}

/// One joint's position, velocity and acceleration as spans, each in its keyframe segment.
struct Quantities {
    position: Vec<Attributed>,
    velocity: Vec<Attributed>,
    acceleration: Vec<Attributed>,
    /// The curve's own jerk on each span.
    jerk: Vec<Attributed>,
    /// Where the acceleration jumps.
    jumps: Vec<jerk::AccelerationJump>,
    /// The values held before and after the window.
    rest: [f64; 2],
}

impl Quantities {
    /// The curve's own derivatives over the window, and the player's differences over one
    /// `period` wherever a step or a corner is within reach of them.
    fn of(trajectory: &Trajectory, joint: usize, period: f64) -> Quantities {
        let curve = JointCurve::new(
            &trajectory.tracks()[joint],
            trajectory.timing(),
            trajectory.start,
            trajectory.end,
            &trajectory.key_times,
            3.0 * period,
        );
        let in_segment = |span: Span| Attributed {
            span,
            segment: trajectory.segment_at(0.5 * (span.start + span.end)),
            cause: Cause::Curve,
        };
        let position: Vec<Attributed> = curve.played.iter().map(|s| in_segment(*s)).collect();
        let velocity_spans: Vec<Span> = curve.played.iter().map(Span::derivative).collect();
        let mut velocity: Vec<Attributed> = velocity_spans.iter().map(|s| in_segment(*s)).collect();
        let mut acceleration: Vec<Attributed> = velocity_spans
            .iter()
            .map(|s| in_segment(s.derivative()))
            .collect();
        let jerk = curve
            .played
            .iter()
            .map(|s| in_segment(jerk::jerk(s)))
            .collect();

        let jumps = curve.discontinuities();
        let attribute = |span: Span| {
            let (segment, cause) =
                discontinuity_segment(trajectory, &jumps, 0.5 * (span.start + span.end));
            Attributed {
                span,
                segment,
                cause,
            }
        };
        let steps: Vec<f64> = jumps
            .iter()
            .filter(|d| d.jump != 0.0)
            .map(|d| d.time)
            .collect();
        let all: Vec<f64> = jumps.iter().map(|d| d.time).collect();
        for (stencil, times, out) in [
            (period::VELOCITY, &steps, &mut velocity),
            (period::ACCELERATION, &all, &mut acceleration),
        ] {
            let windows = period::windows_around(times, stencil, period);
            out.extend(
                period::differences(&curve, stencil, period, &windows)
                    .into_iter()
                    .map(attribute),
            );
        }
        Quantities {
            position,
            velocity,
            acceleration,
            jerk,
            jumps: jerk::acceleration_jumps(&curve),
            rest: curve.rest_values(),
        }
    }
}

/// The keyframe segment a difference across discontinuities at phase `t` is reported in, and
/// its cause, that of the discontinuity nearest `t`. A step is its segment's (whose end it jumps
/// at). A corner is reported on either side in the segment of `t`, so that `retime` stretches
/// both segments whose velocities meet there, unless the curve is at rest on that side (a hold,
/// a step, a start from rest): then in the segment that moves, whose stretch mends it.
fn discontinuity_segment(
    trajectory: &Trajectory,
    jumps: &[Discontinuity],
    t: f64,
) -> (usize, Cause) {
    let i = jumps.partition_point(|d| d.time < t);
    let nearest = [i.checked_sub(1), (i < jumps.len()).then_some(i)]
        .into_iter()
        .flatten()
        .min_by(|&a, &b| {
            (jumps[a].time - t)
                .abs()
                .total_cmp(&(jumps[b].time - t).abs())
        });
    let Some(d) = nearest.map(|k| jumps[k]) else {
        return (trajectory.segment_at(t), Cause::Curve);
    };
    let last_segment = trajectory.key_times.len().saturating_sub(2);
    let ending_at = |time: f64| {
        let before = trajectory.key_times.partition_point(|&k| k < time);
        before.saturating_sub(1).min(last_segment)
    };
    if d.jump != 0.0 {
        return (ending_at(d.time), Cause::Step);
    }
    let segment = match (t < d.time, d.moving) {
        (true, [false, true]) => trajectory.segment_at(d.time),
        (false, [true, false]) => ending_at(d.time),
        _ => trajectory.segment_at(t),
    };
    (segment, Cause::Corner)
}

fn spans_of(attributed: &[Attributed]) -> Vec<Span> {
    attributed.iter().map(|a| a.span).collect()
}

/// Checks playback at `speed` with a control rate of `rate` Hz: velocities scale with the speed
/// and accelerations with its square, so the unscaled trajectory is checked against the limits
/// divided by them, differenced at the sequence time one control period covers. The report is
/// then scaled back: it shows the robot's own limits and the velocities and accelerations the
/// servos would be asked for, which is what a user compares with the robot file.
pub fn check_at_speed(
    trajectory: &Trajectory,
    robot: &Robot,
    rate: f64,
    speed: f64,
) -> CheckReport {
    let mut scaled = robot.clone();
    for joint in &mut scaled.joints {
        joint.limits.velocity /= speed;
        joint.limits.acceleration /= speed * speed;
        joint.limits.jerk = joint.limits.jerk.map(|j| j / speed.powi(3));
    }
    let mut report = check_limits(trajectory, &scaled, rate / speed);
    to_wall_clock(&mut report, robot, rate, speed);
    add_clearance(&mut report, trajectory, robot);
    report.loads = Some(check_loads(trajectory, robot, speed));
    report
}

/// Rescales a report made in sequence time to the servos' time at `speed`, with the limits
/// taken from `robot` itself (not rescaled twice, so they print as the file gives them).
fn to_wall_clock(report: &mut CheckReport, robot: &Robot, rate: f64, speed: f64) {
    report.rate = rate;
    report.speed = speed;
    for v in &mut report.violations {
        let Some(joint) = robot.joints.iter().find(|j| j.name == v.joint) else {
            continue;
        };
        let (factor, limit) = match v.kind {
            LimitKind::Position => continue,
            LimitKind::Velocity => (speed, joint.limits.velocity),
            LimitKind::Acceleration => (speed * speed, joint.limits.acceleration),
            LimitKind::Jerk => (speed.powi(3), joint.limits.jerk.unwrap_or(f64::INFINITY)),
        };
        v.acceleration_jump = v.acceleration_jump.map(|a| a * speed * speed);
        v.peak *= factor;
        v.limit = limit.copysign(v.limit);
        v.excess = v.peak.abs() - limit;
    }
    for (summary, joint) in report.joints.iter_mut().zip(&robot.joints) {
        summary.peak_velocity *= speed;
        summary.velocity_limit = joint.limits.velocity;
        summary.peak_acceleration *= speed * speed;
        summary.acceleration_limit = joint.limits.acceleration;
        summary.peak_jerk *= speed.powi(3);
        summary.acceleration_jump *= speed * speed;
        summary.jerk_limit = joint.limits.jerk;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::Sequence;

    /// The SO-101 (115 °/s, 344 °/s²) and `keys` as `(time, wrist_flex)` in `mode`.
    fn wrist(mode: &str, keys: &[(f64, f64)]) -> (Trajectory, Robot) {
        let robot = Robot::builtin("so101").unwrap();
        let keys: Vec<String> = keys
            .iter()
            .map(|(t, v)| format!(r#"{{"time": {t}, "joints": {{"wrist_flex": {v}}}}}"#))
            .collect();
        let text = format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "{mode}",
                "keyframes": [{}]}}"#,
            keys.join(",")
        );
        let sequence = Sequence::from_json("wrist.json", &text).unwrap();
        (Trajectory::build(&sequence, &robot).unwrap(), robot)
    }

    fn wrist_summary(report: &CheckReport) -> &JointSummary {
        report
            .joints
            .iter()
            .find(|j| j.joint == "wrist_flex")
            .unwrap()
    }

    fn close(actual: f64, expected: f64) -> bool {
        (actual - expected).abs() <= 1e-9 * expected.abs().max(1.0)
    }

    #[test]
    fn a_spike_between_any_two_samples_is_measured_at_its_peaks_at_every_rate() {
        // 0 → 60 → 0° with zero slopes at the keys: two smoothsteps 3f² − 2f³ of h seconds,
        // whose velocity peaks at 1.5·60/h and acceleration at 6·60/h² (at their ends).
        for h in [0.001, 0.0015, 0.002] {
            let (trajectory, robot) = wrist("cubic", &[(0.0, 0.0), (h, 60.0), (2.0 * h, 0.0)]);
            for rate in [10.0, 50.0, 100.0, 500.0, 1000.0] {
                let report = check(&trajectory, &robot, rate);
                assert!(!report.passed(), "h = {h}, {rate} Hz");
                let wrist = wrist_summary(&report);
                assert!(close(wrist.max_position, 60.0), "{wrist:?}");
                assert!(close(wrist.peak_velocity, 1.5 * 60.0 / h), "{wrist:?}");
                assert!(
                    close(wrist.peak_acceleration, 6.0 * 60.0 / (h * h)),
                    "{wrist:?}"
                );
                assert!(report.violations.iter().all(|v| v.cause == Cause::Curve));
            }
        }
    }

    #[test]
    fn a_linear_corner_is_its_velocity_change_within_one_control_period() {
        // 0 → 10° in 1 s: the velocity steps from 0 to 10 °/s at 0 s and back at 1 s.
        let (trajectory, robot) = wrist("linear", &[(0.0, 0.0), (1.0, 10.0)]);
        // 10 Hz: 10 °/s within 0.1 s is 100 °/s², inside 344.
        let slow = check(&trajectory, &robot, 10.0);
        assert!(slow.passed(), "{:?}", slow.violations);
        assert!(close(wrist_summary(&slow).peak_acceleration, 100.0));
        assert!(close(wrist_summary(&slow).peak_velocity, 10.0));
        // 100 Hz: 1000 °/s², at the start (the segment that moves) and at the end.
        let report = check(&trajectory, &robot, 100.0);
        assert!(close(wrist_summary(&report).peak_acceleration, 1000.0));
        let corners: Vec<(f64, f64)> = report
            .violations
            .iter()
            .map(|v| (v.peak_time, v.peak))
            .collect();
        assert_eq!(corners.len(), 2, "{corners:?}");
        assert!(close(corners[0].0, 0.0) && close(corners[0].1, 1000.0));
        assert!(close(corners[1].0, 1.0) && close(corners[1].1, -1000.0));
        for v in &report.violations {
            assert_eq!(
                (v.kind, v.cause, v.segment),
                (LimitKind::Acceleration, Cause::Corner, 0)
            );
            // The goals turn it within one period either side of the corner.
            assert!(v.to - v.from <= 0.02 + 1e-12, "{v:?}");
        }
    }

    #[test]
    fn a_step_is_its_jump_within_one_control_period_however_small() {
        // Holds 0 until 1 s, then 5°.
        let (trajectory, robot) = wrist("step", &[(0.0, 0.0), (1.0, 5.0)]);
        let report = check(&trajectory, &robot, 100.0);
        let wrist = wrist_summary(&report);
        // 5° within 10 ms: 500 °/s; up and down again in two periods: 5/0.01² = 50 000 °/s².
        assert!(close(wrist.peak_velocity, 500.0), "{wrist:?}");
        assert!(close(wrist.peak_acceleration, 50_000.0), "{wrist:?}");
        assert!(!report.violations.is_empty());
        for v in &report.violations {
            assert_eq!((v.cause, v.segment), (Cause::Step, 0), "{v:?}");
        }
    }

    #[test]
    fn a_start_in_motion_is_a_corner_from_rest() {
        // Control ends: the window starts at key 1, where the cubic moves at the central
        // difference (20 − 0)/(2 − 0) = 10 °/s; the arm is at rest before it.
        let robot = Robot::builtin("so101").unwrap();
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "ends": "control",
            "keyframes": [{"time": 0, "joints": {"wrist_flex": 0}},
                          {"time": 1, "joints": {"wrist_flex": 10}},
                          {"time": 2, "joints": {"wrist_flex": 20}},
                          {"time": 3, "joints": {"wrist_flex": 30}}]}"#;
        let sequence = Sequence::from_json("control.json", text).unwrap();
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let report = check(&trajectory, &robot, 100.0);
        let start = report
            .violations
            .iter()
            .find(|v| close(v.peak_time, 1.0))
            .unwrap_or_else(|| panic!("{:?}", report.violations));
        // 10 °/s from rest within 10 ms: 1000 °/s².
        assert_eq!(
            (start.kind, start.cause),
            (LimitKind::Acceleration, Cause::Corner)
        );
        assert!(close(start.peak, 1000.0), "{start:?}");
    }
}
