//! Collisions of a pose without MuJoCo: the boxes and capsules of the built-in simulation
//! models (`sim/models/*.xml`), posed by the joint values, checked pair by pair against each
//! other and the floor with the pairs MuJoCo checks — not two parts of one body, not a body
//! and its parent, not the pairs a model's `<contact><exclude>` names, not two parts fixed to
//! the world (the floor, the bases) — so that it agrees with `keypose pose` and the
//! simulation's contacts (tests/simulation/collision.rs compares them) at a fraction of their
//! cost: the teaching rules judge every jog and tool move with it before the arm moves.
//!
//! A cell is every arm's model at its base, so two arms are checked against each other too.
//! A robot without a built-in model has no collision model (nothing is checked).

mod gjk;
pub(crate) mod mjcf;
mod reach;
pub(crate) mod sweep;

use crate::pose::RigidTransform;
use crate::robot::{JointKind, Robot};
use gjk::Core;
use glam::DVec3;

/// What a part touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TouchKind {
    /// The floor (z = 0 of the robot's or the cell's frame).
    Floor,
    /// Another part of the same arm.
    SelfCollision,
    /// A part of another arm of the cell.
    BetweenArms,
}

/// Two bodies closer than a clearance (or a body and the floor).
#[derive(Debug, Clone, PartialEq)]
pub struct Touch {
    /// What the first body touches.
    pub kind: TouchKind,
    /// The bodies as the model names them (a cell's as `ARM/BODY`); the second is `None` for
    /// the floor.
    pub bodies: (String, Option<String>),
    /// The links they are on, as the page names them: the body's own joint or its nearest
    /// jointed ancestor's (a cell's as `ARM/JOINT`), `""` for the base (a cell's `ARM/`);
    /// the second is `None` for the floor.
    pub links: (String, Option<String>),
    /// Their distance, metres: negative is a penetration that deep.
    pub distance: f64,
}

impl TouchKind {
    /// Lower-case name, as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            TouchKind::Floor => "floor",
            TouchKind::SelfCollision => "self",
            TouchKind::BetweenArms => "between_arms",
        }
    }
}

impl Touch {
    /// In words: `upper_arm touches the floor (2.1 mm deep)`.
    pub fn describe(&self) -> String {
        let what = match &self.bodies.1 {
            None => "the floor".to_string(),
            Some(other) => other.clone(),
        };
        if self.distance < 0.0 {
            format!(
                "{} touches {what} ({:.1} mm deep)",
                self.bodies.0,
                -self.distance * 1000.0
            )
        } else {
            format!(
                "{} is {:.1} mm from {what}",
                self.bodies.0,
                self.distance * 1000.0
            )
        }
    }
}

/// How a body moves with the robot's values.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Motion {
    Fixed,
    /// The robot's joint `index`.
    Joint {
        index: usize,
        kind: JointKind,
        axis: DVec3,
    },
    /// A model joint that follows the robot's joint `index` (`offset + scale · value`).
    Mimic {
        index: usize,
        kind: JointKind,
        axis: DVec3,
        offset: f64,
        scale: f64,
    },
}

impl Motion {
    /// How a body with `joint` of the model `parsed` moves, the robot's joints numbered from
    /// `first`; `None` when the joint is neither the robot's nor a mimic of one.
    pub(crate) fn of(
        joint: Option<&mjcf::Joint>,
        parsed: &mjcf::Model,
        robot: &Robot,
        first: usize,
    ) -> Option<Motion> {
        let Some(joint) = joint else {
            return Some(Motion::Fixed);
        };
        Some(match robot.joint_index(&joint.name) {
            Some(index) => Motion::Joint {
                index: first + index,
                kind: joint.kind,
                axis: joint.axis,
            },
            None => {
                let mimic = parsed.mimics.iter().find(|m| m.joint == joint.name)?;
                Motion::Mimic {
                    index: first + robot.joint_index(&mimic.follows)?,
                    kind: joint.kind,
                    axis: joint.axis,
                    offset: mimic.offset,
                    scale: mimic.scale,
                }
            }
        })
    }
}

#[derive(Debug, Clone)]
struct Body {
    name: String,
    parent: Option<usize>,
    /// For a top-level body, its arm's base.
    origin: RigidTransform,
    motion: Motion,
    arm: usize,
    /// Fixed to the world: it and every ancestor have no joint.
    fixed: bool,
    /// The link it belongs to for the page (see [`Touch::links`]).
    link: String,
}

#[derive(Debug, Clone)]
struct Geom {
    body: usize,
    shape: mjcf::Shape,
}

