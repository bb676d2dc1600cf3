//! Tool keys into joint values, and straight tool lines into joint samples: the step between
//! reading a sequence and building its tracks, where the robot is first known. Everything after
//! it (interpolation, the limit check, retime, playback, simulation) sees joint values only.
//!
//! Each key is solved as a person would choose it (`Solver::solve_key`: clear of the floor and
//! of the arm itself in the robot's collision model, margins to the limits, near the previous
//! key's pose, an approach direction when the key gives one); what it found is reported per key
//! ([`ToolKeyReport`]) and per line ([`LineReport`], with [`LineReport::speed`] saying what the
//! check found a line to need).

use super::approach::minimum_jerk;
use super::{LimitKind, Violation};
use crate::collision::CollisionModel;
use crate::json::InputError;
use crate::kinematics::{
    self, line, Approach, KeyOrientation, KeyTarget, Preference, Solver, ToolTarget,
};
use crate::robot::{cell_joint_name, split_joint_name, Robot};
use crate::sequence::{KeyValue, Sequence, ToolApproach, ToolKey};
use glam::DVec3;
use std::borrow::Cow;
use std::ops::Range;

/// What solving a tool key gave, for `check` to report.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolKeyReport {
    /// The key's index in time order.
    pub key: usize,
    /// The key's name, or "#index".
    pub label: String,
    /// Every joint's value at the key, in joint order.
    pub values: Vec<f64>,
    /// The orientation left unreached, degrees about the tool's x, y, z (None without `r`).
    pub residual_deg: Option<DVec3>,
    /// The smallest margin to the limits among the joints solved (None for a key reached
    /// along a line, which takes the line's last sample).
    pub margin: Option<KeyMargin>,
    /// The key's approach and how far the tool is tilted from it, degrees.
    pub approach: Option<(ToolApproach, f64)>,
    /// The arm whose tool it is, in a cell.
    pub arm: Option<String>,
}

/// A tool key's smallest margin to its joints' limits.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyMargin {
    /// The joint nearest its limit (relative to its range).
    pub joint: String,
    /// Its distance to that limit, in `unit`.
    pub value: f64,
    /// "deg" or "m".
    pub unit: &'static str,
    /// That distance over half the joint's range.
    pub share: f64,
}

/// A straight tool line from key `key` to the next.
#[derive(Debug, Clone, PartialEq)]
pub struct LineReport {
    /// Index of the line's first key, in time order.
    pub key: usize,
    /// That key's name, or "#index".
    pub label: String,
    /// Share of the line that can be followed (1 when all of it).
    pub fraction: f64,
    /// Why the rest cannot; then the segment is interpolated in joint space instead.
    pub problem: Option<String>,
    /// Samples solved along the line (joint order), at `times`.
    pub samples: Vec<Vec<f64>>,
    /// Sequence time of each sample, seconds.
    pub times: Vec<f64>,
    /// The robot's joints the line moves, in order: those on the chain to the tool (of one
    /// arm's in a cell). A joint past the tool, a gripper, is not part of the line: it follows
    /// its own keys through it, and the line's samples do not key it.
    pub joints: Range<usize>,
    /// The arm whose tool it is, in a cell.
    pub arm: Option<String>,
    /// When the tool moves along it (the end of the first key's hold, the second key's time),
    /// seconds.
    pub span: (f64, f64),
}

/// A joint that moves faster along a line than its limits allow.
#[derive(Debug, Clone, PartialEq)]
pub struct LineExcess {
    /// The joint's name.
    pub joint: String,
    /// Which limit: velocity or acceleration (a position outside the limits ends the line
    /// before, [`crate::kinematics::LineError`]).
    pub kind: LimitKind,
    /// The worst value along the line (absolute), per second or per second squared.
    pub peak: f64,
    /// The joint's limit.
    pub limit: f64,
    /// "deg" or "m".
    pub unit: &'static str,
}

