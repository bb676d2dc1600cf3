//! Closed-form inverse kinematics for arms built like the built-ins: a pan joint, three pitch
//! joints with parallel axes square to the pan's, and optionally a roll joint carrying the tool.
//!
//! The geometry is read off the robot's own joint origins and axes ([`ArmGeometry::derive`]),
//! so an arm with the same shape and other dimensions (SO-100 beside SO-101) needs no code.
//! docs/robots.md §12.2 derives the solution. In short, in the *pan frame* (joint 0's moving
//! frame) the pitch joints only move the tool within planes square to their common axis `n`:
//!
//! 1. the tool point's offset along `n` is fixed (it depends on the roll only), so the pan angle
//!    is the one that puts the target at that offset: two branches (reaching forward or back
//!    over the base);
//! 2. the tool pitch φ (the sum of the three pitch rotations) comes from the asked orientation
//!    (the roll axis turned about `n` as near as it goes to where the target wants it; the roll
//!    anchor, and so the pan, follows from the orientation in closed form), or, with a position
//!    alone, is kept from the previous pose, or is the nearest pitch at which the two links
//!    reach the wrist (a closed-form arc of pitches);
//! 3. the wrist point is the target minus the last link turned by φ, and the first two pitch
//!    joints reach it as a planar two-link arm: two elbow branches;
//! 4. the roll is the remaining twist about the roll axis.

use super::planar::{angle_of, two_link};
use super::{
    joint_distance, orientation_residual_deg, walk_arm, within_limits, Solution, ToolTarget,
};
use crate::pose::{twist_swing, unwrap_within, wrap_pi, RigidTransform};
use crate::robot::{JointKind, Robot};
use glam::{DQuat, DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// How far from parallel (or square) two axes may be and still count as such: the built-ins'
/// files carry their URDFs' six-digit quaternions, a few 1e-6 off.
const AXIS_TOLERANCE: f64 = 1e-4;
/// The position a solution must reproduce through the forward kinematics, metres: a check that
/// the branch assembled is a solution at all, never a wrong one.
const POSITION_CHECK_M: f64 = 1e-6;
/// Roll iterations when the roll moves the tool point (the tool point is off the roll axis on
/// SO-101 and Koch): each pass shrinks the error by about offset / reach (< 0.1).
const ROLL_PASSES: usize = 40;
/// Step of the search for a roll when the seed's cannot reach a position, degrees.
const ROLL_SEARCH_STEP_DEG: f64 = 30.0;
/// Orientation residuals this close count as equal when choosing a branch, degrees: of the
/// branches that orient the tool best, the nearest to the previous key wins.
const RESIDUAL_TIE_DEG: f64 = 0.05;
/// A residual this small means the orientation was reached, degrees.
const EXACT_DEG: f64 = 1e-6;
/// Step of the search for a tool pitch that reaches a position the previous pitch cannot, degrees.
const PITCH_SEARCH_STEP_DEG: f64 = 1.0;
/// Bisections from the first search step that reaches back towards the seed's pitch: the
/// pitch found is within 1° / 2¹² of the edge of what reaches.
const PITCH_REFINE_PASSES: usize = 12;

/// The roll joint, in the pan frame at zero pitch.
#[derive(Debug, Clone, PartialEq)]
struct Roll {
    index: usize,
    anchor: DVec3,
    axis: DVec3,
}

/// The shape of a pan + three-pitch (+ roll) arm, in its pan frame at zero pitch and roll.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmGeometry {
    /// Joint 0's origin in the base frame (the pan frame at zero pan).
    base: RigidTransform,
    pan_axis: DVec3,
    pitch: [usize; 3],
    /// The common pitch axis, and each pitch joint's axis as ±n.
    n: DVec3,
    signs: [f64; 3],
    /// Plane axes with u × v = n, so a turn about n is counter-clockwise in (u, v).
    u: DVec3,
    v: DVec3,
    /// Pitch joint anchors.
    anchors: [DVec3; 3],
    roll: Option<Roll>,
    /// The tool frame at zero pitch and roll.
    tool: RigidTransform,
}

