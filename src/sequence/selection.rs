//! Several keys at once, as a keyframe editor selects them: the current key plus the keys a
//! studio's Ctrl-click (toggle) or Shift-click (range) adds. What acts on the selection: copy
//! (the keys as they are), paste (copies inserted after the current key), delete, and a move
//! in time of all of them together (a drag of one on the timeline), which keeps every key's
//! order and every hold, or is refused whole.

use super::edit::KeyframeList;
use super::{Keyframe, TimeRefusal};

impl KeyframeList {
    /// The selected keys' indices in order, the current key among them (none when the list is
    /// empty).
    pub fn selection(&self) -> Vec<usize> {
        if self.is_empty() {
            return Vec::new();
        }
        let mut all = self.also.clone();
        all.push(self.current);
        all.sort_unstable();
        all
    }

    /// Adds key `index` to the selection, or takes it out (a Ctrl-click). Taking the current key
    /// out makes the nearest other selected key current; the last selected key stays. False
    /// when there is no such key.
    pub fn toggle_selected(&mut self, index: usize) -> bool {
        if index >= self.len() {
            return false;
        }
        if index == self.current {
            if let Some(next) = self.nearest_other(index) {
                self.also.retain(|&i| i != next);
                self.current = next;
            }
        } else if let Some(at) = self.also.iter().position(|&i| i == index) {
            self.also.remove(at);
        } else {
            self.also.push(index);
            self.also.sort_unstable();
        }
        true
    }

    /// Selects every key from the current one to `index`, both included (a Shift-click); the
    /// current key stays current. False when there is no such key.
    pub fn select_range(&mut self, index: usize) -> bool {
        if index >= self.len() {
            return false;
        }
        let (from, to) = (self.current.min(index), self.current.max(index));
        self.also = (from..=to).filter(|&i| i != self.current).collect();
        true
    }

    fn nearest_other(&self, index: usize) -> Option<usize> {
        self.also.iter().copied().min_by_key(|&i| i.abs_diff(index))
    }

    /// Copies of the selected keys, in order, with their times as they are now (absolute, so
    /// that a paste keeps their rhythm).
    pub fn copy_selected(&self) -> Vec<Keyframe> {
        self.selection()
            .into_iter()
            .map(|i| {
                let mut key = self.sequence.keyframes[i].clone();
                key.time = Some(self.sequence.key_time(i));
                key
            })
            .collect()
    }

    /// Inserts copies of `keys` after the current key; they become the selection, the first
    /// of them current. In a uniformly spaced list they take the next places; with absolute
    /// times they keep their own spacing, starting one gap after the current key's hold (the
    /// gap the current key had to the next one, else the first copied key's gap to the key
    /// before it, else the default interval), and the later keys move later by what the paste
    /// takes. Refused, nothing inserted, when the keys would end past the longest sequence.
    pub fn paste_after(&mut self, keys: &[Keyframe]) -> Result<(), TimeRefusal> {
        if keys.is_empty() {
            return Ok(());
        }
        let at = if self.is_empty() { 0 } else { self.current + 1 };
        let mut pasted: Vec<Keyframe> = keys.to_vec();
        for key in &mut pasted {
            // The copied key's profile timed the segment after it, in its old place.
            key.timing = None;
        }
        let uniform = self.sequence.key_interval.is_some() && self.uniform_fits(&pasted, at);
        if uniform {
            for key in &mut pasted {
                key.time = None;
            }
        } else {
            self.place_in_time(&mut pasted, at)?;
        }
        let count = pasted.len();
        self.sequence.keyframes.splice(at..at, pasted);
        self.untime_around(at);
        self.untime_around(at + count - 1);
        self.also = (at + 1..at + count).collect();
        self.current = at;
        self.dirty = true;
        Ok(())
    }

    /// Whether keys pasted into a uniformly spaced list at `at` keep every hold inside the
    /// interval (a file's uniform list may not have a hold that long).
    fn uniform_fits(&self, keys: &[Keyframe], at: usize) -> bool {
        let interval = self
            .sequence
            .key_interval
            .unwrap_or(super::DEFAULT_KEY_INTERVAL);
        let before_holds = self.sequence.keyframes[..at].iter();
        (keys.iter().chain(before_holds)).all(|k| k.hold <= interval - super::MIN_GAP)
    }

