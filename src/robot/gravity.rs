//! Which joints carry the arm's weight: releasing their torque lets the arm fall.
//!
//! Derived from the geometry, not from a list per robot, so that a robot file needs no extra
//! field and a calibrated or imported arm is judged the same way.

use super::{FixedFrame, JointKind, Robot};

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
        // What each joint moves ends at its own arm's tool (a cell's arms each have theirs):
        // (the arm's joints, its TCP as the cell numbers its joints).
        let chains: Vec<(std::ops::Range<usize>, Option<FixedFrame>)> = if self.is_cell() {
            self.arms
                .iter()
                .map(|arm| {
                    let tcp = arm.robot.tcp.as_ref().map(|tcp| FixedFrame {
                        parent: arm.joints.start + tcp.parent,
                        origin: tcp.origin,
                    });
                    (arm.joints.clone(), tcp)
                })
                .collect()
        } else {
            vec![(0..self.joints.len(), self.tcp.clone())]
        };
        let distal: Vec<Option<glam::DVec3>> = (0..self.joints.len())
            .map(|i| {
                let (range, tcp) = chains.iter().find(|(r, _)| r.contains(&i))?;
                match tcp {
                    Some(tcp) if tcp.parent >= i => {
                        Some(frames.get(tcp.parent)?.compose(&tcp.origin).t)
                    }
                    _ => frames.get(range.end.checked_sub(1)?).map(|f| f.t),
                }
            })
            .collect();
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
                        let distal = distal[i].unwrap_or(anchor);
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

    /// Each arm of a cell carries its weight as it does alone, at the same pose: what a joint
    /// moves ends at its own arm's tool, not at the last arm's. Poses where the distal point
    /// decides: the arm folded so that the wrist flex's lever is its own gripper's.
    #[test]
    fn a_cells_arms_carry_weight_as_each_arm_alone() {
        let so101 = Robot::builtin("so101").unwrap();
        let apart = |y: f64| {
            crate::pose::RigidTransform::new(glam::DVec3::new(0.0, y, 0.0), glam::DQuat::IDENTITY)
        };
        let cell = Robot::cell(vec![
            ("left".into(), so101.clone(), apart(0.25)),
            ("right".into(), so101.clone(), apart(-0.25)),
        ])
        .unwrap();
        for pose in [
            vec![0.0; 6],
            vec![0.0, -90.0, 90.0, 0.0, 0.0, 0.0],
            vec![30.0, -100.0, 0.0, -90.0, 0.0, 0.0],
            vec![0.0, 0.0, 0.0, 90.0, 90.0, 0.0],
        ] {
            let alone = so101.weight_bearing(&pose);
            let both: Vec<f64> = pose.iter().chain(&pose).copied().collect();
            let in_cell = cell.weight_bearing(&both);
            assert_eq!(in_cell[..6], alone[..], "left at {pose:?}");
            assert_eq!(in_cell[6..], alone[..], "right at {pose:?}");
        }
    }
}
