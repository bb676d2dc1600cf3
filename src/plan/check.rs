//! Static checks of a trajectory against the robot's joint limits.
//!
//! The curve is checked, not only the keys: a cubic through keys that are all inside a limit can
//! overshoot it between them. Positions are checked on a grid and at every turning point of every
//! segment (found exactly); velocity and acceleration are the finite differences of the grid at
//! the control rate, which is what the servos will be asked to follow — a step or a linear corner
//! shows up as the jump it really is at that rate. The arm is at rest before the first played
//! sample and after the last, as it is after the approach ramp and at the end of playback.

use super::Trajectory;
use crate::robot::Robot;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitKind {
    Position,
    Velocity,
    Acceleration,
}

impl LimitKind {
    pub fn name(self) -> &'static str {
        match self {
            LimitKind::Position => "position",
            LimitKind::Velocity => "velocity",
            LimitKind::Acceleration => "acceleration",
        }
    }
}

/// One stretch of time where a joint exceeds a limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    pub joint: String,
    /// "deg" or "m" (velocity and acceleration are per s and per s²).
    pub unit: &'static str,
    pub kind: LimitKind,
    /// Keyframe segment index: from key `segment` to key `segment + 1`.
    pub segment: usize,
    pub segment_label: String,
    /// Time span of the violation and the time of its worst point.
    pub from: f64,
    pub to: f64,
    pub peak_time: f64,
    /// The worst value (signed).
    pub peak: f64,
    /// The limit it crossed (signed: the min or max for positions, ±limit otherwise).
    pub limit: f64,
    /// How far past the limit the worst value is (positive).
    pub excess: f64,
}

/// How close each joint comes to its limits.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSummary {
    pub joint: String,
    pub unit: &'static str,
    pub min_position: f64,
    pub max_position: f64,
    pub peak_velocity: f64,
    pub velocity_limit: f64,
    pub peak_acceleration: f64,
    pub acceleration_limit: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// Control rate in Hz: samples are `speed / rate` seconds of sequence time apart.
    pub rate: f64,
    /// Playback speed: 1 for a plain check. Velocities, accelerations and their limits are what
    /// the servos see at this speed; times are the sequence's, so they point at its keys.
    pub speed: f64,
    pub start: f64,
    pub end: f64,
    pub violations: Vec<Violation>,
    pub joints: Vec<JointSummary>,
}

impl CheckReport {
    pub fn passed(&self) -> bool {
        self.violations.is_empty()
    }
}

/// A time series of one quantity of one joint.
struct Series {
    times: Vec<f64>,
    values: Vec<f64>,
}

/// Every joint sampled on an even grid that spans the played window exactly.
#[derive(Debug, Clone)]
pub struct Sampled {
    pub times: Vec<f64>,
    /// Grid spacing, at most 1/rate.
    pub dt: f64,
    /// `positions[joint][k]`
    pub positions: Vec<Vec<f64>>,
}

impl Sampled {
    pub fn new(trajectory: &Trajectory, rate: f64) -> Sampled {
        let span = trajectory.duration();
        let steps = ((span * rate).ceil() as usize).max(1);
        let dt = if span > 0.0 {
            span / steps as f64
        } else {
            1.0 / rate
        };
        let times: Vec<f64> = (0..=steps)
            .map(|k| trajectory.start + k as f64 * dt)
            .collect();
        let joints = trajectory.joint_names.len();
        let mut positions = vec![vec![0.0; times.len()]; joints];
        let mut sampler = trajectory.sampler();
        let mut pose = vec![0.0; joints];
        for (k, &t) in times.iter().enumerate() {
            sampler.sample_into(t, &mut pose);
            for (series, &value) in positions.iter_mut().zip(&pose) {
                series[k] = value;
            }
        }
        Sampled {
            times,
            dt,
            positions,
        }
    }

    /// Velocity of a joint at each grid time (central differences, one-sided at the ends).
    pub fn velocity_at_samples(&self, joint: usize) -> Vec<f64> {
        let p = &self.positions[joint];
        let n = p.len();
        (0..n)
            .map(|k| {
                let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
                if b == a {
                    0.0
                } else {
                    (p[b] - p[a]) / ((b - a) as f64 * self.dt)
                }
            })
            .collect()
    }
}

