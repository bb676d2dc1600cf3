//! How a virtual servo moves: towards its goal while torque is on, at most at its model's
//! no-load speed, with the proportional approach of a position servo near the goal (so it lags
//! its goal as a real one does); where it is pushed while torque is off. A [`Profile`] (the
//! servo's profile or speed/acceleration registers) bounds the speed further and limits the
//! acceleration, braking in time to stop at the goal.

pub use crate::bus::protocol::firmware::Profile;
use crate::servo::ServoModel;
use std::time::Instant;

/// Time constant of the proportional approach, seconds: a hobby servo's position loop settles
/// a small error in a few tens of milliseconds.
const TIME_CONSTANT: f64 = 0.03;
/// Longest integration step, seconds: an acceleration bound needs small steps, and a servo is
/// read at arbitrary intervals.
const MAX_STEP: f64 = 0.001;

#[derive(Debug, Clone)]
pub struct Motion {
    /// Present position, ticks (continuous; read as the nearest whole tick).
    pub position: f64,
    pub goal: f64,
    pub torque: bool,
    /// Ticks per second, signed.
    pub velocity: f64,
    pub profile: Profile,
    /// Ticks per second.
    max_speed: f64,
    last_update: Instant,
    /// The shaft is moved from outside (an arm's physics, `super::physics`): the goal, the
    /// profile and the torque are the firmware's, the position and velocity the physics'.
    pub external: bool,
}

impl Motion {
    pub fn new(model: ServoModel, position: f64) -> Self {
        Self {
            position,
            goal: position,
            torque: false,
            velocity: 0.0,
            profile: Profile::default(),
            max_speed: model.spec().no_load_speed_ticks_s(),
            last_update: Instant::now(),
            external: false,
        }
    }

    /// Advances the motion to now.
    pub fn update(&mut self) {
        let now = Instant::now();
        let dt = (now - self.last_update).as_secs_f64();
        self.last_update = now;
        self.step(dt);
    }

    /// Advances the motion by `dt` seconds, in steps of at most [`MAX_STEP`].
    pub fn step(&mut self, dt: f64) {
        if self.external {
            return;
        }
        if !self.torque {
            self.velocity = 0.0;
            return;
        }
        if dt <= 0.0 || (self.goal == self.position && self.velocity == 0.0) {
            return;
        }
        let steps = (dt / MAX_STEP).ceil().min(1e7);
        let h = dt / steps;
        for _ in 0..steps as u64 {
            self.step_once(h);
        }
    }

    fn step_once(&mut self, dt: f64) {
        let error = self.goal - self.position;
        // Exact solution of the proportional approach over dt, capped at the no-load speed
        // and the profile's speed.
        let proportional = error * (1.0 - (-dt / TIME_CONSTANT).exp());
        let cap = self
            .profile
            .max_speed
            .map_or(self.max_speed, |v| v.min(self.max_speed));
        let mut velocity = (proportional / dt).clamp(-cap, cap);
        if let Some(a) = self.profile.acceleration {
            // No faster than it can stop from at the goal, and no faster a change than `a`.
            let braking = (2.0 * a * error.abs()).sqrt();
            velocity = velocity.clamp(-braking, braking);
            velocity = velocity.clamp(self.velocity - a * dt, self.velocity + a * dt);
        }
        self.velocity = velocity;
        self.position += velocity * dt;
        if (self.goal - self.position).abs() < 1e-6 && self.velocity.abs() < 1e-6 {
            // Settled: stop integrating a vanishing error.
            self.position = self.goal;
            self.velocity = 0.0;
        }
    }

    /// Moves the output shaft by hand: it stays there while torque is off.
    pub fn push_to(&mut self, position: f64) {
        self.update();
        if !self.torque && !self.external {
            self.position = position;
        }
    }

    pub fn set_torque(&mut self, on: bool) {
        self.update();
        if on && !self.torque {
            // Torque on holds where the shaft is, not at a stale goal.
            self.goal = self.position;
            self.velocity = 0.0;
        }
        self.torque = on;
    }

    pub fn set_goal(&mut self, goal: f64) {
        self.set_goal_with(goal, Profile::default());
    }

    /// A new goal, reached within `profile`'s bounds.
    pub fn set_goal_with(&mut self, goal: f64, profile: Profile) {
        self.update();
        self.goal = goal;
        self.profile = profile;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_far_goal_is_approached_at_no_load_speed() {
        // XM430 at 12 V: 276 °/s = 3140.27 ticks/s.
        let mut m = Motion::new(ServoModel::Xm430W350, 0.0);
        m.set_torque(true);
        m.goal = 4000.0;
        m.step(0.1);
        assert!((m.position - 276.0 * 4096.0 / 360.0 * 0.1).abs() < 1e-9);
    }

    #[test]
    fn time_based_profile_is_a_trapezoid_of_the_given_times() {
        // 1000 ticks in 1 s, 0.25 s accelerating: top speed 1000 / 0.75 = 1333.3 ticks/s,
        // reached in 0.25 s: 5333.3 ticks/s² (e-Manual: t1 = Profile Acceleration, t3 =
        // Profile Velocity in time-based mode).
        let p = Profile::timed(1000.0, 1.0, 0.25);
        assert!((p.max_speed.unwrap() - 1000.0 / 0.75).abs() < 1e-9);
        assert!((p.acceleration.unwrap() - 1000.0 / 0.75 / 0.25).abs() < 1e-9);
        // Acceleration time is at most half the move; 0 s total is no profile.
        let half = Profile::timed(1000.0, 1.0, 0.9);
        assert!((half.max_speed.unwrap() - 2000.0).abs() < 1e-9);
        assert_eq!(Profile::timed(1000.0, 0.0, 0.1), Profile::default());
    }

    #[test]
    fn an_acceleration_bound_ramps_the_speed() {
        // 1000 ticks/s², from rest: after 0.1 s at most 100 ticks/s and 0.5 · 1000 · 0.1² = 5
        // ticks travelled.
        let mut m = Motion::new(ServoModel::Xm430W350, 0.0);
        m.set_torque(true);
        m.goal = 4000.0;
        m.profile = Profile::bounded(0.0, 1000.0);
        m.step(0.1);
        assert!(m.velocity <= 100.0 + 1e-9, "{}", m.velocity);
        assert!((m.position - 5.0).abs() < 0.1, "{}", m.position);
    }

    #[test]
    fn without_torque_it_stays_where_it_is_pushed() {
        let mut m = Motion::new(ServoModel::Sts3215, 2048.0);
        m.goal = 3000.0;
        m.step(1.0);
        assert_eq!(m.position, 2048.0);
        m.push_to(1500.0);
        assert_eq!(m.position, 1500.0);
        m.set_torque(true);
        assert_eq!(m.goal, 1500.0);
    }
}
