//! The servos' own motion profile, as the bus reads and writes it for `--servo-profile`: the
//! registers ([`Setting`], from the servo catalogue) and the joint limits in their units
//! (`robot::profile`, which the simulation shares).

pub use crate::robot::profile::{applied_limits, settings_for, ProfileError};
pub use crate::servo::Setting;