/// What the check found a line to need.
#[derive(Debug, Clone, PartialEq)]
pub struct LineSpeed {
    /// The worst joint for each limit exceeded (velocity first).
    pub worst: Vec<LineExcess>,
    /// About how long the line needs, seconds: its span stretched by the largest ratio, of
    /// peak to limit for a velocity and of its square root for an acceleration (the line's
    /// path stays; timing it over a longer span scales its velocities by the inverse of the
    /// stretch, its accelerations by the inverse square).
    pub needed: f64,
}

impl LineReport {
    /// How much faster than the limits the line runs, from the check's `violations` in its
    /// segment on its own joints; None when it keeps them (or could not be followed).
    pub fn speed(&self, robot: &Robot, violations: &[Violation]) -> Option<LineSpeed> {
        if self.problem.is_some() {
            return None;
        }
        let mine = violations.iter().filter(|v| {
            v.segment == self.key
                && v.mendable_by_timing()
                && robot
                    .joint_index(&v.joint)
                    .is_some_and(|j| self.joints.contains(&j))
        });
        let mut worst: Vec<LineExcess> = Vec::new();
        for v in mine {
            let ratio = |e: &LineExcess| e.peak / e.limit;
            let candidate = LineExcess {
                joint: v.joint.clone(),
                kind: v.kind,
                peak: v.peak.abs(),
                limit: v.limit.abs(),
                unit: v.unit,
            };
            match worst.iter_mut().find(|e| e.kind == v.kind) {
                Some(e) if ratio(&candidate) > ratio(e) => *e = candidate,
                Some(_) => {}
                None => worst.push(candidate),
            }
        }
        if worst.is_empty() {
            return None;
        }
        worst.sort_by_key(|e| e.kind != LimitKind::Velocity);
        let stretch = worst
            .iter()
            .map(|e| match e.kind {
                LimitKind::Acceleration => (e.peak / e.limit).sqrt(),
                LimitKind::Jerk => (e.peak / e.limit).cbrt(),
                _ => e.peak / e.limit,
            })
            .fold(1.0, f64::max);
        Some(LineSpeed {
            worst,
            needed: (self.span.1 - self.span.0) * stretch,
        })
    }
    /// The sampled value of the robot's joint `joint` in sample `k`, when the line gives it.
    pub fn value(&self, k: usize, joint: usize) -> Option<f64> {
        self.joints
            .contains(&joint)
            .then(|| self.samples[k][joint - self.joints.start])
    }
}

/// The tool keys and lines of a sequence, solved.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ToolSolve {
    /// One per tool key, in time order.
    pub keys: Vec<ToolKeyReport>,
    /// One per straight tool line, in time order.
    pub lines: Vec<LineReport>,
}

/// The sequence with every tool key's joints solved (borrowed unchanged when it has none), and
/// what solving found. A target out of reach is an input error naming the key.
pub(crate) fn solve<'a>(
    sequence: &'a Sequence,
    robot: &Robot,
) -> Result<(Cow<'a, Sequence>, ToolSolve), InputError> {
    if robot.is_cell() {
        solve_cell(sequence, robot)
    } else {
        solve_arm(sequence, robot, "tool")
    }
}

