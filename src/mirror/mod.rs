//! Mirroring a motion: the mirror image of a key or of a whole sequence across an arm's own
//! vertical plane (docs/robots.md §13), in place or from one arm of a cell onto another.
//!
//! Joint values follow each joint's [`JointRule`] (derived from the robot's geometry by
//! [`ArmMirror::of`]); `"transforms"` values are joint motions, so the mirror of one is its
//! inverse; tool targets are reflected across the plane. What lands outside the target joint's
//! limits (their ranges need not be symmetric) is clipped to the limit and reported as a
//! [`Clip`].

mod plane;

pub use plane::{ArmMirror, JointRule, MirrorPlane, AXIS_TOLERANCE_DEG, MIN_REACH_M};

use crate::plan;
use crate::robot::{cell_joint_name, split_joint_name, Joint, Robot};
use crate::sequence::{KeyValue, Keyframe, Sequence};

/// Why a motion cannot be mirrored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MirrorError {
    /// The tool point is too close to the first joint's vertical to fix the arm's plane.
    #[error("robot {robot}: the tool point is {distance_m:.4} m from the first joint's vertical at the zero pose; expected at least {min} m to fix the arm's vertical plane", min = MIN_REACH_M)]
    NoPlane {
        /// The robot's name.
        robot: String,
        /// Horizontal distance of the tool point from the first joint's axis, metres.
        distance_m: f64,
    },
    /// A joint axis neither in the arm's plane nor square to it.
    #[error("robot {robot}: the axis of {joint} is {angle_deg:.2}° out of the arm's vertical plane at the zero pose; expected it in the plane or square to it (within {tolerance_deg}°), or no mirror image is a motion of the joints")]
    ObliqueAxis {
        /// The robot's name.
        robot: String,
        /// The joint's name.
        joint: String,
        /// How far out of the plane the axis is, degrees.
        angle_deg: f64,
        /// [`AXIS_TOLERANCE_DEG`].
        tolerance_deg: f64,
    },
    /// `--arms` given for a sequence of one arm.
    #[error("--arms: {file} is a sequence for one arm; expected a sequence for several (\"robots\"), or no --arms")]
    NotACell {
        /// The sequence file.
        file: String,
    },
    /// `--arms` names an arm the sequence does not have.
    #[error("--arms: unknown arm {name:?} in {file}; expected one of: {}", expected.join(", "))]
    UnknownArm {
        /// The sequence file.
        file: String,
        /// The arm named.
        name: String,
        /// The sequence's arms.
        expected: Vec<String>,
    },
    /// `--arms A:A`.
    #[error("--arms: {name}:{name} mirrors an arm onto itself; expected two different arms (or no --arms to mirror each in place)")]
    SameArm {
        /// The arm named twice.
        name: String,
    },
    /// The two arms are not the same robot, so one's motion is no motion of the other.
    #[error("--arms: arms {from} and {to} have different joints ({} and {}); expected the same robot", from_joints.join(", "), to_joints.join(", "))]
    DifferentArms {
        /// The arm whose motion is mirrored.
        from: String,
        /// The arm it is mirrored onto.
        to: String,
        /// `from`'s joints.
        from_joints: Vec<String>,
        /// `to`'s joints.
        to_joints: Vec<String>,
    },
    /// A key that would set nothing once the source arm's motion replaces the target's.
    #[error("{file}: {path}: key {label} sets nothing for arm {from}, whose motion replaces {to}'s: it would set no joint; expected every key to set a joint or tool target of {from} (or no --arms, to mirror each arm in place)")]
    EmptyKey {
        /// The sequence file.
        file: String,
        /// The key's JSON path.
        path: String,
        /// The key's name, or "#index".
        label: String,
        /// The arm whose motion is mirrored.
        from: String,
        /// The arm it is mirrored onto.
        to: String,
    },
    /// A key's value that is no value of its joint ([`plan::KeyValueError`]).
    #[error("{file}: {path}: {message}")]
    Value {
        /// The sequence file.
        file: String,
        /// The value's JSON path.
        path: String,
        /// Why it is no value of the joint.
        message: String,
    },
}

