//! The official meshes of the built-in robots, for the page's 3D view: which mesh goes on which
//! joint's moving frame (none: the base), where, and in what colour, as each robot's
//! `web/meshes/ROBOT/parts.json` says (written by scripts/vendor-meshes.py from the vendor's
//! own MJCF or URDF; sources, commits and licences in docs/meshes.md). The files themselves
//! are served by `assets`.
//!
//! A robot file that is not built in, or whose chain drifted from its built-in model, has no
//! meshes: the page draws the model's boxes and capsules, or plain links, instead.

use serde::Deserialize;
use serde_json::{json, Value};

/// One mesh placed on a link.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub(crate) struct Part {
    /// The file in the robot's folder.
    pub mesh: String,
    /// The joint whose moving frame carries it; `None`: the base.
    pub joint: Option<String>,
    /// Where the mesh's frame is in that frame, metres.
    pub pos: [f64; 3],
    /// Its rotation there, w x y z (MJCF order).
    pub quat: [f64; 4],
    /// Its colour.
    pub rgba: [f64; 4],
}

#[derive(Debug, Deserialize)]
struct Manifest {
    parts: Vec<Part>,
}

/// Why a robot's meshes were left out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum MeshError {
    #[error("{robot}/parts.json: {message}")]
    Manifest { robot: String, message: String },
    #[error("{robot}/parts.json: mesh {mesh} is on joint {joint}, which the model does not have")]
    UnknownJoint {
        robot: String,
        mesh: String,
        joint: String,
    },
}

/// The compiled-in `parts.json` of a built-in robot.
fn manifest(robot: &str) -> Option<&'static str> {
    Some(match robot {
        "so101" => include_str!("web/meshes/so101/parts.json"),
        "so100" => include_str!("web/meshes/so100/parts.json"),
        "koch" => include_str!("web/meshes/koch/parts.json"),
        "omx" => include_str!("web/meshes/omx/parts.json"),
        _ => return None,
    })
}

/// The parts of a built-in robot; `None` for a robot without meshes.
pub(crate) fn parts(robot: &str) -> Option<Result<Vec<Part>, MeshError>> {
    let text = manifest(robot)?;
    Some(
        serde_json::from_str::<Manifest>(text)
            .map(|m| m.parts)
            .map_err(|e| MeshError::Manifest {
                robot: robot.to_string(),
                message: e.to_string(),
            }),
    )
}

