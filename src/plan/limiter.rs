//! The player's last motion check before the position guard: no goal step beyond what the
//! joint's velocity and acceleration limits allow over one control period, whatever the
//! scheduler did. (Droop compensation's lead keeps its goals inside the same band, so the
//! player's limiter stays idle with it too: `lead`.)
//!
//! The timeline already keeps its path within the limits, and after a stall resumes from the
//! rate the arm really followed (see [`crate::pacing`]). This limiter makes that a guarantee
//! rather than a property of the timeline's arithmetic, in the manner of ros2_control's joint
//! saturation limiter: each joint's step is saturated into the band its limits allow from the
//! previous step, and it is kept slow enough to stop before a position limit. It should never
//! engage in ordinary playback; the summary says when it did.
//!
//! The rule, per joint, for a goal written `gap` seconds after the previous one (`T` the
//! control period, `v` and `a` the joint's limits, `Δ₁` the previous step):
//! - the reference step is `Δ₁`, or `Δ₁ · T / gap` after a stall (the goal was held for the
//!   whole gap, so that is the rate the path was really followed at);
//! - the step stays within `v·T` of zero and within `a·T²` of the reference;
//! - from the new goal, decelerating by `a·T²` per period, the joint stops inside its limits.

use crate::robot::Robot;

/// Relative slack for floating-point noise: a step this close to a bound is within it.
const NOISE: f64 = 1e-9;

#[derive(Debug, Clone)]
struct JointLimit {
    velocity_step: f64,
    acceleration_step: f64,
    min: f64,
    max: f64,
}

/// Saturates each cycle's goals into what the joints' limits allow from the previous ones.
#[derive(Debug, Clone)]
pub struct StepLimiter {
    limits: Vec<JointLimit>,
    last: Vec<f64>,
    last_step: Vec<f64>,
    /// Goals the limiter changed, and the largest change, in joint units.
    pub engaged: u64,
    /// The largest change made to a goal.
    pub largest_correction: f64,
    /// The joint it was made to (robot order).
    pub largest_joint: Option<usize>,
}

impl StepLimiter {
    /// A limiter for goals every `period` seconds, starting at rest at `held`.
    pub fn new(robot: &Robot, period: f64, held: &[f64]) -> Self {
        let limits = robot
            .joints
            .iter()
            .map(|j| JointLimit {
                velocity_step: j.limits.velocity * period,
                acceleration_step: j.limits.acceleration * period * period,
                min: j.limits.min,
                max: j.limits.max,
            })
            .collect();
        Self {
            limits,
            last: held.to_vec(),
            last_step: vec![0.0; held.len()],
            engaged: 0,
            largest_correction: 0.0,
            largest_joint: None,
        }
    }

    /// Saturates `goal` in place for a write after the previous one, `followed` being the
    /// share of the path rate the arm really followed in between ([`crate::pacing::followed_share`]
    /// of the time since the previous goal went out, not since the cycle's deadline: 1, or
    /// `period / gap` after a stall).
    pub fn limit(&mut self, goal: &mut [f64], followed: f64) {
        let mut changed = false;
        for (j, limit) in self.limits.iter().enumerate() {
            let reference = self.last_step[j] * followed;
            let wanted = goal[j] - self.last[j];
            // Clamped into the position limits too: the bands' slack for rounding noise must
            // not carry a goal past a limit it is braking towards.
            let step = limit
                .saturate(wanted, reference, self.last[j])
                .clamp(limit.min - self.last[j], limit.max - self.last[j]);
            if (step - wanted).abs() > NOISE * (1.0 + wanted.abs()) {
                changed = true;
                if (step - wanted).abs() > self.largest_correction {
                    self.largest_correction = (step - wanted).abs();
                    self.largest_joint = Some(j);
                }
            }
            goal[j] = self.last[j] + step;
            self.last_step[j] = step;
            self.last[j] = goal[j];
        }
        if changed {
            self.engaged += 1;
        }
    }
}

impl JointLimit {
    fn saturate(&self, wanted: f64, reference: f64, from: f64) -> f64 {
        let slack = NOISE * (self.velocity_step + self.acceleration_step);
        let mut low = (reference - self.acceleration_step).max(-self.velocity_step) - slack;
        let mut high = (reference + self.acceleration_step).min(self.velocity_step) + slack;
        // Slow enough to stop inside the limits; never tighter than the acceleration band
        // allows (braking harder than the limit would break it the other way).
        let a = self.acceleration_step;
        high = high.min(stoppable_step(self.max - from, a)).max(low);
        low = low.max(-stoppable_step(from - self.min, a)).min(high);
        wanted.clamp(low, high)
    }
}

