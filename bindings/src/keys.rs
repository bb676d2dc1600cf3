//! Keys built in Python, as a LeRobot user builds them, turned into a sequence file's
//! `keyframes`: numpy scalars and arrays (LeRobot's data is float32) taken as the numbers they
//! hold, a key's `joints` given as a list in the robot's joint order, and a value that is not a
//! finite number refused with the key and the joint named, as a file's would be.

use keypose::json::InputError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::{Map, Number, Value};

/// `keys` (a list of dicts) as JSON, for a sequence on a robot whose joints are `joints`;
/// errors name `file` and the JSON path of the value (`$.keyframes[1].joints.elbow_flex`).
pub fn keys_json(
    keys: &Bound<'_, PyAny>,
    joints: &[String],
    file: &str,
) -> Result<Value, InputError> {
    let refuse = |path: &str, message: String| InputError::at_path(file, path, message);
    let value = json_of(keys, "$.keyframes", &refuse)?;
    let Value::Array(mut keys) = value else {
        return Err(refuse(
            "$.keyframes",
            "expected a list of keys (dicts)".into(),
        ));
    };
    for (k, key) in keys.iter_mut().enumerate() {
        let Some(values) = key.get_mut("joints") else {
            continue;
        };
        if let Value::Array(list) = values {
            *values = joints_by_name(list, joints)
                .map_err(|m| refuse(&format!("$.keyframes[{k}].joints"), m))?;
        }
    }
    Ok(Value::Array(keys))
}

/// A key's joint values given as a list, in the robot's joint order (`Sequence.joints`).
fn joints_by_name(list: &[Value], joints: &[String]) -> Result<Value, String> {
    if list.len() != joints.len() {
        return Err(format!(
            "a list of {} values in the robot's joint order ({}), or a dict by name; found a \
             list of {}",
            joints.len(),
            joints.join(", "),
            list.len()
        ));
    }
    let by_name: Map<String, Value> = joints.iter().cloned().zip(list.iter().cloned()).collect();
    Ok(Value::Object(by_name))
}

/// A Python value as JSON: `None`, booleans, numbers (numpy's too), text, lists, tuples and
/// dicts with text keys.
fn json_of(
    value: &Bound<'_, PyAny>,
    path: &str,
    refuse: &dyn Fn(&str, String) -> InputError,
) -> Result<Value, InputError> {
    if value.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(i) = value.cast::<PyInt>() {
        return match i.extract::<i64>() {
            Ok(n) => Ok(Value::from(n)),
            Err(_) => Err(refuse(path, format!("{i} is too large a number"))),
        };
    }
    if let Ok(f) = value.cast::<PyFloat>() {
        let x = f.value();
        return Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| refuse(path, format!("expected a finite number, found {x}")));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(Value::String(
            s.to_cow().map_err(|e| refuse(path, e.to_string()))?.into(),
        ));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut object = Map::new();
        for (k, v) in d.iter() {
            let Ok(name) = k.extract::<String>() else {
                return Err(refuse(
                    path,
                    format!("expected text keys in a dict, found {k}"),
                ));
            };
            let item = json_of(&v, &format!("{path}.{name}"), refuse)?;
            object.insert(name, item);
        }
        return Ok(Value::Object(object));
    }
    let items: Option<Vec<Bound<'_, PyAny>>> =
        match (value.cast::<PyList>(), value.cast::<PyTuple>()) {
            (Ok(list), _) => Some(list.iter().collect()),
            (_, Ok(tuple)) => Some(tuple.iter().collect()),
            _ => None,
        };
    if let Some(items) = items {
        let list = items
            .iter()
            .enumerate()
            .map(|(i, item)| json_of(item, &format!("{path}[{i}]"), refuse))
            .collect::<Result<Vec<_>, _>>()?;
        return Ok(Value::Array(list));
    }
    if is_numpy(value) {
        // A numpy scalar's `tolist()` is the Python number it holds; an array's, nested lists.
        let plain = value
            .call_method0("tolist")
            .map_err(|e| refuse(path, e.to_string()))?;
        return json_of(&plain, path, refuse);
    }
    let kind = value
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    Err(refuse(
        path,
        format!("expected a number, text, a list or a dict, found a {kind}"),
    ))
}

/// Whether `value` is a numpy scalar or array (its type's module is numpy's).
fn is_numpy(value: &Bound<'_, PyAny>) -> bool {
    value
        .get_type()
        .module()
        .is_ok_and(|m| m.to_string_lossy().starts_with("numpy"))
}
