//! Clearance along the whole trajectory: every contact of the arm with the floor, with itself
//! and with the other arms of a cell, certified rather than sampled (`collision::sweep`), as
//! part of the check.
//!
//! The motion is each joint's played curve as polynomial spans (`check::spans`), so how far a
//! joint strays over any interval is exact: its values at the interval's ends and at the
//! points where it turns. What is certified is the goals the player sends, as the limit check
//! certifies them; the arm's own lag behind its goals is the dynamics' to bound.
//!
//! A contact a key declares (`"contact"` in the sequence) is allowed on the segments either
//! side of the key, down to the depth it gives; it is still reported, as declared.

use super::check::spans::{JointCurve, Span};
use super::Trajectory;
use crate::collision::sweep::{sweep, Motion, Near, Resolution};
use crate::collision::{CollisionModel, TouchKind};
use crate::json::InputError;
use crate::robot::Robot;
use crate::sequence::{ContactWith, Sequence};

/// A contact is refined to a millisecond of sequence time: its start, end and deepest point.
const CONTACT_RESOLUTION: f64 = 1e-3;
/// The narrowest interval halved to certify a pair clear, seconds: what cannot be cleared
/// over a microsecond is a step's jump (the goals leap from one pose to another) or a pass
/// within rounding of the clearance.
const FINEST: f64 = 1e-6;

/// Why a contact is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactCause {
    /// The goals themselves come closer than the clearance, as measured: no timing mends it.
    Path,
    /// No goal measured comes closer, but within a microsecond the check cannot rule it out:
    /// where a step's goals jump, the arm sweeps from one pose to the other.
    Unresolved,
}

impl ContactCause {
    /// Lower-case name, as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            ContactCause::Path => "path",
            ContactCause::Unresolved => "unresolved",
        }
    }
}

/// One stretch of time where two bodies (or a body and the floor) are closer than the
/// clearance.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// What the first body touches.
    pub kind: TouchKind,
    /// The bodies as the model names them; the second is `None` for the floor.
    pub bodies: (String, Option<String>),
    /// The links they are on (a joint's name, `""` for the base; `ARM/…` in a cell).
    pub links: (String, Option<String>),
    /// Sequence time it starts, seconds (to a millisecond).
    pub from: f64,
    /// Sequence time it ends, seconds (to a millisecond).
    pub to: f64,
    /// Sequence time of its deepest point.
    pub deepest_time: f64,
    /// The distance there, metres: negative is a penetration that deep. For a contact of
    /// cause [`ContactCause::Unresolved`], the least distance that could not be ruled out.
    pub distance: f64,
    /// Why it is found.
    pub cause: ContactCause,
    /// The keyframe segment of its deepest point.
    pub segment: usize,
    /// That segment's "from → to" label.
    pub segment_label: String,
    /// The key whose pose (or hold) it touches at, if any: the key to move.
    pub key: Option<usize>,
    /// The key whose `"contact"` declares it, when one does: then it is allowed.
    pub declared: Option<usize>,
    /// What to do about it, in words.
    pub advice: String,
}

/// What the clearance check covered.
#[derive(Debug, Clone, PartialEq)]
pub struct ClearanceScope {
    /// The clearance kept, metres.
    pub margin: f64,
    /// Whether the robot has a collision model (without one nothing is checked, and the
    /// report says so).
    pub modelled: bool,
}

/// A declared contact and the sequence time it is allowed in.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactWindow {
    /// The key that declares it.
    pub key: usize,
    /// Sequence time it is allowed from: the start of the segment before the key.
    pub from: f64,
    /// Sequence time it is allowed to: the end of the segment after the key.
    pub to: f64,
    /// The link, as [`Contact::links`] names it.
    pub link: String,
    /// The other link; `None` for the floor.
    pub with: Option<String>,
    /// How deep it may go, metres.
    pub depth: f64,
}

impl ContactWindow {
    /// Whether this window allows `contact`: its bodies, all of its time, no deeper.
    fn allows(&self, contact: &Contact) -> bool {
        // A name is a link or a body of it (the gripper's own body hangs on the wrist's
        // roll link, its jaw on the gripper's).
        let is = |name: &str, first: bool| {
            let (link, body) = if first {
                (Some(&contact.links.0), Some(&contact.bodies.0))
            } else {
                (contact.links.1.as_ref(), contact.bodies.1.as_ref())
            };
            link.is_some_and(|l| l == name) || body.is_some_and(|b| b == name)
        };
        let pair = match &self.with {
            None => contact.links.1.is_none() && is(&self.link, true),
            Some(other) => {
                (is(&self.link, true) && is(other, false))
                    || (is(other, true) && is(&self.link, false))
            }
        };
        pair && self.from <= contact.from
            && contact.to <= self.to
            && contact.distance >= -self.depth
    }
}

