//! Tool keys solved as a person would ([`Solver::solve_key`]): of the solutions of a key, one
//! clear of the floor and of the arm itself, with margins to the limits, near the previous key
//! (the rule is `choice`'s); with an approach direction ("down"), one pointing the tool that
//! way, or the least tilted from it when the key allows a tilt. [`Solver::solve`] stays the
//! nearest solution to its seed, which is what a jog wants.

use super::choice::{contact, distinct, first_clear, smallest_margin, Margin, Scorer};
use super::closed_form::ArmGeometry;
use super::families::{self, Member};
use super::{
    approach_axis, orientation_residual_deg, tool_joints, IkError, Solution, Solver, ToolTarget,
};
use crate::collision::{CollisionModel, Touch};
use crate::robot::Robot;
use glam::{DQuat, DVec3};

/// What a tool key says of the tool's orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KeyOrientation {
    /// Nothing: the key is chosen comfortable and near the previous one.
    Free,
    /// The whole orientation (base frame), met as closely as the arm allows.
    Full(DQuat),
    /// Only which way the tool points.
    Approach(Approach),
}

/// Which way the tool should point: its approach axis ([`approach_axis`]: from the wrist towards
/// the fingertips) along a direction; the turn about that axis is left free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// Unit direction, base frame.
    pub direction: DVec3,
    /// Whether a tilted tool is accepted where the direction cannot be met: then the least tilt
    /// that can, in whole degrees, or up to 5° more where that keeps the joints further from
    /// their limits. Otherwise that is an error.
    pub or_tilted: bool,
}

impl Approach {
    /// Straight down (−z of the base frame): the gripper over what it picks.
    pub fn down(or_tilted: bool) -> Approach {
        Approach {
            direction: DVec3::NEG_Z,
            or_tilted,
        }
    }

    /// "down", or the direction's components.
    pub fn name(&self) -> String {
        if self.direction == DVec3::NEG_Z {
            "down".into()
        } else {
            let d = self.direction;
            format!("along ({:.3}, {:.3}, {:.3})", d.x, d.y, d.z)
        }
    }
}

/// A tool key's target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyTarget {
    /// Where the tool frame (the robot's `tcp`) goes, base frame, metres.
    pub position: DVec3,
    /// What the key says of the orientation.
    pub orientation: KeyOrientation,
}

/// What a key is solved from and must keep clear of.
#[derive(Debug, Clone, Copy)]
pub struct Preference<'a> {
    /// The pose the key stays near (every joint, robot order): the previous key's along a
    /// sequence, the arm's present pose, or home.
    pub seed: &'a [f64],
    /// Joints the key gives itself: they keep the seed's values.
    pub held: &'a [bool],
    /// The arm's shapes, for contacts with the floor and itself; None checks the floor by the
    /// arm's skeleton only (a robot file without a built-in model).
    pub collision: Option<&'a CollisionModel>,
}

/// The solution chosen for a key.
#[derive(Debug, Clone, PartialEq)]
pub struct Chosen {
    /// The joints, and the orientation residual when the key gave a full orientation.
    pub solution: Solution,
    /// The smallest margin to the limits among the joints solved.
    pub margin: Option<Margin>,
    /// How far the approach axis is from the direction asked, degrees (with an approach).
    pub tilt_deg: Option<f64>,
}

/// A tilt of the approach this small is the direction met, degrees.
const APPROACH_EXACT_DEG: f64 = 0.1;
/// The largest tilt from an approach direction looked at, degrees.
const MAX_TILT_DEG: u32 = 90;
/// Degrees of tilt beyond the least that a tilted approach may spend on margins to the limits.
const TILT_SLACK_DEG: u32 = 5;
/// Orientation residuals this close count as equal, degrees (as the closed form's choice).
const RESIDUAL_TIE_DEG: f64 = 0.05;
/// Turns about the approach direction the general solver tries, degrees apart.
const APPROACH_TURN_STEP_DEG: f64 = 30.0;

/// Why a key found no solution.
enum Unmet {
    /// None inside the limits and above the floor.
    Nothing,
    /// Every one touches; the one touching least.
    Touches(Touch),
    /// The approach direction cannot be met; the least tilt that can, whole degrees.
    Tilt(Option<u32>),
}

