//! Straight tool lines: the tool's position lerped and its orientation slerped between two
//! poses, solved sample by sample from the previous sample's solution, so the branch stays.

use super::{IkError, Solver, ToolTarget};
use crate::pose::{lerp, slerp};
use crate::robot::Robot;
use glam::DQuat;

/// Largest change of any joint between two samples of a line, degrees (millimetres for a
/// prismatic joint). At the control rate a smooth path moves a joint a degree or two per
/// sample; a step past this is the solution switching branches or racing through a singularity.
pub const JOINT_JUMP_DEG: f64 = 10.0;

/// A line solved at every sample.
#[derive(Debug, Clone, PartialEq)]
pub struct LineSolution {
    /// Joint values (every joint) at each sample, the first being the start pose.
    pub samples: Vec<Vec<f64>>,
}

/// Why a line cannot be followed, and how much of it can.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LineError {
    /// A sample of the line cannot be reached.
    #[error("the line leaves the workspace after {:.0} % of its length: {source}", fraction * 100.0)]
    LeavesWorkspace {
        /// Share of the path (0 … 1) solved before the first sample that is not.
        fraction: f64,
        /// Why that sample cannot be reached.
        source: IkError,
    },
    /// A joint reaches its limit partway and is held there while the others follow the line:
    /// the joint path turns a corner there, which no timing makes smooth.
    #[error(
        "the line runs {joint} onto its limit ({limit} {unit}) after {:.0} % of its length, where \
         the joints turn a corner no timing smooths; move the line's keys so that it stays \
         inside the limits",
        fraction * 100.0
    )]
    AlongLimit {
        /// Share of the path (0 … 1) solved before the joint reached its limit.
        fraction: f64,
        /// The joint.
        joint: String,
        /// The limit it reached.
        limit: f64,
        /// "deg" or "m".
        unit: &'static str,
    },
    /// A joint would move more than [`JOINT_JUMP_DEG`] between two samples.
    #[error(
        "the line needs a joint jump after {:.0} % of its length: {joint} moves {jump:.1}° in one sample \
         (a singularity or a change of branch; at most {JOINT_JUMP_DEG}° expected)",
        fraction * 100.0
    )]
    JointJump {
        /// Share of the path (0 … 1) solved before the jump.
        fraction: f64,
        /// The joint that jumps.
        joint: String,
        /// How far it jumps in one sample, degrees (millimetres for a prismatic joint).
        jump: f64,
    },
}

impl LineError {
    /// Share of the path (0 … 1) that is feasible, as MoveIt reports for Cartesian paths.
    pub fn fraction(&self) -> f64 {
        match self {
            LineError::LeavesWorkspace { fraction, .. }
            | LineError::JointJump { fraction, .. }
            | LineError::AlongLimit { fraction, .. } => *fraction,
        }
    }
}

/// Where the line is at parameter `s` (0 … 1) from `start` to `end`: the start and end poses
/// and whether the orientation is followed (else only the position, the solver keeping the
/// tool pitch and roll of the previous sample).
fn point_on_line(
    start: (glam::DVec3, DQuat),
    end: (glam::DVec3, DQuat),
    s: f64,
    oriented: bool,
) -> ToolTarget {
    let position = lerp(start.0, end.0, s);
    if oriented {
        ToolTarget::pose(position, slerp(start.1, end.1, s))
    } else {
        ToolTarget::position(position)
    }
}

/// Solves the line from the pose at `from` (joint values) to `end` at the parameters
/// `params` (increasing, ending at 1). The orientation is slerped from the start pose's to
/// `end`'s when `end` has one, else only the position is followed. Joints not moving the tool
/// go from their `from` values to `end_values` at the same parameter.
///
/// Each sample is solved by damped least squares from the previous one: a step of a few
/// millimetres converges in a couple of iterations and stays on the branch the line started
/// on by construction, where the closed form's choice among a position's many tool pitches
/// would flicker from sample to sample at a joint limit.
pub fn solve_line(
    robot: &Robot,
    from: &[f64],
    end: &ToolTarget,
    end_values: &[f64],
    params: &[f64],
) -> Result<LineSolution, LineError> {
    let start = robot.tcp_frame(from);
    let end_orientation = end.orientation.unwrap_or(start.r);
    let tool = super::tool_joints(robot);
    let held: Vec<bool> = tool.iter().map(|t| !t).collect();
    let solver = Solver::General(super::Dls::new(robot));
    let mut samples: Vec<Vec<f64>> = Vec::with_capacity(params.len());
    let mut previous = from.to_vec();
    for &s in params {
        let fraction = samples.len().saturating_sub(1) as f64 / (params.len() - 1).max(1) as f64;
        let target = point_on_line(
            (start.t, start.r),
            (end.position, end_orientation),
            s,
            end.orientation.is_some(),
        );
        let mut seed = previous.clone();
        for (i, slot) in seed.iter_mut().enumerate() {
            if !tool[i] {
                *slot = from[i] + (end_values[i] - from[i]) * s;
            }
        }
        let solution = solver
            .solve(robot, &target, &seed, &held)
            .map_err(|source| LineError::LeavesWorkspace { fraction, source })?;
        if let Some((joint, jump)) = largest_jump(robot, &previous, &solution.values) {
            if jump > JOINT_JUMP_DEG {
                return Err(LineError::JointJump {
                    fraction,
                    joint,
                    jump,
                });
            }
        }
        if let Some((i, limit)) = reached_limit(robot, from, &solution.values, &tool) {
            let joint = &robot.joints[i];
            return Err(LineError::AlongLimit {
                fraction,
                joint: joint.name.clone(),
                limit,
                unit: joint.kind.unit(),
            });
        }
        previous = solution.values.clone();
        samples.push(solution.values);
    }
    Ok(LineSolution { samples })
}

/// A tool joint (of `tool`) that sits on a limit in `values` and was not on it at the line's
/// start (`from`), with the limit: the solver clamps at the limits, so a joint that runs into
/// one stays there while the others keep the tool on the line.
fn reached_limit(
    robot: &Robot,
    from: &[f64],
    values: &[f64],
    tool: &[bool],
) -> Option<(usize, f64)> {
    const ON: f64 = 1e-9;
    robot.joints.iter().enumerate().find_map(|(i, joint)| {
        let limits = joint.limits;
        [limits.min, limits.max].into_iter().find_map(|limit| {
            let on = |v: f64| (v - limit).abs() <= ON;
            (tool[i] && on(values[i]) && !on(from[i])).then_some((i, limit))
        })
    })
}

/// The joint that moves most between two poses, and by how much (degrees, or millimetres).
fn largest_jump(robot: &Robot, a: &[f64], b: &[f64]) -> Option<(String, f64)> {
    robot
        .joints
        .iter()
        .zip(a.iter().zip(b))
        .map(|(joint, (x, y))| {
            let jump = ((x - y) * super::comparable_unit(joint.kind)).abs();
            (joint.name.clone(), jump)
        })
        .max_by(|p, q| p.1.total_cmp(&q.1))
}