/// The contacts the keys of `sequence` declare, checked against `robot`'s links, each with the
/// time it is allowed in (`key_times` are the sequence's).
pub(crate) fn declared_windows(
    sequence: &Sequence,
    robot: &Robot,
    key_times: &[f64],
) -> Result<Vec<ContactWindow>, InputError> {
    let mut windows = Vec::new();
    let links = link_names(robot);
    for (index, key) in sequence.keyframes.iter().enumerate() {
        for (k, declared) in key.contact.iter().enumerate() {
            let path = format!("{}.contact[{k}]", sequence.key_path(index));
            let link = |name: &str, field: &str| {
                link_of(robot, name).ok_or_else(|| {
                    InputError::at_path(
                        &sequence.file,
                        &format!("{path}.{field}"),
                        format!(
                            "unknown link {name:?}; expected one of: {}",
                            links.join(", ")
                        ),
                    )
                })
            };
            let with = match &declared.with {
                ContactWith::Floor => None,
                ContactWith::Link(name) => Some(link(name, "with")?),
            };
            let last = key_times.len() - 1;
            windows.push(ContactWindow {
                key: index,
                from: key_times[index.saturating_sub(1)],
                to: if index < last {
                    key_times[index + 1]
                } else {
                    key_times[index] + key.hold
                },
                link: link(&declared.link, "link")?,
                with,
                depth: declared.depth_mm / 1000.0,
            });
        }
    }
    Ok(windows)
}

/// The names a declared contact may give: every joint's, and the base (`ARM/base` in a cell).
fn link_names(robot: &Robot) -> Vec<String> {
    let mut names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    if robot.is_cell() {
        names.extend(robot.arms.iter().map(|a| format!("{}/base", a.name)));
    } else {
        names.push("base".into());
    }
    names
}

/// A link's name as the collision model gives it (`""` for the base, `ARM/` in a cell).
fn link_of(robot: &Robot, name: &str) -> Option<String> {
    if robot.joint_index(name).is_some() {
        return Some(name.to_string());
    }
    if !robot.is_cell() {
        return (name == "base").then(String::new);
    }
    let arm = name.strip_suffix("/base")?;
    robot
        .arms
        .iter()
        .any(|a| a.name == arm)
        .then(|| format!("{arm}/"))
}

/// Every contact of `trajectory` on `robot` closer than the robot's clearance, and what the
/// check covered. A robot without a collision model has none found, and the scope says it was
/// not modelled.
pub(crate) fn contacts(trajectory: &Trajectory, robot: &Robot) -> (Vec<Contact>, ClearanceScope) {
    let model = CollisionModel::for_robot(robot);
    let scope = ClearanceScope {
        margin: robot.clearance,
        modelled: model.is_some(),
    };
    let Some(model) = model else {
        return (Vec::new(), scope);
    };
    // A window that lasts no time is one instant, which the sweep looks at as any other.
    let motion = Played::new(trajectory);
    let resolution = Resolution {
        clearance: robot.clearance,
        contact: CONTACT_RESOLUTION,
        finest: FINEST,
    };
    let near = sweep(
        &model,
        &motion,
        trajectory.start,
        trajectory.end,
        resolution,
    );
    let found = merged(&near)
        .into_iter()
        .map(|run| contact_of(&model, &motion, trajectory, &run, robot.clearance))
        .collect();
    (declare(trajectory, found), scope)
}

/// Why the approach ramp from `from` to `to` (robot order, joint units: a straight line in
/// joint space, as the player and `space` take it) is refused: the contact it would make, in
/// words. `None` when the way is clear, and for a robot without a collision model.
pub fn approach_refusal(robot: &Robot, from: &[f64], to: &[f64]) -> Option<String> {
    let model = CollisionModel::for_robot(robot)?;
    model.refusal(from, to).map(|touch| touch.describe())
}

/// Marks each contact a window allows as declared.
fn declare(trajectory: &Trajectory, mut found: Vec<Contact>) -> Vec<Contact> {
    for contact in &mut found {
        contact.declared = trajectory
            .declared
            .iter()
            .find(|w| w.allows(contact))
            .map(|w| w.key);
    }
    found.sort_by(|a, b| a.from.total_cmp(&b.from));
    found
}

