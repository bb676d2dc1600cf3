//! Choosing among the many solutions of one tool key as a person would.
//!
//! A position alone (or a position with only an approach direction) leaves a 5-joint arm one or
//! two degrees of freedom: the tool pitch and the roll, on each of up to four branches. The
//! nearest solution to the previous pose is what a jog wants (the arm moves least), but as a
//! key it often sits on a hard stop or inside the arm itself. A key is chosen here instead:
//!
//! 1. **Acceptable**: inside the limits, above the floor, and clear of the floor and of the arm
//!    itself by [`CLEARANCE_M`] in the robot's collision model ([`CollisionModel`], the shapes of
//!    its simulation model; a robot without one is checked against the floor by its skeleton
//!    only).
//! 2. **Comfortable first**: the smallest *normalised margin* of the joints solved — each one's
//!    distance to its nearer limit over half its range, 1 in the middle, 0 on a stop — is raised
//!    to [`COMFORT`] where any acceptable solution reaches it, and as high as it goes where none
//!    does.
//! 3. **Then continuity**: among those, the nearest to the seed (the previous key's pose along
//!    a sequence, the arm's present pose, or home), so consecutive keys keep their branch.
//!
//! Steps 2 and 3 are one cost, [`Scorer::cost`]: the shortfall below [`COMFORT`] weighted so
//! that a tenth of a degree of margin outweighs any joint distance, plus the joint distance.

use super::{comparable_unit, joint_distance, lowest_below_floor};
use crate::collision::{CollisionModel, Touch};
use crate::robot::Robot;

/// The normalised margin a key keeps on every joint it solves when it can: a quarter of the
/// half range, so 25° from either stop of the SO-101's ±100° shoulder and 24° of its elbow.
/// Above it, nearness to the previous key decides.
pub const COMFORT: f64 = 0.25;

/// How far a key's pose keeps every part of the arm from the floor and from the arm's other
/// parts, metres: the collision model is the simulation model's shapes, and `pose` and `sim`
/// count contacts from 0.5 mm deep, so a key this clear never shows up there.
pub const CLEARANCE_M: f64 = 0.001;

/// Cost of one unit of normalised margin short of [`COMFORT`], in degrees of joint distance:
/// 10⁵ makes 0.001 of margin (0.1° on a ±100° joint) outweigh a hundred degrees of distance.
const SHORTFALL_WEIGHT: f64 = 1.0e5;

/// A pose's smallest margin to the joint limits, among the joints solved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margin {
    /// The joint with the smallest normalised margin (index in the robot).
    pub joint: usize,
    /// Its distance to the nearer limit, in the joint's unit (degrees, metres).
    pub value: f64,
    /// That distance over half the joint's range: 1 in the middle, 0 on a stop.
    pub share: f64,
}

/// The smallest normalised margin of `values` among the joints marked in `solved`; None when
/// none is marked.
pub fn smallest_margin(robot: &Robot, values: &[f64], solved: &[bool]) -> Option<Margin> {
    robot
        .joints
        .iter()
        .zip(values)
        .enumerate()
        .filter(|(i, _)| solved[*i])
        .map(|(i, (joint, &v))| {
            let value = (v - joint.limits.min).min(joint.limits.max - v);
            let half = 0.5 * (joint.limits.max - joint.limits.min);
            let share = if half > 0.0 { value / half } else { 0.0 };
            Margin {
                joint: i,
                value,
                share,
            }
        })
        .min_by(|a, b| a.share.total_cmp(&b.share))
}

/// What a key prefers: near the seed, comfortable on the joints it solves.
#[derive(Debug, Clone)]
pub(crate) struct Scorer<'a> {
    robot: &'a Robot,
    seed: &'a [f64],
    solved: Vec<bool>,
}

impl<'a> Scorer<'a> {
    /// The preference of a key solved from `seed`, the joints marked in `solved` free.
    pub(crate) fn new(robot: &'a Robot, seed: &'a [f64], solved: Vec<bool>) -> Self {
        Scorer {
            robot,
            seed,
            solved,
        }
    }

    /// The joints the key solves.
    pub(crate) fn solved(&self) -> &[bool] {
        &self.solved
    }

    /// Whether `values` keep every joint solved at least [`COMFORT`] from its limits.
    pub(crate) fn comfortable(&self, values: &[f64]) -> bool {
        smallest_margin(self.robot, values, &self.solved).is_none_or(|m| m.share >= COMFORT)
    }

