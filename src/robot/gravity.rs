//! Which joints carry the arm's weight: releasing their torque lets the arm fall.
//!
//! Derived from the geometry, not from a list per robot, so that a robot file needs no extra
//! field and a calibrated or imported arm is judged the same way.

use super::{JointKind, Robot};

/// A revolute joint whose world axis has a vertical component below this is "horizontal":
/// gravity can turn it (about 25° or more from vertical).
pub const VERTICAL_AXIS: f64 = 0.9;
/// A prismatic joint whose axis has a vertical component above this (more than 30° from
/// horizontal) slides under gravity.
pub const SLIDING_AXIS: f64 = 0.5;
/// A horizontal revolute joint carries weight only if what it moves reaches at least this far
/// from its axis (metres): a wrist roll or a gripper turns the tool about itself, while a
/// shoulder, elbow or wrist flex swings the rest of the arm.
pub const MIN_LEVER_M: f64 = 0.01;

impl Robot {
    /// Which joints carry the arm's weight at `values`.
    ///
    /// A revolute joint carries weight when its world axis is not near vertical (gravity has a
    /// lever about it) and what it moves reaches away from that axis (the TCP when the TCP is
    /// beyond the joint, else the last joint's frame), so shoulder, elbow and wrist flex joints
    /// do and a vertical base pan, a wrist roll or a gripper do not. A prismatic joint carries
    /// weight when its axis is far from horizontal.
    pub fn weight_bearing(&self, values: &[f64]) -> Vec<bool> {
        let frames = self.joint_frames(values);
        let tcp = self
            .tcp
            .as_ref()
            .and_then(|tcp| Some((tcp.parent, frames.get(tcp.parent)?.compose(&tcp.origin).t)));
        let last = frames.last().map(|f| f.t);
        self.joints
            .iter()
            .zip(self.joint_axes(values))
            .enumerate()
            .map(|(i, (joint, (anchor, axis)))| {
                let axis = axis.normalize_or_zero();
                match joint.kind {
                    JointKind::Prismatic => axis.z.abs() > SLIDING_AXIS,
                    JointKind::Revolute if axis.z.abs() >= VERTICAL_AXIS => false,
                    JointKind::Revolute => {
                        let distal = match tcp {
                            Some((parent, point)) if parent >= i => point,
                            _ => last.unwrap_or(anchor),
                        };
                        (distal - anchor).reject_from(axis).length() >= MIN_LEVER_M
                    }
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIFT: usize = 1;
    const ELBOW: usize = 2;

    #[test]
    fn weight_bearing_joints_follow_the_geometry() {
        // Horizontal axes with the arm beyond them carry weight; vertical pans, wrist rolls and
        // grippers do not. The same joints the robots' documentation would name, on all three
        // arms.
        let expected: [(&str, &[bool]); 3] = [
            ("so101", &[false, true, true, true, false, false]),
            ("koch", &[false, true, true, true, false, false]),
            ("omx", &[false, true, true, true, false]),
        ];
        for (name, bearing) in expected {
            let robot = Robot::builtin(name).unwrap();
            assert_eq!(robot.weight_bearing(&robot.home), bearing, "{name}");
        }
        // Pitch the so101 wrist down (wrist flex -90°): the wrist roll axis is now vertical and
        // still carries nothing; lift and elbow still do.
        let robot = Robot::builtin("so101").unwrap();
        let mut pose = robot.home.clone();
        pose[3] = -90.0;
        let bearing = robot.weight_bearing(&pose);
        assert!(bearing[LIFT] && bearing[ELBOW] && !bearing[4]);
    }
}
