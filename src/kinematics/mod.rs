//! Forward and inverse kinematics: tool poses ↔ joint values.
//!
//! Forward kinematics is the robot's own ([`Robot::tcp_frame`]). Inverse kinematics comes in
//! two kinds behind one [`Solver`]: a closed form for arms built like the built-ins (a pan, three
//! parallel pitch joints, optionally a roll; [`ArmGeometry`]), with its geometry derived from the
//! robot's joint origins and axes rather than typed in, and damped least squares on the forward
//! kinematics for any other robot file ([`Dls`]). Straight tool lines: [`solve_line`].
//!
//! [`Solver::solve`] gives the solution nearest a seed, for jogging the tool; a tool key is
//! solved by [`Solver::solve_key`], which chooses among the solutions as a person would: clear
//! of the floor and of the arm itself, with margins to the limits, near the previous key
//! (`choice`), and with an approach direction when the key gives one (`key`).
//!
//! This module knows nothing about servos or files: targets come in as positions and
//! rotations, solutions go out as joint values in the robot's units (degrees, metres).

pub(crate) mod choice;
pub(crate) mod closed_form;
pub(crate) mod dls;
mod families;
mod key;
pub(crate) mod line;
mod planar;

use crate::pose::rotation_vector;
use crate::pose::RigidTransform;
use crate::robot::{JointKind, Robot};
use glam::{DQuat, DVec3};

pub use choice::{smallest_margin, Margin, CLEARANCE_M, COMFORT};
pub use closed_form::ArmGeometry;
pub use dls::Dls;
pub use key::{Approach, Chosen, KeyOrientation, KeyTarget, Preference};
pub use line::{solve_line, LineError, LineSolution, JOINT_JUMP_DEG};

/// Where the tool frame (the robot's `tcp`) should be, in the robot's base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolTarget {
    /// Metres.
    pub position: DVec3,
    /// The tool frame's orientation; None leaves it to the solver (nearest the previous pose).
    pub orientation: Option<DQuat>,
}

impl ToolTarget {
    /// A tool position (metres) with the orientation left to the solver.
    pub fn position(position: DVec3) -> Self {
        Self {
            position,
            orientation: None,
        }
    }

    /// A tool position (metres) and orientation.
    pub fn pose(position: DVec3, orientation: DQuat) -> Self {
        Self {
            position,
            orientation: Some(orientation),
        }
    }
}

/// Joint values that put the tool at a target.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Every joint of the robot, in joint order and units; joints the tool does not depend on
    /// keep the seed's values.
    pub values: Vec<f64>,
    /// The rotation left between the reached and the asked orientation, as a rotation vector in
    /// the tool frame, degrees (x, y, z); None when no orientation was asked. Non-zero when the
    /// arm has fewer than six joints to orient the tool with.
    pub orientation_residual_deg: Option<DVec3>,
}

impl Solution {
    /// The largest residual about any tool axis, degrees (0 without an orientation).
    pub fn orientation_error_deg(&self) -> f64 {
        self.orientation_residual_deg
            .map_or(0.0, |r| r.abs().max_element())
    }
}

