//! The robot as the page draws it: the kinematic chain from the robot description (joint
//! origins, axes, kinds, limits, the TCP) and, for the built-in robots, the link shapes of
//! the simulation model (sim/models/*.xml: boxes, capsules, cylinders and spheres placed in
//! body frames that are the chain's joint frames).
//!
//! The page builds one node per MJCF body at its `pos`/`quat`, turns a jointed body about its
//! axis by the joint's value, and puts the body's shapes in it. That is the chain keypose
//! computes only if each jointed body sits where the robot description puts the joint, so
//! [`model`] checks it and, should a model ever drift from its robot, sends the chain alone
//! (the page then draws plain links) rather than a picture that lies. The official meshes of a
//! built-in robot (`meshes`) come only with shapes that passed that check.

use crate::pose::RigidTransform;
use crate::robot::mjcf::{child, frame, mimics, numbers, vector, AttributeError};
use crate::robot::{JointKind, Robot};
use serde_json::{json, Value};

/// How far a model's body may sit from its joint's origin: the models write six digits.
const MATCH_TOLERANCE: f64 = 1e-5;

/// Why the shapes of a model were left out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum ModelError {
    #[error("the model is not XML: {0}")]
    Xml(String),
    #[error(transparent)]
    Attribute(#[from] AttributeError),
    #[error("body of joint {joint} is not at the robot's joint origin")]
    Mismatch { joint: String },
    #[error("joint {joint} of the robot has no body in the model")]
    Missing { joint: String },
}

/// `GET /api/robot`: the chain, and the shapes when the robot has a model that matches it. A
/// cell is its arms, each the model of the arm alone with its base (cell frame) and where its
/// joints start among the cell's; the page draws each at its base.
pub(crate) fn model(robot: &Robot) -> Value {
    if robot.is_cell() {
        return cell_model(robot);
    }
    let (bodies, mimics, note) = match crate::robot::builtin_mjcf(&robot.name) {
        None => (
            Value::Null,
            Value::Null,
            "no simulation model: plain links".to_string(),
        ),
        Some(text) => match shapes(robot, text) {
            Ok((bodies, mimics)) => (bodies, mimics, format!("sim/models/{}.xml", robot.name)),
            Err(e) => (Value::Null, Value::Null, format!("model left out: {e}")),
        },
    };
    // The official meshes only on a chain that matches its built-in model (checked above),
    // since that is the chain they were placed on.
    let meshes = match bodies.is_null() {
        true => Ok(None),
        false => super::meshes::page_parts(&robot.name, |joint| {
            let mimic = |m: &Value| m["joint"] == joint;
            robot.joint_index(joint).is_some()
                || mimics.as_array().is_some_and(|m| m.iter().any(mimic))
        }),
    };
    let (meshes, mesh_note) = match meshes {
        Ok(meshes) => (meshes.unwrap_or(Value::Null), Value::Null),
        Err(e) => (Value::Null, json!(format!("meshes left out: {e}"))),
    };
    json!({
        "name": robot.name,
        "joints": chain(robot),
        "tcp": robot.tcp.as_ref().map(|tcp| json!({
            "parent": robot.joints[tcp.parent].name,
            "origin": transform(&tcp.origin),
        })),
        "bodies": bodies,
        "mimics": mimics,
        "geometry": note,
        "meshes": meshes,
        "meshes_note": mesh_note,
    })
}

fn cell_model(cell: &Robot) -> Value {
    let arms: Vec<Value> = cell
        .arms
        .iter()
        .map(|arm| {
            json!({
                "name": arm.name,
                "base": transform(&arm.base),
                "first": arm.joints.start,
                "model": model(&arm.robot),
            })
        })
        .collect();
    json!({
        "name": cell.name,
        "joints": chain(cell),
        "tcp": Value::Null,
        "arms": arms,
        "bodies": Value::Null,
        "mimics": Value::Null,
        "geometry": "each arm's own",
    })
}

fn chain(robot: &Robot) -> Vec<Value> {
    robot
        .joints
        .iter()
        .map(|joint| {
            json!({
                "name": joint.name,
                "kind": match joint.kind {
                    JointKind::Revolute => "revolute",
                    JointKind::Prismatic => "prismatic",
                },
                "unit": crate::teach::format::unit(joint).trim(),
                "axis": [joint.axis.x, joint.axis.y, joint.axis.z],
                "origin": transform(&joint.origin),
                "limits": {"min": joint.limits.min, "max": joint.limits.max},
            })
        })
        .collect()
}

