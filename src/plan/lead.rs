//! Droop compensation's lead as it goes out: the goal is the path (through the player's step
//! limiter) plus a lead that follows the compensation's target
//! ([`crate::dynamics::Compensation::leads`]) within a band of its own, a share
//! ([`LEAD_SHARE`]) of each joint's velocity and acceleration limits.
//!
//! The path keeps the whole of the limits: the lead never holds it back or shapes it. The lead
//! follows the weight the servo holds as the pose changes: smooth, at most a few degrees, and
//! changing at a fraction of the path's own speed (about a sixth on the SO-101's 5 V
//! shoulder), so in the band it hardly ever lags; where it would overshoot its target it
//! brakes to meet it (the step limiter's stopping rule). The goals therefore step at most
//! `1 + LEAD_SHARE` times what the limits allow the path, and stay inside the position limits.

use super::limiter::stoppable_step;
use crate::robot::Robot;

/// The lead's share of each joint's velocity and acceleration limits.
pub const LEAD_SHARE: f64 = 0.25;

/// One joint's band for its lead, joint units per period.
#[derive(Debug, Clone, Copy)]
struct Band {
    velocity_step: f64,
    acceleration_step: f64,
    min: f64,
    max: f64,
}

/// The lead that went out, and its last step, per joint.
#[derive(Debug, Clone)]
pub(crate) struct LeadFollower {
    bands: Vec<Band>,
    lead: Vec<f64>,
    step: Vec<f64>,
}

impl LeadFollower {
    /// A follower for goals every `period` seconds, starting with no lead.
    pub(crate) fn new(robot: &Robot, period: f64) -> LeadFollower {
        let bands: Vec<Band> = robot
            .joints
            .iter()
            .map(|j| Band {
                velocity_step: LEAD_SHARE * j.limits.velocity * period,
                acceleration_step: LEAD_SHARE * j.limits.acceleration * period * period,
                min: j.limits.min,
                max: j.limits.max,
            })
            .collect();
        let n = bands.len();
        LeadFollower {
            bands,
            lead: vec![0.0; n],
            step: vec![0.0; n],
        }
    }

    /// Turns `path` (this cycle's pose) into goals leading it towards `target`.
    pub(crate) fn goals_into(&mut self, path: &mut [f64], target: &[f64]) {
        for (j, band) in self.bands.iter().enumerate() {
            let error = target[j] - self.lead[j];
            let (v, a) = (band.velocity_step, band.acceleration_step);
            // The largest step towards the target from which the lead can still stop on it.
            let towards = stoppable_step(error.abs(), a).copysign(error);
            let reference = self.step[j];
            let step = towards.clamp((reference - a).max(-v), (reference + a).min(v));
            self.lead[j] += step;
            self.step[j] = step;
            path[j] = (path[j] + self.lead[j]).clamp(band.min, band.max);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lead_that_jumps_is_taken_up_within_its_band_and_then_held() {
        let robot = Robot::builtin("so101").unwrap();
        let (period, n) = (0.01, robot.joints.len());
        let mut follower = LeadFollower::new(&robot, period);
        let mut target = vec![0.0; n];
        target[1] = 5.0;
        let limits = &robot.joints[1].limits;
        let (v, a) = (
            LEAD_SHARE * limits.velocity,
            LEAD_SHARE * limits.acceleration,
        );
        let (mut last, mut step) = (0.0, 0.0);
        for k in 0..300 {
            let mut pose = vec![0.0; n];
            follower.goals_into(&mut pose, &target);
            let s = pose[1] - last;
            // Within the band, by hand: v·T per period and a·T² per period per period.
            assert!(s.abs() <= v * period * (1.0 + 1e-9), "{k}: step {s}");
            assert!(
                (s - step).abs() <= a * period * period * (1.0 + 1e-9),
                "{k}: {s} after {step}"
            );
            assert!(pose[1] <= 5.0 + 1e-9, "{k}: past the target: {}", pose[1]);
            (last, step) = (pose[1], s);
        }
        assert!(
            (last - 5.0).abs() < 1e-6,
            "the lead reached its target: {last}"
        );
    }

    #[test]
    fn the_goal_stays_inside_the_position_limits() {
        let robot = Robot::builtin("so101").unwrap();
        let n = robot.joints.len();
        let mut follower = LeadFollower::new(&robot, 0.01);
        let max = robot.joints[2].limits.max;
        let mut target = vec![0.0; n];
        target[2] = 10.0;
        for _ in 0..300 {
            let mut pose = vec![0.0; n];
            pose[2] = max;
            follower.goals_into(&mut pose, &target);
            assert_eq!(pose[2], max);
        }
    }
}