/// One pan side for one roll, in the arm plane (u, v): what every tool pitch and elbow there
/// shares, worked out once.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plane {
    /// Radians.
    pub(super) pan: f64,
    roll: f64,
    /// The target, the pitch anchors, and the last link (wrist anchor to tool point).
    target: DVec2,
    anchors: [DVec2; 3],
    last: DVec2,
}

impl Plane {
    /// The first two pitch turns of both elbows that put the wrist where tool pitch `phi`
    /// needs it, or None when the links cannot reach it.
    pub(super) fn reach(&self, phi: f64) -> Option<[(f64, f64); 2]> {
        let [c1, c2, c3] = self.anchors;
        let wrist = self.target - DVec2::from_angle(phi).rotate(self.last);
        two_link(c2 - c1, c3 - c2, wrist - c1)
    }
}

impl ArmGeometry {
    /// The geometry when `robot` has this shape: joints 0–3 revolute, 1–3 parallel and square
    /// to 0, the tool carried by joint 3 or by a revolute joint 4 (the roll). None otherwise.
    pub fn derive(robot: &Robot) -> Option<ArmGeometry> {
        let tcp = robot.tcp.as_ref()?;
        let joints = &robot.joints;
        if joints.len() < 4 || !(3..=4).contains(&tcp.parent) {
            return None;
        }
        if joints[..=tcp.parent]
            .iter()
            .any(|j| j.kind != JointKind::Revolute)
        {
            return None;
        }
        let zero = vec![0.0; joints.len()];
        let frames = robot.joint_frames(&zero);
        let base = joints[0].origin;
        let to_pan = |p: DVec3| frames[0].r.conjugate() * (p - frames[0].t);
        let axis_in_pan =
            |i: usize| (frames[0].r.conjugate() * (frames[i].r * joints[i].axis)).normalize();
        let n = axis_in_pan(1);
        let pan_axis = joints[0].axis.normalize();
        if pan_axis.dot(n).abs() > AXIS_TOLERANCE {
            return None;
        }
        let mut signs = [1.0; 3];
        for (slot, i) in signs.iter_mut().zip(1..=3) {
            let a = axis_in_pan(i);
            if a.cross(n).length() > AXIS_TOLERANCE {
                return None;
            }
            *slot = a.dot(n).signum();
        }
        let roll = (tcp.parent == 4).then(|| Roll {
            index: 4,
            anchor: to_pan(frames[4].t),
            axis: axis_in_pan(4),
        });
        let tool_world = frames[tcp.parent].compose(&tcp.origin);
        let u = pan_axis.cross(n).normalize();
        Some(ArmGeometry {
            base,
            pan_axis,
            pitch: [1, 2, 3],
            n,
            signs,
            u,
            v: n.cross(u),
            anchors: [
                to_pan(frames[1].t),
                to_pan(frames[2].t),
                to_pan(frames[3].t),
            ],
            roll,
            tool: RigidTransform::new(
                to_pan(tool_world.t),
                (frames[0].r.conjugate() * tool_world.r).normalize(),
            ),
        })
    }

    /// How far `position` (base frame) is from the pan axis, metres. Within about the tool
    /// point's offset from the roll axis (8 mm on SO-101 and Koch) the pan is nearly free and
    /// the orientation is solved as well as the general solver manages, not exactly.
    pub fn pan_axis_distance(&self, position: DVec3) -> f64 {
        let p = self.base.r.conjugate() * (position - self.base.t);
        (p - self.pan_axis * p.dot(self.pan_axis)).length()
    }

    /// Whether the arm has a roll joint after its three pitches.
    pub fn has_roll(&self) -> bool {
        self.roll.is_some()
    }

    /// The solution inside the limits and clear of the floor nearest to `seed`, or None.
    pub fn solve(&self, robot: &Robot, target: &ToolTarget, seed: &[f64]) -> Option<Solution> {
        self.solve_with(robot, target, seed, true)
    }

    /// [`ArmGeometry::solve`] without the floor rule, to tell "below the floor" from "out of reach".
    pub(crate) fn solve_ignoring_floor(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
    ) -> Option<Solution> {
        self.solve_with(robot, target, seed, false)
    }