/// Two bodies whose distance is checked (`b` smaller-indexed first), or a body and the floor
/// (`b` is `None`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Pair {
    pub a: usize,
    pub b: Option<usize>,
}

/// The shapes of a robot's (or a cell's) simulation models, ready to pose.
#[derive(Debug, Clone)]
pub struct CollisionModel {
    bodies: Vec<Body>,
    geoms: Vec<Geom>,
    /// Body pairs never checked (index order: smaller first).
    skipped: Vec<(usize, usize)>,
    /// Every pair checked, in the order [`CollisionModel::touches`] finds them; made by
    /// [`CollisionModel::finish`].
    pairs: Vec<Pair>,
    /// Each body's geoms (indices into `geoms`).
    body_geoms: Vec<Vec<usize>>,
    /// How far each pair's bodies can come towards each other per unit of each joint's
    /// change (`reach`), in the order of `pairs`.
    reach: Vec<reach::PairReach>,
}

impl CollisionModel {
    /// The model of `robot` from its built-in simulation model (each arm's, for a cell);
    /// `None` when an arm has none, or its model cannot be read.
    pub fn for_robot(robot: &Robot) -> Option<CollisionModel> {
        let mut model = CollisionModel {
            bodies: Vec::new(),
            geoms: Vec::new(),
            skipped: Vec::new(),
            pairs: Vec::new(),
            body_geoms: Vec::new(),
            reach: Vec::new(),
        };
        if robot.is_cell() {
            for (a, arm) in robot.arms.iter().enumerate() {
                let text = crate::robot::builtin_mjcf(&arm.robot.name)?;
                let parsed = mjcf::parse(text).ok()?;
                model.add(
                    &parsed,
                    &arm.robot,
                    arm.base,
                    a,
                    arm.joints.start,
                    Some(&arm.name),
                )?;
            }
        } else {
            let text = crate::robot::builtin_mjcf(&robot.name)?;
            let parsed = mjcf::parse(text).ok()?;
            model.add(&parsed, robot, RigidTransform::IDENTITY, 0, 0, None)?;
        }
        model.finish(robot);
        Some(model)
    }

    /// The pairs to check, each body's geoms and how far its points reach, once every arm is
    /// added.
    fn finish(&mut self, robot: &Robot) {
        self.body_geoms = vec![Vec::new(); self.bodies.len()];
        for (g, geom) in self.geoms.iter().enumerate() {
            self.body_geoms[geom.body].push(g);
        }
        let shaped: Vec<usize> = (0..self.bodies.len())
            .filter(|&b| !self.body_geoms[b].is_empty())
            .collect();
        let mut pairs = Vec::new();
        for (i, &a) in shaped.iter().enumerate() {
            if !self.bodies[a].fixed {
                pairs.push(Pair { a, b: None });
            }
            for &b in &shaped[i + 1..] {
                if self.checked(a, b) {
                    pairs.push(Pair { a, b: Some(b) });
                }
            }
        }
        let bodies = reach::of_bodies(self, robot);
        self.reach = pairs
            .iter()
            .map(|p| reach::pair_levers(&bodies, p.a, p.b))
            .collect();
        self.pairs = pairs;
    }

    /// Adds one arm's model: its bodies named `ARM/BODY` on a cell, its joints found in
    /// `robot` and numbered from `first` among the cell's.
    fn add(
        &mut self,
        parsed: &mjcf::Model,
        robot: &Robot,
        base: RigidTransform,
        arm: usize,
        first: usize,
        arm_name: Option<&str>,
    ) -> Option<()> {
        let offset = self.bodies.len();
        let named = |n: &str| match arm_name {
            Some(a) => format!("{a}/{n}"),
            None => n.to_string(),
        };
        for body in &parsed.bodies {
            let motion = Motion::of(body.joint.as_ref(), parsed, robot, first)?;
            let parent = body.parent.map(|p| offset + p);
            let fixed = motion == Motion::Fixed && parent.is_none_or(|p| self.bodies[p].fixed);
            let link = match (&body.joint, parent) {
                (Some(j), _) => named(&j.name),
                (None, Some(p)) => self.bodies[p].link.clone(),
                (None, None) => named(""),
            };
            let origin = match parent {
                None => base.compose(&body.origin),
                Some(_) => body.origin,
            };
            self.bodies.push(Body {
                name: named(&body.name),
                parent,
                origin,
                motion,
                arm,
                fixed,
                link,
            });
        }
        for geom in &parsed.geoms {
            self.geoms.push(Geom {
                body: offset + geom.body,
                shape: geom.shape,
            });
        }
        for (a, b) in &parsed.excluded {
            self.skipped
                .push(((offset + a).min(offset + b), (offset + a).max(offset + b)));
        }
        Some(())
    }