    /// Gives `keys` absolute times after key `at − 1` (the list gets absolute times too) and
    /// moves the keys from `at` on later by the time they take.
    fn place_in_time(&mut self, keys: &mut [Keyframe], at: usize) -> Result<(), TimeRefusal> {
        let times = self.sequence.key_times();
        let first_copied = keys[0].time.unwrap_or(0.0);
        let gap = self.paste_gap(&times, at);
        let start = match at.checked_sub(1) {
            Some(before) => times[before] + self.sequence.keyframes[before].hold + gap,
            None => 0.0,
        };
        for key in keys.iter_mut() {
            key.time = Some(start + key.time.unwrap_or(first_copied) - first_copied);
        }
        let last = &keys[keys.len() - 1];
        let end = last.time.unwrap_or(start) + last.hold;
        // The later keys keep the gap they had after the key before them.
        let shift = match at.checked_sub(1) {
            Some(before) => end - (times[before] + self.sequence.keyframes[before].hold),
            None => end + gap,
        };
        let latest = times.last().map_or(end, |&t| (t + shift).max(end));
        if latest > super::MAX_TIME {
            return Err(TimeRefusal::OutOfRange { time: latest });
        }
        self.sequence.make_times_absolute();
        for key in &mut self.sequence.keyframes[at..] {
            key.time = key.time.map(|t| t + shift);
        }
        Ok(())
    }

    /// The gap before pasted keys: the one after key `at − 1` (to the key it had next, or the
    /// gap before it at the list's end), else the default interval.
    fn paste_gap(&self, times: &[f64], at: usize) -> f64 {
        let hold_end = |i: usize| times[i] + self.sequence.keyframes[i].hold;
        let gap = match (at.checked_sub(1), times.get(at)) {
            (Some(before), Some(&next)) => Some(next - hold_end(before)),
            (Some(before), None) if before >= 1 => Some(times[before] - hold_end(before - 1)),
            _ => self.sequence.key_interval,
        };
        gap.filter(|g| *g >= super::MIN_GAP)
            .unwrap_or(super::DEFAULT_KEY_INTERVAL)
    }

    /// Deletes every selected key; the key before the first of them (or the new first key)
    /// becomes current. Returns how many went.
    pub fn delete_selected(&mut self) -> usize {
        let selected = self.selection();
        for &index in selected.iter().rev() {
            self.sequence.keyframes.remove(index);
        }
        let Some(&first) = selected.first() else {
            return 0;
        };
        self.also.clear();
        self.current = first.saturating_sub(1);
        if first < self.len() {
            self.untime_around(first);
        }
        if let Some(last) = self.sequence.keyframes.last_mut() {
            last.timing = None;
        }
        self.dirty = true;
        selected.len()
    }

    /// Moves every selected key `delta` seconds (later when positive), together: refused whole,
    /// nothing moved, when a key would leave 0 … the longest sequence, pass a key that is not
    /// selected, or bring a hold into the key after it. A uniformly spaced list gets absolute
    /// times first.
    pub fn shift_selected(&mut self, delta: f64) -> Result<(), TimeRefusal> {
        if self.is_empty() {
            return Err(TimeRefusal::NoKey);
        }
        let selected = self.selection();
        let times = self.sequence.key_times();
        for &i in &selected {
            let time = times[i] + delta;
            if !(time.is_finite() && (0.0..=super::MAX_TIME).contains(&time)) {
                return Err(TimeRefusal::OutOfRange { time });
            }
        }
        let before = self.sequence.clone();
        self.sequence.make_times_absolute();
        for &i in &selected {
            self.sequence.keyframes[i].time = Some(times[i] + delta);
        }
        if let Some(refusal) = self.order_refusal(&selected, &times, delta) {
            self.sequence = before;
            return Err(refusal);
        }
        self.dirty = true;
        Ok(())
    }

    /// Why the keys' new times (each selected key moved by `delta` from `times`) are no valid
    /// list, if they are not: the first selected key whose neighbour it would reach, with the
    /// farthest the selection may move in that direction.
    fn order_refusal(&self, selected: &[usize], times: &[f64], delta: f64) -> Option<TimeRefusal> {
        if self.holds_fit() {
            return None;
        }
        let keys = &self.sequence.keyframes;
        let hold = |i: usize| keys[i].hold;
        let chosen = |i: usize| selected.binary_search(&i).is_ok();
        // How far the selection could move: each selected key against its unselected
        // neighbours, as they were.
        let room = |i: usize| -> (f64, f64) {
            let earlier = (i > 0 && !chosen(i - 1))
                .then(|| times[i] - (times[i - 1] + hold(i - 1) + super::MIN_GAP));
            let later = (i + 1 < times.len() && !chosen(i + 1))
                .then(|| times[i + 1] - hold(i) - super::MIN_GAP - times[i]);
            (
                earlier.unwrap_or(f64::INFINITY),
                later.unwrap_or(f64::INFINITY),
            )
        };
        let (back, ahead) = selected
            .iter()
            .fold((f64::INFINITY, f64::INFINITY), |acc, &i| {
                let (b, a) = room(i);
                (acc.0.min(b), acc.1.min(a))
            });
        let first = times[selected[0]];
        Some(if delta < 0.0 {
            TimeRefusal::Previous {
                earliest: first - back.max(0.0),
            }
        } else {
            TimeRefusal::Next {
                latest: first + ahead.max(0.0),
            }
        })
    }
}