    fn solve_with(
        &self,
        robot: &Robot,
        target: &ToolTarget,
        seed: &[f64],
        floor: bool,
    ) -> Option<Solution> {
        let best = match target.orientation {
            Some(orientation) => {
                self.best_oriented(robot, target.position, orientation, seed, floor)
            }
            None => self.best_positioned(robot, target.position, seed, floor),
        }?;
        let orientation_residual_deg = target
            .orientation
            .map(|wanted| orientation_residual_deg(robot.tcp_frame(&best).r, wanted));
        Some(Solution {
            values: best,
            orientation_residual_deg,
        })
    }

    /// With a position alone: the seed's tool pitch and roll if any branch reaches with them;
    /// else, per pan branch, the tool pitch nearest the seed's at which the wrist is within
    /// the two links' reach, in closed form ([`ArmGeometry::nearest_reachable_pitch`]). Only
    /// when the limits or the floor refuse those too, the pitch is searched in steps of
    /// [`PITCH_SEARCH_STEP_DEG`] either way, and other rolls are tried when no pitch reaches
    /// with the seed's (the roll moves a tool point that is off its axis, which can take the
    /// pan past its limit).
    fn best_positioned(
        &self,
        robot: &Robot,
        position: DVec3,
        seed: &[f64],
        floor: bool,
    ) -> Option<Vec<f64>> {
        let pitch = self.tool_pitch(seed);
        let rolls = self.roll_candidates(robot, seed);
        rolls.into_iter().find_map(|roll| {
            let planes: Vec<Plane> = [false, true]
                .into_iter()
                .filter_map(|back| self.plane(position, roll, back))
                .collect();
            let at = |phi: f64, planes: &[Plane]| {
                let candidates = planes
                    .iter()
                    .flat_map(|p| self.both_elbows(robot, p, position, phi, seed, floor));
                nearest(robot, candidates, seed)
            };
            at(pitch, &planes)
                .or_else(|| {
                    let candidates = planes.iter().flat_map(|plane| {
                        let pitches = nearest_reachable_pitch(plane, pitch);
                        let one = std::slice::from_ref(plane);
                        pitches
                            .into_iter()
                            .flatten()
                            .filter_map(move |phi| at(phi, one))
                    });
                    nearest(robot, candidates, seed)
                })
                .or_else(|| {
                    let step = PITCH_SEARCH_STEP_DEG.to_radians();
                    let steps = (180.0 / PITCH_SEARCH_STEP_DEG) as i32;
                    (1..=steps).find_map(|k| {
                        [1.0, -1.0].into_iter().find_map(|side| {
                            let reached = side * f64::from(k) * step;
                            at(pitch + reached, &planes)?;
                            // Back towards the seed's pitch, to the edge of what reaches.
                            let (mut short, mut far) = (reached - side * step, reached);
                            for _ in 0..PITCH_REFINE_PASSES {
                                let middle = 0.5 * (short + far);
                                match at(pitch + middle, &planes) {
                                    Some(_) => far = middle,
                                    None => short = middle,
                                }
                            }
                            at(pitch + far, &planes)
                        })
                    })
                })
        })
    }

    /// Rolls (radians) to try for a position alone: the seed's, then every
    /// [`ROLL_SEARCH_STEP_DEG`] either way inside the limits; just 0 without a roll joint.
    pub(super) fn roll_candidates(&self, robot: &Robot, seed: &[f64]) -> Vec<f64> {
        let Some(roll) = &self.roll else {
            return vec![0.0];
        };
        let limits = robot.joints[roll.index].limits;
        let start = seed[roll.index];
        let mut rolls = vec![start];
        for k in 1..=(360.0 / ROLL_SEARCH_STEP_DEG) as i32 {
            for side in [1.0, -1.0] {
                let r = start + side * f64::from(k) * ROLL_SEARCH_STEP_DEG;
                if limits.contains(r) {
                    rolls.push(r);
                }
            }
        }
        rolls.into_iter().map(f64::to_radians).collect()
    }

    /// With an orientation: every branch with the tool pitch and roll the orientation asks for
    /// (the pan changes per branch, and with it what the orientation asks of the pitch). The
    /// roll from the seed's by repetition first; when that reaches the orientation on no
    /// branch exactly, every roll that is a consistent answer (there can be several when the
    /// target is near the pan axis).
    fn best_oriented(
        &self,
        robot: &Robot,
        position: DVec3,
        orientation: DQuat,
        seed: &[f64],
        floor: bool,
    ) -> Option<Vec<f64>> {
        let all = self.oriented_solutions(robot, position, orientation, seed, floor);
        choose_oriented(robot, all, seed)
    }