impl From<Option<Touch>> for Unmet {
    fn from(touch: Option<Touch>) -> Self {
        touch.map_or(Unmet::Nothing, Unmet::Touches)
    }
}

impl Solver {
    /// The joints for a tool key, chosen as a person would (module doc): clear of the floor
    /// and of the arm itself, with margins to the limits, near `preference.seed`. A key that
    /// gives a tool joint itself (`held`) is solved by the general solver from several starts.
    pub fn solve_key(
        &self,
        robot: &Robot,
        target: &KeyTarget,
        preference: &Preference,
    ) -> Result<Chosen, IkError> {
        let tool = tool_joints(robot);
        let solved: Vec<bool> = (0..tool.len())
            .map(|i| tool[i] && !preference.held.get(i).copied().unwrap_or(false))
            .collect();
        let holds_a_tool_joint = solved != tool;
        let scorer = Scorer::new(robot, preference.seed, solved);
        let closed = match self {
            Solver::ClosedForm(geometry) if !holds_a_tool_joint => Some(geometry.as_ref()),
            _ => None,
        };
        let key = Key {
            robot,
            position: target.position,
            scorer: &scorer,
            preference,
        };
        let found = match target.orientation {
            KeyOrientation::Free => key.free(closed),
            KeyOrientation::Full(wanted) => key.oriented(closed, wanted),
            KeyOrientation::Approach(approach) => {
                let Some(axis) = approach_axis(robot) else {
                    return Err(IkError::NoApproachAxis {
                        robot: robot.name.clone(),
                    });
                };
                key.approach(closed, axis, approach)
            }
        };
        let values = match found {
            Ok(values) => values,
            Err(unmet) => return Err(self.unmet(robot, target, preference, unmet)),
        };
        let frame = robot.tcp_frame(&values);
        let orientation_residual_deg = match target.orientation {
            KeyOrientation::Full(wanted) => Some(orientation_residual_deg(frame.r, wanted)),
            _ => None,
        };
        let tilt_deg = match target.orientation {
            KeyOrientation::Approach(a) => approach_axis(robot).map(|axis| tilt(frame.r, axis, a)),
            _ => None,
        };
        Ok(Chosen {
            margin: smallest_margin(robot, &values, scorer.solved()),
            solution: Solution {
                values,
                orientation_residual_deg,
            },
            tilt_deg,
        })
    }

    /// The error for a key that found nothing acceptable.
    fn unmet(
        &self,
        robot: &Robot,
        target: &KeyTarget,
        preference: &Preference,
        unmet: Unmet,
    ) -> IkError {
        match unmet {
            Unmet::Touches(touch) => IkError::Collides {
                target: target.position,
                touch: touch.describe(),
            },
            Unmet::Tilt(least_tilt_deg) => IkError::ApproachOutOfReach {
                target: target.position,
                direction: match target.orientation {
                    KeyOrientation::Approach(a) => a.name(),
                    _ => String::new(),
                },
                least_tilt_deg,
            },
            Unmet::Nothing => {
                let asked = ToolTarget {
                    position: target.position,
                    orientation: match target.orientation {
                        KeyOrientation::Full(q) => Some(q),
                        _ => None,
                    },
                };
                self.explain_failure(robot, &asked, preference.seed, preference.held)
            }
        }
    }
}

/// The angle between the tool's approach axis (`axis`, tool frame) at orientation `tool` and the
/// direction asked, degrees.
fn tilt(tool: DQuat, axis: DVec3, approach: Approach) -> f64 {
    (tool * axis).angle_between(approach.direction).to_degrees()
}

/// One key being solved.
struct Key<'a> {
    robot: &'a Robot,
    position: DVec3,
    scorer: &'a Scorer<'a>,
    preference: &'a Preference<'a>,
}