/// Checks `trajectory` against `robot`'s limits, differencing at `rate` Hz.
pub fn check(trajectory: &Trajectory, robot: &Robot, rate: f64) -> CheckReport {
    let Sampled {
        times,
        dt,
        positions,
    } = Sampled::new(trajectory, rate);

    let mut violations = Vec::new();
    let mut joints = Vec::new();
    for (j, joint) in robot.joints.iter().enumerate() {
        let unit = joint.kind.unit();
        let p = &positions[j];
        let position = position_series(&times, p, trajectory, j);
        let velocity = velocity_series(&times, p, dt);
        let acceleration = acceleration_series(&times, &velocity.values, dt);
        let limits = joint.limits;
        let mut record = |series: &Series, kind: LimitKind, low: f64, high: f64| {
            violations.extend(find_violations(
                series,
                trajectory,
                &joint.name,
                unit,
                kind,
                low,
                high,
            ));
        };
        record(&position, LimitKind::Position, limits.min, limits.max);
        record(
            &velocity,
            LimitKind::Velocity,
            -limits.velocity,
            limits.velocity,
        );
        record(
            &acceleration,
            LimitKind::Acceleration,
            -limits.acceleration,
            limits.acceleration,
        );
        let peak = |s: &Series| s.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        joints.push(JointSummary {
            joint: joint.name.clone(),
            unit,
            min_position: position
                .values
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min),
            max_position: position
                .values
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max),
            peak_velocity: peak(&velocity),
            velocity_limit: limits.velocity,
            peak_acceleration: peak(&acceleration),
            acceleration_limit: limits.acceleration,
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
    }
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
    }
    let mut report = check(trajectory, &scaled, rate / speed);
    to_wall_clock(&mut report, robot, rate, speed);
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
        };
        v.peak *= factor;
        v.limit = limit.copysign(v.limit);
        v.excess = v.peak.abs() - limit;
    }
    for (summary, joint) in report.joints.iter_mut().zip(&robot.joints) {
        summary.peak_velocity *= speed;
        summary.velocity_limit = joint.limits.velocity;
        summary.peak_acceleration *= speed * speed;
        summary.acceleration_limit = joint.limits.acceleration;
    }
}

/// Grid positions merged with the track's turning points inside the played window.
fn position_series(times: &[f64], p: &[f64], trajectory: &Trajectory, joint: usize) -> Series {
    let mut points: Vec<(f64, f64)> = times.iter().copied().zip(p.iter().copied()).collect();
    points.extend(
        trajectory.tracks()[joint]
            .turning_points()
            .into_iter()
            .filter(|(t, _)| *t >= trajectory.start && *t <= trajectory.end),
    );
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    Series {
        times: points.iter().map(|p| p.0).collect(),
        values: points.iter().map(|p| p.1).collect(),
    }
}

/// Velocity over each grid interval, with the arm at rest before the first sample and after the
/// last: intervals k = −1 … n, placed at their midpoints.
fn velocity_series(times: &[f64], p: &[f64], dt: f64) -> Series {
    let n = p.len();
    let mut out_times = Vec::with_capacity(n + 1);
    let mut values = Vec::with_capacity(n + 1);
    out_times.push(times[0] - dt / 2.0);
    values.push(0.0);
    for k in 0..n - 1 {
        out_times.push(times[k] + dt / 2.0);
        values.push((p[k + 1] - p[k]) / dt);
    }
    out_times.push(times[n - 1] + dt / 2.0);
    values.push(0.0);
    Series {
        times: out_times,
        values,
    }
}

/// Acceleration at each grid sample from the velocities of the intervals on either side.
fn acceleration_series(times: &[f64], velocity: &[f64], dt: f64) -> Series {
    Series {
        times: times.to_vec(),
        values: velocity.windows(2).map(|w| (w[1] - w[0]) / dt).collect(),
    }
}

/// Runs of samples outside [low, high], split where the keyframe segment changes, each reported
/// once with its worst point.
fn find_violations(
    series: &Series,
    trajectory: &Trajectory,
    joint: &str,
    unit: &'static str,
    kind: LimitKind,
    low: f64,
    high: f64,
) -> Vec<Violation> {
    // Tiny tolerance: a key exactly on a limit evaluates to the limit ± rounding.
    let slack = 1e-9 * (high - low).abs().max(1.0);
    let mut out: Vec<Violation> = Vec::new();
    let mut open = false;
    for (&t, &v) in series.times.iter().zip(&series.values) {
        let excess = (v - high).max(low - v);
        if excess <= slack {
            open = false;
            continue;
        }
        let segment = trajectory.segment_at(t);
        let limit = if v > high { high } else { low };
        let continues = open
            && out
                .last()
                .is_some_and(|last| last.segment == segment && last.limit == limit);
        if continues {
            if let Some(last) = out.last_mut() {
                last.to = t;
                if excess > last.excess {
                    last.excess = excess;
                    last.peak = v;
                    last.peak_time = t;
                }
            }
        } else {
            out.push(Violation {
                joint: joint.to_string(),
                unit,
                kind,
                segment,
                segment_label: trajectory.segment_label(segment),
                from: t,
                to: t,
                peak_time: t,
                peak: v,
                limit,
                excess,
            });
        }
        open = true;
    }
    out
}