    /// The solutions [`ArmGeometry::best_oriented`] chooses from, each with its orientation
    /// residual (degrees, the length of the rotation vector).
    pub(crate) fn oriented_solutions(
        &self,
        robot: &Robot,
        position: DVec3,
        orientation: DQuat,
        seed: &[f64],
        floor: bool,
    ) -> Vec<(Vec<f64>, f64)> {
        // The pitch and roll depend on the pan branch only: both elbows share them.
        let fast: Vec<(bool, (f64, f64))> = [false, true]
            .into_iter()
            .filter_map(|back| Some((back, self.settle_roll(position, orientation, back, seed)?)))
            .collect();
        let found = self.oriented_candidates(robot, position, orientation, &fast, seed, floor);
        if found.iter().any(|c| c.1 < EXACT_DEG) || self.roll.is_none() {
            return found;
        }
        let thorough: Vec<(bool, (f64, f64))> = [false, true]
            .into_iter()
            .flat_map(|back| {
                let rolls = self.scan_roll(position, orientation, back);
                rolls.into_iter().map(move |r| (back, r))
            })
            .collect();
        let mut all = found;
        all.extend(self.oriented_candidates(robot, position, orientation, &thorough, seed, floor));
        all
    }

    /// The solutions of both elbows for the given pan sides (`back`) and (pitch, roll) pairs,
    /// with their residuals.
    fn oriented_candidates(
        &self,
        robot: &Robot,
        position: DVec3,
        orientation: DQuat,
        choices: &[(bool, (f64, f64))],
        seed: &[f64],
        floor: bool,
    ) -> Vec<(Vec<f64>, f64)> {
        choices
            .iter()
            .filter_map(|&(back, (phi, roll))| Some((self.plane(position, roll, back)?, phi)))
            .flat_map(|(plane, phi)| {
                let elbows = plane.reach(phi).into_iter().flatten();
                elbows.filter_map(move |turns| {
                    let (values, reached) =
                        self.checked(robot, &plane, position, phi, turns, seed, floor)?;
                    let residual = orientation_residual_deg(reached, orientation);
                    Some((values, residual.length()))
                })
            })
            .collect()
    }

    /// The tool pitch and roll (radians) the orientation asks for on pan side `back`. The roll moves
    /// the tool point when the point is off the roll axis, which moves the pan, which changes
    /// what the orientation asks: a fixed point of [`ArmGeometry::next_roll`]. It starts from
    /// the closed-form roll ([`ArmGeometry::roll_of_reachable`]), which is the fixed point when
    /// the orientation is reachable, so one pass confirms it; otherwise repeating converges when
    /// the target is far from the pan axis compared with the tool point's offset; near the pan
    /// axis it need not, and the caller then scans for where the roll asked equals the roll
    /// assumed.
    fn settle_roll(
        &self,
        position: DVec3,
        orientation: DQuat,
        back: bool,
        seed: &[f64],
    ) -> Option<(f64, f64)> {
        let Some(roll_joint) = &self.roll else {
            return Some((self.next_roll(position, orientation, back, 0.0)?.0, 0.0));
        };
        let mut roll = self
            .roll_of_reachable(position, orientation, back)
            .unwrap_or_else(|| seed[roll_joint.index].to_radians());
        for _ in 0..ROLL_PASSES {
            let (phi, next) = self.next_roll(position, orientation, back, roll)?;
            if wrap_pi(next - roll).abs() < 1e-13 {
                return Some((phi, next));
            }
            roll = next;
        }
        None
    }