/// [`solve`] on a robot of one arm, whose keys' targets are at `tool_field` in the file
/// (`tool`, or `tool.ARM` for an arm of a cell).
fn solve_arm<'a>(
    sequence: &'a Sequence,
    robot: &Robot,
    tool_field: &str,
) -> Result<(Cow<'a, Sequence>, ToolSolve), InputError> {
    let has_tools = sequence
        .keyframes
        .iter()
        .any(|k| k.tool.is_some() || k.line);
    if !has_tools {
        return Ok((Cow::Borrowed(sequence), ToolSolve::default()));
    }
    let solver = Solver::for_robot(robot);
    let collision = CollisionModel::for_robot(robot);
    let mut solved = sequence.clone();
    let mut report = ToolSolve::default();
    let mut pose = robot.home.clone();
    // A line's samples are keys of the tracks, which run over path time.
    let times = sequence.path_times();
    for index in 0..solved.keyframes.len() {
        let before = pose.clone();
        apply_joint_values(robot, &solved, index, &mut pose);
        let line_in = index > 0 && solved.keyframes[index - 1].line;
        let followed = if line_in {
            let end = line_end(&solver, robot, &solved, index, &before, collision.as_ref());
            let line = solve_line_into(robot, &solved, &times, index, &before, &pose, end);
            let end = line.samples.last().cloned();
            report.lines.push(line);
            end
        } else {
            None
        };
        if solved.keyframes[index].tool.is_some() {
            let key_report = match followed {
                Some(end) => take_line_end(robot, &mut solved, index, end),
                None => {
                    let how = Solving {
                        solver: &solver,
                        robot,
                        collision: collision.as_ref(),
                        tool_field,
                    };
                    solve_key(&how, &mut solved, index, &pose)?
                }
            };
            pose.clone_from(&key_report.values);
            report.keys.push(key_report);
        }
    }
    for line in &mut report.lines {
        // The last sample is the next key itself, which its own track key holds.
        line.samples.pop();
        line.times.pop();
        solved.keyframes[line.key].interp = Some(crate::curve::Interp::Monotone);
    }
    Ok((Cow::Owned(solved), report))
}

/// A cell's tool keys and lines, arm by arm: each arm's part of the sequence is solved as a
/// sequence of its own on its own robot (its tool targets are in its base frame), and the
/// joints solved are written back under the arm's names.
fn solve_cell<'a>(
    sequence: &'a Sequence,
    cell: &Robot,
) -> Result<(Cow<'a, Sequence>, ToolSolve), InputError> {
    let has_tools = sequence
        .keyframes
        .iter()
        .any(|k| !k.arm_tools.is_empty() || k.line);
    if !has_tools {
        return Ok((Cow::Borrowed(sequence), ToolSolve::default()));
    }
    let mut solved = sequence.clone();
    let mut report = ToolSolve::default();
    for arm in &cell.arms {
        let view = arm_view(sequence, &arm.name);
        let (arm_solved, arm_report) = solve_arm(&view, &arm.robot, &format!("tool.{}", arm.name))
            .map_err(|e| on_arm(e, &arm.name))?;
        for (key, arm_key) in solved.keyframes.iter_mut().zip(&arm_solved.keyframes) {
            for (name, value) in &arm_key.values {
                key.set(&cell_joint_name(&arm.name, name), *value);
            }
            if arm_key.interp.is_some() && key.line {
                key.interp = arm_key.interp;
            }
        }
        report
            .keys
            .extend(arm_report.keys.into_iter().map(|k| ToolKeyReport {
                label: format!("{}: {}", arm.name, k.label),
                arm: Some(arm.name.clone()),
                ..k
            }));
        report
            .lines
            .extend(arm_report.lines.into_iter().map(|l| LineReport {
                label: format!("{}: {}", arm.name, l.label),
                joints: arm.joints.start + l.joints.start..arm.joints.start + l.joints.end,
                arm: Some(arm.name.clone()),
                ..l
            }));
    }
    Ok((Cow::Owned(solved), report))
}

/// One arm's part of a cell's sequence, as a sequence of its own: its joints without the
/// arm's prefix and its tool target as the key's tool. Lines stay where they are: an arm
/// without tool keys on a line follows the tool pose of its joints there.
fn arm_view(sequence: &Sequence, arm: &str) -> Sequence {
    let mut view = sequence.clone();
    view.arms.clear();
    for key in &mut view.keyframes {
        key.values = std::mem::take(&mut key.values)
            .into_iter()
            .filter_map(|(name, value)| match split_joint_name(&name) {
                Some((a, joint)) if a == arm => Some((joint.to_string(), value)),
                _ => None,
            })
            .collect();
        key.tool = key
            .arm_tools
            .iter()
            .find(|(a, _)| a == arm)
            .map(|(_, tool)| *tool);
        key.arm_tools.clear();
    }
    view
}

