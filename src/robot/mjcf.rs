//! Reading the elements of an MJCF model (MuJoCo's XML format) the way MuJoCo does: numbers
//! in whitespace-separated attributes, MuJoCo's defaults where an attribute is absent, and
//! frames as `pos` plus `quat` (w x y z). Shared by whatever reads the built-in models — the
//! collision geometry and the studio's drawn arm — so both read a model alike.

use crate::pose::RigidTransform;
use glam::{DQuat, DVec3};

/// An attribute that does not hold the numbers its element needs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{element} {name:?}: {attribute}={value:?} is not {expected}")]
pub(crate) struct AttributeError {
    /// The element's tag.
    pub element: String,
    /// The element's `name` attribute (empty when it has none).
    pub name: String,
    /// The attribute read.
    pub attribute: String,
    /// Its text.
    pub value: String,
    /// What it should have been.
    pub expected: String,
}

/// The first child element of `node` tagged `tag`.
pub(crate) fn child<'a, 'i>(
    node: &roxmltree::Node<'a, 'i>,
    tag: &str,
) -> Option<roxmltree::Node<'a, 'i>> {
    node.children().find(|n| n.has_tag_name(tag))
}

/// The finite numbers of `attribute` (`default` when the element does not have it), at least
/// `at_least` of them and at least one. MJCF attributes may hold more numbers than a given
/// element kind uses (a sphere reads the first of `size`), so more are not an error.
pub(crate) fn numbers(
    node: &roxmltree::Node,
    attribute: &str,
    default: &str,
    at_least: usize,
) -> Result<Vec<f64>, AttributeError> {
    let text = node.attribute(attribute).unwrap_or(default);
    let parsed: Option<Vec<f64>> = text
        .split_whitespace()
        .map(|x| x.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    let at_least = at_least.max(1);
    match parsed {
        Some(v) if v.len() >= at_least => Ok(v),
        _ => Err(AttributeError {
            element: node.tag_name().name().to_string(),
            name: node.attribute("name").unwrap_or_default().to_string(),
            attribute: attribute.to_string(),
            value: text.to_string(),
            expected: match at_least {
                1 => "a list of numbers".into(),
                n => format!("{n} numbers"),
            },
        }),
    }
}

/// A 3-vector attribute (`pos`, `axis`, …), `default` when absent.
pub(crate) fn vector(
    node: &roxmltree::Node,
    attribute: &str,
    default: &str,
) -> Result<DVec3, AttributeError> {
    let v = numbers(node, attribute, default, 3)?;
    Ok(DVec3::new(v[0], v[1], v[2]))
}

/// The frame of a body or geom in its parent's: `pos`, and `quat` in MuJoCo's w x y z order
/// (normalised, as MuJoCo does).
pub(crate) fn frame(node: &roxmltree::Node) -> Result<RigidTransform, AttributeError> {
    let pos = vector(node, "pos", "0 0 0")?;
    let q = numbers(node, "quat", "1 0 0 0", 4)?;
    Ok(RigidTransform::new(
        pos,
        DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize(),
    ))
}

/// A body's mass properties: `<inertial pos quat mass diaginertia|fullinertia>`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Inertial {
    /// Kilograms.
    pub mass: f64,
    /// The centre of mass in the body's frame, metres.
    pub com: DVec3,
    /// The inertia about the centre of mass, in the body's frame's axes, kg·m².
    pub inertia: glam::DMat3,
}

/// The body's `<inertial>`, `None` where it has none. `fullinertia` is the matrix in the
/// body's axes (M11 M22 M33 M12 M13 M23, MuJoCo's order); `diaginertia` the principal moments
/// along the axes `quat` turns the body's into.
pub(crate) fn inertial(body: &roxmltree::Node) -> Result<Option<Inertial>, AttributeError> {
    let Some(node) = child(body, "inertial") else {
        return Ok(None);
    };
    let frame = frame(&node)?;
    let mass = numbers(&node, "mass", "", 1)?[0];
    let inertia = if node.has_attribute("fullinertia") {
        let m = numbers(&node, "fullinertia", "", 6)?;
        glam::DMat3::from_cols(
            DVec3::new(m[0], m[3], m[4]),
            DVec3::new(m[3], m[1], m[5]),
            DVec3::new(m[4], m[5], m[2]),
        )
    } else {
        let d = vector(&node, "diaginertia", "")?;
        let r = glam::DMat3::from_quat(frame.r);
        r * glam::DMat3::from_diagonal(d) * r.transpose()
    };
    Ok(Some(Inertial {
        mass,
        com: frame.t,
        inertia,
    }))
}

