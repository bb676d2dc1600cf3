//! Collisions in teaching: a jog or a tool move whose goals would put a part of the arm into
//! the floor, into another part of itself or into another arm of the cell is refused before
//! the arm moves, as a tool target out of reach is ([`crate::collision`], the built-in
//! models' shapes; a robot without one is not checked). A move out of a contact, or along it
//! no deeper, is allowed, so an arm that is already touching can be jogged free.

use super::*;
use crate::collision::Touch;

/// Parts this close are shown as near a contact, metres.
pub(crate) const NEAR_M: f64 = 0.01;

impl TeachState {
    /// Why moving the held goals of `jogged` (robot order, joint units) there is refused: the
    /// contact it would make, in words.
    pub(super) fn contact_refusal(&self, jogged: &[(usize, f64)]) -> Option<String> {
        let mut to = self.goals.clone();
        for &(j, v) in jogged {
            to[j] = v;
        }
        self.way_refusal(&to)
    }

    /// Why the way from the held goals to `pose` (every joint, robot order) is refused, as a
    /// jog, `space` and `y` take it: a straight line in joint space, certified.
    pub(super) fn way_refusal(&self, pose: &[f64]) -> Option<String> {
        let model = self.collision.as_ref()?;
        model.refusal(&self.goals, pose).map(|t| t.describe())
    }

    /// The parts of the arm (of every arm) within `NEAR_M` of the floor, of each other or
    /// of another arm at the present pose, or touching: what the studio colours.
    pub fn near_contacts(&self) -> Vec<Touch> {
        match &self.collision {
            Some(model) if self.present.iter().all(|v| v.is_finite()) => {
                model.touches(&self.present, NEAR_M)
            }
            _ => Vec::new(),
        }
    }
}
