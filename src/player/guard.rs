//! The last check before a goal becomes ticks: every value inside its joint's limits.
//!
//! Plans are checked before playback, so a goal outside the limits here is a bug; the player
//! stops rather than send it.

use crate::robot::Robot;

/// A goal outside its joint's limits, refused before it became ticks.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("refusing to send joint {joint} to {value}: outside its limits {min} … {max} (a bug; nothing was sent)")]
pub struct LimitBreach {
    /// The joint's name.
    pub joint: String,
    /// The goal refused, in the joint's unit.
    pub value: f64,
    /// The joint's lower limit.
    pub min: f64,
    /// The joint's upper limit.
    pub max: f64,
}

/// Converts joint values to (servo id, tick) goals, refusing any value outside the limits.
#[derive(Debug, Clone)]
pub struct GoalGuard<'a> {
    robot: &'a Robot,
}

impl<'a> GoalGuard<'a> {
    /// A guard of `robot`'s limits.
    pub fn new(robot: &'a Robot) -> Self {
        Self { robot }
    }

    /// The (servo id, tick) goals of joint values in joint order.
    pub fn goals(&self, values: &[f64]) -> Result<Vec<(u8, i64)>, LimitBreach> {
        let mut goals = Vec::with_capacity(values.len());
        self.goals_into(values, &mut goals)?;
        Ok(goals)
    }

    /// [`GoalGuard::goals`] into a buffer the caller keeps from cycle to cycle (no allocation
    /// once it has grown to the robot's size). On a breach the buffer holds no goals.
    pub fn goals_into(
        &self,
        values: &[f64],
        goals: &mut Vec<(u8, i64)>,
    ) -> Result<(), LimitBreach> {
        goals.clear();
        for (joint, &value) in self.robot.joints.iter().zip(values) {
            match joint.goal_tick(value) {
                Ok(tick) => goals.push((joint.servo.id, tick)),
                Err(_) => {
                    goals.clear();
                    return Err(LimitBreach {
                        joint: joint.name.clone(),
                        value,
                        min: joint.limits.min,
                        max: joint.limits.max,
                    });
                }
            }
        }
        Ok(())
    }
}