    /// The roll (radians) that reaches `orientation` exactly if the arm can reach it, in
    /// closed form (docs/robots.md §12.2): the tool frame fixes the vector from the roll
    /// anchor to the tool point whatever the joints, so the roll anchor is known, its offset
    /// along n is fixed, and its pan is the roll-free one. The fixed point of
    /// [`ArmGeometry::next_roll`] starts here, and is already there when the orientation is
    /// reachable; otherwise it moves on to the nearest consistent roll.
    fn roll_of_reachable(&self, position: DVec3, orientation: DQuat, back: bool) -> Option<f64> {
        let roll = self.roll.as_ref()?;
        let in_origin = (self.base.r.conjugate() * orientation).normalize();
        let p = self.base.r.conjugate() * (position - self.base.t);
        let anchor = p - in_origin * (self.tool.r.conjugate() * (self.tool.t - roll.anchor));
        let pan = self.pan_for_offset(anchor, roll.anchor.dot(self.n), back)?;
        let in_pan =
            (DQuat::from_axis_angle(self.pan_axis, pan).conjugate() * in_origin).normalize();
        Some(self.pitch_and_roll(in_pan).1)
    }

    /// The pitch and roll that `orientation` asks for if the roll were `roll`.
    fn next_roll(
        &self,
        position: DVec3,
        orientation: DQuat,
        back: bool,
        roll: f64,
    ) -> Option<(f64, f64)> {
        let pan = self.pan_angle(position, roll, back)?;
        let in_pan = (DQuat::from_axis_angle(self.pan_axis, pan).conjugate()
            * self.base.r.conjugate()
            * orientation)
            .normalize();
        Some(self.pitch_and_roll(in_pan))
    }