/// One pair's run of adjacent intervals closer than the clearance.
struct Run {
    pair: usize,
    from: f64,
    to: f64,
    /// The deepest measured point (or, with none measured, the lowest bound) and its time.
    distance: f64,
    at: f64,
    measured: bool,
}

/// The sweep's intervals joined into runs, pair by pair: adjacent intervals of one pair are
/// one contact.
fn merged(near: &[Near]) -> Vec<Run> {
    let mut sorted: Vec<&Near> = near.iter().collect();
    sorted.sort_by(|a, b| a.pair.cmp(&b.pair).then(a.from.total_cmp(&b.from)));
    let mut runs: Vec<Run> = Vec::new();
    for n in sorted {
        if let Some(run) = runs.last_mut() {
            if run.pair == n.pair && n.from <= run.to + 1e-12 {
                run.to = run.to.max(n.to);
                // A measured depth outranks any bound; among like, the deeper.
                let better = match (run.measured, n.certain) {
                    (false, true) => true,
                    (true, false) => false,
                    _ => n.distance < run.distance,
                };
                if better {
                    (run.distance, run.at, run.measured) = (n.distance, n.at, n.certain);
                }
                continue;
            }
        }
        runs.push(Run {
            pair: n.pair,
            from: n.from,
            to: n.to,
            distance: n.distance,
            at: n.at,
            measured: n.certain,
        });
    }
    runs
}

fn contact_of(
    model: &CollisionModel,
    motion: &Played,
    trajectory: &Trajectory,
    run: &Run,
    clearance: f64,
) -> Contact {
    let touch = model.touch_of(run.pair, run.distance);
    let segment = trajectory.segment_at(run.at);
    let mut contact = Contact {
        kind: touch.kind,
        bodies: touch.bodies,
        links: touch.links,
        from: run.from,
        to: run.to,
        deepest_time: run.at,
        distance: run.distance,
        cause: if run.measured {
            ContactCause::Path
        } else {
            ContactCause::Unresolved
        },
        segment,
        segment_label: trajectory.segment_label(segment),
        key: key_in_contact(model, motion, trajectory, run, clearance),
        declared: None,
        advice: String::new(),
    };
    contact.advice = advice(&contact, trajectory, clearance);
    contact
}

/// The key whose own pose has the run's pair closer than the clearance, the one nearest the
/// deepest point: the key to move. `None` when every key near the run is clear (the path dips
/// between them).
fn key_in_contact(
    model: &CollisionModel,
    motion: &Played,
    trajectory: &Trajectory,
    run: &Run,
    clearance: f64,
) -> Option<usize> {
    let mut pose = vec![0.0; motion.joints()];
    (0..trajectory.key_times.len())
        .filter(|&k| {
            let (start, end) = (
                trajectory.key_times[k],
                trajectory.key_times[k] + trajectory.key_holds[k],
            );
            start <= run.to + CONTACT_RESOLUTION && end >= run.from - CONTACT_RESOLUTION
        })
        .filter(|&k| {
            let t = trajectory.key_times[k].clamp(trajectory.start, trajectory.end);
            motion.pose(t, &mut pose);
            model.pair_distance(&model.placed(&pose), run.pair) < clearance
        })
        .min_by(|&a, &b| {
            let gap = |k: usize| (trajectory.key_times[k] - run.at).abs();
            gap(a).total_cmp(&gap(b))
        })
}

