//! Sequences: keyframe lists in the `keypose-sequence/1` format.
//!
//! This module knows the file format and the rules that hold for any robot (times, holds,
//! quaternions). What depends on a robot — joint names, axes, limits — is checked by `plan`,
//! which reports through the same [`InputError`] with the key's path in the original file.

mod edit;
mod layout;
mod load;
mod save;
mod selection;
mod timing;

use crate::curve::Interp;
use crate::json::InputError;
use crate::pose::RigidTransform;
use glam::{DQuat, DVec3};
use std::path::Path;

pub use edit::{KeyframeList, TimeRefusal};
pub use load::{valid_arm_name, MAX_TIME, MIN_GAP};
pub use timing::{HoldTiming, SegmentTiming, TimeProfile, EASE_STEPS, MAX_SPEEDS};

/// The `"format"` field of a sequence file this version reads and writes.
pub const SEQUENCE_FORMAT: &str = "keypose-sequence/1";
/// Seconds between untimed keys when the file gives no `key_interval`.
pub const DEFAULT_KEY_INTERVAL: f64 = 2.0;

/// Whether the first and last keys are played, or only shape the curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ends {
    /// Every key is played, the first and last included (the default).
    Played,
    /// The first and last keys are control points: playback runs from the second key to the
    /// second-to-last.
    Control,
}

/// What a key says about one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KeyValue {
    /// Degrees for a revolute joint, metres for a prismatic one.
    Joint(f64),
    /// Percent (0 … 100) of the range a LeRobot calibration recorded, as LeRobot's 0…100 scale
    /// counts it; written `"40%"`. Resolved to a joint value once the calibrated robot is known
    /// (`Trajectory::build`), and saved back as written.
    Percent(f64),
    /// The joint's rigid transform relative to its zero pose.
    Transform(RigidTransform),
}

/// How a tool key gives the tool's orientation, kept as written so saving gives it back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToolOrientation {
    /// `"r": {w, x, y, z}`, a unit quaternion.
    Quaternion(DQuat),
    /// `"rpy": [roll, pitch, yaw]`, radians, URDF convention (R = Rz·Ry·Rx).
    Rpy([f64; 3]),
}

impl ToolOrientation {
    /// The orientation as a unit quaternion, whichever way it was written.
    pub fn quaternion(&self) -> DQuat {
        match *self {
            ToolOrientation::Quaternion(q) => q,
            ToolOrientation::Rpy([r, p, y]) => crate::pose::quat_from_rpy(r, p, y),
        }
    }
}

/// A key's `"approach"`: which way the tool points, the turn about that way left free.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolApproach {
    /// `"down"`: the tool points straight down (the base frame's −z); a key the arm cannot
    /// reach so is an error.
    Down,
    /// `"down-or-tilted"`: down where the arm can, else tilted from down as little as it must.
    DownOrTilted,
}

impl ToolApproach {
    /// Every approach, in the order messages list them.
    pub const ALL: [ToolApproach; 2] = [ToolApproach::Down, ToolApproach::DownOrTilted];

    /// As written in a file (and `pose --approach`).
    pub fn spelling(self) -> &'static str {
        match self {
            ToolApproach::Down => "down",
            ToolApproach::DownOrTilted => "down-or-tilted",
        }
    }

    /// The approach written `text`, if any.
    pub fn parse(text: &str) -> Option<ToolApproach> {
        Self::ALL.into_iter().find(|a| a.spelling() == text)
    }
}

/// A key's `"tool"`: where the robot's tool frame (`tcp`) goes, in the base frame. Inverse
/// kinematics turns it into joint values when the robot is known (`Trajectory::build`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolKey {
    /// Metres.
    pub xyz: DVec3,
    /// The tool frame's orientation; `None` leaves it to the solver.
    pub orientation: Option<ToolOrientation>,
    /// Which way the tool points, for a key without an orientation.
    pub approach: Option<ToolApproach>,
}

/// What a key's declared contact may touch.
#[derive(Debug, Clone, PartialEq)]
pub enum ContactWith {
    /// `"floor"`: the desk the arm stands on (z = 0 of its frame).
    Floor,
    /// Another link, named as `link` is.
    Link(String),
}

/// A contact a key means to make (`"contact": [{"link": "gripper", "with": "floor"}]`): a pen
/// on paper, a finger pressing a button. The check lets `link` come closer to `with` than the
/// clearance, down to `depth_mm` into it, on the segments either side of the key and in its
/// hold; anywhere else, and any deeper, it is a finding like any other.
#[derive(Debug, Clone, PartialEq)]
pub struct DeclaredContact {
    /// A link: a joint's name (the part it moves), or `"base"`; in a cell `ARM/JOINT` or
    /// `ARM/base`.
    pub link: String,
    /// What it may touch.
    pub with: ContactWith,
    /// How deep it may go into it, millimetres.
    pub depth_mm: f64,
}

