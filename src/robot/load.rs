//! The `keypose-robot/1` file format.

use super::servo::{Servo, ServoModel, Variant};
use super::{BusSettings, FixedFrame, Joint, JointKind, Limits, Protocol, Robot, ROBOT_FORMAT};
use crate::json::{self, InputError, Node};
use crate::pose::{quat_from_rpy, RigidTransform};
use glam::{DQuat, DVec3};

pub(super) fn parse_robot(file: &str, text: &str) -> Result<Robot, InputError> {
    let value = json::parse(file, text)?;
    let root = Node::root(file, &value);
    root.object()?;
    root.check_format(ROBOT_FORMAT)?;
    root.only_fields(&[
        "format",
        "name",
        "description",
        "bus",
        "control_hz",
        "joints",
        "tcp",
        "home",
        "clearance_mm",
        "supply_v",
        "payload",
    ])?;
    let name = root.require("name", "the robot's name")?.name("a name")?;
    let description = match root.get("description") {
        Some(d) => d.text("a text")?.to_string(),
        None => String::new(),
    };
    let bus = parse_bus(&root.require("bus", "protocol and baud rate")?)?;
    let hz_node = root.require("control_hz", "the default control rate")?;
    let control_hz = hz_node.number("Hz")?;
    if !(control_hz > 0.0 && control_hz <= 2000.0) {
        return Err(hz_node.expected("a control rate above 0 and at most 2000 Hz"));
    }

    let supply_v = match root.get("supply_v") {
        Some(node) => Some(parse_supply(&node)?),
        None => None,
    };
    let joints = parse_joints(
        &root.require("joints", "the joint chain")?,
        bus.protocol,
        supply_v,
    )?;
    let tcp = match root.get("tcp") {
        Some(node) => Some(parse_tcp(&node, &joints)?),
        None => None,
    };
    let home = parse_home(file, root.get("home"), &joints)?;

    let clearance = match root.get("clearance_mm") {
        None => super::DEFAULT_CLEARANCE_MM,
        Some(node) => {
            let mm = node.number("millimetres")?;
            if !(0.0..=MAX_CLEARANCE_MM).contains(&mm) {
                return Err(node.expected(&format!("a clearance from 0 to {MAX_CLEARANCE_MM} mm")));
            }
            mm
        }
    } / 1000.0;

    let payload = match root.get("payload") {
        Some(node) => Some(parse_payload(&node)?),
        None => None,
    };

    Ok(Robot {
        name: name.to_string(),
        source: super::RobotSource::File(file.into()),
        description,
        bus,
        control_hz,
        joints,
        tcp,
        home,
        lerobot: None,
        arms: Vec::new(),
        clearance,
        payload,
    })
}

/// `"joints"`: at least one, each name and servo id used once.
fn parse_joints(
    joints_node: &Node,
    protocol: Protocol,
    supply_v: Option<f64>,
) -> Result<Vec<Joint>, InputError> {
    let items = joints_node.items()?;
    if items.is_empty() {
        return Err(joints_node.expected("at least one joint"));
    }
    let mut joints: Vec<Joint> = Vec::with_capacity(items.len());
    for item in &items {
        let joint = parse_joint(item, protocol, supply_v)?;
        if joints.iter().any(|j| j.name == joint.name) {
            return Err(item.error(format!("duplicate joint name {:?}", joint.name)));
        }
        if let Some(other) = joints.iter().find(|j| j.servo.id == joint.servo.id) {
            return Err(item.error(format!(
                "servo id {} is already used by joint {:?}",
                joint.servo.id, other.name
            )));
        }
        joints.push(joint);
    }
    Ok(joints)
}