impl Key<'_> {
    fn seed(&self) -> &[f64] {
        self.preference.seed
    }

    fn collision(&self) -> Option<&CollisionModel> {
        self.preference.collision
    }

    /// A position alone: the closed form's families on the pitch grid (with the seed's roll,
    /// then every roll when that leaves the key short of comfort), or the general solver's
    /// solutions from its starts.
    fn free(&self, closed: Option<&ArmGeometry>) -> Result<Vec<f64>, Unmet> {
        let Some(geometry) = closed else {
            let target = ToolTarget::position(self.position);
            let found = self.general(&target);
            return self.cheapest_clear(found);
        };
        let seed_pitch = geometry.tool_pitch(self.seed());
        let mut outcome = Err(Unmet::Nothing);
        for all_rolls in rolls_to_try(geometry) {
            let rolls = families::rolls(geometry, self.robot, self.seed(), all_rolls);
            let found = families::members(
                geometry,
                self.robot,
                self.position,
                &rolls,
                self.seed(),
                |plane| families::free_pitches(plane, seed_pitch),
            );
            outcome = self.cheapest_member(geometry, found);
            if outcome
                .as_ref()
                .is_ok_and(|values| self.scorer.comfortable(values))
            {
                break;
            }
        }
        outcome
    }

    /// A full orientation: the solutions clear of contacts, the best oriented of them (within
    /// [`RESIDUAL_TIE_DEG`]), the cheapest of those.
    fn oriented(&self, closed: Option<&ArmGeometry>, wanted: DQuat) -> Result<Vec<f64>, Unmet> {
        let found: Vec<(Vec<f64>, f64)> = match closed {
            Some(geometry) => {
                geometry.oriented_solutions(self.robot, self.position, wanted, self.seed(), true)
            }
            None => self
                .general(&ToolTarget::pose(self.position, wanted))
                .into_iter()
                .map(|values| {
                    let reached = self.robot.tcp_frame(&values).r;
                    let residual = orientation_residual_deg(reached, wanted).length();
                    (values, residual)
                })
                .collect(),
        };
        self.best_scored(found, RESIDUAL_TIE_DEG)
    }

    /// An approach direction: the solutions pointing the tool that way, the cheapest clear one;
    /// where there is none, the least tilt (in whole degrees) at which there is one, taken
    /// when the key allows it and reported otherwise. The seed's roll is kept where any tilt
    /// works with it (a roll turns the jaws about the approach, which matters to a grasp more
    /// than a degree of tilt); other rolls are tried after.
    fn approach(
        &self,
        closed: Option<&ArmGeometry>,
        axis: DVec3,
        approach: Approach,
    ) -> Result<Vec<f64>, Unmet> {
        let at = |degrees: u32, all_rolls: bool| match closed {
            Some(geometry) => self.approach_closed(geometry, axis, approach, degrees, all_rolls),
            None => self.approach_general(axis, approach, degrees),
        };
        for all_rolls in [false, true] {
            let exact = at(0, all_rolls);
            if exact.is_ok() {
                return exact;
            }
        }
        for all_rolls in [false, true] {
            let Some(least) = (1..=MAX_TILT_DEG).find(|&d| at(d, all_rolls).is_ok()) else {
                continue;
            };
            if !approach.or_tilted {
                return Err(Unmet::Tilt(Some(least)));
            }
            // The least tilt puts some joint on the edge of what works (often a limit): a few
            // degrees more buy the margins, as far as the cost wants them.
            let tilts = least..=(least + TILT_SLACK_DEG).min(MAX_TILT_DEG);
            return tilts
                .filter_map(|d| at(d, all_rolls).ok())
                .min_by(|a, b| self.scorer.cost(a).total_cmp(&self.scorer.cost(b)))
                .ok_or(Unmet::Nothing);
        }
        // Not within 90° of the direction: say so where the position itself has a key, else
        // why it has none.
        match self.free(closed) {
            Ok(_) => Err(Unmet::Tilt(None)),
            Err(unmet) => Err(unmet),
        }
    }

    /// The closed form's members tilted `degrees` from the approach (either way), with the
    /// seed's roll or every roll; the cheapest clear one.
    fn approach_closed(
        &self,
        geometry: &ArmGeometry,
        axis: DVec3,
        approach: Approach,
        degrees: u32,
        all_rolls: bool,
    ) -> Result<Vec<f64>, Unmet> {
        let rolls = families::rolls(geometry, self.robot, self.seed(), all_rolls);
        let found = families::approach_members(
            geometry,
            self.robot,
            self.position,
            &rolls,
            self.seed(),
            (axis, approach.direction),
            f64::from(degrees).to_radians(),
        );
        self.cheapest_clear(found.into_iter().map(|m| m.values).collect())
    }

    /// The general solver's solutions for the tool orientations that point the approach axis
    /// `degrees` off the direction, turned about it every [`APPROACH_TURN_STEP_DEG`]; those
    /// reached within [`APPROACH_EXACT_DEG`] of that tilt, the cheapest clear one.
    fn approach_general(
        &self,
        axis: DVec3,
        approach: Approach,
        degrees: u32,
    ) -> Result<Vec<f64>, Unmet> {
        let pointing = DQuat::from_rotation_arc(axis, approach.direction);
        let side = approach.direction.any_orthonormal_vector();
        let tilted = DQuat::from_axis_angle(side, f64::from(degrees).to_radians()) * pointing;
        let turns = (360.0 / APPROACH_TURN_STEP_DEG) as u32;
        let found: Vec<Vec<f64>> = (0..turns)
            .flat_map(|k| {
                let turn = f64::from(k) * APPROACH_TURN_STEP_DEG.to_radians();
                let wanted = DQuat::from_axis_angle(approach.direction, turn) * tilted;
                self.general(&ToolTarget::pose(self.position, wanted))
            })
            .filter(|values| {
                let reached = tilt(self.robot.tcp_frame(values).r, axis, approach);
                (reached - f64::from(degrees)).abs() < APPROACH_EXACT_DEG
            })
            .collect();
        self.cheapest_clear(distinct(self.robot, found))
    }

    /// The general solver's solutions from its starts, without repeats.
    fn general(&self, target: &ToolTarget) -> Vec<Vec<f64>> {
        let dls = super::dls::Dls::new(self.robot);
        let found = dls.solutions(self.robot, target, self.seed(), self.preference.held);
        distinct(self.robot, found)
    }

    /// The cheapest of `found` that is clear.
    fn cheapest_clear(&self, found: Vec<Vec<f64>>) -> Result<Vec<f64>, Unmet> {
        first_clear(
            self.robot,
            self.collision(),
            found,
            |v| v,
            |v| self.scorer.cost(v),
        )
        .map_err(Unmet::from)
    }

    /// The cheapest clear member, refined along its family (kept only if it is clear too).
    fn cheapest_member(
        &self,
        geometry: &ArmGeometry,
        found: Vec<Member>,
    ) -> Result<Vec<f64>, Unmet> {
        let best = first_clear(
            self.robot,
            self.collision(),
            found,
            |m| &m.values,
            |m| self.scorer.cost(&m.values),
        )
        .map_err(Unmet::from)?;
        let cost = |values: &[f64]| self.scorer.cost(values);
        let refined = families::refine(
            geometry,
            self.robot,
            self.position,
            &best,
            self.seed(),
            cost,
        );
        let clear = contact(self.robot, self.collision(), &refined.values).is_none();
        Ok(if clear { refined.values } else { best.values })
    }

    /// Of solutions scored by a residual, those clear of contacts, the lowest residual of them
    /// within `tie`, the cheapest of those.
    fn best_scored(&self, found: Vec<(Vec<f64>, f64)>, tie: f64) -> Result<Vec<f64>, Unmet> {
        let mut least: Option<Touch> = None;
        let mut clear = Vec::with_capacity(found.len());
        for (values, residual) in found {
            match contact(self.robot, self.collision(), &values) {
                None => clear.push((values, residual)),
                Some(touch) => {
                    if least.as_ref().is_none_or(|l| touch.distance > l.distance) {
                        least = Some(touch);
                    }
                }
            }
        }
        let best = clear.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
        clear
            .into_iter()
            .filter(|c| c.1 <= best + tie)
            .map(|c| c.0)
            .min_by(|a, b| self.scorer.cost(a).total_cmp(&self.scorer.cost(b)))
            .ok_or_else(|| Unmet::from(least))
    }
}

/// Whether to try the seed's roll alone, then every roll: only the first on an arm without one.
fn rolls_to_try(geometry: &ArmGeometry) -> Vec<bool> {
    if geometry.has_roll() {
        vec![false, true]
    } else {
        vec![false]
    }
}