/// An error about an arm's part of a cell's sequence: its message says the arm (its path names
/// the arm's tool, `tool.ARM`, already).
fn on_arm(mut error: InputError, arm: &str) -> InputError {
    error.message = format!("arm {arm}: {}", error.message);
    error
}

/// A tool key reached along a line takes the line's last sample, so the line ends on the
/// branch it ran on.
fn take_line_end(
    robot: &Robot,
    sequence: &mut Sequence,
    index: usize,
    end: Vec<f64>,
) -> ToolKeyReport {
    let key = &mut sequence.keyframes[index];
    let tool_joints = kinematics::tool_joints(robot);
    let wanted = key.tool.and_then(|t| t.orientation).map(|o| o.quaternion());
    for (i, joint) in robot.joints.iter().enumerate() {
        if tool_joints[i] && key.value(&joint.name).is_none() {
            key.set(&joint.name, KeyValue::Joint(end[i]));
        }
    }
    let tool = key.tool;
    ToolKeyReport {
        key: index,
        label: key.label(index),
        residual_deg: wanted
            .map(|w| kinematics::orientation_residual_deg(robot.tcp_frame(&end).r, w)),
        margin: None,
        approach: tool.and_then(|t| approach_report(robot, &t, &end)),
        values: end,
        arm: None,
    }
}

/// The key's plain joint values (degrees, metres) over `pose`: what the previous key left.
fn apply_joint_values(robot: &Robot, sequence: &Sequence, index: usize, pose: &mut [f64]) {
    for (name, value) in &sequence.keyframes[index].values {
        if let (Some(i), KeyValue::Joint(v)) = (robot.joint_index(name), value) {
            pose[i] = *v;
        }
    }
}

/// What solves a sequence's tool keys: the robot's solver, its collision model, and where
/// the keys' targets are in the file (`tool`, or `tool.ARM` in a cell).
struct Solving<'a> {
    solver: &'a Solver,
    robot: &'a Robot,
    collision: Option<&'a CollisionModel>,
    tool_field: &'a str,
}

/// The key target a tool key asks for.
fn key_target(tool: &ToolKey) -> KeyTarget {
    let orientation = match (tool.orientation, tool.approach) {
        (Some(o), _) => KeyOrientation::Full(o.quaternion()),
        (None, Some(a)) => KeyOrientation::Approach(approach_of(a)),
        (None, None) => KeyOrientation::Free,
    };
    KeyTarget {
        position: tool.xyz,
        orientation,
    }
}

/// The kinematics' approach for a file's.
fn approach_of(approach: ToolApproach) -> Approach {
    Approach::down(approach == ToolApproach::DownOrTilted)
}

/// A key's approach and the tilt its pose has from it, degrees.
fn approach_report(robot: &Robot, tool: &ToolKey, values: &[f64]) -> Option<(ToolApproach, f64)> {
    let approach = tool.approach?;
    let axis = kinematics::approach_axis(robot)?;
    let pointing = robot.tcp_frame(values).r * axis;
    let tilt = pointing.angle_between(approach_of(approach).direction);
    Some((approach, tilt.to_degrees()))
}

