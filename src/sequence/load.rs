//! Reading `keypose-sequence/1` files.

use super::{
    ArmSpec, ContactWith, DeclaredContact, Ends, KeyValue, Keyframe, Placement, Sequence,
    ToolApproach, ToolKey, ToolOrientation, DEFAULT_CONTACT_DEPTH_MM, DEFAULT_KEY_INTERVAL,
    SEQUENCE_FORMAT,
};
use crate::curve::Interp;
use crate::json::{self, InputError, Node};
use crate::pose::RigidTransform;
use glam::{DQuat, DVec3};

/// How far from 1 a quaternion's norm may be: hand-typed values such as 0.7071 are a few 1e-5
/// off, while anything further is more likely a typo than rounding.
const UNIT_TOLERANCE: f64 = 1e-3;
/// Key times are bounded to a day either way: a teach-and-play sequence is minutes long, and the
/// bound keeps every later sampling of the curve finite in size.
pub const MAX_TIME: f64 = 86_400.0;
/// Keys (and the end of a hold and the next key) are at least a millisecond apart: closer keys
/// are below any servo's control period and only make the curve's slopes explode.
pub const MIN_GAP: f64 = 0.001;
/// Most keyframes in a sequence: far more than anyone teaches or a recording keeps, while the
/// memory the curve takes stays bounded (without it a 30 MB file took 1.9 GB).
pub const MAX_KEYFRAMES: usize = 100_000;

pub(super) fn parse_sequence(file: &str, text: &str) -> Result<Sequence, InputError> {
    let value = json::parse(file, text)?;
    let mut sequence = sequence_from_node(&Node::root(file, &value), false)?;
    sequence.source = super::layout::Source::of(&sequence, text);
    Ok(sequence)
}

/// The sequence a JSON node holds (a whole file, or a member of another file such as the
/// teach journal's); errors name the node's path. `may_be_empty`: a list being edited, which
/// may have no key (yet, or any more), rather than a sequence to play.
pub(super) fn sequence_from_node(root: &Node, may_be_empty: bool) -> Result<Sequence, InputError> {
    let file = root.file();
    root.object()?;
    root.check_format(SEQUENCE_FORMAT)?;
    root.only_fields(&[
        "format",
        "robot",
        "robots",
        "description",
        "interpolation",
        "ends",
        "key_interval",
        "keyframes",
    ])?;
    let (robot, arms) = parse_robots(root)?;
    let description = match root.get("description") {
        Some(n) => Some(n.text("a text")?.to_string()),
        None => None,
    };
    let interpolation = match root.get("interpolation") {
        Some(n) => parse_interp(&n)?,
        None => Interp::Cubic,
    };
    let ends = parse_ends(root)?;
    let interval_node = root.get("key_interval");
    let key_interval = parse_key_interval(interval_node.as_ref())?;
    let frames_node = root.require("keyframes", "the list of keys")?;
    let items = frames_node.items()?;
    let (keyframes, key_interval) = if items.is_empty() && may_be_empty {
        (Vec::new(), key_interval)
    } else {
        let mut keyframes = parse_keyframes(&frames_node, &items, &arms)?;
        let interval = settle_timing(&mut keyframes, &items, key_interval, interval_node.as_ref())?;
        (keyframes, interval)
    };
    let sequence = Sequence {
        file: file.to_string(),
        robot,
        arms,
        description,
        interpolation,
        ends,
        key_interval,
        keyframes,
        source: Default::default(),
    };
    if !sequence.keyframes.is_empty() {
        validate_keys(&sequence)?;
    }
    Ok(sequence)
}

/// `"robot"` (one arm) or `"robots"` (several, by name), exactly one of them.
fn parse_robots(root: &Node) -> Result<(String, Vec<ArmSpec>), InputError> {
    const ROBOT: &str = "a robot name or file";
    match (root.get("robot"), root.get("robots")) {
        (Some(_), Some(robots)) => Err(robots.error(
            "both \"robot\" and \"robots\" are given; expected \"robot\" for one arm or \"robots\" for several",
        )),
        (Some(robot), None) => Ok((robot.name(ROBOT)?.to_string(), Vec::new())),
        (None, Some(robots)) => Ok((String::new(), parse_arms(&robots)?)),
        (None, None) => Err(root.error(
            "missing field \"robot\" (a robot name or file, or \"robots\" naming several arms)",
        )),
    }
}