/// `<equality><joint joint1 joint2 polycoef>`: `joint` = offset + scale · `follows`, in the
/// model's units (the OMX's second gripper finger follows the first).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Mimic {
    /// The joint that follows (`joint1`).
    pub joint: String,
    /// The joint it follows (`joint2`).
    pub follows: String,
    /// `polycoef`'s first coefficient.
    pub offset: f64,
    /// `polycoef`'s second coefficient.
    pub scale: f64,
}

/// The model's joint equalities (`root` is `<mujoco>`), MuJoCo's default `polycoef` (0 1 0 0 0:
/// the same value) where absent; equalities that do not name two joints are left out.
pub(crate) fn mimics(root: &roxmltree::Node) -> Result<Vec<Mimic>, AttributeError> {
    let Some(equality) = child(root, "equality") else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for node in equality.children().filter(|n| n.has_tag_name("joint")) {
        let (Some(joint), Some(follows)) = (node.attribute("joint1"), node.attribute("joint2"))
        else {
            continue;
        };
        let coef = numbers(&node, "polycoef", "0 1 0 0 0", 2)?;
        out.push(Mimic {
            joint: joint.to_string(),
            follows: follows.to_string(),
            offset: coef[0],
            scale: coef[1],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn element(xml: &str) -> roxmltree::Document<'_> {
        roxmltree::Document::parse(xml).unwrap()
    }

    #[test]
    fn absent_attributes_take_mujocos_defaults_and_quaternions_are_w_first() {
        let doc = element(r#"<body name="b" pos="0 0 0.1" quat="0.7071068 0 0 0.7071068"/>"#);
        let f = frame(&doc.root_element()).unwrap();
        assert_eq!(f.t, DVec3::new(0.0, 0.0, 0.1));
        // A quarter turn about z takes x to y.
        assert!((f.r * DVec3::X - DVec3::Y).length() < 1e-6);
        let bare = element("<geom/>");
        let f = frame(&bare.root_element()).unwrap();
        assert_eq!((f.t, f.r), (DVec3::ZERO, DQuat::IDENTITY));
    }

    #[test]
    fn a_joint_equality_is_a_mimic_with_mujocos_default_coefficients() {
        let doc = element(
            r#"<mujoco><equality>
                <joint joint1="b" joint2="a" polycoef="0.1 -1 0 0 0"/>
                <joint joint1="c" joint2="a"/>
                <weld body1="x"/>
            </equality></mujoco>"#,
        );
        let m = mimics(&doc.root_element()).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].offset, m[0].scale), (0.1, -1.0));
        assert_eq!(
            (m[1].joint.as_str(), m[1].offset, m[1].scale),
            ("c", 0.0, 1.0)
        );
    }

    #[test]
    fn an_inertial_turns_its_principal_moments_into_the_bodys_axes() {
        // Moments 1, 2, 3 along axes turned a quarter about z: the body's x sees the second.
        let doc = element(
            r#"<body><inertial pos="0 0 0.1" quat="0.7071068 0 0 0.7071068" mass="2" diaginertia="1 2 3"/></body>"#,
        );
        let i = inertial(&doc.root_element()).unwrap().unwrap();
        assert_eq!((i.mass, i.com), (2.0, DVec3::new(0.0, 0.0, 0.1)));
        assert!((i.inertia.x_axis.x - 2.0).abs() < 1e-6);
        assert!((i.inertia.y_axis.y - 1.0).abs() < 1e-6);
        assert!((i.inertia.z_axis.z - 3.0).abs() < 1e-12);
        let full = element(r#"<body><inertial mass="1" fullinertia="1 2 3 0.1 0.2 0.3"/></body>"#);
        let i = inertial(&full.root_element()).unwrap().unwrap();
        assert_eq!(i.inertia.col(1), DVec3::new(0.1, 2.0, 0.3));
        assert_eq!(i.inertia.col(2), DVec3::new(0.2, 0.3, 3.0));
        assert_eq!(inertial(&element("<body/>").root_element()).unwrap(), None);
    }

    #[test]
    fn too_few_or_not_numbers_name_the_element_and_attribute() {
        let doc = element(r#"<geom name="g" size="0.1 x" fromto="0 0 0 1"/>"#);
        let g = doc.root_element();
        let error = numbers(&g, "size", "0.005", 1).unwrap_err();
        assert_eq!(
            error.to_string(),
            r#"geom "g": size="0.1 x" is not a list of numbers"#
        );
        let error = numbers(&g, "fromto", "", 6).unwrap_err();
        assert_eq!(
            error.to_string(),
            r#"geom "g": fromto="0 0 0 1" is not 6 numbers"#
        );
        let inf = element(r#"<body pos="0 inf 0"/>"#);
        assert!(vector(&inf.root_element(), "pos", "0 0 0").is_err());
    }
}
