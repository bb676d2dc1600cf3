//! The general solver for robot files: damped least squares on the forward kinematics, with
//! the joint limits, from the previous key's solution.
//!
//! Position is the primary task and orientation the secondary one, solved in the null space
//! of the position's Jacobian (task-priority inverse kinematics): on an arm with fewer than six
//! joints the position is still met exactly and the orientation as closely as what is left
//! allows, which a single weighted least-squares step would trade against each other.
//!
//! Its time is that of its starts: one that converges takes a few dozen iterations, one that is
//! stuck used to run all 500 before the next was tried (a mean 12× the median). A start that
//! stops halving its error gives way to the next, and a pose target's start that reaches the
//! position with the orientation stuck short is kept only if no other start meets both.

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
/// Share of the orientation step taken per iteration while the tool is still far from the
/// target's position ([`POSITION_NEAR_M`]): at full gain the secondary step drags the arm off
/// the position faster than the primary task brings it back.
const ORIENTATION_GAIN: f64 = 0.3;
/// Once the tool is this close to the target's position, metres, the orientation step is taken
/// whole: the linearisation holds, and the orientation converges three times as fast.
const POSITION_NEAR_M: f64 = 1e-4;
/// A start that has not halved its error ([`StartError`]) over this many iterations is stuck
/// (on a limit, in a local minimum, or at a singular pose) and gives way to the next start.
/// Converging steps halve it in one or two.
const STALL_WINDOW: usize = 10;
/// The seed, home and the middle and quarter points of the ranges: the first [`starts`].
const FIXED_STARTS: usize = 5;
/// Starts tried beyond the seed, home and the middle and quarter points of the ranges, when
/// none of those gets there: points spread over the ranges (Halton), which find the pose
/// targets the first five are stuck short of.
const SPREAD_STARTS: u32 = 24;
/// A pose target's orientation is met when the residual is below this, degrees: a start that
/// reaches the position with a larger one (an orientation stuck on a limit) is kept only if no
/// other start does better.
const ORIENTATION_MET_DEG: f64 = 1e-4;
/// How many metres one radian of orientation error weighs in a start's progress.
const ORIENTATION_WEIGHT_M: f64 = 0.1;
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

    /// A solution from `seed` (then from the solver's other starts) inside the limits, clear of the
    /// floor; for a pose target the first that meets the orientation too, else the one that
    /// comes closest to it.
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
        let mut best: Option<Solution> = None;
        for start in starts(robot, seed, &free) {
            let values = iterate(robot, target, start, &free, Patience::WhileProgressing);
            let reached =
                robot.tcp_position(&values).distance(target.position) < POSITION_TOLERANCE_M * 10.0;
            let clear = !floor || lowest_below_floor(robot, &values).is_none();
            if !(reached && clear) {
                continue;
            }
            let solution = Solution {
                orientation_residual_deg: target
                    .orientation
                    .map(|wanted| orientation_residual_deg(robot.tcp_frame(&values).r, wanted)),
                values,
            };
            let residual = solution.orientation_error_deg();
            if residual < ORIENTATION_MET_DEG {
                return Some(solution);
            }
            if best
                .as_ref()
                .is_none_or(|b| residual < b.orientation_error_deg())
            {
                best = Some(solution);
            }
        }
        best
    }

    /// Every solution inside the limits and clear of the floor that the iteration reaches from
    /// one of its [`starts`], repeats included: what a key is chosen from on a robot without the
    /// closed form.
    pub(crate) fn solutions(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        held: &[bool],
    ) -> Vec<Vec<f64>> {
        let free = self.free_joints(held);
        starts(robot, seed, &free)
            .map(|start| iterate(robot, target, start, &free, Patience::WhileProgressing))
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
/// steps from it go nowhere), then [`SPREAD_STARTS`] points spread over the ranges (each joint
/// its own Halton base, within the middle 80 %). Joints not free keep the seed's values.
fn starts<'a>(
    robot: &'a Robot,
    seed: &'a [f64],
    free: &'a [usize],
) -> impl Iterator<Item = Vec<f64>> + 'a {
    const PRIMES: [u32; 8] = [2, 3, 5, 7, 11, 13, 17, 19];
    // Made one by one as they are tried: most solves need only the first.
    let start = move |free_value: &dyn Fn(usize) -> f64| -> Vec<f64> {
        (0..robot.joints.len())
            .map(|i| {
                if free.contains(&i) {
                    free_value(i)
                } else {
                    seed[i]
                }
            })
            .collect()
    };
    let in_range = move |i: usize, share: f64| {
        let limits = robot.joints[i].limits;
        limits.min + share * (limits.max - limits.min)
    };
    let fixed = [None, Some(0.5), Some(0.25), Some(0.75)];
    std::iter::once(seed.to_vec())
        .chain(
            fixed
                .into_iter()
                .map(move |share| start(&|i| share.map_or(robot.home[i], |s| in_range(i, s)))),
        )
        .chain(
            (1..=SPREAD_STARTS).map(move |k| {
                start(&|i| in_range(i, 0.1 + 0.8 * halton(k, PRIMES[i % PRIMES.len()])))
            }),
        )
}

