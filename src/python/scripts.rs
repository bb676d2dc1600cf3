//! The harness scripts embedded in the binary, written to `<cache>/sim/` when used.
//!
//! A script on disk is rewritten whenever its content differs from the embedded one, so the
//! cache never runs a script of another build. Knows nothing about interpreters or processes.

use super::requirements::REQUIREMENTS;
use super::{io_error, PyConfig, PyEnvError};
use crate::atomic_file;
use std::fs;
use std::path::PathBuf;

/// The harness scripts, by file name, as embedded in the binary.
const SCRIPTS: &[(&str, &str)] = &[
    ("sdk_bridge.py", include_str!("../../sim/sdk_bridge.py")),
    ("sim_harness.py", include_str!("../../sim/sim_harness.py")),
    (
        "dataset_reader.py",
        include_str!("../../sim/dataset_reader.py"),
    ),
    (
        "dataset_writer.py",
        include_str!("../../sim/dataset_writer.py"),
    ),
];

/// Modules the harness scripts import, written beside them (all of them before any script
/// starts, so that a script never imports a module of another build: each is rewritten when
/// its content differs from the embedded one).
const SUPPORT: &[(&str, &str)] = &[
    ("harness_io.py", include_str!("../../sim/harness_io.py")),
    ("sim_requests.py", include_str!("../../sim/sim_requests.py")),
    ("sim_model.py", include_str!("../../sim/sim_model.py")),
    ("sim_run.py", include_str!("../../sim/sim_run.py")),
    ("sim_profile.py", include_str!("../../sim/sim_profile.py")),
    ("sim_render.py", include_str!("../../sim/sim_render.py")),
    ("sim_images.py", include_str!("../../sim/sim_images.py")),
    ("sim_scene.py", include_str!("../../sim/sim_scene.py")),
    ("sim_servos.py", include_str!("../../sim/sim_servos.py")),
];

/// The file names of the embedded harness scripts.
pub(crate) fn script_names() -> Vec<&'static str> {
    SCRIPTS.iter().map(|(name, _)| *name).collect()
}

impl PyConfig {
    /// The path of an embedded script, written out when missing or different.
    pub fn script_path(&self, name: &str) -> Result<PathBuf, PyEnvError> {
        let content = SCRIPTS
            .iter()
            .find(|(script, _)| *script == name)
            .map(|(_, content)| *content)
            .ok_or_else(|| PyEnvError::UnknownScript {
                name: name.to_string(),
                known: script_names().join(", "),
            })?;
        // The modules first: a script never starts without what it imports.
        for (module, text) in SUPPORT {
            self.write_embedded(module, text)?;
        }
        self.write_embedded(name, content)
    }

    /// The embedded requirements written out, for a `pip install -r` by hand.
    pub(crate) fn requirements_path(&self) -> Result<PathBuf, PyEnvError> {
        self.write_embedded("requirements.txt", REQUIREMENTS)
    }

    fn write_embedded(&self, name: &str, content: &str) -> Result<PathBuf, PyEnvError> {
        let dir = self.sim_dir();
        let path = dir.join(name);
        if fs::read(&path).is_ok_and(|on_disk| on_disk == content.as_bytes()) {
            return Ok(path);
        }
        atomic_file::create_private_dir(&dir).map_err(io_error("creating", &dir))?;
        // Atomic, so that a process starting the script meanwhile never sees half a file.
        atomic_file::write(&path, content.as_bytes()).map_err(io_error("writing", &path))?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_scripts_are_named_with_the_known_ones() {
        let config = PyConfig::with_cache_dir("/tmp/unused");
        let error = config.script_path("nope.py").expect_err("unknown");
        assert!(error.to_string().contains("sdk_bridge.py"), "{error}");
    }
}