    /// Every body's frame in the robot's (the cell's) frame at `values` (robot order, joint
    /// units).
    fn frames(&self, values: &[f64]) -> Vec<RigidTransform> {
        let mut frames: Vec<RigidTransform> = Vec::with_capacity(self.bodies.len());
        for body in &self.bodies {
            let parent = body.parent.map_or(RigidTransform::IDENTITY, |p| frames[p]);
            let motion = match body.motion {
                Motion::Fixed => RigidTransform::IDENTITY,
                Motion::Joint { index, kind, axis } => moved(kind, axis, values[index]),
                Motion::Mimic {
                    index,
                    kind,
                    axis,
                    offset,
                    scale,
                } => {
                    // The model's equality is in its own units: radians, metres.
                    let model = to_model(kind, values[index]);
                    moved(kind, axis, from_model(kind, offset + scale * model))
                }
            };
            frames.push(parent.compose(&body.origin).compose(&motion));
        }
        frames
    }

    /// Every pair of bodies (and every body and the floor) closer than `clearance` metres at
    /// `values` (robot order, joint units), the nearest pair of shapes of each; a negative
    /// distance is a penetration.
    pub fn touches(&self, values: &[f64], clearance: f64) -> Vec<Touch> {
        let placed = self.placed(values);
        (0..self.pairs.len())
            .filter_map(|p| {
                let d = self.pair_distance(&placed, p);
                (d < clearance).then(|| self.touch_of(p, d))
            })
            .collect()
    }

    /// Every geom's core in the world and its radius at `values`.
    pub(crate) fn placed(&self, values: &[f64]) -> Vec<(Core, f64)> {
        let frames = self.frames(values);
        self.geoms
            .iter()
            .map(|g| g.shape.placed(&frames[g.body]))
            .collect()
    }

    /// The pairs checked, as [`CollisionModel::pair_distance`] numbers them.
    pub(crate) fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// The signed distance of pair `p` (metres, negative inside), its geoms `placed`: the
    /// nearest of its shapes.
    pub(crate) fn pair_distance(&self, placed: &[(Core, f64)], p: usize) -> f64 {
        let Pair { a, b } = self.pairs[p];
        let mut least = f64::INFINITY;
        for &ga in &self.body_geoms[a] {
            let (core_a, radius_a) = &placed[ga];
            match b {
                None => least = least.min(core_a.lowest() - radius_a),
                Some(b) => {
                    for &gb in &self.body_geoms[b] {
                        let (core_b, radius_b) = &placed[gb];
                        let d = gjk::signed_distance(core_a, core_b) - radius_a - radius_b;
                        least = least.min(d);
                    }
                }
            }
        }
        least
    }

    /// How far any point of pair `p`'s bodies can come towards each other when each joint
    /// changes by at most `deviation` (robot order, joint units), metres: both bodies' reach
    /// under the joints they do not share (the floor does not move).
    pub(crate) fn pair_reach(&self, p: usize, deviation: &[f64]) -> f64 {
        self.reach[p].displacement(deviation)
    }

    /// The pairs MuJoCo checks: two bodies, not both fixed to the world, neither the other's
    /// parent, not excluded.
    fn checked(&self, a: usize, b: usize) -> bool {
        let (x, y) = (&self.bodies[a], &self.bodies[b]);
        a != b
            && !(x.fixed && y.fixed)
            && x.parent != Some(b)
            && y.parent != Some(a)
            && !self.skipped.contains(&(a.min(b), a.max(b)))
    }

    /// Pair `p` at distance `distance`, as a [`Touch`].
    pub(crate) fn touch_of(&self, p: usize, distance: f64) -> Touch {
        let Pair { a, b } = self.pairs[p];
        let kind = match b {
            None => TouchKind::Floor,
            Some(b) if self.bodies[b].arm == self.bodies[a].arm => TouchKind::SelfCollision,
            Some(_) => TouchKind::BetweenArms,
        };
        Touch {
            kind,
            bodies: (
                self.bodies[a].name.clone(),
                b.map(|b| self.bodies[b].name.clone()),
            ),
            links: (
                self.bodies[a].link.clone(),
                b.map(|b| self.bodies[b].link.clone()),
            ),
            distance,
        }
    }