/// The page's list of meshes for `robot` (URL, joint, origin in three.js order, colour), each
/// on a joint the model has (`has_joint`: the robot's joints and the model's mimic joints);
/// `Ok(None)` for a robot without meshes.
pub(crate) fn page_parts(
    robot: &str,
    has_joint: impl Fn(&str) -> bool,
) -> Result<Option<Value>, MeshError> {
    let Some(parts) = parts(robot) else {
        return Ok(None);
    };
    let parts = parts?;
    if let Some(part) = parts
        .iter()
        .find(|p| p.joint.as_deref().is_some_and(|j| !has_joint(j)))
    {
        return Err(MeshError::UnknownJoint {
            robot: robot.to_string(),
            mesh: part.mesh.clone(),
            joint: part.joint.clone().unwrap_or_default(),
        });
    }
    Ok(Some(Value::Array(
        parts
            .iter()
            .map(|p| {
                let [w, x, y, z] = p.quat;
                json!({
                    "url": format!("/meshes/{robot}/{}", p.mesh),
                    "joint": p.joint,
                    "origin": {"t": p.pos, "q": [x, y, z, w]},
                    "rgba": p.rgba,
                })
            })
            .collect(),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::RigidTransform;
    use crate::robot::Robot;
    use glam::{DQuat, DVec3};

    /// The vertices of a binary STL (as scripts/vendor-meshes.py writes them).
    fn stl_vertices(bytes: &[u8]) -> Vec<DVec3> {
        let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
        assert_eq!(bytes.len(), 84 + 50 * count, "a binary STL");
        let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64;
        (0..count)
            .flat_map(|t| (0..3).map(move |v| 84 + 50 * t + 12 + 12 * v))
            .map(|at| DVec3::new(float(at), float(at + 4), float(at + 8)))
            .collect()
    }

    /// Every vertex of the robot's meshes at `values`, in the base frame, with the part.
    fn placed(robot: &Robot, values: &[f64]) -> Vec<(Part, Vec<DVec3>)> {
        let frames = robot.joint_frames(values);
        parts(&robot.name)
            .unwrap()
            .unwrap()
            .into_iter()
            .filter_map(|part| {
                let frame = match &part.joint {
                    None => RigidTransform::IDENTITY,
                    // The OMX's right finger mimics the left: the model's joint, not the robot's.
                    Some(j) => frames[robot.joint_index(j)?],
                };
                let [w, x, y, z] = part.quat;
                let local =
                    RigidTransform::new(DVec3::from(part.pos), DQuat::from_xyzw(x, y, z, w));
                let to_base = frame.compose(&local);
                let url = format!("/meshes/{}/{}", robot.name, part.mesh);
                let (_, bytes) = crate::studio::assets::file(&url).expect("served");
                let points = stl_vertices(bytes)
                    .into_iter()
                    .map(|v| to_base.t + to_base.r * v)
                    .collect();
                Some((part, points))
            })
            .collect()
    }

    /// Every built-in robot's meshes are served and placed on joints its model has.
    #[test]
    fn every_built_in_robot_has_its_meshes() {
        for name in crate::robot::BUILTIN_NAMES {
            let robot = Robot::builtin(name).unwrap();
            let model = crate::studio::robot_model::model(&robot);
            let meshes = model["meshes"]
                .as_array()
                .unwrap_or_else(|| panic!("{name}"));
            assert!(meshes.len() >= 7, "{name}");
            for m in meshes {
                assert!(crate::studio::assets::file(m["url"].as_str().unwrap()).is_some());
            }
        }
    }

    /// The fallback: a robot file of another name, or a built-in whose chain drifted from its
    /// model, gets no meshes (the page keeps the boxes and capsules, or plain links).
    #[test]
    fn robots_without_official_meshes_keep_the_shapes() {
        let mut renamed = Robot::builtin("so101").unwrap();
        renamed.name = "my_arm".into();
        assert!(crate::studio::robot_model::model(&renamed)["meshes"].is_null());
        let mut drifted = Robot::builtin("so101").unwrap();
        drifted.joints[2].origin.t.x += 0.01;
        assert!(crate::studio::robot_model::model(&drifted)["meshes"].is_null());
    }

    /// The arm stands on the desk: the lowest point of the base's meshes is the base frame's
    /// z = 0 (keypose's base frame is on the mounting surface, docs/robots.md), within the
    /// 0.5 mm the decimation snaps vertices to and the 2.4 mm the vendor's SO-101 model puts
    /// its base frame above the underside of the base (its `base` geoms at z = -0.0024).
    #[test]
    fn every_base_sits_on_the_desk() {
        for name in crate::robot::BUILTIN_NAMES {
            let robot = Robot::builtin(name).unwrap();
            let home = vec![0.0; robot.joints.len()];
            let lowest = placed(&robot, &home)
                .iter()
                .filter(|(p, _)| p.joint.is_none())
                .flat_map(|(_, points)| points.iter().map(|p| p.z))
                .fold(f64::INFINITY, f64::min);
            assert!(lowest.abs() < 0.0025, "{name}: base bottom at z {lowest}");
        }
    }

    /// The tool centre point (forward kinematics of the robot file, its TCP the vendor's
    /// gripper frame) lies among the meshes of the tool's link: inside the bounding box of the
    /// parts that the TCP's joint and the joints after it carry, at home and at a bent pose, and
    /// at its far end: the fingertips reach at most 25 mm past it along the wrist-to-TCP
    /// direction. A mesh placed on the wrong frame, or with the wrong rotation, misses both.
    #[test]
    fn the_tool_point_is_within_the_gripper_meshes() {
        for name in crate::robot::BUILTIN_NAMES {
            let robot = Robot::builtin(name).unwrap();
            let tcp_parent = robot.tcp.as_ref().unwrap().parent;
            let bent: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| {
                    (0.3 * j.limits.max + 0.1 * j.limits.min).clamp(j.limits.min, j.limits.max)
                })
                .collect();
            for values in [vec![0.0; robot.joints.len()], bent] {
                let tcp = robot.tcp_position(&values);
                let wrist = robot.joint_frames(&values)[tcp_parent].t;
                let along = (tcp - wrist).normalize();
                let tool: Vec<DVec3> = placed(&robot, &values)
                    .iter()
                    .filter(|(p, _)| {
                        p.joint
                            .as_deref()
                            .and_then(|j| robot.joint_index(j))
                            .is_some_and(|j| j >= tcp_parent)
                    })
                    .flat_map(|(_, points)| points.iter().copied())
                    .collect();
                let past = tool
                    .iter()
                    .map(|p| (*p - tcp).dot(along))
                    .fold(f64::MIN, f64::max);

                assert!(
                    (0.0..0.025).contains(&past),
                    "{name} at {values:?}: the fingertips reach {past} m past the tcp"
                );
                let (lo, hi) = tool
                    .iter()
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(*p), hi.max(*p))
                    });
                let outside = (lo - tcp).max(tcp - hi).max(DVec3::ZERO);
                assert!(
                    outside.length() < 0.002,
                    "{name} at {values:?}: tcp {tcp} outside the gripper's box {lo} … {hi}"
                );
            }
        }
    }
}