/// `"home"`: a value per joint named (0 for the others), each within its joint's limits.
fn parse_home(
    file: &str,
    home_node: Option<Node>,
    joints: &[Joint],
) -> Result<Vec<f64>, InputError> {
    let mut home: Vec<f64> = vec![0.0; joints.len()];
    if let Some(home_node) = home_node {
        for (joint_name, value_node) in home_node.named_entries("joint names")? {
            let Some(index) = joints.iter().position(|j| j.name == joint_name) else {
                return Err(value_node.error(format!(
                    "unknown joint {joint_name:?}; expected one of: {}",
                    joint_names(joints)
                )));
            };
            home[index] = value_node.number(joints[index].kind.unit())?;
        }
    }
    for (joint, &value) in joints.iter().zip(&home) {
        if !joint.limits.contains(value) {
            return Err(json::InputError::at_path(
                file,
                &format!("$.home.{}", joint.name),
                format!(
                    "home value {value} {} is outside the joint's limits {} … {}",
                    joint.kind.unit(),
                    joint.limits.min,
                    joint.limits.max
                ),
            ));
        }
    }
    Ok(home)
}

/// `"payload": {"mass": KG, "com": [x, y, z]}`, the centre of mass in the TCP's frame.
fn parse_payload(node: &Node) -> Result<super::Payload, InputError> {
    node.only_fields(&["mass", "com"])?;
    let mass_node = node.require("mass", "the payload's mass in kilograms")?;
    let mass = mass_node.number("kilograms")?;
    if !(0.0..=super::MAX_PAYLOAD_KG).contains(&mass) {
        return Err(mass_node.expected(&format!("a mass from 0 to {} kg", super::MAX_PAYLOAD_KG)));
    }
    let com = match node.get("com") {
        None => DVec3::ZERO,
        Some(n) => {
            let v = n.numbers::<3>("[x, y, z] in metres")?;
            DVec3::new(v[0], v[1], v[2])
        }
    };
    Ok(super::Payload { mass, com })
}

/// The largest clearance a robot file or `--clearance` may ask for, millimetres: more keeps
/// an arm of this size from reaching the desk at all.
pub const MAX_CLEARANCE_MM: f64 = 100.0;