/// Why no joint values reach a target.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// No joint values inside the limits put the tool there.
    #[error(
        "the tool cannot reach ({}): it misses by {:.1} mm; the nearest reachable point is ({}){}",
        mm3(*target),
        miss * 1000.0,
        mm3(*nearest),
        millimetres_hint(*target, *nearest)
    )]
    OutOfReach {
        /// The tool position asked for, metres.
        target: DVec3,
        /// Distance from the target to the nearest reachable point, metres.
        miss: f64,
        /// The nearest tool position the solver reached, metres.
        nearest: DVec3,
    },
    /// Reachable, but only with the arm below the floor (the base frame's z = 0 plane).
    #[error("the tool reaches ({}) only with {part} {depth_mm:.1} mm below the floor (z = 0)", mm3(*target))]
    BelowFloor {
        /// The tool position asked for, metres.
        target: DVec3,
        /// The lowest part: a joint's name, or "the tool point".
        part: String,
        /// How far that part is below the floor, millimetres.
        depth_mm: f64,
    },
    /// The position is reachable, but no orientation near the one asked is inside the limits.
    #[error(
        "the tool reaches ({}) but not with the orientation asked inside the joint limits; \
         drop \"r\" to let the arm choose, or turn the tool less",
        mm3(*target)
    )]
    OrientationOutOfReach {
        /// The tool position asked for, metres.
        target: DVec3,
    },
    /// Every solution inside the limits touches the floor or the arm itself.
    #[error(
        "every way the arm reaches ({}) inside its limits touches the floor or the arm itself \
         (a clearance of {:.0} mm); the least: {touch}",
        mm3(*target),
        CLEARANCE_M * 1000.0
    )]
    Collides {
        /// The tool position asked for, metres.
        target: DVec3,
        /// The contact of the solution that touches least, in words.
        touch: String,
    },
    /// The position is reachable, but not with the tool pointing the way asked.
    #[error(
        "the tool reaches ({}) but not pointing {direction} inside the limits and clear of \
         contacts{}",
        mm3(*target),
        tilt_hint(*least_tilt_deg)
    )]
    ApproachOutOfReach {
        /// The tool position asked for, metres.
        target: DVec3,
        /// The direction asked, in words ("down").
        direction: String,
        /// The least tilt from it the tool reaches with, whole degrees (None: not within 90°).
        least_tilt_deg: Option<u32>,
    },
    /// An approach direction was asked of a robot whose tool has no approach axis.
    #[error("robot {robot} defines no tcp, so its tool has no approach axis to point")]
    NoApproachAxis {
        /// The robot's name.
        robot: String,
    },
    /// The robot has no joint that moves the tool.
    #[error("robot {robot} has no joint that moves its tool frame")]
    NoToolJoints {
        /// The robot's name.
        robot: String,
    },
}

/// How many times farther than the arm reaches a target must be to read as millimetres typed
/// where metres belong: a tool position in millimetres is a thousand times too far, a typo or a
/// target just out of reach is not a hundred times.
const MILLIMETRES_FACTOR: f64 = 100.0;

/// A hint for a target that is millimetres typed as metres: farther from the base than
/// [`MILLIMETRES_FACTOR`] times the nearest reachable point is.
fn millimetres_hint(target: DVec3, nearest: DVec3) -> String {
    if target.length() > MILLIMETRES_FACTOR * nearest.length().max(1e-3) {
        let metres = target / 1000.0;
        format!(
            "; positions are in metres, and these look like millimetres: in metres they are \
             {:.4}, {:.4}, {:.4}",
            metres.x, metres.y, metres.z
        )
    } else {
        String::new()
    }
}

/// What an unreachable approach could be instead, for its message.
fn tilt_hint(least: Option<u32>) -> String {
    match least {
        Some(t) => format!(
            "; the least tilt from it that is: {t}° (the approach \"down-or-tilted\" accepts that)"
        ),
        None => "; nor tilted less than 90° from it".into(),
    }
}

/// A position in millimetres, for messages.
pub(crate) fn mm3(p: DVec3) -> String {
    format!(
        "{:.1}, {:.1}, {:.1} mm",
        p.x * 1000.0,
        p.y * 1000.0,
        p.z * 1000.0
    )
}

/// The inverse kinematics of one robot, chosen once when the robot is known.
#[derive(Debug, Clone)]
pub enum Solver {
    /// The robot is built like the built-in arms: exact solutions, every branch.
    ClosedForm(Box<ArmGeometry>),
    /// Any other chain: damped least squares from the seed.
    General(dls::Dls),
}

impl Solver {
    /// The closed form when the robot's chain has its shape, else the general solver.
    pub fn for_robot(robot: &Robot) -> Solver {
        match ArmGeometry::derive(robot) {
            Some(geometry) => Solver::ClosedForm(Box::new(geometry)),
            None => Solver::General(dls::Dls::new(robot)),
        }
    }

    /// Whether this robot got the exact closed-form solver.
    pub fn is_closed_form(&self) -> bool {
        matches!(self, Solver::ClosedForm(_))
    }