/// `"robots": {"left": {"robot": "so101", "base": {..}}, "right": "so101"}`.
fn parse_arms(node: &Node) -> Result<Vec<ArmSpec>, InputError> {
    let entries = node.entries()?;
    if entries.is_empty() {
        return Err(node.expected("at least one arm, such as {\"left\": \"so101\"}"));
    }
    let mut arms = Vec::with_capacity(entries.len());
    for (name, value) in entries {
        if !valid_arm_name(name) {
            return Err(value.error(format!(
                "arm name {name:?}; expected letters, digits, '_' or '-' (it prefixes the arm's joints as {name}/JOINT)"
            )));
        }
        let arm = parse_arm(name, &value)?;
        if let Some(other) = arms.iter().find(|a: &&ArmSpec| same_base(a, &arm)) {
            let at = arm.base.as_ref().map_or(DVec3::ZERO, |b| b.xyz);
            return Err(value.error(format!(
                "arms {:?} and {name:?} stand on one base (both at [{}, {}, {}] m, an arm without \
                 \"base\" at the cell's origin); expected each arm at its own place: give one a \
                 \"base\": {{\"xyz\": [0, 0.4, 0]}}",
                other.name, at.x, at.y, at.z
            )));
        }
        arms.push(arm);
    }
    Ok(arms)
}

/// Two arms closer than this at their bases (metres) stand on one.
const ONE_BASE: f64 = 1e-3;
/// The farthest an arm's base may be from the cell's origin, metres: a bench, not a factory
/// (a base in millimetres, 250 for 0.25 m, is caught by it).
pub const MAX_BASE_DISTANCE: f64 = 10.0;

fn same_base(a: &ArmSpec, b: &ArmSpec) -> bool {
    let at = |arm: &ArmSpec| arm.base.as_ref().map_or(DVec3::ZERO, |p| p.xyz);
    at(a).distance(at(b)) < ONE_BASE
}

/// An arm name: it prefixes joint names (`left/elbow_flex`), so it holds no '/'.
pub fn valid_arm_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn parse_arm(name: &str, node: &Node) -> Result<ArmSpec, InputError> {
    const ROBOT: &str =
        "a robot name or file, or {\"robot\": .., \"base\": {\"xyz\": [..], \"rpy\": [..]}}";
    if node.value.is_string() {
        return Ok(ArmSpec {
            name: name.to_string(),
            robot: node.name(ROBOT)?.to_string(),
            base: None,
        });
    }
    node.object()?;
    node.only_fields(&["robot", "base"])?;
    let robot = node.require("robot", "a robot name or file")?;
    let base = match node.get("base") {
        Some(base) => Some(parse_placement(&base)?),
        None => None,
    };
    Ok(ArmSpec {
        name: name.to_string(),
        robot: robot.name("a robot name or file")?.to_string(),
        base,
    })
}