fn joint_names(joints: &[Joint]) -> String {
    joints
        .iter()
        .map(|j| j.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

fn parse_bus(node: &Node) -> Result<BusSettings, InputError> {
    node.only_fields(&["protocol", "baud"])?;
    let protocol_node = node.require("protocol", "the bus protocol")?;
    let names: Vec<&str> = Protocol::ALL.iter().map(|p| p.name()).collect();
    let protocol_name = protocol_node.str("a protocol name")?;
    let protocol = Protocol::ALL
        .into_iter()
        .find(|p| p.name() == protocol_name)
        .ok_or_else(|| protocol_node.expected(&format!("one of {}", names.join(", "))))?;
    let baud = node
        .require("baud", "the baud rate")?
        .integer("baud rate", 9600, 10_500_000)? as u32;
    Ok(BusSettings { protocol, baud })
}

fn parse_joint(
    node: &Node,
    protocol: Protocol,
    supply_v: Option<f64>,
) -> Result<Joint, InputError> {
    node.only_fields(&["name", "kind", "axis", "origin", "limits", "servo"])?;
    let name = node.require("name", "the joint's name")?.name("a name")?;
    if name.is_empty() {
        return Err(node.error("a joint name must not be empty"));
    }
    let kind_node = node.require("kind", "revolute or prismatic")?;
    let kind = match kind_node.str("\"revolute\" or \"prismatic\"")? {
        "revolute" => JointKind::Revolute,
        "prismatic" => JointKind::Prismatic,
        _ => return Err(kind_node.expected("\"revolute\" or \"prismatic\"")),
    };
    let axis_node = node.require("axis", "the joint axis in its own frame")?;
    let axis = DVec3::from_array(axis_node.numbers::<3>("axis component")?);
    if axis.length() < 1e-9 {
        return Err(axis_node.expected("a non-zero axis"));
    }
    let origin = parse_origin(&node.require("origin", "the joint's pose in its parent")?)?;
    let limits = parse_limits(
        &node.require("limits", "position, velocity, acceleration")?,
        kind,
    )?;
    let servo = parse_servo(
        &node.require("servo", "the servo mapping")?,
        kind,
        protocol,
        supply_v,
    )?;
    Ok(Joint {
        name: name.to_string(),
        kind,
        axis: axis.normalize(),
        origin,
        limits,
        limits_origin: super::LimitsOrigin::Robot,
        servo,
        calibrated_range: None,
    })
}

/// `{ "xyz": [..], "rpy": [..] }` as in URDF, or `{ "xyz": [..], "quat": [w, x, y, z] }` as in
/// MJCF, for origins whose roll-pitch-yaw sits at gimbal lock.
pub(super) fn parse_origin(node: &Node) -> Result<RigidTransform, InputError> {
    node.only_fields(&["xyz", "rpy", "quat"])?;
    let xyz = match node.get("xyz") {
        Some(n) => DVec3::from_array(n.numbers::<3>("metres")?),
        None => DVec3::ZERO,
    };
    let rotation = match (node.get("rpy"), node.get("quat")) {
        (Some(_), Some(_)) => return Err(node.error("give either \"rpy\" or \"quat\", not both")),
        (Some(rpy), None) => {
            let [r, p, y] = rpy.numbers::<3>("radians")?;
            quat_from_rpy(r, p, y)
        }
        (None, Some(quat)) => {
            let [w, x, y, z] = quat.numbers::<4>("quaternion component, w first")?;
            let q = DQuat::from_xyzw(x, y, z, w);
            if (q.length() - 1.0).abs() > 1e-3 {
                return Err(quat.expected("a unit quaternion [w, x, y, z]"));
            }
            q.normalize()
        }
        (None, None) => DQuat::IDENTITY,
    };
    Ok(RigidTransform::new(xyz, rotation))
}

/// Bounds on what a limit may say, far outside any real joint but small enough that products
/// and differences of joint values stay finite: ±256 turns is the Dynamixel extended-position
/// range; 100 m covers any linear axis.
const MAX_ANGLE_DEG: f64 = 92_160.0;
const MAX_TRAVEL_M: f64 = 100.0;
const MAX_RATE: f64 = 1e7;

fn parse_limits(node: &Node, kind: JointKind) -> Result<Limits, InputError> {
    node.only_fields(&["min", "max", "velocity", "acceleration", "jerk"])?;
    let bound = match kind {
        JointKind::Revolute => MAX_ANGLE_DEG,
        JointKind::Prismatic => MAX_TRAVEL_M,
    };
    let position = |field: &'static str, what: &str| -> Result<f64, InputError> {
        let n = node.require(field, what)?;
        let x = n.number(what)?;
        if x.abs() <= bound {
            Ok(x)
        } else {
            Err(n.expected(&format!("a {what} within ±{bound} {}", kind.unit())))
        }
    };
    let min = position("min", "lower limit")?;
    let max = position("max", "upper limit")?;
    if min >= max {
        return Err(node.error(format!("min ({min}) must be below max ({max})")));
    }
    let positive = |field: &'static str| -> Result<f64, InputError> {
        let n = node.require(field, "a positive limit")?;
        let x = n.number(field)?;
        if x > 0.0 && x <= MAX_RATE {
            Ok(x)
        } else {
            Err(n.expected(&format!("a positive limit up to {MAX_RATE}")))
        }
    };
    let velocity = positive("velocity")?;
    let acceleration = positive("acceleration")?;
    // Optional: a robot file without it plans and checks exactly as before jerk existed.
    let jerk = match node.get("jerk") {
        Some(_) => Some(positive("jerk")?),
        None => None,
    };
    Ok(Limits {
        min,
        max,
        velocity,
        acceleration,
        jerk,
    })
}

