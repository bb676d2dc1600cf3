//! An arm's own mirror plane and what reflecting across it does to each joint (docs/robots.md
//! §13): the vertical plane through the first joint's anchor and the tool point at the zero
//! pose; a joint whose axis lies in it turns the other way in the mirror image, one square to
//! it turns the same way, and a joint the tool point does not ride on (the gripper) keeps its
//! value.

use super::MirrorError;
use crate::pose::RigidTransform;
use crate::robot::{JointKind, Robot};
use crate::sequence::{ToolKey, ToolOrientation};
use glam::{DQuat, DVec3};

/// How far (degrees) a joint axis may lean out of the plane, or off its normal, and still count
/// as in it or square to it. The Koch's tool point (the midpoint of its two unlike finger pads)
/// sits 5.9 mm beside its wrist and turns its plane 1.5° off its pitch axes' normal; an axis
/// leaning further than this makes a mirror image no joint motion can give.
pub const AXIS_TOLERANCE_DEG: f64 = 2.0;
/// Least horizontal distance (metres) between the first joint's anchor and the tool point at the
/// zero pose: closer, the two do not fix a vertical plane.
pub const MIN_REACH_M: f64 = 0.001;

/// A plane in an arm's base frame, given by a point on it and its unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorPlane {
    /// A point on the plane, metres.
    pub point: DVec3,
    /// Its unit normal.
    pub normal: DVec3,
}

impl MirrorPlane {
    /// The arm's own plane: vertical (it holds the base frame's z), through the first joint's
    /// anchor and the tool point at the zero pose.
    pub fn of(robot: &Robot) -> Result<MirrorPlane, MirrorError> {
        let zero = vec![0.0; robot.joints.len()];
        let anchor = robot.frames(&zero).next().map_or(DVec3::ZERO, |f| f.t);
        let reach = robot.tcp_position(&zero) - anchor;
        let horizontal = DVec3::new(reach.x, reach.y, 0.0);
        if horizontal.length() < MIN_REACH_M {
            return Err(MirrorError::NoPlane {
                robot: robot.name.clone(),
                distance_m: horizontal.length(),
            });
        }
        Ok(MirrorPlane {
            point: anchor,
            normal: DVec3::Z.cross(horizontal).normalize(),
        })
    }

    /// The mirror image of a point: `p − 2((p − c)·n) n`.
    pub fn reflect_point(&self, p: DVec3) -> DVec3 {
        p - 2.0 * (p - self.point).dot(self.normal) * self.normal
    }

    /// The mirror image of a direction (the reflection's linear part, `M = I − 2nnᵀ`).
    pub fn reflect_vector(&self, v: DVec3) -> DVec3 {
        v - 2.0 * v.dot(self.normal) * self.normal
    }

    /// `M·R·M`, the rotation the mirrored arm's frame has: a rotation by θ about `a` becomes one
    /// by −θ about `M·a`, so the quaternion (w, v) becomes (w, −M·v).
    pub fn reflect_rotation(&self, q: DQuat) -> DQuat {
        let v = -self.reflect_vector(DVec3::new(q.x, q.y, q.z));
        DQuat::from_xyzw(v.x, v.y, v.z, q.w)
    }
}

/// What the mirror image does to one joint's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointRule {
    /// The value changes sign: a revolute axis in the plane, a prismatic one square to it.
    Negate,
    /// The value stays: a revolute axis square to the plane, a prismatic one in it.
    Keep,
    /// The tool point does not ride on the joint: it opens the gripper, and an opening has no
    /// side to mirror, so the value stays whatever its axis.
    Gripper,
}

/// An arm's plane and the rule of each of its joints, in joint order.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmMirror {
    /// The arm's own vertical plane, in its base frame.
    pub plane: MirrorPlane,
    /// (joint name, rule) of every joint, in joint order.
    pub rules: Vec<(String, JointRule)>,
    /// The tool frame at the zero pose, which the mirror image of a turn starts from.
    pub zero_tool: RigidTransform,
}

impl ArmMirror {
    /// Derives the plane and the rules from the robot's own geometry at the zero pose; an axis
    /// neither in the plane nor square to it is refused, naming the joint.
    pub fn of(robot: &Robot) -> Result<ArmMirror, MirrorError> {
        let plane = MirrorPlane::of(robot)?;
        let zero = vec![0.0; robot.joints.len()];
        // A joint past the tool point's parent moves something the tool point is not on.
        let moves_tool = crate::kinematics::tool_joints(robot);
        let mut rules = Vec::with_capacity(robot.joints.len());
        for (index, (joint, (_, axis))) in
            robot.joints.iter().zip(robot.joint_axes(&zero)).enumerate()
        {
            let rule = if !moves_tool[index] {
                JointRule::Gripper
            } else {
                axis_rule(robot, index, joint.kind, axis, &plane)?
            };
            rules.push((joint.name.clone(), rule));
        }
        Ok(ArmMirror {
            plane,
            rules,
            zero_tool: robot.tcp_frame(&zero),
        })
    }

