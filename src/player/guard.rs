//! The last check before a goal becomes ticks: every value inside its joint's limits.
//!
//! Plans are checked before playback, so a goal outside the limits here is a bug; the player
//! stops rather than send it.

use super::position_slack;
use crate::robot::{Joint, Robot};

/// Where to hold a joint measured at `present` when its torque comes on: where it is, or at the
/// limit it is a little past (within [`position_slack`]). None when it is further past: a goal
/// there is forbidden, and pulling it to the limit at once would be a jump, so it must be moved
/// inside by hand first.
pub fn hold_value(joint: &Joint, present: f64) -> Option<f64> {
    let excess = (joint.limits.min - present).max(present - joint.limits.max);
    (excess <= position_slack(joint.kind))
        .then(|| present.clamp(joint.limits.min, joint.limits.max))
}

/// [`hold_value`] for a servo measured at `present` ticks, as the goal tick to write.
pub fn hold_tick(joint: &Joint, present: i64) -> Option<i64> {
    hold_value(joint, joint.servo.value(present)).and_then(|value| joint.goal_tick(value).ok())
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("refusing to send joint {joint} to {value}: outside its limits {min} … {max} (a bug; nothing was sent)")]
pub struct LimitBreach {
    pub joint: String,
    pub value: f64,
    pub min: f64,
    pub max: f64,
}

/// Converts joint values to (servo id, tick) goals, refusing any value outside the limits.
#[derive(Debug, Clone)]
pub struct GoalGuard<'a> {
    robot: &'a Robot,
}

impl<'a> GoalGuard<'a> {
    pub fn new(robot: &'a Robot) -> Self {
        Self { robot }
    }

    pub fn goals(&self, values: &[f64]) -> Result<Vec<(u8, i64)>, LimitBreach> {
        self.robot
            .joints
            .iter()
            .zip(values)
            .map(|(joint, &value)| {
                let breach = || LimitBreach {
                    joint: joint.name.clone(),
                    value,
                    min: joint.limits.min,
                    max: joint.limits.max,
                };
                joint
                    .goal_tick(value)
                    .map(|tick| (joint.servo.id, tick))
                    .map_err(|_| breach())
            })
            .collect()
    }
}