/// What to do about a contact, in words a person acts on.
fn advice(contact: &Contact, trajectory: &Trajectory, clearance: f64) -> String {
    let needed_mm = ((clearance - contact.distance) * 1000.0).ceil().max(1.0);
    let body = &contact.bodies.0;
    let other = contact.bodies.1.as_deref().unwrap_or("the floor");
    let label = |k: usize| trajectory.key_labels[k].clone();
    let between = {
        let s = contact.segment;
        let next = (s + 1).min(trajectory.key_labels.len() - 1);
        format!("keys '{}' and '{}'", label(s), label(next))
    };
    match (contact.cause, contact.key, contact.kind) {
        (ContactCause::Unresolved, _, _) => format!(
            "the goals jump at {:.3} s (a step), and while the player turns the jump each joint \
             moves on its own, so {body} may come within {:.1} mm of {other}: replace the step \
             with a motion that keeps {body} clear",
            contact.deepest_time,
            contact.distance * 1000.0
        ),
        (ContactCause::Path, Some(k), TouchKind::Floor) => format!(
            "raise key '{}' by {needed_mm:.0} mm ({body} {} there)",
            label(k),
            depth_words(contact.distance)
        ),
        (ContactCause::Path, Some(k), _) => format!(
            "move key '{}' so that {body} and {other} part by {needed_mm:.0} mm more",
            label(k)
        ),
        (ContactCause::Path, None, TouchKind::Floor) => format!(
            "retime does not help: the path itself goes through the floor between {between} \
             ({body} {} at {:.3} s, though both keys are clear); add a key between them that \
             keeps {body} higher, or use monotone interpolation, which does not overshoot its \
             keys",
            depth_words(contact.distance),
            contact.deepest_time
        ),
        (ContactCause::Path, None, _) => format!(
            "retime does not help: the path itself brings {body} and {other} together between \
             {between} (at {:.3} s, though both keys are clear); add a key between them that \
             keeps them apart",
            contact.deepest_time
        ),
    }
}

fn depth_words(distance: f64) -> String {
    if distance < 0.0 {
        format!("is {:.1} mm into it", -distance * 1000.0)
    } else {
        format!("is {:.1} mm from it", distance * 1000.0)
    }
}

/// The trajectory as the sweep follows it: each joint's played spans.
struct Played {
    joints: Vec<JointPath>,
}

/// One joint's spans and, for each, the times inside it where it turns.
struct JointPath {
    spans: Vec<Span>,
    turns: Vec<Vec<f64>>,
}

impl Played {
    fn new(trajectory: &Trajectory) -> Played {
        let joints = (0..trajectory.tracks().len())
            .map(|j| {
                let curve = JointCurve::new(
                    &trajectory.tracks()[j],
                    trajectory.timing(),
                    trajectory.start,
                    trajectory.end,
                    &trajectory.key_times,
                    0.0,
                );
                // A window that lasts no time has no played span: its rest is the pose.
                let spans = if curve.played.is_empty() {
                    curve.extended[..1].to_vec()
                } else {
                    curve.played
                };
                let turns = spans
                    .iter()
                    .map(|s| {
                        let breaks = s.poly.monotone_breaks(s.len());
                        breaks[1..breaks.len() - 1]
                            .iter()
                            .map(|x| s.start + x)
                            .collect()
                    })
                    .collect();
                JointPath { spans, turns }
            })
            .collect();
        Played { joints }
    }
}

impl JointPath {
    fn at(&self, t: f64) -> f64 {
        let i = self
            .spans
            .partition_point(|s| s.start <= t)
            .saturating_sub(1);
        let span = &self.spans[i];
        span.poly.eval((t - span.start).clamp(0.0, span.len()))
    }

    /// The lowest and highest value on [a, b], both ends included: where two spans meet at a
    /// jump, both sides.
    fn range(&self, a: f64, b: f64) -> (f64, f64) {
        let first = self.spans.partition_point(|s| s.end < a);
        let mut low = f64::INFINITY;
        let mut high = f64::NEG_INFINITY;
        for (span, turns) in self.spans[first..]
            .iter()
            .zip(&self.turns[first..])
            .take_while(|(s, _)| s.start <= b)
        {
            let (from, to) = (a.max(span.start), b.min(span.end));
            let inside = turns.iter().copied().filter(|&t| t > from && t < to);
            for t in [from, to].into_iter().chain(inside) {
                let v = span.poly.eval((t - span.start).clamp(0.0, span.len()));
                low = low.min(v);
                high = high.max(v);
            }
        }
        if low > high {
            let v = self.at(a);
            return (v, v);
        }
        (low, high)
    }
}

impl Motion for Played {
    fn joints(&self) -> usize {
        self.joints.len()
    }

    fn pose(&self, s: f64, out: &mut [f64]) {
        for (slot, joint) in out.iter_mut().zip(&self.joints) {
            *slot = joint.at(s);
        }
    }

    fn deviation(&self, a: f64, b: f64, middle: f64, out: &mut [f64]) {
        for (slot, joint) in out.iter_mut().zip(&self.joints) {
            let (low, high) = joint.range(a, b);
            let centre = joint.at(middle);
            // Rounding between the spans' evaluations is no motion the bound must miss.
            let slack = 1e-9 * (1.0 + centre.abs());
            *slot = (high - centre).max(centre - low).max(0.0) + slack;
        }
    }
}