/// Which arm's motion goes where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mapping<'a> {
    /// Every arm (or the one arm) mirrored in its own plane.
    InPlace,
    /// The motion of arm `from` mirrored onto arm `to`, whose own keys it replaces.
    Onto {
        /// The arm whose motion is mirrored.
        from: &'a str,
        /// The arm it is mirrored onto.
        to: &'a str,
    },
}

/// A mirrored value outside the target joint's limits, clipped to the limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Clip {
    /// Index of the key in time order.
    pub key: usize,
    /// Its name or "#index".
    pub key_label: String,
    /// The target joint's name.
    pub joint: String,
    /// The mirrored value, in the joint's unit.
    pub value: f64,
    /// The limit it was clipped to.
    pub limit: f64,
    /// "deg" or "m".
    pub unit: &'static str,
}

impl std::fmt::Display for Clip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "key {} ({}): {} mirrored to {:.3} {unit}, outside its limits: clipped to {} {unit}",
            self.key,
            self.key_label,
            self.joint,
            self.value,
            self.limit,
            unit = self.unit
        )
    }
}

/// One arm's motion going to one arm: names as the keys write them (with or without `ARM/`).
#[derive(Debug, Clone)]
struct Pair {
    /// The arm names in a cell; None for a robot of one arm.
    from: Option<String>,
    to: Option<String>,
    /// The source arm's plane and rules (the target's are the same robot's).
    arm: ArmMirror,
}

/// A mirroring worked out for a robot (one arm, or a cell) and a [`Mapping`].
#[derive(Debug, Clone)]
pub struct Mirror {
    pairs: Vec<Pair>,
}

impl Mirror {
    /// Derives every arm's plane and rules; `file` names the sequence in errors.
    pub fn new(robot: &Robot, mapping: Mapping, file: &str) -> Result<Mirror, MirrorError> {
        let pairs = match (robot.is_cell(), mapping) {
            (false, Mapping::InPlace) => vec![Pair {
                from: None,
                to: None,
                arm: ArmMirror::of(robot)?,
            }],
            (false, Mapping::Onto { .. }) => {
                return Err(MirrorError::NotACell { file: file.into() })
            }
            (true, Mapping::InPlace) => robot
                .arms
                .iter()
                .map(|a| {
                    Ok(Pair {
                        from: Some(a.name.clone()),
                        to: Some(a.name.clone()),
                        arm: ArmMirror::of(&a.robot)?,
                    })
                })
                .collect::<Result<_, MirrorError>>()?,
            (true, Mapping::Onto { from, to }) => vec![onto(robot, from, to, file)?],
        };
        Ok(Mirror { pairs })
    }

    /// The mapping teach and the studio use for the arm of joint `selected`: onto the other arm
    /// of a two-arm cell, else in place.
    pub fn for_selected_joint(robot: &Robot, selected: usize) -> Mapping<'_> {
        match (robot.arms.as_slice(), robot.arm_of_joint(selected)) {
            ([a, b], Some(arm)) => {
                let other = if arm.name == a.name { b } else { a };
                Mapping::Onto {
                    from: &arm.name,
                    to: &other.name,
                }
            }
            _ => Mapping::InPlace,
        }
    }

    /// Mirrors every key of `sequence`; the clips are in key order.
    pub fn sequence(
        &self,
        sequence: &Sequence,
        robot: &Robot,
    ) -> Result<(Sequence, Vec<Clip>), MirrorError> {
        let mut mirrored = sequence.clone();
        let mut clips = Vec::new();
        for index in 0..mirrored.keyframes.len() {
            clips.extend(self.key(&mut mirrored, robot, index)?);
        }
        Ok((mirrored, clips))
    }

    /// Mirrors key `index` of `sequence` in place.
    pub fn key(
        &self,
        sequence: &mut Sequence,
        robot: &Robot,
        index: usize,
    ) -> Result<Vec<Clip>, MirrorError> {
        let context = KeyContext {
            file: sequence.file.clone(),
            path: sequence.key_path(index),
            label: sequence.keyframes[index].label(index),
            index,
        };
        let key = &mut sequence.keyframes[index];
        let mut clips = Vec::new();
        for pair in &self.pairs {
            clips.extend(pair.mirror_key(key, robot, &context)?);
        }
        Ok(clips)
    }
}

