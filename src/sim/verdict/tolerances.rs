//! Every threshold a verdict applies, in one place, apart from the checks that apply them (as
//! a trajectory controller keeps its goal and path tolerances apart from its control law).
//!
//! Knows nothing about traces or robots: plain numbers in joint units.

/// The thresholds of a verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Largest tracking error, degrees (revolute) during motion.
    pub max_error_deg: f64,
    /// Largest tracking error, metres (prismatic).
    pub max_error_m: f64,
    /// Error allowed once the arm has settled at a key, degrees.
    pub settled_error_deg: f64,
    /// The same for a prismatic joint, metres.
    pub settled_error_m: f64,
    /// How long after the command comes to rest at a key the arm has to settle there, and how
    /// long the command must rest for the key to be judged as settled, seconds.
    pub settle_time: f64,
    /// A command that moves less than this over the settling window is at rest, degrees: well
    /// below the settled error allowed, well above float noise.
    pub rest_deg: f64,
    /// The same for a prismatic joint, metres.
    pub rest_m: f64,
    /// Saturation shorter than this is normal during fast moves, seconds.
    pub saturation_time: f64,
    /// Share of the force limit that counts as saturated.
    pub saturation_share: f64,
    /// Contacts shallower than this are resting touches, not collisions, metres.
    pub contact_depth: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            max_error_deg: 15.0,
            max_error_m: 0.005,
            // The check's droop warning measures against the same tolerance.
            settled_error_deg: crate::plan::SETTLED_TOLERANCE_DEG,
            settled_error_m: crate::plan::SETTLED_TOLERANCE_M,
            settle_time: 0.5,
            rest_deg: 0.05,
            rest_m: 0.00005,
            saturation_time: 0.25,
            saturation_share: 0.98,
            contact_depth: 0.0005,
        }
    }
}

impl Thresholds {
    /// (in motion, once settled) error allowed for a revolute or a prismatic joint.
    pub fn error_allowed(&self, revolute: bool) -> (f64, f64) {
        if revolute {
            (self.max_error_deg, self.settled_error_deg)
        } else {
            (self.max_error_m, self.settled_error_m)
        }
    }

    /// How far a command may move and still be at rest, for a revolute or a prismatic joint.
    pub fn rest_allowed(&self, revolute: bool) -> f64 {
        if revolute {
            self.rest_deg
        } else {
            self.rest_m
        }
    }
}