/// The `index`th number of van der Corput's sequence in `base`, in [0, 1).
fn halton(mut index: u32, base: u32) -> f64 {
    let (mut value, mut scale) = (0.0, 1.0);
    while index > 0 {
        scale /= f64::from(base);
        value += scale * f64::from(index % base);
        index /= base;
    }
    value
}

/// The reachable tool position nearest to `position` that the solver finds (the limits
/// clamping it) from each of its [`FIXED_STARTS`] fixed [`starts`].
pub(crate) fn nearest_reachable(
    robot: &Robot,
    position: DVec3,
    seed: &[f64],
    held: &[bool],
) -> DVec3 {
    let free = Dls::new(robot).free_joints(held);
    let target = ToolTarget::position(position);
    // Each start runs its full thousand iterations, and this only measures the miss of a target
    // out of reach: the fixed starts, not the spread ones.
    starts(robot, seed, &free)
        .take(FIXED_STARTS)
        .map(|start| {
            robot.tcp_position(&iterate(robot, &target, start, &free, Patience::Full(1000)))
        })
        .min_by(|a, b| a.distance(position).total_cmp(&b.distance(position)))
        .unwrap_or(position)
}

/// How long one start is iterated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Patience {
    /// Up to [`MAX_ITERATIONS`], until converged or stuck ([`STALL_WINDOW`]): a solve.
    WhileProgressing,
    /// This many iterations whatever the progress: the nearest reachable point of a target
    /// out of reach, approached slowly along the limits.
    Full(usize),
}

/// Damped least-squares steps from `values`, clamped to the limits after each.
fn iterate(
    robot: &Robot,
    target: &ToolTarget,
    mut values: Vec<f64>,
    free: &[usize],
    patience: Patience,
) -> Vec<f64> {
    let iterations = match patience {
        Patience::WhileProgressing => MAX_ITERATIONS,
        Patience::Full(n) => n,
    };
    let mut checkpoint = f64::INFINITY;
    for n in 0..iterations {
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
        if patience == Patience::WhileProgressing && n % STALL_WINDOW == 0 {
            let error = position_error.length()
                + ORIENTATION_WEIGHT_M * orientation_error.map_or(0.0, |e| e.length());
            if error > checkpoint / 2.0 {
                break;
            }
            checkpoint = error;
        }
        let jacobian = Jacobian::at(robot, &values, free);
        let lambda = DAMPING * (position_error.length() / DAMPING_ERROR).clamp(1e-3, 1.0);
        let gain = if position_error.length() < POSITION_NEAR_M {
            1.0
        } else {
            ORIENTATION_GAIN
        };
        let step = jacobian.step(position_error, orientation_error, lambda, gain);
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
        gain: f64,
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
            .map(|(a, b)| a + gain * b)
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
