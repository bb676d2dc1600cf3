//! Writing sequences back to `keypose-sequence/1` JSON.

use super::{
    ArmSpec, ContactWith, DeclaredContact, Ends, KeyValue, Keyframe, Placement, Sequence, ToolKey,
    ToolOrientation, SEQUENCE_FORMAT,
};
use serde_json::{json, Map, Value};

pub(super) fn to_json(sequence: &Sequence) -> String {
    let mut text = compact_keys(&to_value(sequence));
    text.push('\n');
    text
}

/// The sequence as the canonical JSON value: its fields in a fixed order, defaults left out.
pub(super) fn to_value(sequence: &Sequence) -> Value {
    let mut root = Map::new();
    root.insert("format".into(), json!(SEQUENCE_FORMAT));
    if sequence.is_cell() {
        root.insert("robots".into(), arms_json(&sequence.arms));
    } else {
        root.insert("robot".into(), json!(sequence.robot));
    }
    if let Some(d) = &sequence.description {
        root.insert("description".into(), json!(d));
    }
    root.insert("interpolation".into(), json!(sequence.interpolation.name()));
    if sequence.ends == Ends::Control {
        root.insert("ends".into(), json!("control"));
    }
    if let Some(interval) = sequence.key_interval {
        root.insert("key_interval".into(), json!(interval));
    }
    let keys: Vec<Value> = sequence
        .keyframes
        .iter()
        .map(|key| key_value(key, sequence.key_interval.is_none()))
        .collect();
    root.insert("keyframes".into(), Value::Array(keys));
    Value::Object(root)
}

/// One keyframe as its canonical JSON object (`timed`: the sequence gives each key its own
/// time, not a key interval).
fn key_value(key: &Keyframe, timed: bool) -> Value {
    let mut k = Map::new();
    if let Some(name) = &key.name {
        k.insert("name".into(), json!(name));
    }
    if timed {
        k.insert("time".into(), json!(key.time.unwrap_or(0.0)));
    }
    if key.hold > 0.0 {
        k.insert("hold".into(), json!(key.hold));
    }
    if key.line {
        k.insert("interp".into(), json!("line"));
    } else if let Some(interp) = key.interp {
        k.insert("interp".into(), json!(interp.name()));
    }
    if let Some(timing) = &key.timing {
        k.insert("timing".into(), super::timing::to_value(timing));
    }
    if let Some(tool) = &key.tool {
        k.insert("tool".into(), tool_json(tool));
    }
    if !key.contact.is_empty() {
        k.insert("contact".into(), contacts_json(&key.contact));
    }
    if !key.effort.is_empty() {
        let efforts = key
            .effort
            .iter()
            .map(|(joint, percent)| (joint.clone(), json!(percent)))
            .collect();
        k.insert("effort".into(), Value::Object(efforts));
    }
    if !key.arm_tools.is_empty() {
        let tools = key
            .arm_tools
            .iter()
            .map(|(arm, tool)| (arm.clone(), tool_json(tool)))
            .collect();
        k.insert("tool".into(), Value::Object(tools));
    }
    let (joints, transforms) = values_json(&key.values);
    if !joints.is_empty() {
        k.insert("joints".into(), Value::Object(joints));
    }
    if !transforms.is_empty() {
        k.insert("transforms".into(), Value::Object(transforms));
    }
    Value::Object(k)
}

/// A key's values as its `"joints"` (degrees, metres, percent) and `"transforms"` objects.
fn values_json(values: &[(String, KeyValue)]) -> (Map<String, Value>, Map<String, Value>) {
    let mut joints = Map::new();
    let mut transforms = Map::new();
    for (name, value) in values {
        match value {
            KeyValue::Joint(v) => {
                joints.insert(name.clone(), json!(v));
            }
            KeyValue::Percent(p) => {
                joints.insert(name.clone(), json!(format!("{p}%")));
            }
            KeyValue::Transform(tf) => {
                let mut t = Map::new();
                if tf.t != glam::DVec3::ZERO {
                    t.insert("t".into(), json!([tf.t.x, tf.t.y, tf.t.z]));
                }
                t.insert(
                    "r".into(),
                    json!({ "w": tf.r.w, "x": tf.r.x, "y": tf.r.y, "z": tf.r.z }),
                );
                transforms.insert(name.clone(), Value::Object(t));
            }
        }
    }
    (joints, transforms)
}

/// `"robots"`: an arm without a base as its robot's name alone, one with a base as an object,
/// the base as it was written.
fn arms_json(arms: &[ArmSpec]) -> Value {
    let arms = arms
        .iter()
        .map(|arm| {
            let value = match &arm.base {
                None => json!(arm.robot),
                Some(base) => json!({ "robot": arm.robot, "base": placement_json(base) }),
            };
            (arm.name.clone(), value)
        })
        .collect();
    Value::Object(arms)
}

fn placement_json(placement: &Placement) -> Value {
    let mut p = Map::new();
    p.insert("xyz".into(), json!(placement.xyz.to_array()));
    match placement.rotation {
        Some(ToolOrientation::Rpy(rpy)) => {
            p.insert("rpy".into(), json!(rpy));
        }
        Some(ToolOrientation::Quaternion(q)) => {
            p.insert("quat".into(), json!([q.w, q.x, q.y, q.z]));
        }
        None => {}
    }
    Value::Object(p)
}

/// A key's declared contacts as written (`depth_mm` always, so the file says it).
fn contacts_json(contacts: &[DeclaredContact]) -> Value {
    contacts
        .iter()
        .map(|c| {
            let with = match &c.with {
                ContactWith::Floor => "floor",
                ContactWith::Link(name) => name.as_str(),
            };
            json!({ "link": c.link, "with": with, "depth_mm": c.depth_mm })
        })
        .collect()
}

/// A tool key as written: `xyz`, and `r`, `rpy` or `approach` if it had one.
fn tool_json(tool: &ToolKey) -> Value {
    let mut t = Map::new();
    t.insert("xyz".into(), json!(tool.xyz.to_array()));
    match tool.orientation {
        Some(ToolOrientation::Quaternion(q)) => {
            t.insert(
                "r".into(),
                json!({ "w": q.w, "x": q.x, "y": q.y, "z": q.z }),
            );
        }
        Some(ToolOrientation::Rpy(rpy)) => {
            t.insert("rpy".into(), json!(rpy));
        }
        None => {}
    }
    if let Some(approach) = tool.approach {
        t.insert("approach".into(), json!(approach.spelling()));
    }
    Value::Object(t)
}

/// Pretty JSON with one keyframe per line: sequences are read and diffed by people, and a key per
/// line keeps both short.
fn compact_keys(root: &Value) -> String {
    let mut out = String::from("{\n");
    let Some(map) = root.as_object() else {
        return root.to_string();
    };
    let last = map.len().saturating_sub(1);
    for (i, (name, value)) in map.iter().enumerate() {
        out.push_str(&format!("  {}: ", Value::String(name.clone())));
        match value {
            Value::Array(items) if name == "keyframes" => {
                out.push_str("[\n");
                for (j, item) in items.iter().enumerate() {
                    out.push_str("    ");
                    out.push_str(&item.to_string());
                    out.push_str(if j + 1 < items.len() { ",\n" } else { "\n" });
                }
                out.push_str("  ]");
            }
            other => out.push_str(&other.to_string()),
        }
        out.push_str(if i < last { ",\n" } else { "\n" });
    }
    out.push('}');
    out
}
