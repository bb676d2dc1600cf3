//! The direction check's record: a joint's servo direction written into the robot file the
//! session uses, every other field kept as it was (the file is read back as JSON in its own
//! order and written in the two-space layout keypose's robot files have), atomically.

use crate::json::{self, InputError};
use serde_json::Value;
use std::path::Path;

/// Sets `joints[..].servo.direction` of the joint named `name` in the robot file at `path` to
/// `direction` (1 or -1) and writes the file atomically; nothing is written on an error.
pub(crate) fn write_direction(path: &Path, name: &str, direction: i8) -> Result<(), InputError> {
    let file = path.display().to_string();
    let text = json::read_text(path)?;
    let mut root = json::parse(&file, &text)?;
    let joints = root
        .get_mut("joints")
        .and_then(Value::as_array_mut)
        .ok_or_else(|| InputError::at_path(&file, "$.joints", "expected an array of joints"))?;
    let (index, joint) = joints
        .iter_mut()
        .enumerate()
        .find(|(_, j)| j.get("name").and_then(Value::as_str) == Some(name))
        .ok_or_else(|| {
            InputError::at_path(
                &file,
                "$.joints",
                format!("expected a joint named {name:?}"),
            )
        })?;
    let servo = joint
        .get_mut("servo")
        .and_then(Value::as_object_mut)
        .ok_or_else(|| {
            let at = format!("$.joints[{index}].servo");
            InputError::at_path(&file, &at, "expected the joint's servo object")
        })?;
    servo.insert("direction".into(), Value::from(direction));
    let mut out = serde_json::to_string_pretty(&root).expect("a JSON value always serialises");
    out.push('\n');
    crate::atomic_file::write(path, out.as_bytes())
        .map_err(|e| InputError::new(&file, json::Location::File, format!("not written: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_named_joints_direction_changes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("arm.json");
        let original = include_str!("../../robots/so101.json");
        std::fs::write(&path, original).unwrap();
        write_direction(&path, "elbow_flex", -1).unwrap();
        let before: Value = serde_json::from_str(original).unwrap();
        let after: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let elbow = before["joints"]
            .as_array()
            .unwrap()
            .iter()
            .position(|j| j["name"] == "elbow_flex")
            .unwrap();
        let mut expected = before.clone();
        expected["joints"][elbow]["servo"]["direction"] = Value::from(-1);
        assert_eq!(after, expected);
        assert_ne!(before["joints"][elbow]["servo"]["direction"], -1);
    }

    #[test]
    fn a_joint_the_file_lacks_is_an_error_and_nothing_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("arm.json");
        let original = include_str!("../../robots/so101.json");
        std::fs::write(&path, original).unwrap();
        let e = write_direction(&path, "knee", -1).unwrap_err();
        assert!(e.to_string().contains("\"knee\""), "{e}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), original);
    }
}