/// How deep a declared contact may go when the key does not say, millimetres: a pen's or a
/// fingertip's give, not room for a crash.
pub const DEFAULT_CONTACT_DEPTH_MM: f64 = 2.0;

/// One key of a sequence: a pose (joint values, a tool target, or both), when it is reached
/// and how the motion leaves it.
#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    /// The key's name, shown by the teach pendant and in messages; `None` for an unnamed key.
    pub name: Option<String>,
    /// Absolute time in seconds; `None` in a uniformly spaced sequence.
    pub time: Option<f64>,
    /// Seconds the pose stays at this key before moving on.
    pub hold: f64,
    /// Mode of the segment after this key, overriding the sequence's.
    pub interp: Option<Interp>,
    /// (joint name, value) in the order written.
    pub values: Vec<(String, KeyValue)>,
    /// The tool pose this key asks for, solved into the joints `values` does not give.
    pub tool: Option<ToolKey>,
    /// In a sequence of several arms, each arm's tool target (`"tool": {"left": {..}}`), in
    /// that arm's own base frame; `tool` stays `None` there.
    pub arm_tools: Vec<(String, ToolKey)>,
    /// `"interp": "line"`: the tool moves in a straight line from this key to the next.
    pub line: bool,
    /// `"timing"`: how the segment after this key runs along its curve; `None` runs it at the
    /// pace of the key times.
    pub timing: Option<SegmentTiming>,
    /// `"contact"`: the contacts this key means to make (empty: none).
    pub contact: Vec<DeclaredContact>,
    /// `"effort"`: (joint name, percent of its servo's stall torque) from the segment that
    /// arrives at this key on, until a later key sets another (`plan::EffortLimit`).
    pub effort: Vec<(String, f64)>,
    /// Index of this key in the file it was loaded from, for error paths after sorting.
    pub source_index: Option<usize>,
}

impl Keyframe {
    /// An untimed, unnamed key with these joint values, no hold and no tool target.
    pub fn new(values: Vec<(String, KeyValue)>) -> Self {
        Self {
            name: None,
            time: None,
            hold: 0.0,
            interp: None,
            values,
            tool: None,
            arm_tools: Vec::new(),
            line: false,
            timing: None,
            contact: Vec::new(),
            effort: Vec::new(),
            source_index: None,
        }
    }

    /// The value this key gives `joint`; `None` when it does not name the joint.
    pub fn value(&self, joint: &str) -> Option<&KeyValue> {
        self.values
            .iter()
            .find(|(name, _)| name == joint)
            .map(|(_, v)| v)
    }

    /// Sets a joint's value, replacing any earlier one for the same joint.
    pub fn set(&mut self, joint: &str, value: KeyValue) {
        match self.values.iter_mut().find(|(name, _)| name == joint) {
            Some(slot) => slot.1 = value,
            None => self.values.push((joint.to_string(), value)),
        }
    }

    /// Seconds of path time the key's hold spans: its seconds, unless its timing runs the hold
    /// on an S-curve of its own over another path time (`retime --fastest` lengthens a hold
    /// whose joints cannot go through its path time in its seconds under jerk limits).
    pub fn hold_path_time(&self) -> f64 {
        match self.timing.as_ref().and_then(|t| t.hold) {
            Some(hold) if self.hold > 0.0 => hold.path_time,
            _ => self.hold,
        }
    }

    /// "name" or "#index" for messages.
    pub fn label(&self, index: usize) -> String {
        match &self.name {
            Some(name) => name.clone(),
            None => format!("#{index}"),
        }
    }
}

/// One arm of a sequence that names several (`"robots"`): its name, which is the prefix of its
/// joints (`ARM/JOINT`), its robot, and where its base stands in the cell.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmSpec {
    /// The arm's name (`left`, `right`, …), the prefix of its joints.
    pub name: String,
    /// A built-in robot, a LeRobot type or a robot file, as for `"robot"`.
    pub robot: String,
    /// The arm's base frame in the cell frame; `None` is the cell's origin.
    pub base: Option<Placement>,
}

/// A frame's place as written in a file, `xyz` in metres and optionally a rotation (`rpy` in
/// radians, URDF order, or `quat` `[w, x, y, z]`), kept as written so saving gives it back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Position, metres.
    pub xyz: DVec3,
    /// Rotation; `None` is no rotation.
    pub rotation: Option<ToolOrientation>,
}