    /// Every fixed point of [`ArmGeometry::next_roll`], found by sign changes of (asked −
    /// assumed) over a grid of rolls, each refined by bisection.
    fn scan_roll(&self, position: DVec3, orientation: DQuat, back: bool) -> Vec<(f64, f64)> {
        const STEPS: usize = 360;
        let gap = |roll: f64| {
            self.next_roll(position, orientation, back, roll)
                .map(|(_, next)| wrap_pi(next - roll))
        };
        let at = |k: usize| -PI + TAU * k as f64 / STEPS as f64;
        (0..STEPS)
            .filter_map(|k| {
                let (mut lo, mut hi) = (at(k), at(k + 1));
                let (g_lo, g_hi) = (gap(lo)?, gap(hi)?);
                // A sign change across a wrap of ±π is a jump, not a root.
                if g_lo.signum() == g_hi.signum() || (g_lo - g_hi).abs() > PI {
                    return None;
                }
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if gap(mid)?.signum() == g_lo.signum() {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let roll = 0.5 * (lo + hi);
                self.next_roll(position, orientation, back, roll)
                    .map(|(phi, _)| (phi, roll))
            })
            .collect()
    }

    /// The pitch φ and roll ψ for which Rot(n, φ)·Rot(roll axis, ψ)·tool comes nearest to
    /// `in_pan`: φ turns the roll axis about n onto the plane through where `in_pan` puts it,
    /// ψ is what remains about the roll axis. Without a roll, φ is the twist about n.
    fn pitch_and_roll(&self, in_pan: DQuat) -> (f64, f64) {
        let m = (in_pan * self.tool.r.conjugate()).normalize();
        let Some(roll) = &self.roll else {
            return (twist_swing(m, self.n).0, 0.0);
        };
        let flat = |a: DVec3| a - self.n * a.dot(self.n);
        let (from, to) = (flat(roll.axis), flat(m * roll.axis));
        let phi = self.n.dot(from.cross(to)).atan2(from.dot(to));
        let rest = DQuat::from_axis_angle(self.n, -phi) * m;
        (phi, twist_swing(rest, roll.axis).0)
    }

    /// The tool pitch of a pose: the sum of the pitch rotations about n, radians.
    pub(super) fn tool_pitch(&self, values: &[f64]) -> f64 {
        self.pitch
            .iter()
            .zip(self.signs)
            .map(|(&i, s)| s * values[i].to_radians())
            .sum()
    }

    /// The tool point in the pan frame at zero pitch, for a roll of `roll` radians.
    fn tool_point(&self, roll: f64) -> DVec3 {
        match &self.roll {
            Some(r) => r.anchor + DQuat::from_axis_angle(r.axis, roll) * (self.tool.t - r.anchor),
            None => self.tool.t,
        }
    }

    /// The pan angle (radians) that puts `position` at the tool point's fixed offset along n,
    /// on the branch reaching forward or (`back`) back over the base.
    fn pan_angle(&self, position: DVec3, roll: f64, back: bool) -> Option<f64> {
        let p = self.base.r.conjugate() * (position - self.base.t);
        self.pan_for_offset(p, self.tool_point(roll).dot(self.n), back)
    }

    /// The pan angle (radians) that puts `p` (in joint 0's origin frame) at `offset` along n.
    fn pan_for_offset(&self, p: DVec3, offset: f64, back: bool) -> Option<f64> {
        // The target's offset along n after turning the pan by q: a·cos q + b·sin q.
        let a = p.dot(self.n);
        let b = p.dot(self.pan_axis.cross(self.n));
        let radius = a.hypot(b);
        // A target on the circle of tangency computed in floating point lands a hair inside it.
        if radius + 1e-9 < offset.abs() || radius == 0.0 {
            return None;
        }
        let spread = (radius * radius - offset * offset)
            .max(0.0)
            .sqrt()
            .atan2(offset);
        let side = if back { -1.0 } else { 1.0 };
        Some(b.atan2(a) + side * spread)
    }

    /// The tool pitch (radians) that turns the approach axis (`approach`, a direction in the
    /// tool frame) as near as it goes to `direction` (base frame) on `plane`. The pitch joints
    /// turn it within the arm's plane only, so a direction out of that plane is met as nearly
    /// as the plane allows; straight down is always in it, since the pan axis is.
    pub(super) fn approach_pitch(&self, plane: &Plane, approach: DVec3, direction: DVec3) -> f64 {
        let turn_back = DQuat::from_axis_angle(self.pan_axis, -plane.pan);
        let wanted = turn_back * (self.base.r.conjugate() * direction);
        let mut axis = self.tool.r * approach;
        if let Some(r) = &self.roll {
            axis = DQuat::from_axis_angle(r.axis, plane.roll) * axis;
        }
        let angle = |x: DVec3| x.dot(self.v).atan2(x.dot(self.u));
        wrap_pi(angle(wanted) - angle(axis))
    }

    /// The pan side `back` for roll `roll`: what every tool pitch and elbow there shares.
    pub(super) fn plane(&self, position: DVec3, roll: f64, back: bool) -> Option<Plane> {
        let pan = self.pan_angle(position, roll, back)?;
        let turn_back = DQuat::from_axis_angle(self.pan_axis, -pan);
        let in_pan = turn_back * (self.base.r.conjugate() * (position - self.base.t));
        let flat = |p: DVec3| DVec2::new(p.dot(self.u), p.dot(self.v));
        let anchors = self.anchors.map(flat);
        Some(Plane {
            pan,
            roll,
            target: flat(in_pan),
            last: flat(self.tool_point(roll)) - anchors[2],
            anchors,
        })
    }

    /// Both elbows at tool pitch `phi` on `plane`, each checked ([`ArmGeometry::checked`]).
    fn both_elbows<'a>(
        &'a self,
        robot: &'a Robot,
        plane: &'a Plane,
        position: DVec3,
        phi: f64,
        seed: &'a [f64],
        floor: bool,
    ) -> impl Iterator<Item = Vec<f64>> + 'a {
        let elbows = plane.reach(phi).into_iter().flatten();
        elbows.filter_map(move |turns| {
            let solution = self.checked(robot, plane, position, phi, turns, seed, floor);
            solution.map(|s| s.0)
        })
    }

    /// The joint values for the first two pitch turns `turns` (radians) at tool pitch `phi`,
    /// each unwrapped into its limits nearest the seed, with the tool orientation reached;
    /// None when they leave the limits, miss the target or (with `floor`) go below the floor.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn checked(
        &self,
        robot: &Robot,
        plane: &Plane,
        position: DVec3,
        phi: f64,
        (shoulder, elbow): (f64, f64),
        seed: &[f64],
        floor: bool,
    ) -> Option<(Vec<f64>, DQuat)> {
        let turns = [shoulder, elbow, phi - shoulder - elbow];
        let mut values = seed.to_vec();
        values[0] = plane.pan.to_degrees();
        for ((&i, s), turn) in self.pitch.iter().zip(self.signs).zip(turns) {
            values[i] = s * turn.to_degrees();
        }
        if let Some(r) = &self.roll {
            values[r.index] = plane.roll.to_degrees();
        }
        self.fit_to_limits(robot, &mut values, seed)?;
        // The robot's own forward kinematics, in one walk that allocates nothing: the branch
        // must put the tool on the target (never a wrong branch) and stay above the floor.
        let (below, tool) = walk_arm(robot, &values);
        let reached = tool.t.distance(position) < POSITION_CHECK_M;
        let clear = !floor || below.is_none();
        (reached && clear).then_some((values, tool.r))
    }

    /// Each solved angle as the turn of it inside the joint's limits nearest the seed.
    fn fit_to_limits(&self, robot: &Robot, values: &mut [f64], seed: &[f64]) -> Option<()> {
        let solved = [0, 1, 2, 3]
            .into_iter()
            .chain(self.roll.as_ref().map(|r| r.index));
        for i in solved {
            let limits = robot.joints[i].limits;
            values[i] = unwrap_within(values[i], seed[i], limits.min, limits.max, 360.0)?;
        }
        within_limits(robot, values).then_some(())
    }
}

