//! The general solver for robot files: damped least squares on the forward kinematics, with
//! the joint limits, from the previous key's solution.
//!
//! Position is the primary task and orientation the secondary one, solved in the null space
//! of the position's Jacobian (task-priority inverse kinematics): on an arm with fewer than six
//! joints the position is still met exactly and the orientation as closely as what is left
//! allows, which a single weighted least-squares step would trade against each other.

use super::{lowest_below_floor, orientation_residual_deg, tool_joints, Solution, ToolTarget};
use crate::pose::rotation_vector;
use crate::robot::{JointKind, Robot};
use glam::{DMat3, DQuat, DVec3};

/// Damping far from the target, metres (and radians for the orientation task): keeps steps
/// bounded near singularities, where the undamped inverse blows up. It shrinks with the error
/// ([`damping`]) so the last steps are Gauss–Newton's and converge fast.
const DAMPING: f64 = 1e-3;
/// Damping of the orientation task, radians. It stays: on a 5-joint arm what is left after the
/// position is two-dimensional, and without damping the third direction's tiny singular value
/// would turn any residual into a huge step.
const ORIENTATION_DAMPING: f64 = 0.05;
/// Share of the orientation step taken per iteration.
const ORIENTATION_GAIN: f64 = 0.3;
/// The error below which the damping shrinks with it, metres.
const DAMPING_ERROR: f64 = 0.01;
/// Largest change of one joint in one iteration, radians (metres ×10 for prismatic joints):
/// the linearisation holds only near the present pose.
const MAX_STEP: f64 = 0.2;
const MAX_ITERATIONS: usize = 500;
/// Converged when the tool is this close to the target, metres.
const POSITION_TOLERANCE_M: f64 = 1e-7;

/// The general solver; it keeps nothing of the robot but which joints move the tool.
#[derive(Debug, Clone, PartialEq)]
pub struct Dls {
    tool_joints: Vec<bool>,
}

/// The Jacobian of the tool point (and frame) for the free joints: one column per free joint,
/// per radian (or metre) of the joint.
struct Jacobian {
    free: Vec<usize>,
    linear: Vec<DVec3>,
    angular: Vec<DVec3>,
}

impl Dls {
    /// The solver for `robot`.
    pub fn new(robot: &Robot) -> Dls {
        Dls {
            tool_joints: tool_joints(robot),
        }
    }

