//! What keypose reads of an MJCF model's bodies: the body tree (each body's frame in its
//! parent's, its joint at the body's origin, as keypose's models place them, its mass), the
//! collision shapes (boxes and capsules, as the built-in models have them; spheres too), the
//! excluded body pairs and the mimic joints. The collision check and the inverse dynamics
//! (`dynamics`) read the same tree, so both see the arm alike.

use super::gjk::Core;
use crate::pose::RigidTransform;
use crate::robot::mjcf::{
    child, frame, inertial, mimics, numbers, vector, AttributeError, Inertial, Mimic,
};
use crate::robot::JointKind;
use glam::DVec3;

/// A shape in its body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shape {
    /// A segment swept by a radius (a capsule; a sphere when the ends coincide).
    Swept { a: DVec3, b: DVec3, radius: f64 },
    /// A box: its frame and half sizes.
    Box { frame: RigidTransform, half: DVec3 },
}

impl Shape {
    /// Its core in the world and its radius, the body at `frame`.
    pub(crate) fn placed(&self, frame: &RigidTransform) -> (Core, f64) {
        match *self {
            Shape::Swept { a, b, radius } => (
                Core::Segment {
                    a: frame.t + frame.r * a,
                    b: frame.t + frame.r * b,
                },
                radius,
            ),
            Shape::Box { frame: local, half } => {
                let world = frame.compose(&local);
                let axes =
                    [DVec3::X * half.x, DVec3::Y * half.y, DVec3::Z * half.z].map(|h| world.r * h);
                (
                    Core::Box {
                        centre: world.t,
                        axes,
                    },
                    0.0,
                )
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub axis: DVec3,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Body {
    pub name: String,
    /// Index among the model's bodies; `None` under the world body.
    pub parent: Option<usize>,
    pub origin: RigidTransform,
    pub joint: Option<Joint>,
    /// Its mass properties; `None` where the model gives none.
    pub inertial: Option<Inertial>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Geom {
    pub body: usize,
    pub shape: Shape,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct Model {
    /// Parents before children.
    pub bodies: Vec<Body>,
    pub geoms: Vec<Geom>,
    pub excluded: Vec<(usize, usize)>,
    pub mimics: Vec<Mimic>,
}

/// Why a model cannot be read for the check.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum MjcfError {
    #[error("not XML: {0}")]
    Xml(String),
    #[error(transparent)]
    Attribute(#[from] AttributeError),
    #[error("<exclude> names body {0:?}, which the model does not have")]
    UnknownBody(String),
}

pub(crate) fn parse(text: &str) -> Result<Model, MjcfError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| MjcfError::Xml(e.to_string()))?;
    let root = doc.root_element();
    let mut model = Model::default();
    if let Some(world) = child(&root, "worldbody") {
        for body in world.children().filter(|n| n.has_tag_name("body")) {
            read_body(&body, None, &mut model)?;
        }
    }
    if let Some(contact) = child(&root, "contact") {
        for exclude in contact.children().filter(|n| n.has_tag_name("exclude")) {
            let index = |attribute: &str| {
                let name = exclude.attribute(attribute).unwrap_or_default();
                model
                    .bodies
                    .iter()
                    .position(|b| b.name == name)
                    .ok_or_else(|| MjcfError::UnknownBody(name.to_string()))
            };
            let pair = (index("body1")?, index("body2")?);
            model.excluded.push(pair);
        }
    }
    model.mimics = mimics(&root)?;
    Ok(model)
}

fn read_body(
    node: &roxmltree::Node,
    parent: Option<usize>,
    model: &mut Model,
) -> Result<(), MjcfError> {
    let index = model.bodies.len();
    let joint = match child(node, "joint") {
        None => None,
        Some(j) => Some(Joint {
            name: j.attribute("name").unwrap_or_default().to_string(),
            kind: match j.attribute("type").unwrap_or("hinge") {
                "slide" => JointKind::Prismatic,
                _ => JointKind::Revolute,
            },
            axis: vector(&j, "axis", "0 0 1")?.normalize(),
        }),
    };
    model.bodies.push(Body {
        name: node.attribute("name").unwrap_or_default().to_string(),
        parent,
        origin: frame(node)?,
        joint,
        inertial: inertial(node)?,
    });
    for g in node.children().filter(|n| n.has_tag_name("geom")) {
        if let Some(shape) = shape(&g)? {
            model.geoms.push(Geom { body: index, shape });
        }
    }
    for b in node.children().filter(|n| n.has_tag_name("body")) {
        read_body(&b, Some(index), model)?;
    }
    Ok(())
}

/// A geom's collision shape; `None` for kinds the built-in models do not collide with
/// (planes are the world's floor, checked apart).
fn shape(node: &roxmltree::Node) -> Result<Option<Shape>, MjcfError> {
    let size = |count| numbers(node, "size", "0.005", count);
    Ok(Some(match node.attribute("type").unwrap_or("sphere") {
        "box" => {
            let s = size(3)?;
            Shape::Box {
                frame: frame(node)?,
                half: DVec3::new(s[0], s[1], s[2]),
            }
        }
        "capsule" => {
            let radius = size(0)?[0];
            match node.attribute("fromto") {
                Some(_) => {
                    let v = numbers(node, "fromto", "", 6)?;
                    Shape::Swept {
                        a: DVec3::new(v[0], v[1], v[2]),
                        b: DVec3::new(v[3], v[4], v[5]),
                        radius,
                    }
                }
                None => {
                    let half = size(2)?[1];
                    let f = frame(node)?;
                    Shape::Swept {
                        a: f.t + f.r * DVec3::new(0.0, 0.0, -half),
                        b: f.t + f.r * DVec3::new(0.0, 0.0, half),
                        radius,
                    }
                }
            }
        }
        "sphere" => {
            let centre = frame(node)?.t;
            Shape::Swept {
                a: centre,
                b: centre,
                radius: size(0)?[0],
            }
        }
        _ => return Ok(None),
    }))
}
