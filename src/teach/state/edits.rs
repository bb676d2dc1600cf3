//! The edits of the current key typed in or cycled: its name, its hold, the interpolation of
//! the segment from it, and one joint's value. Each refusal leaves the key as it was.

use super::*;
use crate::curve::Interp;
use crate::sequence::SegmentTiming;
use crate::teach::prompt::number;

impl TeachState {
    /// Opens the text prompt for an edit of the current key; a name starts from the present
    /// one (to correct a typo), numbers start empty (the question shows the present value).
    pub(super) fn ask_about_key(&mut self, field: Field) -> Vec<Command> {
        let Some(key) = self.list.show() else {
            return self.fail("no key yet: n adds one from the present pose");
        };
        if let Field::Value(j) = field {
            let joint = &self.robot.joints[j];
            if let Some(KeyValue::Transform(_)) = key.value(&joint.name) {
                return self.fail(format!(
                    "{} gives {} as a transform: edit it in the file",
                    self.key_label(self.list.current_index()),
                    joint.name
                ));
            }
        }
        let text = match field {
            Field::Name => key.name.clone().unwrap_or_default(),
            _ => String::new(),
        };
        self.ask(field, text)
    }

    /// Names the current key (empty: no name). A name another key has is kept but warned
    /// of, since `play --from NAME` refuses a name two keys share.
    pub(super) fn name_key(&mut self, text: &str) -> Vec<Command> {
        // The file would hold a name no keypose command loads (the studio's page can send
        // any character).
        if text.chars().any(crate::terminal_text::is_layout_control) {
            return self.fail(format!(
                "{text:?} holds a control character; a key name is text on one line: name unchanged"
            ));
        }
        let index = self.list.current_index();
        let name = (!text.is_empty()).then(|| text.to_string());
        self.list.set_name(name);
        let label = self.key_label(index);
        match self.name_clash(index, text) {
            Some(clash) => self.warn(format!("named {label}, but {clash}")),
            None if text.is_empty() => self.info(format!("{label} has no name now")),
            None => self.info(format!("named {label}")),
        }
        self.edited()
    }

    /// Why `name` would not pick key `index` out for `play --from`, if it would not.
    fn name_clash(&self, index: usize, name: &str) -> Option<String> {
        if name.is_empty() {
            return None;
        }
        let others: Vec<String> = (self.list.sequence().keyframes.iter().enumerate())
            .filter(|(i, key)| *i != index && key.name.as_deref() == Some(name))
            .map(|(i, _)| i.to_string())
            .collect();
        if !others.is_empty() {
            return Some(format!(
                "key {} has this name too: play --from {name} refuses a name two keys share",
                others.join(", ")
            ));
        }
        name.parse::<usize>().is_ok().then(|| {
            format!("play --from {name} reads a number as a key's index, not as this name")
        })
    }

    /// Sets the current key's hold in seconds (0 clears it); refused when the hold would run
    /// into the next key.
    pub(super) fn hold_key(&mut self, text: &str) -> Vec<Command> {
        let Some(hold) = number(text) else {
            return self.fail(format!(
                "{text:?} is not a number of seconds: hold unchanged"
            ));
        };
        if hold < 0.0 {
            return self.fail("a hold cannot be negative (0 clears it): hold unchanged");
        }
        let index = self.list.current_index();
        if !self.list.set_hold(hold) {
            // The hold is a valid number, so only the next key (or, after the last key of a
            // uniformly spaced list, the interval a new key would come at) refused it.
            let sequence = self.list.sequence();
            let gap = sequence.key_time(index + 1) - sequence.key_time(index);
            return self.fail(if index + 1 < self.list.len() {
                format!(
                    "a {hold} s hold runs into key {}, {gap:.2} s later: hold unchanged",
                    index + 1
                )
            } else {
                format!(
                    "a {hold} s hold is as long as the {gap:.2} s between keys (a key added \
                     after it would come then): hold unchanged"
                )
            });
        }
        let label = self.key_label(index);
        if hold == 0.0 {
            self.info(format!("{label} holds no longer"));
        } else {
            self.info(format!("{label} holds {hold} s"));
        }
        self.edited()
    }