/// Of solutions with their orientation residuals, those orienting the tool best (within
/// [`RESIDUAL_TIE_DEG`]), and of those the nearest to `seed`.
fn choose_oriented(
    robot: &Robot,
    candidates: Vec<(Vec<f64>, f64)>,
    seed: &[f64],
) -> Option<Vec<f64>> {
    let best = candidates.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    let close = candidates
        .into_iter()
        .filter(|c| c.1 <= best + RESIDUAL_TIE_DEG)
        .map(|c| c.0);
    nearest(robot, close, seed)
}

/// Of `candidates`, the one nearest to `seed` in joint space.
fn nearest(
    robot: &Robot,
    candidates: impl Iterator<Item = Vec<f64>>,
    seed: &[f64],
) -> Option<Vec<f64>> {
    candidates
        .min_by(|a, b| joint_distance(robot, a, seed).total_cmp(&joint_distance(robot, b, seed)))
}

/// The tool pitches (radians) nearest to `pitch` at which the two links reach the wrist
/// point, one on each of the two arcs of
/// reachable pitches on `plane` (docs/robots.md §12.2), a little inside the arc's end so the arm is
/// not at its stretched or folded singularity; None where no pitch reaches.
pub(super) fn nearest_reachable_pitch(plane: &Plane, pitch: f64) -> [Option<f64>; 2] {
    const INSIDE: f64 = 0.1 * PI / 180.0;
    let none = [None, None];
    let [c1, c2, c3] = plane.anchors;
    let last = plane.last;
    let to_target = plane.target - c1;
    let (l1, l2) = ((c2 - c1).length(), (c3 - c2).length());
    // |wrist − c1|² = |D|² + |L|² − 2|D||L|·cos(φ − α): reachable while it lies between
    // the folded (|l1 − l2|) and the stretched (l1 + l2) arm.
    let (d, l) = (to_target.length(), last.length());
    if d * l < 1e-12 {
        return none;
    }
    let cos_at = |reach: f64| (d * d + l * l - reach * reach) / (2.0 * d * l);
    let (cos_far, cos_near) = (cos_at(l1 + l2), cos_at((l1 - l2).abs()));
    if cos_far > 1.0 || cos_near < -1.0 {
        return none;
    }
    let (from, to) = (cos_near.min(1.0).acos(), cos_far.max(-1.0).acos());
    let alpha = angle_of(to_target) - angle_of(last);
    let wanted = wrap_pi(pitch - alpha);
    let (from, to) = if to - from > 2.0 * INSIDE {
        (from + INSIDE, to - INSIDE)
    } else {
        let middle = 0.5 * (from + to);
        (middle, middle)
    };
    // The arc on the seed's side of α holds the nearest pitch; on the other arc, the end
    // nearer the seed's pitch (the way round past α or past α + π).
    let side = if wanted < 0.0 { -1.0 } else { 1.0 };
    let far_end = if wanted.abs() + from <= TAU - wanted.abs() - to {
        from
    } else {
        to
    };
    let at = |delta: f64| Some(pitch + wrap_pi(alpha + delta - pitch));
    [at(side * wanted.abs().clamp(from, to)), at(-side * far_end)]
}
