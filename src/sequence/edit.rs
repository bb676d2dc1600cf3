//! Editing a keyframe list the way a teach pendant does: there is always a current key, and
//! every operation acts on it or moves it.

use super::{KeyValue, Keyframe, Sequence};
use crate::curve::Interp;
use crate::json::InputError;
use std::path::Path;

/// Why [`KeyframeList::set_time`] left a key where it was.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TimeRefusal {
    /// The list is empty.
    #[error("there is no key")]
    NoKey,
    /// The time is not a number from 0 to [`MAX_TIME`](super::MAX_TIME).
    #[error("{time} s is outside 0 … {max} s", max = super::MAX_TIME)]
    OutOfRange {
        /// The time asked for, seconds.
        time: f64,
    },
    /// The time is before the previous key and its hold end.
    #[error("the previous key (and its hold) ends later: {earliest:.3} s is the earliest")]
    Previous {
        /// The earliest time the key can have, seconds.
        earliest: f64,
    },
    /// The time, plus the key's hold, reaches the next key.
    #[error("the next key comes sooner: {latest:.3} s is the latest")]
    Next {
        /// The latest time the key can have, seconds.
        latest: f64,
    },
}

/// A sequence being edited, with its current key and whether it has unsaved changes.
#[derive(Debug, Clone)]
pub struct KeyframeList {
    pub(super) sequence: Sequence,
    pub(super) current: usize,
    pub(super) dirty: bool,
    /// The keys selected with the current one (a studio's Ctrl- or Shift-click), in order,
    /// without it: what copy, delete and a drag in time act on besides the current key
    /// ([`super::selection`]). Any edit that renumbers the keys, and any move of the current
    /// key, leaves the current key alone selected.
    pub(super) also: Vec<usize>,
    /// The keys and settings as loaded or last saved: a version put back by undo or redo that
    /// equals them leaves the list clean.
    clean: Sequence,
}

impl KeyframeList {
    /// The list of `sequence`'s keys, clean, with the first key current.
    pub fn new(sequence: Sequence) -> Self {
        Self {
            clean: sequence.clone(),
            sequence,
            current: 0,
            dirty: false,
            also: Vec::new(),
        }
    }

    /// The list of the sequence in the file at `path` ([`Sequence::load`]).
    pub fn load(path: &Path) -> Result<Self, InputError> {
        Ok(Self::new(Sequence::load(path)?))
    }

    /// Saves atomically; the list is then clean.
    pub fn save(&mut self, path: &Path) -> Result<(), InputError> {
        self.sequence.save(path)?;
        self.sequence.file = path.display().to_string();
        let written = self.sequence.to_text();
        self.sequence.mark_written(&written);
        self.clean = self.sequence.clone();
        self.dirty = false;
        Ok(())
    }

    /// The sequence as edited so far.
    pub fn sequence(&self) -> &Sequence {
        &self.sequence
    }

    /// Number of keys.
    pub fn len(&self) -> usize {
        self.sequence.keyframes.len()
    }

    /// Whether there are no keys.
    pub fn is_empty(&self) -> bool {
        self.sequence.keyframes.is_empty()
    }

    /// Whether there are changes not saved yet.
    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    /// Index of the current key (0 when the list is empty).
    pub fn current_index(&self) -> usize {
        self.current
    }

    /// The current key.
    pub fn show(&self) -> Option<&Keyframe> {
        self.sequence.keyframes.get(self.current)
    }

    /// Time of the current key.
    pub fn current_time(&self) -> Option<f64> {
        (!self.is_empty()).then(|| self.sequence.key_time(self.current))
    }

    /// Moves to the next key; false (and no move) at the last one.
    pub fn next_key(&mut self) -> bool {
        let at = self.current + 1;
        at < self.len() && self.select(at)
    }

    /// Moves to the previous key; false (and no move) at the first one.
    pub fn previous_key(&mut self) -> bool {
        self.current > 0 && self.select(self.current - 1)
    }