/// Solves key `index`'s tool target as a key ([`Solver::solve_key`]) from `seed` (the previous
/// key's pose with this key's own joint values, which stay as given) and writes the solved
/// joints into the key.
fn solve_key(
    how: &Solving,
    sequence: &mut Sequence,
    index: usize,
    seed: &[f64],
) -> Result<ToolKeyReport, InputError> {
    let robot = how.robot;
    let key = &sequence.keyframes[index];
    let Some(tool) = key.tool else {
        unreachable!("solve_key is called for tool keys only");
    };
    let held: Vec<bool> = robot
        .joints
        .iter()
        .map(|j| key.value(&j.name).is_some())
        .collect();
    let label = key.label(index);
    let preference = Preference {
        seed,
        held: &held,
        collision: how.collision,
    };
    let chosen = how
        .solver
        .solve_key(robot, &key_target(&tool), &preference)
        .map_err(|e| {
            InputError::at_path(
                &sequence.file,
                &format!("{}.{}.xyz", sequence.key_path(index), how.tool_field),
                format!("key {label}: {e}"),
            )
        })?;
    let values = chosen.solution.values;
    let tool_joints = kinematics::tool_joints(robot);
    let key = &mut sequence.keyframes[index];
    for (i, joint) in robot.joints.iter().enumerate() {
        if tool_joints[i] && !held[i] {
            key.set(&joint.name, KeyValue::Joint(values[i]));
        }
    }
    Ok(ToolKeyReport {
        key: index,
        label,
        residual_deg: chosen.solution.orientation_residual_deg,
        margin: chosen.margin.map(|m| {
            let joint = &robot.joints[m.joint];
            KeyMargin {
                joint: joint.name.clone(),
                value: m.value,
                unit: joint.kind.unit(),
                share: m.share,
            }
        }),
        approach: approach_report(robot, &tool, &values),
        values,
        arm: None,
    })
}

/// Where a line into key `index` ends: the key's tool target; for a key with an approach, the
/// orientation of the key solved on its own from the line's start, so that the line ends
/// pointing the way the key asks.
fn line_end(
    solver: &Solver,
    robot: &Robot,
    sequence: &Sequence,
    index: usize,
    from: &[f64],
    collision: Option<&CollisionModel>,
) -> Option<ToolTarget> {
    let tool = sequence.keyframes[index].tool?;
    let orientation = match (tool.orientation, tool.approach) {
        (Some(o), _) => Some(o.quaternion()),
        (None, Some(_)) => {
            let held = vec![false; robot.joints.len()];
            let preference = Preference {
                seed: from,
                held: &held,
                collision,
            };
            let chosen = solver.solve_key(robot, &key_target(&tool), &preference);
            chosen.ok().map(|c| robot.tcp_frame(&c.solution.values).r)
        }
        (None, None) => None,
    };
    Some(ToolTarget {
        position: tool.xyz,
        orientation,
    })
}

/// The line from key `index − 1` (at `from`) to key `index`: to its tool target (`end`, see
/// [`line_end`]) if it has one, else to the tool pose of its joints (`to`), solved at the
/// robot's control rate. The tool moves along it with minimum-jerk timing between the end of
/// the first key's hold and the second key, so it starts and ends at rest there.
fn solve_line_into(
    robot: &Robot,
    sequence: &Sequence,
    times: &[f64],
    index: usize,
    from: &[f64],
    to: &[f64],
    end: Option<ToolTarget>,
) -> LineReport {
    let first = &sequence.keyframes[index - 1];
    let end = end.unwrap_or_else(|| {
        let frame = robot.tcp_frame(to);
        ToolTarget::pose(frame.t, frame.r)
    });
    let start = times[index - 1] + first.hold_path_time();
    let span = times[index] - start;
    let count = ((span * robot.control_hz).ceil() as usize).max(2);
    let shares: Vec<f64> = (1..=count).map(|k| k as f64 / count as f64).collect();
    let params: Vec<f64> = shares.iter().map(|&u| minimum_jerk(u)).collect();
    let label = first.label(index - 1);
    let joints = kinematics::tool_chain(robot);
    match line::solve_line(robot, from, &end, to, &params) {
        Ok(solved) => LineReport {
            key: index - 1,
            label,
            fraction: 1.0,
            problem: None,
            samples: solved.samples,
            times: shares.iter().map(|u| start + u * span).collect(),
            joints: joints.clone(),
            arm: None,
            span: (start, times[index]),
        },
        Err(e) => LineReport {
            key: index - 1,
            label,
            fraction: e.fraction(),
            problem: Some(e.to_string()),
            samples: Vec::new(),
            times: Vec::new(),
            joints,
            arm: None,
            span: (start, times[index]),
        },
    }
}
