//! The torque-speed line as a constraint of the path parameterisation, TOPP-RA's way.
//!
//! Along the path q(u), with path speed u̇ (x = u̇²) and acceleration ü, the joints move at
//! q̇ = q'·u̇ and q̈ = q'·ü + q''·x, so inverse dynamics gives each servo's torque as
//! τ = a·ü + b·x + c, with a = M(q)·q' (the inertia along the path), b = M(q)·q'' + C(q, q')·q'
//! (curvature and Coriolis) and c = g(q) (gravity): three evaluations of the inverse dynamics
//! per grid point. The servo's line bounds τ by its stall torque braking and by
//! `stall · (1 − |q'|·√x / (n·ω₀))` driving the motion: for each x that is an interval of ü,
//! which is all the passes ask of a constraint.

use crate::dynamics::Dynamics;
use crate::robot::Robot;
use crate::servo::Drive;

/// One servo at one grid point: τ = a·ü + b·x + c (N·m at its output), and its line.
#[derive(Debug, Clone, Copy)]
pub(super) struct TorqueRow {
    a: f64,
    b: f64,
    c: f64,
    /// The servo's speed per unit of path speed (rad/s per path second per second), signed:
    /// the direction it drives.
    speed_per_rate: f64,
    /// The stall torque times the segment's share, N·m.
    stall: f64,
    /// The no-load speed, rad/s.
    no_load: f64,
}

impl TorqueRow {
    /// The interval of τ the line allows at squared path speed `x`.
    fn allowed(&self, x: f64) -> (f64, f64) {
        let speed = self.speed_per_rate * x.max(0.0).sqrt();
        let driving = self.stall * (1.0 - speed.abs() / self.no_load).max(0.0);
        if speed > 0.0 {
            (-self.stall, driving)
        } else if speed < 0.0 {
            (-driving, self.stall)
        } else {
            (-self.stall, self.stall)
        }
    }

    /// Narrows `(low, high)`, the path accelerations allowed at `x`, to what this servo's
    /// line allows; an empty interval (low > high) where no acceleration does.
    pub(super) fn narrow(&self, x: f64, (low, high): (f64, f64)) -> (f64, f64) {
        let (tmin, tmax) = self.allowed(x);
        let rest = self.b * x + self.c;
        if self.a.abs() <= 1e-12 {
            // The acceleration does not change this torque: x is feasible or it is not.
            return if rest >= tmin && rest <= tmax {
                (low, high)
            } else {
                (f64::INFINITY, f64::NEG_INFINITY)
            };
        }
        let u = (tmin - rest) / self.a;
        let v = (tmax - rest) / self.a;
        (low.max(u.min(v)), high.min(u.max(v)))
    }

    /// The same servo seen from the previous grid point of a step of `step` path seconds at
    /// constant ü: x there becomes x + 2·step·ü here (TOPP-RA's interpolation scheme).
    pub(super) fn ahead(&self, step: f64) -> TorqueRow {
        TorqueRow {
            a: self.a + 2.0 * step * self.b,
            ..*self
        }
    }
}

/// What the line constraint needs of a robot: its inverse dynamics and each joint's drive.
#[derive(Debug, Clone)]
pub(super) struct Loads {
    dynamics: Dynamics,
    drives: Vec<Option<&'static Drive>>,
}

impl Loads {
    /// `None` where the robot has no masses (a robot file without a built-in model): the
    /// kinematic limits alone then.
    pub(super) fn of(robot: &Robot) -> Option<Loads> {
        let dynamics = Dynamics::for_robot(robot).ok()?;
        let drives = robot.joints.iter().map(|j| j.servo.drive()).collect();
        Some(Loads { dynamics, drives })
    }

    /// Each rated servo's row at a point of the path: joint values `q`, slopes `p` and
    /// curvatures `c` along it (joint units per path second), the line at `share` of stall.
    pub(super) fn rows(&self, q: &[f64], p: &[f64], c: &[f64], share: f64) -> Vec<TorqueRow> {
        let rest = vec![0.0; q.len()];
        let gravity = self.dynamics.servo_torques(q, &rest, &rest);
        let inertia = self.dynamics.servo_torques(q, &rest, p);
        let curvature = self.dynamics.servo_torques(q, p, c);
        let speeds = self.dynamics.servo_speeds(p);
        self.drives
            .iter()
            .enumerate()
            .filter_map(|(j, drive)| {
                let d = (*drive)?;
                Some(TorqueRow {
                    a: inertia[j] - gravity[j],
                    b: curvature[j] - gravity[j],
                    c: gravity[j],
                    speed_per_rate: speeds[j],
                    stall: share * d.stall_torque.value,
                    no_load: d.no_load_speed.value,
                })
            })
            .collect()
    }
}
