//! How far a body's points can move when the joints change: the bound that makes the clearance
//! check certified rather than sampled (`sweep`).
//!
//! A joint K above body b (or b's own) turns b's points about an axis through K's frame
//! origin, so a turn by Δθ moves each point by at most Δθ times its distance from that origin.
//! That distance is bounded in every pose by the chain itself: the lengths of the body
//! origins from K down to b, the travel of any prismatic joint on the way, and the farthest
//! point of b's shapes from b's own origin. A prismatic joint moves every point below it by
//! its own change. Summed over the joints, this bounds how far any point of b moves between
//! two poses, whatever the order the joints move in: `Σ_K lever_K · |Δq_K|`.
//!
//! Two bodies of one chain move together under every joint they share: their distance depends
//! only on the joints below the last body they share. So a pair's bound sums the two bodies'
//! levers of those joints alone (`pair_levers`), which is what makes a wrist and its own
//! gripper, a handful of millimetres apart, certifiable while the shoulder swings.

use super::mjcf::Shape;
use super::{CollisionModel, Motion};
use crate::robot::{JointKind, Robot};

/// One body's coefficients: metres its points can move per unit (degree or metre) of each
/// robot joint's change.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Reach {
    /// One entry per moving body from this one up to its root.
    levers: Vec<Lever>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Lever {
    /// The robot joint that moves `body`.
    joint: usize,
    /// The body it moves (this body or an ancestor).
    body: usize,
    /// Metres per joint unit.
    metres: f64,
}

/// A pair's coefficients: (robot joint, metres per joint unit) of every joint that changes the
/// pair's distance.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct PairReach(Vec<(usize, f64)>);

impl PairReach {
    /// How far the pair's bodies can come towards each other when joint `j` changes by at
    /// most `deviation[j]`, metres.
    pub(super) fn displacement(&self, deviation: &[f64]) -> f64 {
        self.0.iter().map(|&(j, m)| m * deviation[j].abs()).sum()
    }
}

/// The coefficients of the pair of `a` and `b` (`None`: the floor), the levers of bodies both
/// share left out.
pub(super) fn pair_levers(reach: &[Reach], a: usize, b: Option<usize>) -> PairReach {
    let shared = |lever: &Lever, other: Option<usize>| {
        other.is_some_and(|o| reach[o].levers.iter().any(|l| l.body == lever.body))
    };
    let mut out: Vec<(usize, f64)> = Vec::new();
    let mut take = |body: usize, other: Option<usize>| {
        for lever in reach[body].levers.iter().filter(|l| !shared(l, other)) {
            add(&mut out, lever.joint, lever.metres);
        }
    };
    take(a, b);
    if let Some(b) = b {
        take(b, Some(a));
    }
    PairReach(out)
}

/// The reach of every body of `model`, whose joints are `robot`'s.
pub(super) fn of_bodies(model: &CollisionModel, robot: &Robot) -> Vec<Reach> {
    let radius: Vec<f64> = (0..model.bodies.len())
        .map(|b| {
            model.body_geoms[b]
                .iter()
                .map(|&g| farthest_point(&model.geoms[g].shape))
                .fold(0.0, f64::max)
        })
        .collect();
    (0..model.bodies.len())
        .map(|b| body_reach(model, robot, b, radius[b]))
        .collect()
}

/// The farthest point of a shape from its body's origin, metres.
fn farthest_point(shape: &Shape) -> f64 {
    match *shape {
        Shape::Swept { a, b, radius } => a.length().max(b.length()) + radius,
        Shape::Box { frame, half } => frame.t.length() + half.length(),
    }
}

/// Body `b`'s reach: every moving body from `b` up to its root contributes its joint.
fn body_reach(model: &CollisionModel, robot: &Robot, b: usize, radius: f64) -> Reach {
    let mut levers: Vec<Lever> = Vec::new();
    // The distance from the current body's frame origin to b's farthest point, bounded: it
    // grows by each body origin's length (and a prismatic joint's travel) on the way up.
    let mut below = radius;
    let mut k = Some(b);
    while let Some((at, body)) = k.map(|i| (i, &model.bodies[i])) {
        let joint = match body.motion {
            Motion::Fixed => None,
            Motion::Joint { index, kind, .. } => Some((index, kind, 1.0, 0.0)),
            Motion::Mimic {
                index,
                kind,
                offset,
                scale,
                ..
            } => Some((index, kind, scale.abs(), offset.abs())),
        };
        if let Some((index, kind, scale, offset)) = joint {
            let lever = match kind {
                // A turn of one degree of the robot's joint is `scale` degrees of the body's.
                JointKind::Revolute => below * scale * 1f64.to_radians(),
                JointKind::Prismatic => scale,
            };
            levers.push(Lever {
                joint: index,
                body: at,
                metres: lever,
            });
            if kind == JointKind::Prismatic {
                below += travel(robot, index, scale, offset);
            }
        }
        below += body.origin.t.length();
        k = body.parent;
    }
    Reach { levers }
}

/// The largest translation a prismatic joint following robot joint `index` makes (its
/// limits, scaled as the model's mimic scales them), metres.
fn travel(robot: &Robot, index: usize, scale: f64, offset: f64) -> f64 {
    robot.joints.get(index).map_or(0.0, |joint| {
        offset + scale * joint.limits.min.abs().max(joint.limits.max.abs())
    })
}

fn add(levers: &mut Vec<(usize, f64)>, index: usize, lever: f64) {
    match levers.iter_mut().find(|(j, _)| *j == index) {
        Some(entry) => entry.1 += lever,
        None => levers.push((index, lever)),
    }
}

#[cfg(test)]
mod tests {
    use crate::collision::CollisionModel;
    use crate::robot::Robot;
    use proptest::prelude::*;

    /// Two poses of `robot` from shares of each joint's range.
    fn poses(robot: &Robot, shares: &[(f64, f64)]) -> (Vec<f64>, Vec<f64>) {
        let at = |j: &crate::robot::Joint, u: f64| j.limits.min + (j.limits.max - j.limits.min) * u;
        robot
            .joints
            .iter()
            .zip(shares)
            .map(|(j, &(a, b))| (at(j, a), at(j, b)))
            .unzip()
    }

    proptest! {
        /// The bound holds: between any two poses, no pair of parts apart at both comes closer
        /// or parts by more than the reach the joints' changes allow (the geometry is the
        /// oracle: the distances are measured at both poses).
        #[test]
        fn no_pair_distance_changes_by_more_than_its_reach(
            robot in 0..crate::robot::BUILTIN_NAMES.len(),
            shares in proptest::collection::vec((0.0..1.0f64, 0.0..1.0f64), 8),
        ) {
            let robot = Robot::builtin(crate::robot::BUILTIN_NAMES[robot]).unwrap();
            let model = CollisionModel::for_robot(&robot).unwrap();
            let (from, to) = poses(&robot, &shares);
            let change: Vec<f64> = from.iter().zip(&to).map(|(a, b)| b - a).collect();
            let (pa, pb) = (model.placed(&from), model.placed(&to));
            for p in 0..model.pairs().len() {
                let (da, db) = (model.pair_distance(&pa, p), model.pair_distance(&pb, p));
                // Penetration depths are not distances: the bound is for poses apart, which is
                // what the check certifies.
                if da > 0.0 && db > 0.0 {
                    let reach = model.pair_reach(p, &change);
                    prop_assert!((db - da).abs() <= reach + 1e-12, "pair {p}: {da} → {db}, reach {reach}");
                }
            }
        }
    }
}