    /// Puts an earlier (or later) version of the list in place (undo, redo): its sequence and
    /// its current key (the last one if `current` is past it). The list has unsaved changes
    /// unless the version is what was loaded or last saved (undone back to it).
    pub fn restore(&mut self, sequence: Sequence, current: usize) {
        self.also.clear();
        self.current = current.min(sequence.keyframes.len().saturating_sub(1));
        self.dirty = !sequence.same_content(&self.clean);
        self.sequence = sequence;
    }

    /// Makes key `index` current; false if there is no such key.
    pub fn select(&mut self, index: usize) -> bool {
        if index < self.len() {
            self.also.clear();
            self.current = index;
            true
        } else {
            false
        }
    }

    /// Replaces the current key's pose with `values` (its name, time and hold stay).
    pub fn update(&mut self, values: Vec<(String, KeyValue)>) -> bool {
        let Some(key) = self.sequence.keyframes.get_mut(self.current) else {
            return false;
        };
        key.values = values;
        self.dirty = true;
        true
    }

    /// Inserts a key with `values` after the current one and makes it current.
    ///
    /// In a uniformly spaced list, later keys simply move one interval on. With absolute times
    /// the new key goes halfway to the next key, or one interval (the last gap, else the default
    /// interval) after the last key. A uniformly spaced list whose last key holds as long as
    /// the interval or longer (a file may have it so) gets absolute times first when a key is
    /// added after that one: one interval later would be inside the hold.
    pub fn insert_after(&mut self, values: Vec<(String, KeyValue)>) {
        self.also.clear();
        let mut key = Keyframe::new(values);
        let at = if self.is_empty() { 0 } else { self.current + 1 };
        if let (Some(interval), Some(last)) =
            (self.sequence.key_interval, self.sequence.keyframes.last())
        {
            if at == self.len() && last.hold > interval - super::MIN_GAP {
                self.sequence.make_times_absolute();
            }
        }
        if self.sequence.key_interval.is_none() {
            let times = self.sequence.key_times();
            let time = match (at.checked_sub(1).map(|i| times[i]), times.get(at)) {
                (None, _) => 0.0,
                (Some(before), Some(&after)) => {
                    let hold = self.sequence.keyframes[at - 1].hold;
                    // Halfway through the moving part, so the previous key's hold still fits.
                    before + hold + (after - before - hold) / 2.0
                }
                (Some(before), None) => {
                    let gap = if at >= 2 {
                        times[at - 1] - times[at - 2]
                    } else {
                        super::DEFAULT_KEY_INTERVAL
                    };
                    before + self.sequence.keyframes[at - 1].hold + gap
                }
            };
            key.time = Some(time);
        }
        self.sequence.keyframes.insert(at, key);
        self.untime_around(at);
        self.current = at;
        self.dirty = true;
    }

    /// Inserts a key of `values` at `time` (seconds), among the keys where that time falls,
    /// and makes it current: a key captured at a time parked on the studio's timeline. It must
    /// come after the previous key's hold and before the next key by at least
    /// [`super::MIN_GAP`], within 0 … [`super::MAX_TIME`]; a uniformly spaced list gets
    /// absolute times first, so that no other key moves. The refusal says why.
    pub fn insert_at(
        &mut self,
        values: Vec<(String, KeyValue)>,
        time: f64,
    ) -> Result<(), TimeRefusal> {
        if !(time.is_finite() && (0.0..=super::MAX_TIME).contains(&time)) {
            return Err(TimeRefusal::OutOfRange { time });
        }
        let times = self.sequence.key_times();
        let at = times.partition_point(|&t| t <= time);
        if let Some(before) = at.checked_sub(1) {
            let earliest = times[before] + self.sequence.keyframes[before].hold + super::MIN_GAP;
            if time < earliest {
                return Err(TimeRefusal::Previous { earliest });
            }
        }
        if let Some(&next) = times.get(at) {
            let latest = next - super::MIN_GAP;
            if time > latest {
                return Err(TimeRefusal::Next { latest });
            }
        }
        self.also.clear();
        self.sequence.make_times_absolute();
        let mut key = Keyframe::new(values);
        key.time = Some(time);
        self.sequence.keyframes.insert(at, key);
        self.untime_around(at);
        self.current = at;
        self.dirty = true;
        Ok(())
    }