/// Where an arm's base stands when nothing says (a LeRobot dataset, a recording): this far to
/// either side of the cell origin along y, both facing +x as an arm's own base frame does. 0.4 m
/// apart is less than an SO-101's reach (its tool is 0.39 m ahead of its base at the zero pose),
/// so the arms' spaces overlap between them, where bimanual tasks hand things over; the user
/// edits `"base"` for the real bench.
pub const DEFAULT_ARM_HALF_SPACING_M: f64 = 0.2;

impl Placement {
    /// The base of arm `arm` when nothing says (see [`DEFAULT_ARM_HALF_SPACING_M`]): `left` on
    /// +y (the cell's left when facing +x), `right` on −y, any other arm at the origin. Written
    /// with a zero roll-pitch-yaw, so the file shows where to turn an arm.
    pub fn default_for(arm: &str) -> Placement {
        let y = match arm {
            "left" => DEFAULT_ARM_HALF_SPACING_M,
            "right" => -DEFAULT_ARM_HALF_SPACING_M,
            _ => 0.0,
        };
        Placement {
            xyz: DVec3::new(0.0, y, 0.0),
            rotation: Some(ToolOrientation::Rpy([0.0; 3])),
        }
    }

    /// A placement written as `xyz` and `quat`.
    pub fn from_transform(transform: RigidTransform) -> Self {
        Placement {
            xyz: transform.t,
            rotation: Some(ToolOrientation::Quaternion(transform.r)),
        }
    }

    /// The placement as a rigid transform (identity rotation when none is written).
    pub fn transform(&self) -> RigidTransform {
        let r = self.rotation.map_or(DQuat::IDENTITY, |o| o.quaternion());
        RigidTransform::new(self.xyz, r)
    }
}

/// A sequence file in memory: which robot (or arms), how keys are interpolated and spaced, and
/// the keyframes.
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    /// Where it came from, for messages (`"<new>"` when built in memory).
    pub file: String,
    /// The robot of a one-arm sequence; empty when `arms` names several.
    pub robot: String,
    /// The arms of a sequence for several (`"robots"`), in the order written; empty for one.
    pub arms: Vec<ArmSpec>,
    /// Free text about the sequence; `None` when the file has none.
    pub description: Option<String>,
    /// Mode of every segment whose key does not set its own.
    pub interpolation: Interp,
    /// Whether the first and last keys are played.
    pub ends: Ends,
    /// Spacing of untimed keys; `None` when keys carry absolute times.
    pub key_interval: Option<f64>,
    /// In time order.
    pub keyframes: Vec<Keyframe>,
    /// The text it was loaded from, so that saving keeps what the user did not change.
    pub(crate) source: layout::Source,
}

impl Sequence {
    /// An empty sequence for `robot` with uniform spacing, interpolated `monotone`: unlike a
    /// cubic it cannot overshoot a key taught next to a limit (as `record` uses it too).
    pub fn new(robot: &str) -> Self {
        Self {
            file: "<new>".into(),
            robot: robot.into(),
            arms: Vec::new(),
            description: None,
            interpolation: Interp::Monotone,
            ends: Ends::Played,
            key_interval: Some(DEFAULT_KEY_INTERVAL),
            keyframes: Vec::new(),
            source: layout::Source::default(),
        }
    }

    /// Reads and checks a sequence file (the rules that hold for any robot).
    pub fn load(path: &Path) -> Result<Sequence, InputError> {
        let text = crate::json::read_text(path)?;
        load::parse_sequence(&path.display().to_string(), &text)
    }

    /// Parses sequence text; `file` names the source in errors.
    pub fn from_json(file: &str, text: &str) -> Result<Sequence, InputError> {
        load::parse_sequence(file, text)
    }

    /// The list a JSON node holds (a member of another file, such as the teach journal's
    /// list and its undo history): a sequence, or one without keys, as a list being edited may
    /// be; errors name the file and the node's path.
    pub(crate) fn from_node(node: &crate::json::Node) -> Result<Sequence, InputError> {
        load::sequence_from_node(node, true)
    }

    /// The sequence as a `keypose-sequence/1` JSON value, for a file that holds it as a
    /// member (the teach journal).
    pub(crate) fn to_value(&self) -> serde_json::Value {
        save::to_value(self)
    }

    /// The sequence as `keypose-sequence/1` JSON text in the canonical layout: one key per
    /// line, fields in a fixed order.
    pub fn to_json(&self) -> String {
        save::to_json(self)
    }

    /// The sequence as [`Sequence::save`] writes it: in the layout of the file it was loaded
    /// from, every value nobody changed in its original text (`0.7071` stays `0.7071`), changed
    /// values in the shortest form that reads back the same; the canonical layout
    /// ([`Sequence::to_json`]) for a sequence that came from no file.
    pub fn to_text(&self) -> String {
        layout::to_text(self)
    }

