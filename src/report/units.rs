//! How joint values and forces are shown to a person: degrees for revolute joints, millimetres
//! for prismatic ones (files and traces keep metres, but a gripper's travel is a few tens of
//! millimetres, and metres at three decimals would print 0.000 for most of its errors), N·m for
//! a revolute actuator's torque and N for a prismatic one's force.
//!
//! Shared by the check report and the simulation's verdict. Knows nothing about what the values
//! mean.

use crate::robot::JointKind;
use std::fmt;

/// A joint value (degrees or metres) as shown: padded as a whole when given a width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown {
    /// The value in `unit`.
    pub value: f64,
    /// `"deg"` or `"mm"`.
    pub unit: &'static str,
    /// Decimals it is printed with.
    pub decimals: usize,
}

/// `value` (degrees or metres, as in files) in the unit a person reads.
pub fn shown(kind: JointKind, value: f64) -> Shown {
    match kind {
        JointKind::Revolute => Shown {
            value,
            unit: "deg",
            decimals: 3,
        },
        // Micrometres are below what any gripper servo resolves: two decimals of a millimetre.
        JointKind::Prismatic => Shown {
            value: value * 1000.0,
            unit: "mm",
            decimals: 2,
        },
    }
}

/// The factor and unit a person reads values in the file unit `unit` with ("m" → mm, the rest
/// as they are): for reports that know a joint's unit but not its kind.
pub fn display_scale(unit: &'static str) -> (f64, &'static str) {
    match unit {
        "m" => (1000.0, "mm"),
        other => (1.0, other),
    }
}

/// `value`, or 0 when it shows as zero at `decimals`: a value a hair below zero (the rounding
/// of a curve that ends at 0) prints as 0.00, not −0.00.
pub fn no_negative_zero(value: f64, decimals: i32) -> f64 {
    if (value * 10f64.powi(decimals)).round() == 0.0 {
        0.0
    } else {
        value
    }
}

/// The unit of an actuator's force for a joint of `kind`.
pub fn force_unit(kind: JointKind) -> &'static str {
    match kind {
        JointKind::Revolute => "N·m",
        JointKind::Prismatic => "N",
    }
}

impl Shown {
    /// The number alone, at its precision.
    pub fn number(&self) -> String {
        format!("{:.*}", self.decimals, self.value)
    }
}

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(&format!("{} {}", self.number(), self.unit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prismatic_values_show_in_millimetres_revolute_in_degrees() {
        // 0.0123 m is 12.3 mm.
        assert_eq!(shown(JointKind::Prismatic, 0.0123).to_string(), "12.30 mm");
        assert_eq!(shown(JointKind::Revolute, 4.5).to_string(), "4.500 deg");
        assert_eq!(
            format!("[{:>10}]", shown(JointKind::Prismatic, 0.002)),
            "[   2.00 mm]"
        );
        assert_eq!(force_unit(JointKind::Revolute), "N·m");
        assert_eq!(format!("{:.2}", no_negative_zero(-7e-15, 2)), "0.00");
        assert_eq!(format!("{:.2}", no_negative_zero(-0.004, 2)), "0.00");
        assert_eq!(format!("{:.2}", no_negative_zero(-0.006, 2)), "-0.01");
    }
}