    /// Joint values for `target`, nearest to `seed` (every joint, in joint order). Joints marked
    /// in `held` keep their seed value (a key that gives them explicitly, e.g. the gripper).
    pub fn solve(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> Result<Solution, IkError> {
        // The closed form moves every joint of the chain; a key that gives one of them itself
        // (say the roll) leaves fewer to solve, which the general solver handles.
        let last = last_tool_joint(robot);
        let holds_a_tool_joint = held.iter().take(last + 1).any(|&h| h);
        let solution = match self {
            Solver::ClosedForm(_) if holds_a_tool_joint => {
                dls::Dls::new(robot).solve(robot, target, seed, held)
            }
            Solver::ClosedForm(geometry) => {
                let exact = geometry.solve(robot, target, seed);
                if exact
                    .as_ref()
                    .is_some_and(|s| s.orientation_error_deg() < EXACT_DEG)
                {
                    exact
                } else {
                    better_of(exact, dls::Dls::new(robot).solve(robot, target, seed, held))
                }
            }
            Solver::General(dls) => dls.solve(robot, target, seed, held),
        };
        match solution {
            Some(solution) => Ok(solution),
            None => Err(self.explain_failure(robot, target, seed, held)),
        }
    }

    /// Why `target` has no solution: below the floor, or out of reach by how much.
    pub(super) fn explain_failure(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> IkError {
        let position_only = ToolTarget::position(target.position);
        let unfloored = match self {
            Solver::ClosedForm(geometry) => {
                geometry.solve_ignoring_floor(robot, &position_only, seed)
            }
            Solver::General(dls) => dls.solve_ignoring_floor(robot, &position_only, seed, held),
        };
        if let Some(solution) = unfloored {
            if let Some((part, depth)) = lowest_below_floor(robot, &solution.values) {
                return IkError::BelowFloor {
                    target: target.position,
                    part,
                    depth_mm: depth * 1000.0,
                };
            }
            if target.orientation.is_some() {
                return IkError::OrientationOutOfReach {
                    target: target.position,
                };
            }
        }
        if !tool_joints(robot).iter().any(|&j| j) {
            return IkError::NoToolJoints {
                robot: robot.name.clone(),
            };
        }
        let nearest = dls::nearest_reachable(robot, target.position, seed, held);
        IkError::OutOfReach {
            target: target.position,
            miss: nearest.distance(target.position),
            nearest,
        }
    }
}

/// An orientation residual this small is the orientation reached, degrees.
const EXACT_DEG: f64 = 1e-6;

/// The closed form's answer, or the general solver's where the closed form has none or
/// orients the tool worse. The closed form misses solutions in two thin places: right above
/// the pan axis, where the pan is nearly free and the roll moves the tool point round it, and
/// where the feasible tool pitches are narrower than its search step; the general solver,
/// started from the previous key, covers them.
fn better_of(closed: Option<Solution>, general: Option<Solution>) -> Option<Solution> {
    match (closed, general) {
        (Some(c), Some(g)) if g.orientation_error_deg() + 0.05 < c.orientation_error_deg() => {
            Some(g)
        }
        (Some(c), _) => Some(c),
        (None, g) => g,
    }
}

/// Which joints move the tool frame: those on the chain up to the tcp's parent.
pub fn tool_joints(robot: &Robot) -> Vec<bool> {
    let chain = tool_chain(robot);
    (0..robot.joints.len())
        .map(|i| chain.contains(&i))
        .collect()
}

/// The joints that move the tool frame, as a range: the chain is the first joints, up to the
/// tcp's parent (a gripper after it does not move the tcp).
pub fn tool_chain(robot: &Robot) -> std::ops::Range<usize> {
    if robot.joints.is_empty() {
        return 0..0;
    }
    0..last_tool_joint(robot) + 1
}

/// The last joint on the chain to the tcp (the tcp's parent).
fn last_tool_joint(robot: &Robot) -> usize {
    match &robot.tcp {
        Some(tcp) => tcp.parent,
        None => robot.joints.len().saturating_sub(1),
    }
}

/// How far below the floor a joint ends up at `values` (if any part does): the lowest of the
/// moving joints' anchors and the tool point, with its name and depth in metres.
///
/// The floor is the base frame's z = 0 plane, where the MuJoCo models put it. Anchors and the
/// tool point are the skeleton of the arm: links are a few centimetres thick, so a pose that
/// passes this can still graze the floor, which `pose` and `sim` check with MuJoCo's geometry.
pub fn lowest_below_floor(robot: &Robot, values: &[f64]) -> Option<(String, f64)> {
    let (lowest, _) = walk_arm(robot, values);
    lowest.map(|(part, depth)| {
        let name = match part {
            Some(i) => robot.joints[i].name.clone(),
            None => "the tool point".to_string(),
        };
        (name, depth)
    })
}

/// One walk of the forward kinematics, without allocating: the lowest part below the floor
/// (a joint index, None for the tool point, with its depth in metres) and the tcp frame. The
/// closed form checks every branch it assembles with it.
pub(crate) fn walk_arm(
    robot: &Robot,
    values: &[f64],
) -> (Option<(Option<usize>, f64)>, RigidTransform) {
    const SLACK_M: f64 = 1e-6;
    let mut lowest: Option<(Option<usize>, f64)> = None;
    let mut consider = |part: Option<usize>, z: f64| {
        if z < -SLACK_M && lowest.is_none_or(|(_, d)| -z > d) {
            lowest = Some((part, -z));
        }
    };
    let carrier = robot.tcp.as_ref().map(|tcp| tcp.parent);
    let mut carried = RigidTransform::IDENTITY;
    for (i, frame) in robot.frames(values).enumerate() {
        if i > 0 {
            consider(Some(i), frame.t.z);
        }
        if carrier.is_none_or(|c| c == i) {
            carried = frame;
        }
    }
    let tool = match &robot.tcp {
        Some(tcp) => carried.compose(&tcp.origin),
        None => carried,
    };
    consider(None, tool.t.z);
    (lowest, tool)
}

/// The tool's approach axis in the tool frame: from the wrist towards the fingertips. It is the
/// axis of the joint carrying the tcp, turned towards the tcp, when the tcp lies within 30° of
/// that axis seen from the joint (a roll joint: SO-101, SO-100, Koch); else the direction from
/// the joint to the tcp (OpenMANIPULATOR-X's wrist pitch). None without a tcp or when the tcp
/// sits on the joint's anchor.
pub fn approach_axis(robot: &Robot) -> Option<DVec3> {
    const ALONG_AXIS_DEG: f64 = 30.0;
    let tcp = robot.tcp.as_ref()?;
    let to_tcp = tcp.origin.t.try_normalize()?;
    let joint = &robot.joints[tcp.parent];
    let axis = joint.axis.normalize();
    let along = match joint.kind {
        JointKind::Revolute if to_tcp.angle_between(axis).to_degrees() <= ALONG_AXIS_DEG => axis,
        JointKind::Revolute if to_tcp.angle_between(-axis).to_degrees() <= ALONG_AXIS_DEG => -axis,
        _ => to_tcp,
    };
    Some(tcp.origin.r.conjugate() * along)
}

/// The rotation from `reached` to `wanted`, in the tool frame, degrees about x, y, z.
pub fn orientation_residual_deg(reached: DQuat, wanted: DQuat) -> DVec3 {
    let delta = (reached.conjugate() * wanted).normalize();
    let delta = if delta.w < 0.0 { -delta } else { delta };
    rotation_vector(delta) * (180.0 / std::f64::consts::PI)
}

/// Joint-space distance used to choose between solutions: squared differences, degrees for
/// revolute joints and millimetres for prismatic ones, so that neither unit dominates.
pub fn joint_distance(robot: &Robot, a: &[f64], b: &[f64]) -> f64 {
    robot
        .joints
        .iter()
        .zip(a.iter().zip(b))
        .map(|(joint, (x, y))| ((x - y) * comparable_unit(joint.kind)).powi(2))
        .sum()
}

/// The factor that makes a joint's unit comparable with degrees: 1 for revolute joints,
/// 1000 for prismatic ones (millimetres), whose travel is centimetres.
pub(crate) fn comparable_unit(kind: JointKind) -> f64 {
    match kind {
        JointKind::Revolute => 1.0,
        JointKind::Prismatic => 1000.0,
    }
}

/// Whether every value is inside its joint's limits.
pub(crate) fn within_limits(robot: &Robot, values: &[f64]) -> bool {
    robot
        .joints
        .iter()
        .zip(values)
        .all(|(joint, &v)| joint.limits.contains(v))
}