    /// Why moving from `from` to `to` (robot order, joint units) is refused: a contact
    /// anywhere along the way that `from` does not have, or one that goes deeper. The way is
    /// the straight line in joint space a jog and the player's approach ramp take, certified
    /// along its whole length (`sweep`), so that a wrist swung through the floor is refused
    /// although both ends are clear. A pose already in contact can still be left.
    pub fn refusal(&self, from: &[f64], to: &[f64]) -> Option<Touch> {
        let before: Vec<f64> = {
            let placed = self.placed(from);
            (0..self.pairs.len())
                .map(|p| self.pair_distance(&placed, p))
                .collect()
        };
        let line = sweep::Line { from, to };
        let resolution = sweep::Resolution {
            clearance: 0.0,
            contact: LINE_RESOLUTION,
            finest: LINE_FINEST,
        };
        sweep::sweep(self, &line, 0.0, 1.0, resolution)
            .into_iter()
            .find(|near| {
                let start = before[near.pair];
                // A pair touching at the start may stay as deep or part; a bound that cannot
                // be cleared beside it is that contact, not a new one.
                start >= 0.0 || (near.certain && near.distance < start - DEEPER)
            })
            .map(|near| self.touch_of(near.pair, near.distance))
    }
}

/// How finely a refused move's contact is located, as a share of the move.
const LINE_RESOLUTION: f64 = 1e-3;

/// The narrowest share of a move halved to certify it clear: below it what cannot be cleared
/// is refused.
const LINE_FINEST: f64 = 1e-7;

/// How much deeper an existing contact may go before a move into it is refused, metres:
/// rounding, not a tolerance for collisions.
const DEEPER: f64 = 1e-6;

fn to_model(kind: JointKind, value: f64) -> f64 {
    match kind {
        JointKind::Revolute => value.to_radians(),
        JointKind::Prismatic => value,
    }
}

fn from_model(kind: JointKind, value: f64) -> f64 {
    match kind {
        JointKind::Revolute => value.to_degrees(),
        JointKind::Prismatic => value,
    }
}

/// A joint's motion by `value` in joint units.
fn moved(kind: JointKind, axis: DVec3, value: f64) -> RigidTransform {
    match kind {
        JointKind::Revolute => RigidTransform::new(
            DVec3::ZERO,
            glam::DQuat::from_axis_angle(axis, value.to_radians()),
        ),
        JointKind::Prismatic => RigidTransform::new(axis * value, glam::DQuat::IDENTITY),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At home no built-in arm touches anything (its models are drawn apart at home).
    #[test]
    fn no_built_in_arm_touches_anything_at_home() {
        for name in crate::robot::BUILTIN_NAMES {
            let robot = Robot::builtin(name).unwrap();
            let model = CollisionModel::for_robot(&robot).unwrap();
            let home = vec![0.0; robot.joints.len()];
            assert_eq!(model.touches(&home, 0.0), vec![], "{name}");
        }
    }

    /// The SO-101's shoulder lift at −100° (its limit) folds the arm down: with the elbow
    /// stretched the upper arm's capsule reaches below the desk.
    #[test]
    fn a_folded_arm_touches_the_floor_and_is_refused_but_may_leave() {
        let robot = Robot::builtin("so101").unwrap();
        let model = CollisionModel::for_robot(&robot).unwrap();
        let home = vec![0.0; 6];
        let mut down = home.clone();
        down[1] = 100.0;
        let touches = model.touches(&down, 0.0);
        assert!(
            touches.iter().any(|t| t.kind == TouchKind::Floor),
            "{touches:?}"
        );
        assert!(model.refusal(&home, &down).is_some());
        assert!(model.refusal(&down, &home).is_none(), "leaving is allowed");
    }

    /// The SO-101 with its elbow at 30°: the wrist swung from −85.5° to +85.5° points the
    /// gripper at the desk on the way (at about 38°), though at both ends it is clear. The
    /// move is refused, on the floor, and each half that stops short of the desk is not.
    #[test]
    fn a_move_through_a_contact_is_refused_though_both_ends_are_clear() {
        let robot = Robot::builtin("so101").unwrap();
        let model = CollisionModel::for_robot(&robot).unwrap();
        let pose = |wrist: f64| vec![0.0, 0.0, 30.0, wrist, 0.0, 0.0];
        let (from, to) = (pose(-85.5), pose(85.5));
        assert_eq!(model.touches(&from, 0.0), vec![]);
        assert_eq!(model.touches(&to, 0.0), vec![]);
        let on_the_way = model.touches(&pose(38.0), 0.0);
        assert!(
            on_the_way.iter().any(|t| t.kind == TouchKind::Floor),
            "{on_the_way:?}"
        );
        let refused = model.refusal(&from, &to).expect("refused");
        assert_eq!(refused.kind, TouchKind::Floor, "{}", refused.describe());
        assert!(model.refusal(&from, &pose(20.0)).is_none());
    }
}