/// The pair for `--arms from:to`, checked.
fn onto(robot: &Robot, from: &str, to: &str, file: &str) -> Result<Pair, MirrorError> {
    let find = |name: &str| {
        robot.arm(name).ok_or_else(|| MirrorError::UnknownArm {
            file: file.into(),
            name: name.into(),
            expected: robot.arms.iter().map(|a| a.name.clone()).collect(),
        })
    };
    let (source, target) = (find(from)?, find(to)?);
    if from == to {
        return Err(MirrorError::SameArm { name: from.into() });
    }
    let joints = |r: &Robot| -> Vec<String> { r.joints.iter().map(|j| j.name.clone()).collect() };
    if joints(&source.robot) != joints(&target.robot) {
        return Err(MirrorError::DifferentArms {
            from: from.into(),
            to: to.into(),
            from_joints: joints(&source.robot),
            to_joints: joints(&target.robot),
        });
    }
    Ok(Pair {
        from: Some(from.into()),
        to: Some(to.into()),
        arm: ArmMirror::of(&source.robot)?,
    })
}

/// Where a key is, for reports and errors.
struct KeyContext {
    file: String,
    path: String,
    label: String,
    index: usize,
}

impl Pair {
    /// The arm-local name of a key's joint if it is this pair's source arm's.
    fn source_joint<'n>(&self, name: &'n str) -> Option<&'n str> {
        match &self.from {
            None => Some(name),
            Some(arm) => split_joint_name(name)
                .filter(|(a, _)| a == arm)
                .map(|(_, j)| j),
        }
    }

    fn full_name(arm: &Option<String>, joint: &str) -> String {
        match arm {
            None => joint.to_string(),
            Some(arm) => cell_joint_name(arm, joint),
        }
    }

    fn mirror_key(
        &self,
        key: &mut Keyframe,
        robot: &Robot,
        at: &KeyContext,
    ) -> Result<Vec<Clip>, MirrorError> {
        let (mirrored, clips) = self.mirror_values(key, robot, at)?;
        self.place_values(key, mirrored);
        self.mirror_tools(key);
        if key.values.is_empty() && key.tool.is_none() && key.arm_tools.is_empty() {
            return Err(MirrorError::EmptyKey {
                file: at.file.clone(),
                path: at.path.clone(),
                label: at.label.clone(),
                from: self.from.clone().unwrap_or_default(),
                to: self.to.clone().unwrap_or_default(),
            });
        }
        Ok(clips)
    }

    /// The source arm's values of `key`, mirrored and named as the target arm's, in the order
    /// written, and what had to be clipped.
    fn mirror_values(
        &self,
        key: &Keyframe,
        robot: &Robot,
        at: &KeyContext,
    ) -> Result<(Values, Vec<Clip>), MirrorError> {
        let mut clips = Vec::new();
        let mut mirrored = Vec::new();
        for (name, value) in &key.values {
            let Some(local) = self.source_joint(name) else {
                continue;
            };
            let target_name = Self::full_name(&self.to, local);
            let value_error = |message: String| MirrorError::Value {
                file: at.file.clone(),
                path: plan::key_value_path(&at.path, name, value),
                message,
            };
            let (Some(rule), Some(source), Some(target)) = (
                self.arm.rule(local),
                robot.joint_index(name),
                robot.joint_index(&target_name),
            ) else {
                return Err(value_error(format!(
                    "unknown joint {name:?}; expected one of: {}",
                    robot.joint_names().join(", ")
                )));
            };
            let (value, clip) = mirror_value(rule, value, robot, source, target)
                .map_err(|error| value_error(error.to_string()))?;
            if let Some((value, limit)) = clip {
                clips.push(Clip {
                    key: at.index,
                    key_label: at.label.clone(),
                    joint: target_name.clone(),
                    value,
                    limit,
                    unit: robot.joints[target].kind.unit(),
                });
            }
            mirrored.push((target_name, value));
        }
        Ok((mirrored, clips))
    }

    /// Puts the mirrored values in the key: in place where the source's stood, or instead of
    /// all the target arm's.
    fn place_values(&self, key: &mut Keyframe, mirrored: Values) {
        if self.from == self.to {
            let slots = key
                .values
                .iter_mut()
                .filter(|(n, _)| self.source_joint(n).is_some());
            for (slot, (_, value)) in slots.zip(mirrored) {
                slot.1 = value;
            }
        } else {
            let to = self.to.as_deref().unwrap_or_default();
            key.values
                .retain(|(n, _)| split_joint_name(n).is_none_or(|(a, _)| a != to));
            key.values.extend(mirrored);
        }
    }

    /// The tool target of the source arm, reflected, becomes the target arm's.
    fn mirror_tools(&self, key: &mut Keyframe) {
        match (&self.from, &self.to) {
            (Some(from), Some(to)) => {
                let source = key
                    .arm_tools
                    .iter()
                    .find(|(a, _)| a == from)
                    .map(|(_, t)| self.arm.reflect_tool(t));
                match key.arm_tools.iter_mut().find(|(a, _)| a == to) {
                    Some(slot) => match source {
                        Some(tool) => slot.1 = tool,
                        None => key.arm_tools.retain(|(a, _)| a != to),
                    },
                    None => key.arm_tools.extend(source.map(|t| (to.clone(), t))),
                }
            }
            _ => key.tool = key.tool.map(|t| self.arm.reflect_tool(&t)),
        }
    }
}

