//! What a verdict reports: a [`Finding`] of one [`FindingKind`].
//!
//! Knows nothing about how findings are found; the kinds' names are what reports print.

use serde::{Serialize, Serializer};
use std::fmt;

/// The kinds of finding, one per check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FindingKind {
    /// The position strayed too far from the command in motion.
    Tracking,
    /// The arm was not at a key soon enough after it.
    Settling,
    /// The servo's shaft turned, or was commanded, faster than its no-load speed.
    Speed,
    /// The joint ran into its stop.
    JointLimit,
    /// The actuator stayed at its force limit.
    Saturation,
    /// The arm touched the floor.
    FloorCollision,
    /// The arm touched itself.
    SelfCollision,
    /// Two arms of a cell ran into each other.
    ArmCollision,
    /// A contact with the environment other than the floor.
    Collision,
    /// The physics went unstable.
    Divergence,
}

impl FindingKind {
    /// The name reports print (text and JSON).
    pub fn name(self) -> &'static str {
        match self {
            FindingKind::Tracking => "tracking",
            FindingKind::Settling => "settling",
            FindingKind::Speed => "speed",
            FindingKind::JointLimit => "joint limit",
            FindingKind::Saturation => "saturation",
            FindingKind::FloorCollision => "floor collision",
            FindingKind::SelfCollision => "self collision",
            FindingKind::ArmCollision => "arm collision",
            FindingKind::Collision => "collision",
            FindingKind::Divergence => "divergence",
        }
    }
}

impl fmt::Display for FindingKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // `pad`, so that reports can align the column with a width (`{:<16}`).
        f.pad(self.name())
    }
}

impl Serialize for FindingKind {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Something the simulation caught.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// Which check caught it.
    pub kind: FindingKind,
    /// The joint it is about; `None` for a contact or a divergence.
    pub joint: Option<String>,
    /// In a cell, the arms it is about: the joint's, or the arms of the colliding bodies.
    pub arms: Vec<String>,
    /// When, in the sequence's time (negative during the approach).
    pub time: f64,
    /// What happened, for people.
    pub message: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_print_and_serialise_as_their_names() {
        assert_eq!(
            format!("[{:<12}]", FindingKind::JointLimit),
            "[joint limit ]"
        );
        assert_eq!(
            serde_json::to_value(FindingKind::FloorCollision).unwrap(),
            serde_json::json!("floor collision")
        );
    }
}