    /// Lower is better: the margin's shortfall below [`COMFORT`] first, then the distance from
    /// the seed (degrees; millimetres for a prismatic joint).
    pub(crate) fn cost(&self, values: &[f64]) -> f64 {
        let share = smallest_margin(self.robot, values, &self.solved).map_or(1.0, |m| m.share);
        let shortfall = (COMFORT - share).max(0.0);
        SHORTFALL_WEIGHT * shortfall + joint_distance(self.robot, values, self.seed).sqrt()
    }
}

/// Whether `values` keep clear of the floor and of the arm itself; the nearest contact when not.
pub(crate) fn contact(
    robot: &Robot,
    collision: Option<&CollisionModel>,
    values: &[f64],
) -> Option<Touch> {
    match collision {
        Some(model) => model
            .touches(values, CLEARANCE_M)
            .into_iter()
            .min_by(|a, b| a.distance.total_cmp(&b.distance)),
        None => lowest_below_floor(robot, values).map(|(part, depth)| Touch {
            kind: crate::collision::TouchKind::Floor,
            bodies: (part.clone(), None),
            links: (part, None),
            distance: -depth,
        }),
    }
}

/// Of `candidates`, cheapest first, the first that is clear ([`contact`]); or, when none is,
/// the contact of the one that touches least (for the error to name).
pub(crate) fn first_clear<T>(
    robot: &Robot,
    collision: Option<&CollisionModel>,
    candidates: Vec<T>,
    values: impl Fn(&T) -> &[f64],
    cost: impl Fn(&T) -> f64,
) -> Result<T, Option<Touch>> {
    let mut scored: Vec<(f64, T)> = candidates.into_iter().map(|c| (cost(&c), c)).collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut least: Option<Touch> = None;
    for (_, candidate) in scored {
        match contact(robot, collision, values(&candidate)) {
            None => return Ok(candidate),
            Some(touch) => {
                if least.as_ref().is_none_or(|l| touch.distance > l.distance) {
                    least = Some(touch);
                }
            }
        }
    }
    Err(least)
}

/// Two solutions closer than this on every joint are the same one (degrees; a tenth of a
/// millimetre on a prismatic joint): the general solver reaches one from several starts.
const SAME_DEG: f64 = 0.01;

/// `candidates` without repeats (within [`SAME_DEG`] on every joint), first kept.
pub(crate) fn distinct(robot: &Robot, candidates: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let mut kept: Vec<Vec<f64>> = Vec::with_capacity(candidates.len());
    for c in candidates {
        let seen = kept.iter().any(|k| {
            robot
                .joints
                .iter()
                .zip(k.iter().zip(&c))
                .all(|(j, (a, b))| ((a - b) * comparable_unit(j.kind)).abs() < SAME_DEG)
        });
        if !seen {
            kept.push(c);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SO-101 limits: shoulder_lift ±100°, so −75° is 25° from its stop: a share of 0.25;
    /// elbow_flex ±96.83°, so 90° is 6.83° away: 0.0705, the smallest.
    #[test]
    fn the_smallest_margin_is_worked_out_per_half_range() {
        let robot = Robot::builtin("so101").unwrap();
        let values = [0.0, -75.0, 90.0, 0.0, 0.0, 0.0];
        let solved = [true, true, true, true, true, false];
        let m = smallest_margin(&robot, &values, &solved).unwrap();
        assert_eq!(m.joint, 2);
        assert!((m.value - 6.83).abs() < 1e-9, "{m:?}");
        assert!((m.share - 6.83 / 96.83).abs() < 1e-12, "{m:?}");
        let without_elbow = [true, true, false, true, true, false];
        let m = smallest_margin(&robot, &values, &without_elbow).unwrap();
        assert_eq!((m.joint, m.share), (1, 0.25));
    }

    /// A comfortable pose far from the seed costs less than a near one on a stop.
    #[test]
    fn comfort_outweighs_distance() {
        let robot = Robot::builtin("so101").unwrap();
        let seed = vec![0.0; 6];
        let scorer = Scorer::new(&robot, &seed, vec![true, true, true, true, true, false]);
        let on_the_stop = [0.0, -100.0, 0.0, 0.0, 0.0, 0.0];
        let comfortable = [60.0, -60.0, 60.0, 60.0, 60.0, 0.0];
        assert!(scorer.cost(&comfortable) < scorer.cost(&on_the_stop));
        // Both comfortable: the nearer wins.
        let nearer = [10.0, -10.0, 0.0, 0.0, 0.0, 0.0];
        assert!(scorer.cost(&nearer) < scorer.cost(&comfortable));
    }
}