/// A key's values as it names them, in the order written.
type Values = Vec<(String, KeyValue)>;

/// A mirrored value, and (value, limit) when it had to be clipped to a limit.
type Mirrored = (KeyValue, Option<(f64, f64)>);

/// The mirror image of joint `source`'s value as joint `target`'s, clipped into `target`'s
/// limits when it falls outside them.
fn mirror_value(
    rule: JointRule,
    value: &KeyValue,
    robot: &Robot,
    source: usize,
    target: usize,
) -> Result<Mirrored, plan::KeyValueError> {
    let (from, to) = (&robot.joints[source], &robot.joints[target]);
    let original = plan::joint_value(from, value, robot.home[source])?;
    let sign = if rule == JointRule::Negate { -1.0 } else { 1.0 };
    let mirrored = match (*value, rule) {
        (_, JointRule::Keep | JointRule::Gripper) => *value,
        // `0 − v`, not `−v`: a zero stays 0 rather than becoming −0 in the file.
        (KeyValue::Joint(v), JointRule::Negate) => KeyValue::Joint(0.0 - v),
        (KeyValue::Transform(tf), JointRule::Negate) => KeyValue::Transform(inverse(&tf)),
        (KeyValue::Percent(_), JointRule::Negate) => as_percent(to, 0.0 - original),
    };
    // A percent means a share of the target's own range; anything else the number mirrored.
    let wanted = match mirrored {
        KeyValue::Percent(_) => plan::joint_value(to, &mirrored, robot.home[target])?,
        KeyValue::Joint(v) => v,
        KeyValue::Transform(_) => sign * original,
    };
    if to.limits.contains(wanted) {
        return Ok((mirrored, None));
    }
    let limit = wanted.clamp(to.limits.min, to.limits.max);
    let clipped = match mirrored {
        KeyValue::Joint(_) => KeyValue::Joint(limit),
        KeyValue::Percent(_) => as_percent(to, limit),
        KeyValue::Transform(_) => KeyValue::Transform(to.motion(limit)),
    };
    Ok((clipped, Some((wanted, limit))))
}

/// `value` as a percent of `joint`'s calibrated range, or as a number when it has none.
fn as_percent(joint: &Joint, value: f64) -> KeyValue {
    match joint.calibrated_range {
        Some(range) => KeyValue::Percent(range.percent(value)),
        None => KeyValue::Joint(value),
    }
}

/// The joint motion back: a turn (or slide) of −θ for one of θ.
fn inverse(tf: &crate::pose::RigidTransform) -> crate::pose::RigidTransform {
    let r = tf.r.inverse();
    crate::pose::RigidTransform::new(-(r * tf.t), r)
}

#[cfg(test)]
mod tests;
