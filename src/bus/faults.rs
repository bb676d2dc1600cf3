//! Which faults end a loop that reads the bus, and which joint a fault names.
//!
//! Shared by everything that reads servos over time (playback, recording): the tolerance for a
//! lost answer is a property of the bus, not of what the reading is for.

use super::{BusError, Health};
use crate::robot::Robot;

/// Consecutive failed read-backs that count as a fault.
pub const MAX_READ_FAILURES: u32 = 3;

/// Consecutive failed reads. One lost answer is skipped; [`MAX_READ_FAILURES`] in a row are a
/// fault, reported by the failure that began the streak: on a shared bus a late answer from one
/// servo delays the others' answers, so the later failures name servos that did nothing wrong.
/// A port that is gone, a hung bus (in a cell) or an alarm is a fault at once.
#[derive(Debug, Default)]
pub struct ReadStreak {
    failures: u32,
    first: Option<BusError>,
}

impl ReadStreak {
    pub fn succeeded(&mut self) {
        *self = ReadStreak::default();
    }

    /// Counts a failed read; returns the error to stop with when it ends the tolerance.
    pub fn failed(&mut self, error: BusError) -> Option<BusError> {
        if matches!(
            error.root(),
            BusError::Port { .. } | BusError::Alarm { .. } | BusError::Hung { .. }
        ) {
            return Some(error);
        }
        self.failures += 1;
        let first = self.first.get_or_insert(error);
        (self.failures >= MAX_READ_FAILURES)
            .then(|| std::mem::replace(first, BusError::Protocol(String::new())))
    }
}

/// "joint NAME: " before a fault's message, when the fault names a servo.
pub fn joint_prefix(joint: &Option<String>) -> String {
    joint
        .as_ref()
        .map(|j| format!("joint {j}: "))
        .unwrap_or_default()
}

/// The joint whose servo a bus error names, if it names one.
pub fn faulty_joint(robot: &Robot, error: &BusError) -> Option<String> {
    error
        .servo()
        .and_then(|id| robot.joint_of_servo(id))
        .map(str::to_owned)
}

/// The fault of a servo whose health shows an alarm. In a cell the alarm is its arm's
/// ([`BusError::Arm`]): the servo by its own id on the arm's bus inside, by its cell id outside.
pub fn alarm_error(robot: &Robot, health: &Health) -> BusError {
    let alarm = |id| BusError::Alarm {
        id,
        alarms: health.alarms,
    };
    let index = robot.joints.iter().position(|j| j.servo.id == health.id);
    let Some((arm, index)) = index.and_then(|i| robot.arm_of_joint(i).map(|arm| (arm, i))) else {
        return alarm(health.id);
    };
    let own = arm.robot.joints[index - arm.joints.start].servo.id;
    BusError::Arm {
        arm: arm.name.clone(),
        servo: Some(health.id),
        source: Box::new(alarm(own)),
    }
}
