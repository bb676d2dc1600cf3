//! Droop compensation: goals that lead the path by what each servo's position loop gives
//! under the arm's weight, so that the arm, not the goal, rests on the keys.
//!
//! A hobby servo's firmware is a proportional position loop: below saturation its torque is
//! `k·(goal − position)`, `k` the loop's stiffness at the gain the arm's software writes.
//! Holding still under a weight `τ` it rests `τ / k` short of its goal: the droop the check
//! warns of (the 5 V SO-101's shoulder 3–6° at the examples' keys). Sending the goal
//! `path + τ(path) / k`, `τ` the servo's share of the arm's weight at the path's pose, puts it
//! on the path instead.
//!
//! Only the weight, on purpose. The motion's own torque — inertia, and the back-EMF's that
//! grows with speed — would have the lead jump where the path's acceleration jumps and grow
//! with its speed, so that on a path at its limits the goals would outrun the limits by far;
//! the position loop takes it up as a lag, which `sim` bounds as tracking error. The weight
//! changes smoothly with the pose, at a fraction of the path's speed.
//!
//! The lead is bounded where it stops helping: past the stall torque the servo gives no more
//! however far the goal runs ahead, so the lead goes no further than `stall / k`. This is the
//! lead's target; `plan::lead` makes the goals follow it within a band of the joints' limits.

use super::{from_si, Dynamics, DynamicsError};
use crate::robot::{JointKind, Robot};

/// One joint's servo as its position loop acts on the goal.
#[derive(Debug, Clone, Copy)]
struct Loop {
    /// N·m per radian of the shaft.
    stiffness: f64,
    stall: f64,
    /// Joint SI units per radian of the shaft.
    transmission: f64,
    kind: JointKind,
}

impl Loop {
    /// The goal's lead over the path, joint units, for the servo to hold `torque` (N·m).
    fn lead(&self, torque: f64) -> f64 {
        let asked = torque.clamp(-self.stall, self.stall);
        from_si(self.kind, asked / self.stiffness * self.transmission)
    }
}

/// The goals that make each servo's position loop hold the arm's weight on the path.
#[derive(Debug, Clone)]
pub struct Compensation {
    dynamics: Dynamics,
    /// By joint; `None` for a servo whose drive is not rated (it is sent the path itself).
    loops: Vec<Option<Loop>>,
}

impl Compensation {
    /// The compensation of `robot`'s servos at their build, from its inverse dynamics.
    pub fn for_robot(robot: &Robot) -> Result<Compensation, DynamicsError> {
        let dynamics = Dynamics::for_robot(robot)?;
        let loops = robot
            .joints
            .iter()
            .map(|joint| {
                let drive = joint.servo.drive()?;
                let stall = drive.stall_torque.value;
                Some(Loop {
                    stiffness: drive.stiffness.value,
                    stall,
                    transmission: joint.servo.transmission(joint.kind),
                    kind: joint.kind,
                })
            })
            .collect();
        Ok(Compensation { dynamics, loops })
    }

    /// Each joint's lead over the path at `values`, joint units (robot order).
    pub fn leads(&self, values: &[f64]) -> Vec<f64> {
        let torques = self.dynamics.holding_torques(values);
        self.loops
            .iter()
            .zip(&torques)
            .map(|(servo, &torque)| servo.map_or(0.0, |l| l.lead(torque)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn so101() -> Robot {
        Robot::builtin("so101").unwrap()
    }

    #[test]
    fn the_lead_is_the_droop_the_check_predicts() {
        // The weight over the stiffness, by hand: the 5 V STS3215 at P = 16 is 6 N·m/rad.
        let robot = so101();
        let comp = Compensation::for_robot(&robot).unwrap();
        let pose = vec![0.0, -60.0, 60.0, 0.0, 0.0, 0.0];
        let holding = Dynamics::for_robot(&robot).unwrap().holding_torques(&pose);
        let leads = comp.leads(&pose);
        for j in 0..pose.len() {
            let expected = (holding[j] / 6.0).to_degrees();
            assert!(
                (leads[j] - expected).abs() < 1e-9,
                "{j}: {} vs {expected}",
                leads[j]
            );
        }
        assert!(
            leads[1].abs() > 1.0,
            "the shoulder holds the arm: {}",
            leads[1]
        );
    }

    #[test]
    fn the_lead_stops_at_what_the_stall_torque_can_give() {
        let mut robot = so101();
        // A payload far heavier than the 5 V shoulder can hold, the arm stretched out.
        robot.payload = Some(crate::robot::Payload {
            mass: 50.0,
            com: glam::DVec3::ZERO,
        });
        let comp = Compensation::for_robot(&robot).unwrap();
        let drive = robot.joints[1].servo.drive().unwrap();
        let most = (drive.stall_torque.value / drive.stiffness.value).to_degrees();
        let leads = comp.leads(&[0.0, 0.0, 90.0, 0.0, 0.0, 0.0]);
        assert!(
            (leads[1].abs() - most).abs() < 1e-9,
            "{} vs {most}",
            leads[1]
        );
    }
}