    /// `e`: the selected joint's effort in the current key, percent of its servo's stall torque
    /// (empty clears it), refused at or above the servo's factory overload threshold (the
    /// player refuses it too, against the threshold it reads from the servo).
    pub(super) fn effort_key(&mut self, joint: usize, text: &str) -> Vec<Command> {
        let name = self.robot.joints[joint].name.clone();
        let percent = match text.trim().trim_end_matches('%').trim() {
            "" => None,
            t => match number(t) {
                Some(p) if p > 0.0 && p <= 100.0 => Some(p),
                _ => {
                    return self.fail(format!(
                        "{text:?} is not an effort from above 0 to 100 %: effort unchanged"
                    ))
                }
            },
        };
        let threshold = self.robot.joints[joint]
            .servo
            .model
            .spec()
            .table
            .overload
            .threshold_percent(None);
        if let Some(p) = percent.filter(|&p| p < 100.0 && p >= threshold) {
            return self.fail(format!(
                "{name} at {p} % would hold at or above its servo's overload threshold \
                 ({threshold:.0} %) and trip it: effort unchanged"
            ));
        }
        let index = self.list.current_index();
        if !self.list.set_effort(&name, percent) {
            return self.fail("no key to set an effort on: effort unchanged");
        }
        let label = self.key_label(index);
        match percent {
            Some(p) => self.info(format!(
                "{label}: {name} pushes with at most {p} % of its torque"
            )),
            None => self.info(format!(
                "{label}: {name}'s effort as the keys before it set it"
            )),
        }
        self.edited()
    }