fn parse_servo(
    node: &Node,
    kind: JointKind,
    protocol: Protocol,
    robot_supply_v: Option<f64>,
) -> Result<Servo, InputError> {
    node.only_fields(&[
        "id",
        "model",
        "zero_tick",
        "direction",
        "metres_per_tick",
        "homing_offset",
        "variant",
        "supply_v",
    ])?;
    let id = node
        .require("id", "the servo id")?
        .integer("servo id", 0, 252)? as u8;
    let model_node = node.require("model", "the servo model")?;
    let names: Vec<&str> = ServoModel::ALL.iter().map(|m| m.name()).collect();
    let model = ServoModel::parse(model_node.str("a servo model")?)
        .ok_or_else(|| model_node.expected(&format!("one of {}", names.join(", "))))?;
    if !model.speaks(protocol) {
        return Err(model_node.error(format!(
            "servo model {} does not speak the robot's bus protocol {}",
            model.name(),
            protocol.name()
        )));
    }
    let zero_tick = node
        .require("zero_tick", "tick at joint value 0")?
        .number("ticks")?;
    let direction_node = node.require("direction", "1 or -1")?;
    let direction = match direction_node.value.as_i64() {
        Some(1) => 1.0,
        Some(-1) => -1.0,
        _ => return Err(direction_node.expected("1 or -1")),
    };
    let units_per_tick = parse_units_per_tick(node, kind, model)?;
    let homing_offset = match node.get("homing_offset") {
        Some(n) => Some(n.integer("homing offset ticks", -1_048_575, 1_048_575)?),
        None => None,
    };
    let variant = parse_variant(node, model)?;
    let supply_v = servo_supply(node, variant, robot_supply_v)?;
    Ok(Servo {
        id,
        model,
        zero_tick,
        direction,
        units_per_tick,
        homing_offset,
        variant,
        supply_v,
    })
}

/// Joint units per tick: the model's degrees for a revolute joint, the file's
/// `metres_per_tick` (required) for a prismatic one.
fn parse_units_per_tick(
    node: &Node,
    kind: JointKind,
    model: ServoModel,
) -> Result<f64, InputError> {
    match (kind, node.get("metres_per_tick")) {
        (JointKind::Revolute, None) => Ok(model.spec().degrees_per_tick()),
        (JointKind::Revolute, Some(n)) => {
            Err(n.error("metres_per_tick is only for prismatic joints"))
        }
        (JointKind::Prismatic, None) => {
            Err(node.error("missing field \"metres_per_tick\" (a prismatic joint needs it)"))
        }
        (JointKind::Prismatic, Some(n)) => {
            let x = n.number("metres per tick")?;
            if x <= 0.0 {
                return Err(n.expected("a positive number of metres per tick"));
            }
            Ok(x)
        }
    }
}

/// `"variant"`: one of the model's, else its default.
fn parse_variant(node: &Node, model: ServoModel) -> Result<&'static Variant, InputError> {
    let Some(n) = node.get("variant") else {
        return Ok(model.default_variant());
    };
    let names: Vec<&str> = model.variants().map(|v| v.name).collect();
    model.variant(n.str("a servo variant")?).ok_or_else(|| {
        n.expected(&format!(
            "one of {} (variants of {})",
            names.join(", "),
            model.name()
        ))
    })
}

/// The servo's supply: its own `supply_v`, else the robot's, else the variant's first rated
/// one; a supply the variant has drive data for, where it has any.
fn servo_supply(
    node: &Node,
    variant: &'static Variant,
    robot_supply_v: Option<f64>,
) -> Result<f64, InputError> {
    if let Some(n) = node.get("supply_v") {
        let v = parse_supply(&n)?;
        if variant.at(v).is_none() && !variant.drives.is_empty() {
            return Err(n.expected(&format!(
                "a supply {} is rated for: {}",
                variant.name,
                variant.supplies()
            )));
        }
        return Ok(v);
    }
    match robot_supply_v {
        Some(v) if variant.at(v).is_some() || variant.drives.is_empty() => Ok(v),
        Some(v) => Err(node.error(format!(
            "the robot's supply_v {v} V is not one {} is rated for ({}); give this servo its own supply_v",
            variant.name,
            variant.supplies()
        ))),
        None => Ok(variant.drives.first().map_or(0.0, |d| d.supply_v)),
    }
}

