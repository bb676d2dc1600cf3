//! Tool keys into joint values, and straight tool lines into joint samples: the step between
//! reading a sequence and building its tracks, where the robot is first known. Everything after
//! it (interpolation, the limit check, retime, playback, simulation) sees joint values only.

use crate::json::InputError;
use crate::kinematics::{self, line, Solver, ToolTarget};
use crate::robot::Robot;
use crate::sequence::{KeyValue, Sequence};
use glam::DVec3;
use std::borrow::Cow;

/// What solving a tool key gave, for `check` to report.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolKeyReport {
    /// The key's index in time order, and its name or "#index".
    pub key: usize,
    pub label: String,
    /// Every joint's value at the key, in joint order.
    pub values: Vec<f64>,
    /// The orientation left unreached, degrees about the tool's x, y, z (None without `r`).
    pub residual_deg: Option<DVec3>,
}

/// A straight tool line from key `key` to the next.
#[derive(Debug, Clone, PartialEq)]
pub struct LineReport {
    pub key: usize,
    pub label: String,
    /// Share of the line that can be followed (1 when all of it).
    pub fraction: f64,
    /// Why the rest cannot; then the segment is interpolated in joint space instead.
    pub problem: Option<String>,
    /// Samples solved along the line (joint order), at `times`.
    pub samples: Vec<Vec<f64>>,
    pub times: Vec<f64>,
}

/// The tool keys and lines of a sequence, solved.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolSolve {
    pub keys: Vec<ToolKeyReport>,
    pub lines: Vec<LineReport>,
}

/// The sequence with every tool key's joints solved (borrowed unchanged when it has none), and
/// what solving found. A target out of reach is an input error naming the key.
pub fn solve<'a>(
    sequence: &'a Sequence,
    robot: &Robot,
) -> Result<(Cow<'a, Sequence>, ToolSolve), InputError> {
    let has_tools = sequence.keyframes.iter().any(|k| k.tool.is_some() || k.line);
    if !has_tools {
        return Ok((Cow::Borrowed(sequence), ToolSolve::default()));
    }
    let solver = Solver::for_robot(robot);
    let mut solved = sequence.clone();
    let mut report = ToolSolve::default();
    let mut pose = robot.home.clone();
    let mut poses = Vec::with_capacity(sequence.keyframes.len());
    for index in 0..solved.keyframes.len() {
        apply_joint_values(robot, &solved, index, &mut pose);
        if solved.keyframes[index].tool.is_some() {
            let key_report = solve_key(&solver, robot, &mut solved, index, &pose)?;
            pose.clone_from(&key_report.values);
            report.keys.push(key_report);
        }
        poses.push(pose.clone());
    }
    report.lines = solve_lines(&solver, robot, &mut solved, &poses);
    Ok((Cow::Owned(solved), report))
}

/// The key's plain joint values (degrees, metres) over `pose`: what the previous key left.
fn apply_joint_values(robot: &Robot, sequence: &Sequence, index: usize, pose: &mut [f64]) {
    for (name, value) in &sequence.keyframes[index].values {
        if let (Some(i), KeyValue::Joint(v)) = (robot.joint_index(name), value) {
            pose[i] = *v;
        }
    }
}

/// Solves key `index`'s tool target from `seed` (the previous key's pose with this key's own
/// joint values, which stay as given) and writes the solved joints into the key.
fn solve_key(
    solver: &Solver,
    robot: &Robot,
    sequence: &mut Sequence,
    index: usize,
    seed: &[f64],
) -> Result<ToolKeyReport, InputError> {
    let key = &sequence.keyframes[index];
    let Some(tool) = key.tool else {
        unreachable!("solve_key is called for tool keys only");
    };
    let held: Vec<bool> = robot
        .joints
        .iter()
        .map(|j| key.value(&j.name).is_some())
        .collect();
    let target = ToolTarget {
        position: tool.xyz,
        orientation: tool.orientation.map(|o| o.quaternion()),
    };
    let label = key.label(index);
    let solution = solver.solve(robot, &target, seed, &held).map_err(|e| {
        InputError::at_path(
            &sequence.file,
            &format!("{}.tool.xyz", sequence.key_path(index)),
            format!("key {label}: {e}"),
        )
    })?;
    let tool_joints = kinematics::tool_joints(robot);
    let key = &mut sequence.keyframes[index];
    for (i, joint) in robot.joints.iter().enumerate() {
        if tool_joints[i] && !held[i] {
            key.set(&joint.name, KeyValue::Joint(solution.values[i]));
        }
    }
    Ok(ToolKeyReport {
        key: index,
        label,
        residual_deg: solution.orientation_residual_deg,
        values: solution.values,
    })
}

/// Every `"interp": "line"` key's segment solved at the robot's control rate. The tool moves
/// along the line with minimum-jerk timing between the end of the key's hold and the next key,
/// so it starts and ends at rest there; the samples become monotone keys of the tracks.
fn solve_lines(
    solver: &Solver,
    robot: &Robot,
    sequence: &mut Sequence,
    poses: &[Vec<f64>],
) -> Vec<LineReport> {
    let times = sequence.key_times();
    let mut reports = Vec::new();
    for index in 0..sequence.keyframes.len().saturating_sub(1) {
        let key = &sequence.keyframes[index];
        if !key.line {
            continue;
        }
        let oriented = key.tool.is_some_and(|t| t.orientation.is_some())
            || sequence.keyframes[index + 1]
                .tool
                .is_some_and(|t| t.orientation.is_some());
        let start = times[index] + key.hold;
        let span = times[index + 1] - start;
        let count = ((span * robot.control_hz).ceil() as usize).max(2);
        let shares: Vec<f64> = (1..count).map(|k| k as f64 / count as f64).collect();
        let params: Vec<f64> = shares.iter().map(|&u| minimum_jerk(u)).collect();
        let label = key.label(index);
        let result = line::solve_line(solver, robot, &poses[index], &poses[index + 1], &params, oriented);
        let report = match result {
            Ok(solved) => LineReport {
                key: index,
                label,
                fraction: 1.0,
                problem: None,
                samples: solved.samples,
                times: shares.iter().map(|u| start + u * span).collect(),
            },
            Err(e) => LineReport {
                key: index,
                label,
                fraction: e.fraction(),
                problem: Some(e.to_string()),
                samples: Vec::new(),
                times: Vec::new(),
            },
        };
        reports.push(report);
        // The samples are monotone keys: they never overshoot between two of them.
        sequence.keyframes[index].interp = Some(crate::curve::Interp::Monotone);
    }
    reports
}

/// The minimum-jerk share of the path at the share `u` of the time: 10u³ − 15u⁴ + 6u⁵, at rest
/// (zero velocity and acceleration) at both ends.
pub fn minimum_jerk(u: f64) -> f64 {
    u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
}