/// A transform as the page reads it: translation and quaternion in three.js order (x y z w).
fn transform(t: &RigidTransform) -> Value {
    json!({"t": [t.t.x, t.t.y, t.t.z], "q": [t.r.x, t.r.y, t.r.z, t.r.w]})
}

/// The body tree and the mimic joints of an MJCF text, checked against the robot's chain.
fn shapes(robot: &Robot, text: &str) -> Result<(Value, Value), ModelError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| ModelError::Xml(e.to_string()))?;
    let root = doc.root_element();
    let materials = materials(&root)?;
    let world =
        child(&root, "worldbody").ok_or_else(|| ModelError::Xml("no <worldbody>".into()))?;
    let mut found = Vec::new();
    let bodies = world
        .children()
        .filter(|n| n.has_tag_name("body"))
        .map(|b| body(&b, &materials, &mut found))
        .collect::<Result<Vec<_>, _>>()?;
    for joint in &robot.joints {
        match found.iter().find(|(name, _)| name == &joint.name) {
            None => {
                return Err(ModelError::Missing {
                    joint: joint.name.clone(),
                })
            }
            Some((_, origin)) if !same_frame(origin, &joint.origin) => {
                return Err(ModelError::Mismatch {
                    joint: joint.name.clone(),
                })
            }
            Some(_) => {}
        }
    }
    let mimics = mimics(&root)?
        .into_iter()
        .map(|m| json!({"joint": m.joint, "follows": m.follows, "offset": m.offset, "scale": m.scale}))
        .collect();
    Ok((Value::Array(bodies), Value::Array(mimics)))
}

fn same_frame(a: &RigidTransform, b: &RigidTransform) -> bool {
    (a.t - b.t).length() < MATCH_TOLERANCE && a.r.dot(b.r).abs() > 1.0 - MATCH_TOLERANCE
}

/// Material name → rgba.
fn materials(root: &roxmltree::Node) -> Result<Vec<(String, Vec<f64>)>, ModelError> {
    let Some(asset) = child(root, "asset") else {
        return Ok(Vec::new());
    };
    asset
        .children()
        .filter(|n| n.has_tag_name("material"))
        .filter_map(|m| Some((m, m.attribute("name")?, m.attribute("rgba")?)))
        .map(|(m, name, _)| Ok((name.to_string(), numbers(&m, "rgba", "", 4)?)))
        .collect()
}

/// One body with its shapes and child bodies; records each joint's body frame in `found`.
fn body(
    node: &roxmltree::Node,
    materials: &[(String, Vec<f64>)],
    found: &mut Vec<(String, RigidTransform)>,
) -> Result<Value, ModelError> {
    let origin = frame(node)?;
    let joint = match child(node, "joint") {
        Some(j) => {
            let name = j.attribute("name").unwrap_or_default().to_string();
            found.push((name.clone(), origin));
            let axis = vector(&j, "axis", "0 0 1")?;
            let kind = match j.attribute("type").unwrap_or("hinge") {
                "slide" => "prismatic",
                _ => "revolute",
            };
            json!({"name": name, "kind": kind, "axis": [axis.x, axis.y, axis.z]})
        }
        None => Value::Null,
    };
    let geoms = node
        .children()
        .filter(|n| n.has_tag_name("geom"))
        .map(|g| geom(&g, materials))
        .collect::<Result<Vec<_>, _>>()?;
    let children = node
        .children()
        .filter(|n| n.has_tag_name("body"))
        .map(|b| body(&b, materials, found))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(json!({
        "name": node.attribute("name").unwrap_or_default(),
        "origin": transform(&origin),
        "joint": joint,
        "geoms": geoms.into_iter().flatten().collect::<Vec<_>>(),
        "children": children,
    }))
}

