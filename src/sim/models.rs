//! The built-in robots' MJCF models (held by the robot registry, `robot::builtin`), written to
//! the cache when a simulation needs them (MuJoCo loads models from files), and the check of a
//! model given with `--mjcf`.

use super::SimError;
use crate::json::{InputError, Location};
use crate::python::PyConfig;
use std::path::{Path, PathBuf};

/// The path of the built-in model of `robot` (found by its name), written out when missing or
/// different.
pub fn model_path(config: &PyConfig, robot: &crate::robot::Robot) -> Result<PathBuf, SimError> {
    let text = crate::robot::builtin_mjcf(&robot.name).ok_or_else(|| SimError::Model {
        model: robot.name.clone(),
        message: format!(
            "keypose has no built-in model of a robot named {:?} (the built-in models go by \
             the robot's name){}; or give one with --mjcf",
            robot.name,
            crate::robot::named_like_hint(robot)
        ),
    })?;
    let robot = robot.name.as_str();
    let dir = config.sim_dir().join("models");
    let path = dir.join(format!("{robot}.xml"));
    if std::fs::read(&path).is_ok_and(|on_disk| on_disk == text.as_bytes()) {
        return Ok(path);
    }
    let io = |e: std::io::Error| SimError::Model {
        model: path.display().to_string(),
        message: format!("cannot write: {e}"),
    };
    crate::atomic_file::create_private_dir(&dir).map_err(io)?;
    crate::atomic_file::write(&path, text.as_bytes()).map_err(io)?;
    Ok(path)
}

/// Checks a model given with `--mjcf` before MuJoCo starts: a regular file (not a FIFO MuJoCo
/// would wait on) whose root element is `<mujoco>`, or a URDF `<robot>`, which MuJoCo also
/// compiles. Anything else is bad input, not a simulation failure.
pub fn check_mjcf_file(path: &Path) -> Result<(), InputError> {
    let text = crate::json::read_text(path)?;
    match root_element(&text) {
        Some("mujoco" | "robot") => Ok(()),
        found => Err(InputError::new(
            &path.display().to_string(),
            Location::File,
            format!(
                "expected a MuJoCo model (XML whose root element is <mujoco>, or a URDF <robot>), found {}",
                match found {
                    Some(name) => format!("<{name}>"),
                    None => "no XML element".to_string(),
                }
            ),
        )),
    }
}

/// The name of the first element of an XML text, past its declaration, comments and doctype.
fn root_element(text: &str) -> Option<&str> {
    let mut rest = text.trim_start_matches('\u{feff}').trim_start();
    loop {
        rest = if let Some(r) = rest.strip_prefix("<?") {
            r.split_once("?>")?.1
        } else if let Some(r) = rest.strip_prefix("<!--") {
            r.split_once("-->")?.1
        } else if let Some(r) = rest.strip_prefix("<!") {
            r.split_once('>')?.1
        } else {
            break;
        }
        .trim_start();
    }
    let name = rest.strip_prefix('<')?;
    let end = name
        .find(|c: char| c.is_whitespace() || c == '>' || c == '/')
        .unwrap_or(name.len());
    Some(&name[..end]).filter(|n| !n.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_root_element_is_found_past_the_prolog() {
        let mjcf =
            "\u{feff}<?xml version=\"1.0\"?>\n<!-- arm -->\n<!DOCTYPE x>\n<mujoco model=\"a\">";
        assert_eq!(root_element(mjcf), Some("mujoco"));
        assert_eq!(root_element("<robot name=\"r\"/>"), Some("robot"));
        assert_eq!(root_element("{\"format\": \"keypose-sequence/1\"}"), None);
        assert_eq!(root_element("<html><body>"), Some("html"));
        assert_eq!(root_element("<!-- never closed"), None);
    }
}