/// The largest step towards a limit `room` away after which a joint can still stop before it,
/// slowing by one acceleration step `a` per period. After a step `s` with `n·a ≤ s < (n+1)·a`
/// come the steps `s − a, …, s − n·a`, so the whole distance is `(n+1)·s − a·n(n+1)/2`; the
/// largest `s` within `room` lies in the piece where `a·n(n+1)/2 ≤ room` first fails for
/// `n + 1`.
pub(crate) fn stoppable_step(room: f64, a: f64) -> f64 {
    if room <= 0.0 {
        return 0.0;
    }
    let n = ((-1.0 + (1.0 + 8.0 * room / a).sqrt()) / 2.0).floor();
    ((room + a * n * (n + 1.0) / 2.0) / (n + 1.0)).min((n + 1.0) * a)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn so101_limiter(period: f64) -> (Robot, StepLimiter) {
        let robot = Robot::builtin("so101").unwrap();
        let held = vec![0.0; robot.joints.len()];
        let limiter = StepLimiter::new(&robot, period, &held);
        (robot, limiter)
    }

    #[test]
    fn a_step_within_the_limits_passes_untouched() {
        let (_, mut limiter) = so101_limiter(0.01);
        // 344 °/s² over 10 ms: 0.0344° of step change per period is allowed.
        let mut goal = vec![0.03, 0.0, -0.03, 0.0, 0.0, 0.0];
        limiter.limit(&mut goal, 1.0);
        assert_eq!(goal, vec![0.03, 0.0, -0.03, 0.0, 0.0, 0.0]);
        assert_eq!(limiter.engaged, 0);
    }

    #[test]
    fn a_jump_is_cut_to_one_acceleration_step_from_rest() {
        let (_, mut limiter) = so101_limiter(0.01);
        let mut goal = vec![10.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        limiter.limit(&mut goal, 1.0);
        // From rest: a·T² = 344 · 0.01² = 0.0344°.
        assert!((goal[0] - 0.0344).abs() < 1e-8, "{}", goal[0]);
        assert_eq!(limiter.engaged, 1);
        assert!((limiter.largest_correction - (10.0 - 0.0344)).abs() < 1e-8);
        assert_eq!(limiter.largest_joint, Some(0));
    }

    #[test]
    fn velocity_is_capped_at_the_limit() {
        let (_, mut limiter) = so101_limiter(0.01);
        let mut goal = vec![0.0; 6];
        let mut steps = Vec::new();
        for _ in 0..40 {
            let before = goal[0];
            goal[0] = before + 5.0; // asks for 500 °/s
            limiter.limit(&mut goal, 1.0);
            steps.push(goal[0] - before);
        }
        // 115 °/s · 10 ms = 1.15° per period, reached after 1.15 / 0.0344 ≈ 34 periods.
        let top = steps.iter().cloned().fold(0.0, f64::max);
        assert!((top - 1.15).abs() < 1e-8, "{top}");
        assert!(steps[32] < 1.15 && (steps[33] - 1.15).abs() < 1e-8);
    }

    #[test]
    fn after_a_stall_the_reference_step_is_the_rate_really_followed() {
        let (_, mut limiter) = so101_limiter(0.01);
        let mut goal = vec![0.0; 6];
        for k in 1..=40 {
            goal[0] = 1.0 * k as f64; // 100 °/s, built up within the limits below
            limiter.limit(&mut goal, 1.0);
        }
        let before = goal[0];
        let cruising = limiter.last_step[0];
        // Half a second without a write: the reference is cruising · 0.01 / 0.5.
        goal[0] = before + cruising;
        limiter.limit(&mut goal, 0.01 / 0.5);
        let step = goal[0] - before;
        let reference = cruising * 0.01 / 0.5;
        assert!(
            (step - (reference + 0.0344)).abs() < 1e-8,
            "{step} vs {reference}"
        );
    }

    #[test]
    fn it_slows_in_time_to_stop_at_a_position_limit() {
        let (robot, mut limiter) = so101_limiter(0.01);
        let max = robot.joints[0].limits.max;
        let mut goal = vec![0.0; 6];
        let mut peak: f64 = 0.0;
        for _ in 0..2000 {
            goal[0] = 1000.0; // far past the limit
            limiter.limit(&mut goal, 1.0);
            peak = peak.max(goal[0]);
        }
        assert!(peak <= max + 1e-9, "{peak} past {max}");
        assert!(max - goal[0] < 0.05, "stopped {} short", max - goal[0]);
    }

    #[test]
    fn a_parabola_braking_at_the_limit_into_a_position_limit_is_left_alone() {
        // The joint comes to rest exactly at its limit, decelerating at exactly a: sampled
        // every period, its steps are A·(n − ½) with n periods to go — the tightest motion
        // the rule must still allow.
        let (robot, mut limiter) = so101_limiter(0.01);
        let (max, a) = (robot.joints[0].limits.max, 344.0 * 1e-4);
        let n = 30;
        let at = |k: i32| max - a * f64::from(k * k) / 2.0;
        let mut goal = vec![0.0; 6];
        goal[0] = at(n + 1);
        limiter.last.copy_from_slice(&goal);
        limiter.last_step[0] = at(n + 1) - at(n + 2);
        for k in (0..=n).rev() {
            goal[0] = at(k);
            limiter.limit(&mut goal, 1.0);
        }
        assert_eq!(
            limiter.engaged, 0,
            "corrected by {}",
            limiter.largest_correction
        );
    }
}
