//! How a virtual servo moves: towards its goal while torque is on, at most at its model's
//! no-load speed, with the proportional approach of a position servo near the goal (so it lags
//! its goal as a real one does); where it is pushed while torque is off.

use crate::robot::{servo::TICKS_PER_REVOLUTION, ServoModel};
use std::time::Instant;

/// Time constant of the proportional approach, seconds: a hobby servo's position loop settles
/// a small error in a few tens of milliseconds.
const TIME_CONSTANT: f64 = 0.03;

#[derive(Debug, Clone)]
pub struct Motion {
    /// Present position, ticks (continuous; read as the nearest whole tick).
    pub position: f64,
    pub goal: f64,
    pub torque: bool,
    /// Ticks per second.
    max_speed: f64,
    last_update: Instant,
}

impl Motion {
    pub fn new(model: ServoModel, position: f64) -> Self {
        Self {
            position,
            goal: position,
            torque: false,
            max_speed: model.spec().no_load_speed_deg_s * TICKS_PER_REVOLUTION / 360.0,
            last_update: Instant::now(),
        }
    }

    /// Advances the motion to now.
    pub fn update(&mut self) {
        let now = Instant::now();
        let dt = (now - self.last_update).as_secs_f64();
        self.last_update = now;
        self.step(dt);
    }

    /// Advances the motion by `dt` seconds.
    pub fn step(&mut self, dt: f64) {
        if !self.torque || dt <= 0.0 {
            return;
        }
        let error = self.goal - self.position;
        // Exact solution of the proportional approach over dt, capped at the no-load speed.
        let proportional = error * (1.0 - (-dt / TIME_CONSTANT).exp());
        let cap = self.max_speed * dt;
        self.position += proportional.clamp(-cap, cap);
    }

    /// Moves the output shaft by hand: it stays there while torque is off.
    pub fn push_to(&mut self, position: f64) {
        self.update();
        if !self.torque {
            self.position = position;
        }
    }

    pub fn set_torque(&mut self, on: bool) {
        self.update();
        if on && !self.torque {
            // Torque on holds where the shaft is, not at a stale goal.
            self.goal = self.position;
        }
        self.torque = on;
    }

    pub fn set_goal(&mut self, goal: f64) {
        self.update();
        self.goal = goal;
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
