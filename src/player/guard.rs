//! The last check before a goal becomes ticks: every value inside its joint's limits.
//!
//! Plans are checked before playback, so a goal outside the limits here is a bug; the player
//! stops rather than send it.

use crate::robot::Robot;

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
