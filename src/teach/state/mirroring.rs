//! Mirroring in teaching: `m` mirrors the current key, `M` the whole list, across the arm's own
//! vertical plane (crate::mirror). On a cell of exactly two arms the arm of the selected joint
//! is mirrored onto the other one (which it replaces); otherwise every arm in place. Mirroring
//! in place twice gives the key back (unless a value was clipped), which is the undo.

use super::*;
use crate::mirror::{Clip, Mapping, Mirror, MirrorError};

impl TeachState {
    /// `m`: the current key's mirror image.
    pub(super) fn mirror_key(&mut self) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no key to mirror: n adds one");
        }
        let index = self.list.current_index();
        let (mirror, what) = match self.mirror() {
            Ok(found) => found,
            Err(e) => return self.fail(format!("cannot mirror: {e}")),
        };
        let mut copy = self.list.sequence().clone();
        match mirror.key(&mut copy, &self.robot, index) {
            Ok(clips) => {
                self.list.replace_current(copy.keyframes.swap_remove(index));
                let label = self.key_label(index);
                self.report_mirror(format!("{what} {label}"), &clips)
            }
            Err(e) => self.fail(format!("cannot mirror: {e}")),
        }
    }

    /// `M`: the mirror image of every key.
    pub(super) fn mirror_sequence(&mut self) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no keys to mirror: n adds one");
        }
        let (mirror, what) = match self.mirror() {
            Ok(found) => found,
            Err(e) => return self.fail(format!("cannot mirror: {e}")),
        };
        match mirror.sequence(self.list.sequence(), &self.robot) {
            Ok((mirrored, clips)) => {
                self.list.replace_keys(mirrored.keyframes);
                let count = format::count(self.list.len());
                self.report_mirror(format!("{what} all {count}"), &clips)
            }
            Err(e) => self.fail(format!("cannot mirror: {e}")),
        }
    }

    /// The mirroring for the selected joint's arm, and how to say what it did.
    fn mirror(&self) -> Result<(Mirror, String), MirrorError> {
        let mapping = Mirror::for_selected_joint(&self.robot, self.selected);
        let what = match mapping {
            Mapping::InPlace => "mirrored".to_string(),
            Mapping::Onto { from, to } => format!("mirrored {from} onto {to} in"),
        };
        let mirror = Mirror::new(&self.robot, mapping, &self.list.sequence().file)?;
        Ok((mirror, what))
    }

    /// The status after a mirror: what changed, and each value clipped to a limit (a warning:
    /// the key is no longer the exact mirror image).
    fn report_mirror(&mut self, done: String, clips: &[Clip]) -> Vec<Command> {
        if clips.is_empty() {
            self.info(format!("{done} (space moves the arm there)"));
        } else {
            let clipped: Vec<String> = clips
                .iter()
                .map(|c| format!("{} {:.2} → {} {}", c.joint, c.value, c.limit, c.unit))
                .collect();
            self.warn(format!(
                "{done}, clipped to the limits: {}",
                clipped.join(", ")
            ));
        }
        self.edited()
    }
}

#[cfg(test)]
mod tests;