/// A supply voltage: what hobby and research servos run on.
fn parse_supply(node: &Node) -> Result<f64, InputError> {
    let v = node.number("volts")?;
    if !(v > 0.0 && v <= 48.0) {
        return Err(node.expected("a supply above 0 and at most 48 V"));
    }
    Ok(v)
}

fn parse_tcp(node: &Node, joints: &[Joint]) -> Result<FixedFrame, InputError> {
    node.only_fields(&["parent", "xyz", "rpy", "quat"])?;
    let parent_node = node.require("parent", "the joint that carries the TCP")?;
    let parent_name = parent_node.name("a joint name")?;
    let parent = joints
        .iter()
        .position(|j| j.name == parent_name)
        .ok_or_else(|| parent_node.expected(&format!("one of {}", joint_names(joints))))?;
    // The origin fields sit beside "parent"; parse them from a copy without it.
    let mut origin_value = node.value.clone();
    if let Some(map) = origin_value.as_object_mut() {
        map.remove("parent");
    }
    let origin_node = Node::root(node.file(), &origin_value);
    let origin = parse_origin(&origin_node).map_err(|mut e| {
        if let json::Location::Path(p) = &mut e.location {
            *p = p.replacen('$', "$.tcp", 1);
        }
        e
    })?;
    Ok(FixedFrame { parent, origin })
}

#[cfg(test)]
mod tests {
    use super::parse_robot;
    use serde_json::{json, Value};

    /// A change to a robot file.
    type Edit = Box<dyn FnOnce(&mut Value)>;

    /// The built-in SO-101's file with `edit` applied: what parsing it refuses, if anything.
    fn refusal(edit: impl FnOnce(&mut Value)) -> Option<String> {
        let mut file: Value =
            serde_json::from_str(include_str!("../../robots/so101.json")).unwrap();
        edit(&mut file);
        parse_robot("r.json", &file.to_string())
            .err()
            .map(|e| e.to_string())
    }

    #[test]
    fn the_built_in_file_parses_and_each_rule_names_its_field() {
        assert_eq!(refusal(|_| {}), None);
        let cases: Vec<(Edit, &str)> = vec![
            (
                Box::new(|f| f["joints"][1]["name"] = json!("shoulder_pan")),
                "r.json: $.joints[1]: duplicate joint name \"shoulder_pan\"",
            ),
            (
                Box::new(|f| f["joints"][1]["servo"]["id"] = json!(1)),
                "r.json: $.joints[1]: servo id 1 is already used by joint \"shoulder_pan\"",
            ),
            (
                Box::new(|f| f["home"] = json!({"elbow_flex": 120})),
                "r.json: $.home.elbow_flex: home value 120 deg is outside the joint's limits",
            ),
            (
                Box::new(|f| f["home"] = json!({"elbow": 0})),
                "unknown joint \"elbow\"; expected one of: shoulder_pan",
            ),
            (
                Box::new(|f| f["joints"][0]["servo"]["metres_per_tick"] = json!(0.001)),
                "metres_per_tick is only for prismatic joints",
            ),
            (
                Box::new(|f| f["joints"][0]["servo"]["variant"] = json!("c999")),
                "(variants of sts3215)",
            ),
            (
                Box::new(|f| f["joints"][0]["servo"]["supply_v"] = json!(24)),
                "$.joints[0].servo.supply_v",
            ),
            (
                Box::new(|f| f["supply_v"] = json!(24)),
                "the robot's supply_v 24 V is not one",
            ),
        ];
        for (edit, expected) in cases {
            let message = refusal(edit).expect(expected);
            assert!(
                message.contains(expected),
                "{message}\nexpected: {expected}"
            );
        }
    }
}