    /// `p`: the next mode, in the order step → linear → cubic → smooth → monotone
    /// (`Interp::ALL`), for the segment from the current key. The sequence's own mode is stored
    /// as no override, so the file names it once and a later change of the default reaches the
    /// segment.
    pub(super) fn cycle_interp(&mut self) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no key yet: n adds one from the present pose");
        }
        let index = self.list.current_index();
        let label = self.key_label(index);
        if index + 1 >= self.list.len() {
            return self.fail(format!(
                "{label} is the last key: no segment follows it (n adds a key)"
            ));
        }
        let default = self.list.sequence().interpolation;
        let now = format::segment_interp(self.list.sequence(), index);
        let at = Interp::ALL.iter().position(|&m| m == now).unwrap_or(0);
        let next = Interp::ALL[(at + 1) % Interp::ALL.len()];
        self.list.set_interp((next != default).then_some(next));
        let note = if next == default {
            " (the sequence's default)"
        } else {
            ""
        };
        self.info(format!(
            "{label} → key {}: {}{note}",
            index + 1,
            next.name()
        ));
        self.edited()
    }

    /// Eases the segment from the current key: it speeds up evenly from rest over `out` % of
    /// its path and slows evenly to rest over the last `into` % (a trapezoidal profile,
    /// [`SegmentTiming::eased`](crate::sequence::SegmentTiming::eased)), its keys' times and
    /// path unchanged. Only where the interpolation allows it: a linear segment, whose path
    /// is the same however it is timed. A cubic's slopes at its keys come from its neighbours,
    /// so slowing to rest there would break the motion's smoothness; a tool line has its own
    /// timing.
    pub(super) fn ease(&mut self, out: u8, into: u8) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no key yet: n adds one from the present pose");
        }
        let index = self.list.current_index();
        let label = self.key_label(index);
        let sequence = self.list.sequence();
        if index + 1 >= self.list.len() {
            return self.fail(format!(
                "{label} is the last key: no segment follows it to ease"
            ));
        }
        let mode = format::segment_interp(sequence, index);
        let key = &sequence.keyframes[index];
        if key.line {
            return self.fail(format!(
                "{label} → key {}: a straight tool line is timed by its own ease",
                index + 1
            ));
        }
        if mode != Interp::Linear {
            return self.fail(format!(
                "{label} → key {}: easing is for linear segments (this one is {}: p makes it linear)",
                index + 1,
                mode.name()
            ));
        }
        if u16::from(out) + u16::from(into) > 100 || out % 5 != 0 || into % 5 != 0 {
            return self.fail(format!(
                "ease {out} % and {into} %: expected multiples of 5 % that add up to 100 % at most"
            ));
        }
        let paths = sequence.path_times();
        let path_time = paths[index + 1] - paths[index] - key.hold;
        let timing =
            SegmentTiming::eased(path_time, f64::from(out) / 100.0, f64::from(into) / 100.0);
        let steady = timing.is_none();
        self.list.set_timing(timing);
        if steady {
            self.info(format!("{label} → key {}: steady (no easing)", index + 1));
        } else {
            self.info(format!(
                "{label} → key {}: speeds up over {out} % of the way, slows down over {into} %",
                index + 1
            ));
        }
        self.edited()
    }

    /// Sets joint `j` of the current key to a value typed in the screen's unit, refused
    /// outside the joint's limits. With the arm held, offers to move it there by the safe
    /// ramp of `space` rather than jump.
    pub(super) fn type_value(&mut self, j: usize, text: &str) -> Vec<Command> {
        let joint = &self.robot.joints[j];
        let Some(shown) = number(text) else {
            return self.fail(format!(
                "{text:?} is not a number: {} unchanged",
                joint.name
            ));
        };
        let value = format::from_screen(joint, shown);
        if !(joint.limits.min..=joint.limits.max).contains(&value) {
            return self.fail(format!(
                "{shown}{} is outside {}'s limits {}: unchanged",
                format::unit(joint),
                joint.name,
                format::limits(joint)
            ));
        }
        let name = joint.name.clone();
        let shown_value = format::value(joint, value);
        self.list.set_value(&name, KeyValue::Joint(value));
        let label = self.key_label(self.list.current_index());
        let held = self.torque.iter().all(|&t| t);
        let later = if !held {
            " (once the arm is held, space moves it there)"
        } else if self.is_moving() {
            " (once the arm stops, space moves it there)"
        } else {
            // Asked, not done: the arm may be far from the key, and the user is looking at
            // the number, not at the arm.
            self.prompt = Some(Prompt::MoveThere);
            ""
        };
        self.info(format!("{label}: {name} {shown_value}{later}"));
        self.edited()
    }

    /// Makes key `index` current, as `>`/`<` would step to it.
    pub(super) fn select_key(&mut self, index: usize) -> Vec<Command> {
        if !self.list.select(index) {
            return self.fail(format!(
                "there is no key {index} ({})",
                format::count(self.list.len())
            ));
        }
        let label = self.key_label(index);
        self.info(format!("{label} (space moves the arm there)"));
        Vec::new()
    }

    /// Moves the current key to `millis` ms (a drag on the timeline), keeping the keys in
    /// order; a uniformly spaced list becomes a timed one.
    /// A new key from the present pose at `millis` ms (the timeline's parked playhead),
    /// where that time falls among the keys; refused, nothing added, where it does not fit.
    pub(super) fn capture_at(&mut self, millis: u64) -> Vec<Command> {
        let time = millis as f64 / 1000.0;
        let (values, note) = self.capture();
        if let Err(why) = self.list.insert_at(values, time) {
            return self.fail(format!("no key captured at {time:.3} s: {why}"));
        }
        self.info(format!(
            "new {} at {time:.3} s from the present pose{note} ({})",
            self.key_label(self.list.current_index()),
            format::count(self.list.len())
        ));
        self.edited()
    }

    pub(super) fn set_key_time(&mut self, millis: u64) -> Vec<Command> {
        let time = millis as f64 / 1000.0;
        let label = self.key_label(self.list.current_index());
        if let Err(why) = self.list.set_time(time) {
            return self.fail(format!("{label} stays where it was: {why}"));
        }
        self.info(format!("{label} at {time:.3} s"));
        self.edited()
    }
}