/// An arm's base as a joint origin is written: `xyz`, and `rpy` or `quat` `[w, x, y, z]`.
fn parse_placement(node: &Node) -> Result<Placement, InputError> {
    node.object()?;
    node.only_fields(&["xyz", "rpy", "quat"])?;
    let xyz = match node.get("xyz") {
        Some(n) => {
            let xyz = DVec3::from_array(n.numbers::<3>("metres")?);
            let far = xyz.abs().max_element();
            if far > MAX_BASE_DISTANCE {
                // Within 10 m once read as millimetres: say so.
                let in_mm = match far <= MAX_BASE_DISTANCE * 1000.0 {
                    true => {
                        let m = xyz / 1000.0;
                        format!(" (millimetres? that is [{}, {}, {}] m)", m.x, m.y, m.z)
                    }
                    false => String::new(),
                };
                let far = match far < 1e6 {
                    true => format!("{far}"),
                    false => format!("{far:e}"),
                };
                return Err(n.error(format!(
                    "a base {far} m from the cell's origin along an axis; expected metres, \
                     within {MAX_BASE_DISTANCE} m{in_mm}"
                )));
            }
            xyz
        }
        None => DVec3::ZERO,
    };
    let rotation = match (node.get("rpy"), node.get("quat")) {
        (Some(_), Some(quat)) => {
            return Err(
                quat.error("the rotation is given twice (\"rpy\" and \"quat\"); expected one")
            )
        }
        (Some(rpy), None) => Some(ToolOrientation::Rpy(radians(&rpy)?)),
        (None, Some(quat)) => {
            let [w, x, y, z] = quat.numbers::<4>("quaternion component, w first")?;
            Some(ToolOrientation::Quaternion(unit_quaternion(
                &quat,
                DQuat::from_xyzw(x, y, z, w),
            )?))
        }
        (None, None) => None,
    };
    Ok(Placement { xyz, rotation })
}

fn parse_ends(root: &Node) -> Result<Ends, InputError> {
    match root.get("ends") {
        None => Ok(Ends::Played),
        Some(n) => match n.value.as_str() {
            Some("played") => Ok(Ends::Played),
            Some("control") => Ok(Ends::Control),
            _ => Err(n.expected("\"played\" or \"control\"")),
        },
    }
}

fn parse_key_interval(node: Option<&Node>) -> Result<Option<f64>, InputError> {
    let Some(n) = node else {
        return Ok(None);
    };
    let x = n.number("seconds")?;
    if x < MIN_GAP {
        return Err(n.expected(&format!("a key interval of at least {MIN_GAP} s")));
    }
    Ok(Some(x))
}

/// Every key, numbered by its place in the file (for messages), at most [`MAX_KEYFRAMES`].
fn parse_keyframes(
    frames_node: &Node,
    items: &[Node],
    arms: &[ArmSpec],
) -> Result<Vec<Keyframe>, InputError> {
    if items.is_empty() {
        return Err(frames_node.expected("at least one keyframe"));
    }
    if items.len() > MAX_KEYFRAMES {
        return Err(frames_node.error(format!(
            "{} keyframes; expected at most {MAX_KEYFRAMES}",
            items.len()
        )));
    }
    let mut keyframes = Vec::with_capacity(items.len());
    for (index, item) in items.iter().enumerate() {
        let mut key = parse_keyframe(item, arms)?;
        key.source_index = Some(index);
        keyframes.push(key);
    }
    Ok(keyframes)
}

