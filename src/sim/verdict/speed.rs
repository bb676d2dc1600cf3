//! Speeds at the servo's output shaft against its no-load speed: the simulated motion's, and
//! the command's own (a command faster than the servo names the cause of lag and saturation).
//!
//! Knows nothing about tolerances: the servo model's figure is the limit.

use super::column::{peak, Column};
use super::{Finding, FindingKind};

impl Column<'_> {
    /// `v` (joint units per second) at the servo's shaft, through its tick mapping, °/s.
    fn servo_speed(&self, v: f64) -> f64 {
        let degrees_per_tick = self.joint.servo.model.spec().degrees_per_tick();
        (v / self.joint.servo.units_per_tick).abs() * degrees_per_tick
    }

    /// The servo's no-load speed, °/s.
    pub fn servo_speed_limit(&self) -> f64 {
        self.joint.servo.model.spec().no_load_speed_deg_s
    }

    /// The commanded speed at the servo between `row - 1` and `row`, when time advanced.
    fn commanded_servo_speed(&self, row: usize) -> Option<f64> {
        let (time, commanded) = (&self.trace.time, &self.trace.commanded);
        let dt = time[row] - time[row - 1];
        (dt > 0.0).then(|| {
            self.servo_speed((commanded[row][self.index] - commanded[row - 1][self.index]) / dt)
        })
    }
}

/// The top simulated speed at the servo, °/s, and when.
pub(super) fn peak_servo_speed(column: &Column) -> (f64, f64) {
    let velocity = &column.trace.velocity;
    peak(column.trace, |row| {
        column.servo_speed(velocity[row][column.index])
    })
}

/// The simulated motion faster than the servo.
pub(super) fn check_speed(column: &Column, (top, top_time): (f64, f64)) -> Option<Finding> {
    let limit = column.servo_speed_limit();
    (top > limit).then(|| {
        column.finding(
            FindingKind::Speed,
            top_time,
            format!(
                "servo speed {top:.0} °/s beyond the {} no-load speed {limit:.0} °/s",
                column.joint.servo.model.name()
            ),
        )
    })
}

/// The first command step faster than the servo.
pub(super) fn check_commanded_speed(column: &Column) -> Option<Finding> {
    let limit = column.servo_speed_limit();
    (1..column.rows()).find_map(|row| {
        let asked = column
            .commanded_servo_speed(row)
            .filter(|&asked| asked > limit)?;
        Some(column.finding_at(
            FindingKind::Speed,
            row,
            format!(
                "commanded {asked:.0} °/s at the servo, beyond the {} no-load speed {limit:.0} °/s",
                column.joint.servo.model.name()
            ),
        ))
    })
}