    /// Deletes the current key; the key before it (or the new first key) becomes current.
    pub fn delete(&mut self) -> Option<Keyframe> {
        self.also.clear();
        if self.is_empty() {
            return None;
        }
        let removed = self.sequence.keyframes.remove(self.current);
        if self.current < self.len() {
            self.untime_around(self.current);
        } else if let Some(last) = self.sequence.keyframes.last_mut() {
            last.timing = None;
        }
        self.current = self.current.saturating_sub(1);
        self.dirty = true;
        Some(removed)
    }

    /// Moves the current key `delta` places earlier (negative) or later (positive) and keeps it
    /// current. With absolute times the keys trade places but the times stay where they were, so
    /// the rhythm of the sequence is unchanged. False when the move would leave the list, or
    /// would bring a key's hold into the key after it (a held key moved to a shorter gap, the
    /// last key's hold moved before another key): the list stays one that loads.
    pub fn move_by(&mut self, delta: isize) -> bool {
        self.also.clear();
        let Some(target) = self.current.checked_add_signed(delta) else {
            return false;
        };
        if target >= self.len() || delta == 0 {
            return false;
        }
        let before = self.sequence.keyframes.clone();
        let keys = &mut self.sequence.keyframes;
        let times: Vec<Option<f64>> = keys.iter().map(|k| k.time).collect();
        let key = keys.remove(self.current);
        keys.insert(target, key);
        for (k, t) in keys.iter_mut().zip(times) {
            k.time = t;
        }
        if !self.holds_fit() {
            self.sequence.keyframes = before;
            return false;
        }
        for index in self.current.min(target)..=self.current.max(target) {
            self.untime_around(index);
        }
        self.current = target;
        self.dirty = true;
        true
    }

    /// Drops the timing profiles of the segments into and out of key `index`, whose segments an
    /// edit has just split, joined or reordered: a profile's path time belongs to the curve it
    /// was made for (the segments' keys then move at the pace of their key times), and the
    /// last key times no segment.
    pub(super) fn untime_around(&mut self, index: usize) {
        let keys = &mut self.sequence.keyframes;
        for i in [index.checked_sub(1), Some(index)].into_iter().flatten() {
            if let Some(key) = keys.get_mut(i) {
                key.timing = None;
            }
        }
        if let Some(last) = keys.last_mut() {
            last.timing = None;
        }
    }

    /// Whether every key's hold ends at least [`super::MIN_GAP`] before the next key, as a
    /// sequence file must have it.
    pub(super) fn holds_fit(&self) -> bool {
        let times = self.sequence.key_times();
        (self.sequence.keyframes.iter().zip(times.windows(2)))
            .all(|(key, pair)| key.hold <= pair[1] - pair[0] - super::MIN_GAP)
    }

    /// Names (or unnames) the current key; false when there is no key.
    pub fn set_name(&mut self, name: Option<String>) -> bool {
        self.edit_current(|k| k.name = name)
    }

    /// Sets the mode of the segment from the current key to the next; `None` follows the
    /// sequence's.
    pub fn set_interp(&mut self, interp: Option<Interp>) -> bool {
        let step = interp == Some(Interp::Step);
        self.edit_current(|k| {
            k.interp = interp;
            // A step does not move along a curve: a timing profile has nothing to time.
            if step {
                k.timing = None;
            }
        })
    }

    /// Sets (or clears) the timing profile of the segment from the current key (the studio's
    /// easing); false when there is no key.
    pub fn set_timing(&mut self, timing: Option<super::SegmentTiming>) -> bool {
        self.edit_current(|k| k.timing = timing)
    }

    /// Sets one joint's value in the current key (added if the key did not name the joint).
    pub fn set_value(&mut self, joint: &str, value: KeyValue) -> bool {
        self.edit_current(|k| k.set(joint, value))
    }

    /// Replaces the current key whole (an edit worked out on a copy, such as its mirror
    /// image); false when there is no key.
    pub fn replace_current(&mut self, key: Keyframe) -> bool {
        self.edit_current(|k| *k = key)
    }

    /// Replaces every key, keeping their number (an edit of the whole list worked out on a
    /// copy); false, and no change, when the count differs.
    pub fn replace_keys(&mut self, keys: Vec<Keyframe>) -> bool {
        if keys.len() != self.len() {
            return false;
        }
        self.sequence.keyframes = keys;
        self.dirty = true;
        true
    }