/// Either every key has a time (then they are sorted by it and `key_interval` has no use) or
/// none has (then they are `key_interval` apart); returns the interval in force.
fn settle_timing(
    keyframes: &mut [Keyframe],
    items: &[Node],
    key_interval: Option<f64>,
    interval_node: Option<&Node>,
) -> Result<Option<f64>, InputError> {
    let timed = keyframes.iter().filter(|k| k.time.is_some()).count();
    if timed != 0 && timed != keyframes.len() {
        let odd = keyframes
            .iter()
            .position(|k| k.time.is_none())
            .unwrap_or_default();
        return Err(items[odd].error(format!(
            "this key has no \"time\" but {timed} of {} keys do; give every key a time, or none \
             (then keys are spaced by key_interval)",
            keyframes.len()
        )));
    }
    if timed == 0 {
        return Ok(Some(key_interval.unwrap_or(DEFAULT_KEY_INTERVAL)));
    }
    if let Some(n) = interval_node {
        return Err(n.error(
            "key_interval spaces untimed keys, but every key here has a time; remove one of them",
        ));
    }
    // Keys may be written in any order; stable, so equal times stay in file order and are then
    // reported as duplicates.
    keyframes.sort_by(|a, b| {
        a.time
            .partial_cmp(&b.time)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    Ok(None)
}

/// Rules on key times and holds that hold for any robot.
pub(super) fn validate_keys(sequence: &Sequence) -> Result<(), InputError> {
    let file = sequence.file.as_str();
    let n = sequence.keyframes.len();
    if n == 0 {
        return Err(InputError::at_path(
            file,
            "$.keyframes",
            "expected at least one keyframe, found none",
        ));
    }
    if sequence.ends == Ends::Control && n < 4 {
        return Err(InputError::at_path(
            file,
            "$.ends",
            format!("\"control\" ends need at least 4 keys (2 played between 2 control keys), found {n}"),
        ));
    }
    let times = sequence.key_times();
    for i in 0..n {
        validate_key(sequence, &times, i)?;
        if i + 1 < n {
            validate_gap(sequence, &times, i)?;
        }
    }
    Ok(())
}

/// Key `i`'s own time, hold and timing profile.
fn validate_key(sequence: &Sequence, times: &[f64], i: usize) -> Result<(), InputError> {
    let file = sequence.file.as_str();
    let key = &sequence.keyframes[i];
    let path = sequence.key_path(i);
    if times[i].is_nan() || times[i].abs() > MAX_TIME {
        let field = if sequence.key_interval.is_some() {
            "$.key_interval".to_string()
        } else {
            format!("{path}.time")
        };
        return Err(InputError::at_path(
            file,
            &field,
            format!(
                "key time {} s is out of range; expected -{MAX_TIME} … {MAX_TIME} s (a day)",
                times[i]
            ),
        ));
    }
    if !(key.hold.is_finite() && key.hold >= 0.0) {
        return Err(InputError::at_path(
            file,
            &format!("{path}.hold"),
            format!("expected a hold of 0 s or more, found {}", key.hold),
        ));
    }
    if let Some(message) = timing_refusal(sequence, i) {
        return Err(InputError::at_path(
            file,
            &format!("{path}.timing"),
            message,
        ));
    }
    let hold_profile = key.timing.as_ref().is_some_and(|t| t.hold.is_some());
    if hold_profile && key.hold == 0.0 {
        return Err(InputError::at_path(
            file,
            &format!("{path}.timing.hold"),
            "a hold's timing times the key's hold, but this key has none; expected a \
             \"hold\" above 0 s on the key, or no \"hold\" in its timing",
        ));
    }
    Ok(())
}

/// The time from key `i` to the next: at least [`MIN_GAP`], and room for key `i`'s hold.
fn validate_gap(sequence: &Sequence, times: &[f64], i: usize) -> Result<(), InputError> {
    let file = sequence.file.as_str();
    let key = &sequence.keyframes[i];
    let path = sequence.key_path(i);
    let gap = times[i + 1] - times[i];
    if gap < MIN_GAP {
        if gap > 0.0 {
            return Err(InputError::at_path(
                file,
                &format!("{}.time", sequence.key_path(i + 1)),
                format!(
                    "key {gap} s after the previous key ({path}); expected at least {MIN_GAP} s between keys"
                ),
            ));
        }
        return Err(InputError::at_path(
            file,
            &format!("{}.time", sequence.key_path(i + 1)),
            format!(
                "duplicate key time {} s (also at {path}); expected each key at its own time",
                times[i + 1]
            ),
        ));
    }
    if key.hold > gap - MIN_GAP {
        return Err(InputError::at_path(
            file,
            &format!("{path}.hold"),
            format!(
                "hold of {} s overruns the next key, {gap} s later; expected at most {} s",
                key.hold,
                gap - MIN_GAP
            ),
        ));
    }
    Ok(())
}

/// Why key `i`'s timing profile has no segment to time, if it has one and none.
fn timing_refusal(sequence: &Sequence, i: usize) -> Option<&'static str> {
    let key = &sequence.keyframes[i];
    key.timing.as_ref()?;
    if i + 1 == sequence.keyframes.len() {
        return Some(
            "a timing profile times the segment after its key, but this is the last key; \
             expected it on a key that a segment starts from",
        );
    }
    let mode = key.interp.unwrap_or(sequence.interpolation);
    (mode == Interp::Step && !key.line).then_some(
        "the segment after this key is a step, which does not move along a curve; expected \
         no timing on it (or another interpolation)",
    )
}

fn parse_interp(node: &Node) -> Result<Interp, InputError> {
    node.value
        .as_str()
        .and_then(Interp::parse)
        .ok_or_else(|| node.expected(&format!("one of {} (or line on a key)", Interp::names())))
}

fn parse_keyframe(node: &Node, arms: &[ArmSpec]) -> Result<Keyframe, InputError> {
    node.object()?;
    node.only_fields(&[
        "name",
        "time",
        "hold",
        "interp",
        "joints",
        "transforms",
        "tool",
        "timing",
        "contact",
        "effort",
    ])?;
    let mut key = Keyframe::new(Vec::new());
    if let Some(n) = node.get("name") {
        key.name = Some(n.name("a key name")?.to_string());
    }
    if let Some(n) = node.get("time") {
        key.time = Some(n.number("seconds")?);
    }
    if let Some(n) = node.get("hold") {
        let hold = n.number("seconds")?;
        if hold < 0.0 {
            return Err(n.expected("a hold of 0 s or more"));
        }
        key.hold = hold;
    }
    if let Some(n) = node.get("interp") {
        if n.value.as_str() == Some("line") {
            key.line = true;
        } else {
            key.interp = Some(parse_interp(&n)?);
        }
    }
    if let Some(n) = node.get("timing") {
        key.timing = Some(super::timing::parse(&n)?);
    }
    if let Some(n) = node.get("contact") {
        key.contact = parse_contacts(&n)?;
    }
    if let Some(n) = node.get("effort") {
        for (name, value) in n.named_entries("joint names")? {
            let percent = value.number("a percent of the servo's stall torque")?;
            if !(percent > 0.0 && percent <= 100.0) {
                return Err(value
                    .expected("a percent of the servo's stall torque, above 0 and at most 100"));
            }
            key.effort.push((name.to_string(), percent));
        }
    }
    if let Some(n) = node.get("tool") {
        if arms.is_empty() {
            key.tool = Some(parse_tool(&n)?);
        } else {
            key.arm_tools = parse_arm_tools(&n, arms)?;
        }
    }
    if let Some(joints) = node.get("joints") {
        for (name, value) in joints.named_entries("joint names")? {
            key.values
                .push((name.to_string(), parse_joint_value(&value)?));
        }
    }
    if let Some(transforms) = node.get("transforms") {
        for (name, value) in transforms.named_entries("joint names")? {
            if key.value(name).is_some() {
                return Err(value.error(format!(
                    "joint {name:?} is given both in \"joints\" and in \"transforms\"; expected one"
                )));
            }
            let transform = parse_transform(&value)?;
            key.values
                .push((name.to_string(), KeyValue::Transform(transform)));
        }
    }
    if key.values.is_empty() && key.tool.is_none() && key.arm_tools.is_empty() {
        return Err(node.error(
            "this key sets no joint; expected \"joints\" or \"transforms\" with at least one joint, or \"tool\"",
        ));
    }
    Ok(key)
}

/// A key's `"contact"`: a list of `{"link", "with", "depth_mm"}`. Which links there are is the
/// robot's to say (`plan`); here, only the shape.
fn parse_contacts(node: &Node) -> Result<Vec<DeclaredContact>, InputError> {
    node.items()?
        .iter()
        .map(|item| {
            item.object()?;
            item.only_fields(&["link", "with", "depth_mm"])?;
            let link = item
                .require("link", "the link that touches: a joint's name, or \"base\"")?
                .name("a link name")?
                .to_string();
            let with_node = item.require("with", "\"floor\" or another link's name")?;
            let with = match with_node.name("\"floor\" or a link name")? {
                "floor" => ContactWith::Floor,
                other => ContactWith::Link(other.to_string()),
            };
            let depth_mm = match item.get("depth_mm") {
                None => DEFAULT_CONTACT_DEPTH_MM,
                Some(d) => {
                    let depth = d.number("millimetres")?;
                    if !(0.0..=50.0).contains(&depth) {
                        return Err(d.expected("a depth from 0 to 50 mm"));
                    }
                    depth
                }
            };
            Ok(DeclaredContact {
                link,
                with,
                depth_mm,
            })
        })
        .collect()
}

/// A joint's value in "joints": a number (degrees, metres for a prismatic joint), or a percent
/// of the calibrated range as a string such as "40%".
fn parse_joint_value(node: &Node) -> Result<KeyValue, InputError> {
    const EXPECTED: &str =
        "degrees (metres for a prismatic joint), or a percent of the calibrated range such as \"40%\"";
    let Some(text) = node.value.as_str() else {
        return Ok(KeyValue::Joint(node.number(EXPECTED)?));
    };
    let percent = text
        .strip_suffix('%')
        .and_then(|n| n.trim().parse::<f64>().ok())
        .filter(|p| p.is_finite())
        .ok_or_else(|| node.expected(EXPECTED))?;
    if !(0.0..=100.0).contains(&percent) {
        return Err(node.expected("a percent of the calibrated range from 0% to 100%"));
    }
    Ok(KeyValue::Percent(percent))
}

/// `q` scaled to unit length, or `q` itself when it already is one to rounding: normalizing a
/// normalized quaternion moves its last bits, so a saved key would not load back as saved.
fn unit(q: DQuat) -> DQuat {
    if (q.length_squared() - 1.0).abs() <= 4.0 * f64::EPSILON {
        q
    } else {
        q.normalize()
    }
}

/// A key's `"tool"`: `xyz` in metres, optionally `r` (a unit quaternion) or `rpy` (radians), or
/// instead of either an `approach` (`"down"`, `"down-or-tilted"`).
fn parse_tool(node: &Node) -> Result<ToolKey, InputError> {
    node.object()?;
    node.only_fields(&["xyz", "r", "rpy", "approach"])?;
    let xyz_node = node.require("xyz", "the tool position [x, y, z] in metres")?;
    let xyz = DVec3::from_array(xyz_node.numbers::<3>("metres")?);
    let orientation = match (node.get("r"), node.get("rpy")) {
        (Some(r), Some(_)) => {
            return Err(
                r.error("the tool orientation is given twice (\"r\" and \"rpy\"); expected one")
            )
        }
        (Some(r), None) => Some(ToolOrientation::Quaternion(parse_quaternion(&r)?)),
        (None, Some(rpy)) => Some(ToolOrientation::Rpy(radians(&rpy)?)),
        (None, None) => None,
    };
    let approach = match node.get("approach") {
        Some(a) => Some(parse_approach(&a, orientation.is_some())?),
        None => None,
    };
    Ok(ToolKey {
        xyz,
        orientation,
        approach,
    })
}

/// A tool key's `"approach"`, refused beside a whole orientation (`"r"` or `"rpy"`), which
/// already says which way the tool points.
fn parse_approach(node: &Node, oriented: bool) -> Result<ToolApproach, InputError> {
    let spellings = ToolApproach::ALL.map(|a| format!("{:?}", a.spelling()));
    let expected = format!("one of {}", spellings.join(", "));
    let text = node
        .value
        .as_str()
        .ok_or_else(|| node.expected(&expected))?;
    let approach = ToolApproach::parse(text).ok_or_else(|| node.expected(&expected))?;
    if oriented {
        return Err(node.error(
            "an approach and a whole orientation (\"r\" or \"rpy\") both say which way the \
             tool points; expected one",
        ));
    }
    Ok(approach)
}

/// Roll, pitch and yaw in radians (URDF order). A value past a full turn is refused: any
/// orientation is written within ±π, so such a value is degrees typed where radians belong,
/// and the message gives them in radians.
fn radians(node: &Node) -> Result<[f64; 3], InputError> {
    let rpy = node.numbers::<3>("radians")?;
    if rpy.iter().any(|a| a.abs() > std::f64::consts::TAU) {
        let converted: Vec<String> = rpy
            .iter()
            .map(|a| format!("{:.4}", a.to_radians()))
            .collect();
        return Err(node.error(format!(
            "expected roll, pitch, yaw in radians (each within ±2π), found [{}]: these look \
             like degrees; in radians they are [{}]",
            rpy.map(|a| a.to_string()).join(", "),
            converted.join(", ")
        )));
    }
    Ok(rpy)
}

/// A key's `"tool"` in a sequence of several arms: one tool target per arm, by arm name.
fn parse_arm_tools(node: &Node, arms: &[ArmSpec]) -> Result<Vec<(String, ToolKey)>, InputError> {
    let entries = node.entries()?;
    let names: Vec<&str> = arms.iter().map(|a| a.name.as_str()).collect();
    let mut tools = Vec::with_capacity(entries.len());
    for (arm, value) in entries {
        if !names.contains(&arm) {
            return Err(value.error(format!(
                "unknown arm {arm:?}; expected a tool target per arm, named as in \"robots\": {}",
                names.join(", ")
            )));
        }
        tools.push((arm.to_string(), parse_tool(&value)?));
    }
    Ok(tools)
}

fn parse_transform(node: &Node) -> Result<RigidTransform, InputError> {
    node.only_fields(&["t", "r"])?;
    let t = match node.get("t") {
        Some(n) => DVec3::from_array(n.numbers::<3>("metres")?),
        None => DVec3::ZERO,
    };
    let r = match node.get("r") {
        Some(n) => parse_quaternion(&n)?,
        None => DQuat::IDENTITY,
    };
    Ok(RigidTransform::new(t, r))
}

/// `{w, x, y, z}`, of norm 1 within [`UNIT_TOLERANCE`], normalised (see [`unit`]).
fn parse_quaternion(n: &Node) -> Result<DQuat, InputError> {
    n.only_fields(&["w", "x", "y", "z"])?;
    let mut c = [0.0; 4];
    for (slot, name) in c.iter_mut().zip(["w", "x", "y", "z"]) {
        *slot = n
            .require(name, "a quaternion component")?
            .number("quaternion component")?;
    }
    unit_quaternion(n, DQuat::from_xyzw(c[1], c[2], c[3], c[0]))
}

/// `q` of norm 1 within [`UNIT_TOLERANCE`], normalised (see [`unit`]); `n` is where it was.
fn unit_quaternion(n: &Node, q: DQuat) -> Result<DQuat, InputError> {
    let norm = q.length();
    if (norm - 1.0).abs() > UNIT_TOLERANCE {
        return Err(n.error(format!(
            "expected a unit quaternion (norm 1 ± {UNIT_TOLERANCE}), found norm {norm:.6}"
        )));
    }
    Ok(unit(q))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by the `sequence_loader` fuzz target: a key rotation of norm 1.0001 (inside the
    /// tolerance) is normalized on load; saved and loaded again it came back changed in its
    /// last bits (0.707206760934951 became 0.7072067609349509).
    #[test]
    fn a_normalized_key_rotation_loads_back_as_saved() {
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"time": 0, "joints": {"shoulder_pan": 0}},
                          {"time": 1, "transforms": {"wrist_roll":
                              {"r": {"w": 0.7071, "x": 0, "y": 0, "z": 0.7073}}}}]}"#;
        let loaded = parse_sequence("a.json", text).unwrap();
        let rotation = |s: &Sequence| match s.keyframes[1].value("wrist_roll") {
            Some(KeyValue::Transform(t)) => t.r,
            other => panic!("{other:?}"),
        };
        // The loaded rotation is the unit quaternion along (0.7071, 0.7073): w/z = 0.7071/0.7073.
        let r = rotation(&loaded);
        assert!((r.length() - 1.0).abs() < 1e-15);
        assert!((r.w / r.z - 7071.0 / 7073.0).abs() < 1e-12);
        let again = parse_sequence("a.json", &loaded.to_json()).unwrap();
        assert_eq!(rotation(&again), r);
    }
}