    /// A solution from `seed` (then from the home pose) inside the limits, clear of the floor.
    pub fn solve(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> Option<Solution> {
        self.solve_with(robot, target, seed, held, true)
    }

    /// [`Dls::solve`] without the floor rule, to tell "below the floor" from "out of reach".
    pub(crate) fn solve_ignoring_floor(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> Option<Solution> {
        self.solve_with(robot, target, seed, held, false)
    }

    fn solve_with(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
        floor: bool,
    ) -> Option<Solution> {
        let free = self.free_joints(held);
        starts(robot, seed, &free).into_iter().find_map(|start| {
            let values = iterate(robot, target, start, &free, MAX_ITERATIONS);
            let reached =
                robot.tcp_position(&values).distance(target.position) < POSITION_TOLERANCE_M * 10.0;
            let clear = !floor || lowest_below_floor(robot, &values).is_none();
            (reached && clear).then(|| Solution {
                orientation_residual_deg: target
                    .orientation
                    .map(|wanted| orientation_residual_deg(robot.tcp_frame(&values).r, wanted)),
                values,
            })
        })
    }

    /// Every solution inside the limits and clear of the floor that the iteration reaches from
    /// one of its starts (the seed, home, the middle and quarter points of the ranges), repeats
    /// included: what a key is chosen from on a robot without the closed form.
    pub(crate) fn solutions(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> Vec<Vec<f64>> {
        let free = self.free_joints(held);
        starts(robot, seed, &free)
            .into_iter()
            .map(|start| iterate(robot, target, start, &free, MAX_ITERATIONS))
            .filter(|values| {
                robot.tcp_position(values).distance(target.position) < POSITION_TOLERANCE_M * 10.0
                    && lowest_below_floor(robot, values).is_none()
            })
            .collect()
    }

    fn free_joints(&self, held: &[bool]) -> Vec<usize> {
        (0..self.tool_joints.len())
            .filter(|&i| self.tool_joints[i] && !held.get(i).copied().unwrap_or(false))
            .collect()
    }
}

/// Where to start iterating, in order: the seed, the home pose, the middle and the quarter
/// points of every free joint's range (a stretched arm, the zero pose of some, is singular:
/// steps from it go nowhere). Joints not free keep the seed's values.
fn starts(robot: &Robot, seed: &[f64], free: &[usize]) -> Vec<Vec<f64>> {
    let at = |share: Option<f64>| -> Vec<f64> {
        (0..robot.joints.len())
            .map(|i| {
                let limits = robot.joints[i].limits;
                match share {
                    _ if !free.contains(&i) => seed[i],
                    Some(s) => limits.min + s * (limits.max - limits.min),
                    None => robot.home[i],
                }
            })
            .collect()
    };
    vec![
        seed.to_vec(),
        at(None),
        at(Some(0.5)),
        at(Some(0.25)),
        at(Some(0.75)),
    ]
}

/// The reachable tool position nearest to `position` that the solver finds (the limits
/// clamping it) from each of its [`starts`].
pub(crate) fn nearest_reachable(
    robot: &Robot,
    position: DVec3,
    seed: &[f64],
    held: &[bool],
) -> DVec3 {
    let free = Dls::new(robot).free_joints(held);
    let target = ToolTarget::position(position);
    starts(robot, seed, &free)
        .into_iter()
        .map(|start| robot.tcp_position(&iterate(robot, &target, start, &free, 1000)))
        .min_by(|a, b| a.distance(position).total_cmp(&b.distance(position)))
        .unwrap_or(position)
}

/// Damped least-squares steps from `values`, clamped to the limits after each.
fn iterate(
    robot: &Robot,
    target: &ToolTarget,
    mut values: Vec<f64>,
    free: &[usize],
    iterations: usize,
) -> Vec<f64> {
    for _ in 0..iterations {
        let frame = robot.tcp_frame(&values);
        let position_error = target.position - frame.t;
        let orientation_error = target
            .orientation
            .map(|wanted| rotation_vector(shortest(wanted * frame.r.conjugate())));
        if position_error.length() < POSITION_TOLERANCE_M
            && orientation_error.is_none_or(|e| e.length() < 1e-9)
        {
            break;
        }
        let jacobian = Jacobian::at(robot, &values, free);
        let lambda = DAMPING * (position_error.length() / DAMPING_ERROR).clamp(1e-3, 1.0);
        let step = jacobian.step(position_error, orientation_error, lambda);
        let largest = step.iter().fold(0.0_f64, |m, s| m.max(s.abs()));
        let scale = if largest > MAX_STEP {
            MAX_STEP / largest
        } else {
            1.0
        };
        for (&i, s) in free.iter().zip(&step) {
            let joint = &robot.joints[i];
            let change = match joint.kind {
                JointKind::Revolute => (s * scale).to_degrees(),
                JointKind::Prismatic => s * scale,
            };
            values[i] = (values[i] + change).clamp(joint.limits.min, joint.limits.max);
        }
    }
    values
}

/// `q` or `−q`, whichever has w ≥ 0 (the short way round).
fn shortest(q: DQuat) -> DQuat {
    if q.w < 0.0 {
        -q
    } else {
        q
    }
}

impl Jacobian {
    fn at(robot: &Robot, values: &[f64], free: &[usize]) -> Jacobian {
        let frames = robot.joint_frames(values);
        let tool = robot.tcp_position(values);
        let mut linear = Vec::with_capacity(free.len());
        let mut angular = Vec::with_capacity(free.len());
        for &i in free {
            let axis = frames[i].r * robot.joints[i].axis;
            match robot.joints[i].kind {
                JointKind::Revolute => {
                    linear.push(axis.cross(tool - frames[i].t));
                    angular.push(axis);
                }
                JointKind::Prismatic => {
                    linear.push(axis);
                    angular.push(DVec3::ZERO);
                }
            }
        }
        Jacobian {
            free: free.to_vec(),
            linear,
            angular,
        }
    }

    /// The joint step: the damped pseudo-inverse of the position rows applied to the position
    /// error, plus the orientation's step projected into that task's null space.
    fn step(
        &self,
        position_error: DVec3,
        orientation_error: Option<DVec3>,
        lambda: f64,
    ) -> Vec<f64> {
        let primary = damped_solve(&self.linear, position_error, lambda);
        let Some(orientation_error) = orientation_error else {
            return primary;
        };
        let n = self.free.len();
        // Null-space projector N = I − J⁺J of the position task (n × n, n ≤ a handful).
        let pinv = damped_pseudo_inverse(&self.linear, lambda);
        let mut projector = vec![vec![0.0; n]; n];
        for (r, row) in projector.iter_mut().enumerate() {
            for (c, slot) in row.iter_mut().enumerate() {
                let jpj: f64 = (0..3).map(|k| pinv[r][k] * self.linear[c][k]).sum();
                *slot = f64::from(u8::from(r == c)) - jpj;
            }
        }
        // Orientation columns through the projector: (J_o N), column c = Σ_r J_o[r] N[r][c].
        let projected: Vec<DVec3> = (0..n)
            .map(|c| (0..n).map(|r| self.angular[r] * projector[r][c]).sum())
            .collect();
        let achieved: DVec3 = (0..n).map(|c| self.angular[c] * primary[c]).sum();
        let secondary = damped_solve(
            &projected,
            orientation_error - achieved,
            ORIENTATION_DAMPING,
        );
        // The secondary step only follows the linearisation so far: at full gain it drags the
        // arm off the position faster than the primary task brings it back.
        primary
            .iter()
            .zip(secondary)
            .map(|(a, b)| a + ORIENTATION_GAIN * b)
            .collect()
    }
}

/// Jᵀ(JJᵀ + λ²I)⁻¹·e for a 3-row Jacobian given by columns.
fn damped_solve(columns: &[DVec3], error: DVec3, lambda: f64) -> Vec<f64> {
    let y = normal_matrix(columns, lambda).inverse() * error;
    columns.iter().map(|c| c.dot(y)).collect()
}

/// Jᵀ(JJᵀ + λ²I)⁻¹ as n rows of 3.
fn damped_pseudo_inverse(columns: &[DVec3], lambda: f64) -> Vec<[f64; 3]> {
    let inverse = normal_matrix(columns, lambda).inverse();
    columns
        .iter()
        .map(|c| (inverse.transpose() * *c).to_array())
        .collect()
}

/// JJᵀ + λ²I.
fn normal_matrix(columns: &[DVec3], lambda: f64) -> DMat3 {
    let outer = |c: &DVec3| DMat3::from_cols(*c * c.x, *c * c.y, *c * c.z);
    columns
        .iter()
        .map(outer)
        .fold(DMat3::IDENTITY * lambda * lambda, |a, b| a + b)
}