    /// Sets (or clears) the current key's tool target.
    pub fn set_tool(&mut self, tool: Option<super::ToolKey>) -> bool {
        self.edit_current(|k| k.tool = tool)
    }

    /// Sets the current key's tool target for arm `arm` of a cell, in place of any it had.
    pub fn set_arm_tool(&mut self, arm: &str, tool: super::ToolKey) -> bool {
        self.edit_current(|k| {
            k.arm_tools.retain(|(a, _)| a != arm);
            k.arm_tools.push((arm.to_string(), tool));
        })
    }

    /// Sets the current key's hold; refused when it would overrun the next key. In a uniformly
    /// spaced list the last key's hold is held to the interval too: a key added after it comes
    /// one interval later (and [`KeyframeList::set_key_interval`] holds every key to it).
    pub fn set_hold(&mut self, hold: f64) -> bool {
        let times = self.sequence.key_times();
        let gap = (times.get(self.current + 1).map(|t| t - times[self.current]))
            .or(self.sequence.key_interval);
        if !(hold.is_finite() && hold >= 0.0) || gap.is_some_and(|g| hold > g - super::MIN_GAP) {
            return false;
        }
        self.edit_current(|k| {
            k.hold = hold;
            // A hold's S-curve has nothing to time without a hold.
            if let Some(timing) = k.timing.as_mut().filter(|_| hold == 0.0) {
                timing.hold = None;
            }
        })
    }

    /// Sets the current key's effort for `joint`, percent of its servo's stall torque (`None`
    /// clears it); refused outside (0, 100].
    pub fn set_effort(&mut self, joint: &str, percent: Option<f64>) -> bool {
        if percent.is_some_and(|p| !(p > 0.0 && p <= 100.0)) {
            return false;
        }
        self.edit_current(|k| {
            k.effort.retain(|(name, _)| name != joint);
            if let Some(p) = percent {
                k.effort.push((joint.to_string(), p));
            }
        })
    }

    /// Sets the spacing of a uniformly spaced list; refused below 0.1 s or on a timed list.
    pub fn set_key_interval(&mut self, interval: f64) -> bool {
        if self.sequence.key_interval.is_none() || !(interval >= 0.1 && interval.is_finite()) {
            return false;
        }
        if self
            .sequence
            .keyframes
            .iter()
            .any(|k| k.hold > interval - super::MIN_GAP)
        {
            return false;
        }
        self.sequence.key_interval = Some(interval);
        self.dirty = true;
        true
    }

    /// Moves the current key to `time` (seconds), keeping the order of the keys: it must stay
    /// after the previous key's hold and before the next key, with its own hold, by at least
    /// [`super::MIN_GAP`], and within 0 … [`super::MAX_TIME`]. A uniformly spaced list gets
    /// absolute times first (the spacing made explicit). The refusal says why.
    pub fn set_time(&mut self, time: f64) -> Result<(), TimeRefusal> {
        if self.is_empty() {
            return Err(TimeRefusal::NoKey);
        }
        if !(time.is_finite() && (0.0..=super::MAX_TIME).contains(&time)) {
            return Err(TimeRefusal::OutOfRange { time });
        }
        let times = self.sequence.key_times();
        let i = self.current;
        if i > 0 {
            let earliest = times[i - 1] + self.sequence.keyframes[i - 1].hold + super::MIN_GAP;
            if time < earliest {
                return Err(TimeRefusal::Previous { earliest });
            }
        }
        if let Some(&next) = times.get(i + 1) {
            let latest = next - self.sequence.keyframes[i].hold - super::MIN_GAP;
            if time > latest {
                return Err(TimeRefusal::Next { latest });
            }
        }
        self.sequence.make_times_absolute();
        self.sequence.keyframes[i].time = Some(time);
        self.dirty = true;
        Ok(())
    }

    fn edit_current(&mut self, edit: impl FnOnce(&mut Keyframe)) -> bool {
        match self.sequence.keyframes.get_mut(self.current) {
            Some(key) => {
                edit(key);
                self.dirty = true;
                true
            }
            None => false,
        }
    }
}