    /// Whether `other` has the same keys and settings, wherever each came from and however
    /// its file is laid out (a key's place in its file is not part of it).
    pub fn same_content(&self, other: &Sequence) -> bool {
        let unplaced = |k: &Keyframe| Keyframe {
            source_index: None,
            ..k.clone()
        };
        self.robot == other.robot
            && self.arms == other.arms
            && self.description == other.description
            && self.interpolation == other.interpolation
            && self.ends == other.ends
            && self.key_interval == other.key_interval
            && self.keyframes.len() == other.keyframes.len()
            && (self.keyframes.iter().map(unplaced)).eq(other.keyframes.iter().map(unplaced))
    }

    /// The text of the file this sequence was loaded from or last written to, when it keeps
    /// that file's layout ([`Sequence::to_text`]).
    pub(crate) fn source_text(&self) -> Option<&str> {
        self.source.text()
    }

    /// Where each key was in the file of [`Sequence::source_text`] (`None`: a new key).
    pub(crate) fn source_places(&self) -> Vec<Option<usize>> {
        self.keyframes.iter().map(|k| k.source_index).collect()
    }

    /// Takes on the layout of `file` (a sequence loaded from the file this one was edited
    /// from), `places` saying where each of this one's keys was in it: a list recovered from
    /// the teach journal is then saved in its file's layout, as it would have been before the
    /// crash. Places beyond the keys, or keys beyond the places, count as new keys.
    pub(crate) fn adopt_layout(&mut self, file: &Sequence, places: &[Option<usize>]) {
        self.source = file.source.clone();
        for (index, key) in self.keyframes.iter_mut().enumerate() {
            key.source_index = places.get(index).copied().flatten();
        }
    }

    /// Takes `text`, which has just been written for this sequence, as the file it now comes
    /// from: the next save keeps its layout, and keys are matched to their places in it.
    pub fn mark_written(&mut self, text: &str) {
        layout::written(self, text);
    }

    /// Writes the sequence atomically, so a crash never leaves a half-written file, as
    /// [`Sequence::to_text`] has it.
    pub fn save(&self, path: &Path) -> Result<(), InputError> {
        self.validate()?;
        crate::atomic_file::write(path, self.to_text().as_bytes()).map_err(|e| {
            InputError::new(
                &path.display().to_string(),
                crate::json::Location::File,
                format!("cannot write: {e}"),
            )
        })
    }

    /// An empty sequence for the arms of a cell (see [`Sequence::new`]).
    pub fn new_cell(arms: Vec<ArmSpec>) -> Self {
        Self {
            robot: String::new(),
            arms,
            ..Self::new("")
        }
    }

    /// Whether the sequence is for several arms (`"robots"`).
    pub fn is_cell(&self) -> bool {
        !self.arms.is_empty()
    }

    /// Time of keyframe `index`.
    pub fn key_time(&self, index: usize) -> f64 {
        match self.key_interval {
            Some(interval) => index as f64 * interval,
            None => self.keyframes[index].time.unwrap_or(0.0),
        }
    }

    /// Every keyframe's time, seconds, in order.
    pub fn key_times(&self) -> Vec<f64> {
        (0..self.keyframes.len())
            .map(|i| self.key_time(i))
            .collect()
    }

    /// Every keyframe's path time, seconds: the time its segments' curves are shaped with.
    /// The key times themselves, except after a segment with a timing profile, whose curve
    /// spans the profile's `path_time` however long it takes to run.
    pub fn path_times(&self) -> Vec<f64> {
        let times = self.key_times();
        let mut out = Vec::with_capacity(times.len());
        for (i, &t) in times.iter().enumerate() {
            let path = match i.checked_sub(1) {
                None => t,
                Some(p) => {
                    let key = &self.keyframes[p];
                    let moving = match &key.timing {
                        Some(timing) => timing.path_time,
                        None => t - times[p] - key.hold,
                    };
                    out[p] + key.hold_path_time() + moving
                }
            };
            out.push(path);
        }
        out
    }

    /// Whether any segment has a timing profile.
    pub fn has_timing(&self) -> bool {
        self.keyframes.iter().any(|k| k.timing.is_some())
    }

    /// Gives every key an absolute time (the uniform spacing made explicit).
    pub fn make_times_absolute(&mut self) {
        let times = self.key_times();
        for (key, time) in self.keyframes.iter_mut().zip(times) {
            key.time = Some(time);
        }
        self.key_interval = None;
    }

    /// The JSON path of a keyframe (by its index in time order) in the file it came from.
    pub fn key_path(&self, index: usize) -> String {
        let source = self.keyframes[index].source_index.unwrap_or(index);
        format!("$.keyframes[{source}]")
    }

    /// Checks the robot-independent rules; loading applies the same rules with paths.
    pub fn validate(&self) -> Result<(), InputError> {
        load::validate_keys(self)
    }
}
