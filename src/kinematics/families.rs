//! The closed form's solutions of a position as families a key is chosen from.
//!
//! With a position alone, a pan + three-pitch (+ roll) arm has, for each pan side, elbow and
//! roll, one solution per tool pitch φ (docs/robots.md §12.2): a *family* along which φ is free.
//! A key's solutions are drawn from each family on a grid of pitches over the whole turn
//! ([`PITCH_GRID_DEG`]), plus the seed's pitch and the pitches nearest it at which the links
//! reach; the cheapest is then refined along its family between its grid neighbours
//! ([`refine`]). With an approach direction, φ is the one that points the tool that way.

use super::closed_form::{nearest_reachable_pitch, ArmGeometry, Plane};
use crate::robot::Robot;
use glam::DVec3;
use std::f64::consts::TAU;

/// Step of the grid of tool pitches, degrees.
pub(crate) const PITCH_GRID_DEG: f64 = 2.0;

/// Golden-section steps of [`refine`]: the bracket of two grid steps shrinks by 0.618 each, to
/// 4° · 0.618³⁰ ≈ 2·10⁻⁶ degrees.
const REFINE_STEPS: usize = 30;

/// One pan side, elbow and roll: the tool pitch is free along it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Family {
    back: bool,
    elbow: usize,
    /// Radians.
    roll: f64,
}

/// A solution, with its family and tool pitch (radians).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Member {
    pub(crate) family: Family,
    pub(crate) phi: f64,
    pub(crate) values: Vec<f64>,
}

/// The family's solution at tool pitch `phi`: inside the limits, above the floor, on the
/// target; None where it has none.
pub(crate) fn member(
    geometry: &ArmGeometry,
    robot: &Robot,
    position: DVec3,
    family: Family,
    phi: f64,
    seed: &[f64],
) -> Option<Member> {
    let plane = geometry.plane(position, family.roll, family.back)?;
    on_plane(geometry, robot, &plane, position, family, phi, seed)
}

fn on_plane(
    geometry: &ArmGeometry,
    robot: &Robot,
    plane: &Plane,
    position: DVec3,
    family: Family,
    phi: f64,
    seed: &[f64],
) -> Option<Member> {
    let turns = plane.reach(phi)?[family.elbow];
    let (values, _) = geometry.checked(robot, plane, position, phi, turns, seed, true)?;
    Some(Member {
        family,
        phi,
        values,
    })
}

/// The rolls (radians) a key tries: the seed's alone, or (`all`) every 30° inside the limits
/// from it. The roll turns the tool about its approach axis, which a position leaves free: the
/// previous key's is what a person keeps.
pub(crate) fn rolls(geometry: &ArmGeometry, robot: &Robot, seed: &[f64], all: bool) -> Vec<f64> {
    let mut rolls = geometry.roll_candidates(robot, seed);
    if !all {
        rolls.truncate(1);
    }
    rolls
}

/// Every family's members at the pitches `pitches` gives for each of its planes (one per pan
/// side and roll), both elbows.
pub(crate) fn members(
    geometry: &ArmGeometry,
    robot: &Robot,
    position: DVec3,
    rolls: &[f64],
    seed: &[f64],
    pitches: impl Fn(&Plane) -> Vec<f64>,
) -> Vec<Member> {
    let mut found = Vec::new();
    for &roll in rolls {
        for back in [false, true] {
            let Some(plane) = geometry.plane(position, roll, back) else {
                continue;
            };
            for phi in pitches(&plane) {
                for elbow in 0..2 {
                    let family = Family { back, elbow, roll };
                    found.extend(on_plane(
                        geometry, robot, &plane, position, family, phi, seed,
                    ));
                }
            }
        }
    }
    found
}

/// The pitches a position alone is looked at with on a plane: the grid over the whole turn,
/// the seed's pitch, and the pitches nearest it at which the two links reach (so an arc of
/// reachable pitches narrower than the grid step is not missed).
pub(crate) fn free_pitches(plane: &Plane, seed_pitch: f64) -> Vec<f64> {
    let steps = (360.0 / PITCH_GRID_DEG).round() as usize;
    let mut pitches: Vec<f64> = (0..steps).map(|k| k as f64 * TAU / steps as f64).collect();
    pitches.push(seed_pitch);
    pitches.extend(
        nearest_reachable_pitch(plane, seed_pitch)
            .into_iter()
            .flatten(),
    );
    pitches
}

/// The member of `best`'s family whose pitch, within one grid step either way, minimises
/// `cost`, by golden-section search; `best` itself when nothing there is cheaper.
pub(crate) fn refine(
    geometry: &ArmGeometry,
    robot: &Robot,
    position: DVec3,
    best: &Member,
    seed: &[f64],
    cost: impl Fn(&[f64]) -> f64,
) -> Member {
    let at = |phi: f64| member(geometry, robot, position, best.family, phi, seed);
    let price = |phi: f64| at(phi).map_or(f64::INFINITY, |m| cost(&m.values));
    let step = PITCH_GRID_DEG.to_radians();
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (best.phi - step, best.phi + step);
    let mut a = hi - ratio * (hi - lo);
    let mut b = lo + ratio * (hi - lo);
    let (mut fa, mut fb) = (price(a), price(b));
    for _ in 0..REFINE_STEPS {
        if fa <= fb {
            hi = b;
            (b, fb) = (a, fa);
            a = hi - ratio * (hi - lo);
            fa = price(a);
        } else {
            lo = a;
            (a, fa) = (b, fb);
            b = lo + ratio * (hi - lo);
            fb = price(b);
        }
    }
    let phi = if fa <= fb { a } else { b };
    match at(phi) {
        Some(m) if cost(&m.values) < cost(&best.values) => m,
        _ => best.clone(),
    }
}

/// The members pointing the approach axis `approach` (tool frame) along `direction` (base
/// frame), tilted from it by `tilt` radians (either way; 0 for exactly), on every plane of the
/// rolls given.
pub(crate) fn approach_members(
    geometry: &ArmGeometry,
    robot: &Robot,
    position: DVec3,
    rolls: &[f64],
    seed: &[f64],
    (approach, direction): (DVec3, DVec3),
    tilt: f64,
) -> Vec<Member> {
    members(geometry, robot, position, rolls, seed, |plane| {
        let phi = geometry.approach_pitch(plane, approach, direction);
        if tilt == 0.0 {
            vec![phi]
        } else {
            vec![phi - tilt, phi + tilt]
        }
    })
}