    /// A tool target's mirror image: the point reflected across the plane, and the tool
    /// frame turned from its zero-pose orientation `R0` by the mirror image of the turn that
    /// takes `R0` to the target's `R`: `R' = M(R·R0⁻¹)M · R0`. Where the tool frame at zero is
    /// not itself symmetric (the SO-101's leans 2.8° with its jaw, the SO-100's has its x
    /// axis across the plane), `M·R·M` alone is not a pose the mirrored joints reach; this is
    /// exactly the pose they do (docs/robots.md §13). The orientation keeps the form it was
    /// written in.
    pub fn reflect_tool(&self, tool: &ToolKey) -> ToolKey {
        let r0 = self.zero_tool.r;
        let turn = |q: DQuat| (self.plane.reflect_rotation(q * r0.inverse()) * r0).normalize();
        let orientation = tool.orientation.map(|o| match o {
            ToolOrientation::Quaternion(q) => ToolOrientation::Quaternion(turn(q)),
            ToolOrientation::Rpy(_) => {
                let (r, p, y) = crate::pose::rpy_from_quat(turn(o.quaternion()));
                ToolOrientation::Rpy([r, p, y])
            }
        });
        ToolKey {
            xyz: self.plane.reflect_point(tool.xyz),
            orientation,
            // The plane is vertical: down stays down.
            approach: tool.approach,
        }
    }

    /// The rule of the joint called `name`.
    pub fn rule(&self, name: &str) -> Option<JointRule> {
        self.rules.iter().find(|(n, _)| n == name).map(|(_, r)| *r)
    }
}

