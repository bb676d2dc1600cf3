//! The built-in robots' MJCF models, compiled into the binary and written to the cache when a
//! simulation needs them (MuJoCo loads models from files).

use super::SimError;
use crate::pyenv::PyConfig;
use std::path::PathBuf;

const MODELS: [(&str, &str); 3] = [
    ("so101", include_str!("../../sim/models/so101.xml")),
    ("koch", include_str!("../../sim/models/koch.xml")),
    ("omx", include_str!("../../sim/models/omx.xml")),
];

/// The path of the built-in model of `robot`, written out when missing or different.
pub fn model_path(config: &PyConfig, robot: &str) -> Result<PathBuf, SimError> {
    let (_, text) = MODELS
        .iter()
        .find(|(name, _)| *name == robot)
        .ok_or_else(|| SimError::Model {
            model: robot.to_string(),
            message: "keypose has no built-in model of this robot; give one with --mjcf".into(),
        })?;
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
