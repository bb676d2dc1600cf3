//! Collisions: contacts deeper than a resting touch, one finding per colliding pair and kind
//! (the deepest), and the physics' own divergence warnings.
//!
//! Knows nothing about joints.

use super::{Contact, ContactKind, Finding, FindingKind, Thresholds, Trace};

pub(super) fn check_contacts(trace: &Trace, t: &Thresholds) -> Vec<Finding> {
    collisions(&trace.contacts, t)
        .into_iter()
        .map(|c| Finding {
            kind: match c.kind {
                ContactKind::Floor => FindingKind::FloorCollision,
                ContactKind::SelfCollision => FindingKind::SelfCollision,
                ContactKind::BetweenArms => FindingKind::ArmCollision,
                ContactKind::Environment => FindingKind::Collision,
            },
            joint: None,
            arms: arms_of(c),
            time: c.time,
            message: format!(
                "{}: {:.1} mm deep, {:.1} N",
                c.bodies(),
                c.depth * 1000.0,
                c.force
            ),
        })
        .collect()
}

/// The arms of a contact's bodies, each once.
fn arms_of(c: &Contact) -> Vec<String> {
    let mut arms: Vec<String> = c.arms.iter().flatten().cloned().collect();
    arms.dedup();
    arms
}

/// The collisions among `contacts`: the deepest contact of each kind and pair of bodies (in
/// whichever order MuJoCo names them) at least the thresholds' contact depth deep, in the order
/// the pairs first touch.
pub fn collisions<'a>(contacts: &'a [Contact], t: &Thresholds) -> Vec<&'a Contact> {
    let mut worst: Vec<&Contact> = Vec::new();
    for c in contacts.iter().filter(|c| c.depth >= t.contact_depth) {
        match worst
            .iter_mut()
            .find(|w| w.kind == c.kind && w.same_bodies(c))
        {
            Some(w) if w.depth < c.depth => *w = c,
            Some(_) => {}
            None => worst.push(c),
        }
    }
    worst
}

/// Each divergence the physics reported.
pub(super) fn check_divergence(trace: &Trace) -> Vec<Finding> {
    trace
        .divergence
        .iter()
        .map(|(time, message)| Finding {
            kind: FindingKind::Divergence,
            joint: None,
            arms: Vec::new(),
            time: *time,
            message: message.clone(),
        })
        .collect()
}