/// A shape in its body's frame; `None` for kinds the page does not draw (planes, meshes).
fn geom(
    node: &roxmltree::Node,
    materials: &[(String, Vec<f64>)],
) -> Result<Option<Value>, ModelError> {
    let kind = node.attribute("type").unwrap_or("sphere");
    if !matches!(kind, "box" | "capsule" | "cylinder" | "sphere") {
        return Ok(None);
    }
    let size = numbers(node, "size", "0.005", 0)?;
    let rgba = match (node.attribute("rgba"), node.attribute("material")) {
        (Some(_), _) => numbers(node, "rgba", "", 4)?,
        (None, Some(m)) => materials
            .iter()
            .find(|(name, _)| name == m)
            .map_or(vec![0.6, 0.6, 0.6, 1.0], |(_, rgba)| rgba.clone()),
        (None, None) => vec![0.6, 0.6, 0.6, 1.0],
    };
    let fromto = match node.attribute("fromto") {
        Some(_) => Some(numbers(node, "fromto", "", 6)?),
        None => None,
    };
    Ok(Some(json!({
        "name": node.attribute("name").unwrap_or_default(),
        "type": kind,
        "size": size,
        "rgba": rgba,
        "fromto": fromto,
        "origin": transform(&frame(node)?),
    })))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};

    /// Every built-in robot's model places its jointed bodies where its robot description
    /// puts the joints (the oracle: robots/*.json, which the models were written from).
    #[test]
    fn every_built_in_model_matches_its_robot_and_has_shapes() {
        for name in crate::robot::BUILTIN_NAMES {
            let robot = Robot::builtin(name).unwrap();
            let model = model(&robot);
            assert_eq!(
                model["geometry"],
                format!("sim/models/{name}.xml"),
                "{name}"
            );
            assert_eq!(
                model["joints"].as_array().unwrap().len(),
                robot.joints.len()
            );
            let text = model.to_string();
            assert!(text.contains("\"type\":\"box\""), "{name} has boxes");
        }
    }

    #[test]
    fn the_so101_base_plate_is_read_as_written() {
        // sim/models/so101.xml: <geom name="base_plate" type="box" pos="0.02 0 0.028"
        // size="0.05 0.04 0.028" material="yellow"/>, yellow = rgba "1 0.82 0.12 1".
        let model = model(&Robot::builtin("so101").unwrap());
        let base = &model["bodies"][0];
        assert_eq!(base["name"], "base");
        assert!(base["joint"].is_null());
        let plate = &base["geoms"][0];
        assert_eq!(plate["size"], json!([0.05, 0.04, 0.028]));
        assert_eq!(plate["rgba"], json!([1.0, 0.82, 0.12, 1.0]));
        assert_eq!(plate["origin"]["t"], json!([0.02, 0.0, 0.028]));
        assert_eq!(base["children"][0]["joint"]["name"], "shoulder_pan");
    }

    #[test]
    fn a_model_that_drifted_from_its_robot_is_left_out() {
        let mut robot = Robot::builtin("so101").unwrap();
        robot.joints[2].origin.t.x += 0.01;
        let text = crate::robot::builtin_mjcf("so101").unwrap();
        assert_eq!(
            shapes(&robot, text).unwrap_err(),
            ModelError::Mismatch {
                joint: "elbow_flex".into()
            }
        );
        assert!(model(&robot)["bodies"].is_null());
    }

    /// A cell is drawn arm by arm: each arm's own model (shapes included) at its base, with
    /// the index of its first joint among the cell's.
    #[test]
    fn a_cell_is_its_arms_each_at_its_base() {
        let so101 = Robot::builtin("so101").unwrap();
        let right = RigidTransform::new(DVec3::new(0.0, -0.25, 0.0), DQuat::IDENTITY);
        let cell = Robot::cell(vec![
            ("left".into(), so101.clone(), RigidTransform::IDENTITY),
            ("right".into(), so101, right),
        ])
        .unwrap();
        let model = model(&cell);
        let arms = model["arms"].as_array().unwrap();
        assert_eq!(arms.len(), 2);
        assert_eq!(arms[1]["name"], "right");
        assert_eq!(arms[1]["first"], 6);
        assert_eq!(arms[1]["base"]["t"], json!([0.0, -0.25, 0.0]));
        assert_eq!(arms[1]["model"]["geometry"], "sim/models/so101.xml");
        assert_eq!(arms[1]["model"]["joints"][0]["name"], "shoulder_pan");
        assert_eq!(model["joints"][6]["name"], "right/shoulder_pan");
    }

    #[test]
    fn the_omx_second_finger_mimics_the_first() {
        let model = model(&Robot::builtin("omx").unwrap());
        assert_eq!(
            model["mimics"],
            json!([{"joint": "gripper_right_joint", "follows": "gripper_left_joint", "offset": 0.0, "scale": 1.0}])
        );
    }
}