/// In the plane, square to it, or (an error) neither.
fn axis_rule(
    robot: &Robot,
    index: usize,
    kind: JointKind,
    axis: DVec3,
    plane: &MirrorPlane,
) -> Result<JointRule, MirrorError> {
    let out_of_plane = axis
        .normalize()
        .dot(plane.normal)
        .abs()
        .min(1.0)
        .asin()
        .to_degrees();
    let in_plane = out_of_plane <= AXIS_TOLERANCE_DEG;
    let square = out_of_plane >= 90.0 - AXIS_TOLERANCE_DEG;
    match (kind, in_plane, square) {
        (JointKind::Revolute, true, _) | (JointKind::Prismatic, _, true) => Ok(JointRule::Negate),
        (JointKind::Revolute, _, true) | (JointKind::Prismatic, true, _) => Ok(JointRule::Keep),
        _ => Err(MirrorError::ObliqueAxis {
            robot: robot.name.clone(),
            joint: robot.joints[index].name.clone(),
            angle_deg: out_of_plane,
            tolerance_deg: AXIS_TOLERANCE_DEG,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    fn rules_of(name: &str) -> Vec<JointRule> {
        let robot = Robot::builtin(name).unwrap();
        let mirror = ArmMirror::of(&robot).unwrap();
        let plane = mirror.plane;
        let zero = vec![0.0; robot.joints.len()];
        // The numbers docs/robots.md §13 quotes: each axis's angle out of the plane, and how
        // far each in-plane axis line passes from it.
        println!(
            "{name}: plane normal {:?} through {:?}",
            plane.normal, plane.point
        );
        for ((joint, (anchor, axis)), (_, rule)) in robot
            .joints
            .iter()
            .zip(robot.joint_axes(&zero))
            .zip(&mirror.rules)
        {
            let angle = axis.dot(plane.normal).abs().min(1.0).asin().to_degrees();
            let offset = (anchor - plane.point).dot(plane.normal);
            println!(
                "  {:<20} {angle:7.3}° out of the plane, anchor {offset:+.5} m off it: {rule:?}",
                joint.name
            );
        }
        mirror.rules.iter().map(|(_, r)| *r).collect()
    }

    use JointRule::{Gripper, Keep, Negate};

    #[test]
    fn the_built_ins_mirror_their_pan_and_roll_and_keep_their_pitches() {
        // Read off the axis tables of docs/robots.md §1.3, §2.3, §3.3 and §11.3: pan vertical
        // (in the plane), pitches along the plane's normal, roll along the forearm (in it).
        assert_eq!(
            rules_of("so101"),
            [Negate, Keep, Keep, Keep, Negate, Gripper]
        );
        assert_eq!(
            rules_of("so100"),
            [Negate, Keep, Keep, Keep, Negate, Gripper]
        );
        assert_eq!(
            rules_of("koch"),
            [Negate, Keep, Keep, Keep, Negate, Gripper]
        );
        let omx = rules_of("omx");
        assert_eq!(omx[..4], [Negate, Keep, Keep, Keep]);
        assert!(omx[4..].iter().all(|&r| r == Gripper));
    }

    #[test]
    fn a_reflected_tool_orientation_is_the_one_the_mirrored_joints_reach() {
        // Orientations depend on the axis directions alone, which classify within 0.002° on
        // the SO-101, SO-100 and OMX and 1.5° on the Koch (whose pitch axes are 1.5° off the
        // plane's normal): the rule's joints reach the reflected orientation that closely.
        for name in crate::robot::BUILTIN_NAMES {
            let tolerance_deg = match name {
                "so101" | "so100" | "omx" => 0.01,
                "koch" => 6.0,
                other => panic!("{other}: a new built-in needs its tolerance here"),
            };
            let robot = Robot::builtin(name).unwrap();
            let mirror = ArmMirror::of(&robot).unwrap();
            let n = robot.joints.len();
            let q = [20.0, -30.0, 40.0, 30.0, 25.0, 0.0][..n].to_vec();
            let mirrored: Vec<f64> = q
                .iter()
                .zip(&mirror.rules)
                .map(|(v, (_, rule))| if *rule == Negate { -v } else { *v })
                .collect();
            let target = robot.tcp_frame(&q);
            let tool = ToolKey {
                xyz: target.t,
                orientation: Some(ToolOrientation::Quaternion(target.r)),
                approach: None,
            };
            let reflected = mirror.reflect_tool(&tool).orientation.unwrap().quaternion();
            let reached = robot.tcp_frame(&mirrored).r;
            let error = reached.angle_between(reflected).to_degrees();
            println!("{name}: reflected orientation {error:.2e}° from the mirrored joints'");
            assert!(error < tolerance_deg, "{name}: {error}");
        }
    }

    #[test]
    fn the_so101_plane_is_its_x_z_plane() {
        let plane = MirrorPlane::of(&Robot::builtin("so101").unwrap()).unwrap();
        // The TCP at zero is (0.39136, −0.00001, 0.22647), the pan anchor (0.03884, 0, 0.0624)
        // (§1.3): a normal 3e-5 rad off ±y.
        assert!(plane.normal.y.abs() > 1.0 - 1e-8, "{:?}", plane.normal);
        let p = plane.reflect_point(DVec3::new(0.25, 0.1, 0.2));
        assert!((p - DVec3::new(0.25, -0.1, 0.2)).length() < 2e-5, "{p:?}");
    }

    #[test]
    fn a_rotation_reflects_to_the_opposite_turn_about_the_mirrored_axis() {
        let plane = MirrorPlane {
            point: DVec3::ZERO,
            normal: DVec3::Y,
        };
        // About z (in the plane x-z): the turn reverses. About y (the normal): it stays.
        let about_z = DQuat::from_rotation_z(0.7);
        assert!(
            plane
                .reflect_rotation(about_z)
                .angle_between(DQuat::from_rotation_z(-0.7))
                < 1e-12
        );
        let about_y = DQuat::from_rotation_y(0.7);
        assert!(plane.reflect_rotation(about_y).angle_between(about_y) < 1e-12);
        // M·R·M as matrices, for a rotation about a general axis.
        let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
        let m = glam::DMat3::from_diagonal(DVec3::new(1.0, -1.0, 1.0));
        let expected = DQuat::from_mat3(&(m * glam::DMat3::from_quat(q) * m));
        assert!(plane.reflect_rotation(q).angle_between(expected) < 1e-12);
    }

    #[test]
    fn an_oblique_axis_is_refused_naming_its_joint() {
        let mut robot = Robot::builtin("so101").unwrap();
        // Tilt the elbow's axis 30° in its own frame: neither in the plane nor square to it.
        robot.joints[2].axis = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
        match ArmMirror::of(&robot).unwrap_err() {
            MirrorError::ObliqueAxis {
                joint, angle_deg, ..
            } => {
                assert_eq!(joint, "elbow_flex");
                assert!(
                    (angle_deg - 60.0).abs() < 0.1 || (angle_deg - 30.0).abs() < 0.1,
                    "{angle_deg}"
                );
            }
            other => panic!("{other}"),
        }
    }
}
