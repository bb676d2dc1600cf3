//! keypose's own virtual environment: found, or built once per requirements text.
//!
//! A build happens under a private name and is renamed into place only when complete, so
//! racing processes and killed builds never leave a half-built environment under the real
//! name. Knows nothing about the scripts run in it or how they are spoken to.

use super::base_python::{find_base_python, BasePython};
use super::requirements::{env_key, REQUIREMENTS};
use super::streamed::{run_streamed, StreamFailure};
use super::{io_error, PyConfig, PyEnvError};
use crate::atomic_file;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::time::{Duration, SystemTime};

/// Written into a finished environment; an environment without it is not used.
const MARKER: &str = "keypose-env.json";

/// Temporary environments older than this are leftovers of a killed build.
const STALE_BUILD: Duration = Duration::from_secs(6 * 3600);

/// An interpreter ready to run the harness scripts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PythonEnv {
    /// The interpreter's executable.
    pub python: PathBuf,
    /// keypose's own virtual environment; `None` when `KEYPOSE_PYTHON` is used.
    pub venv: Option<PathBuf>,
    /// Whether this call ran pip to build the environment.
    pub created: bool,
}

/// The variable, and its value, under which a Python run in keypose's own environment keeps
/// the bytecode it compiles. The environment is installed without bytecode (`pip_install`), so
/// Python compiles each module on first import; PYTHONDONTWRITEBYTECODE, which container images
/// often set, would make every start compile numpy and MuJoCo's Python from source again
/// (0.2–0.3 s of CPU). An empty value is unset for Python. An interpreter of the user's
/// (`KEYPOSE_PYTHON`) keeps the user's rule.
pub const KEEP_BYTECODE: (&str, &str) = ("PYTHONDONTWRITEBYTECODE", "");

/// Serialises environment builds inside one process; other processes are handled by building
/// in a private directory and renaming it into place.
static BUILD_LOCK: Mutex<()> = Mutex::new(());

impl PyConfig {
    /// The interpreter to use if it is there now, without building anything.
    pub fn find_python(&self) -> Result<Option<PythonEnv>, PyEnvError> {
        if let Some(python) = &self.python_override {
            return resolve_override(python).map(|python| {
                Some(PythonEnv {
                    python,
                    venv: None,
                    created: false,
                })
            });
        }
        let venv = self.venv_dir();
        Ok(env_is_ready(&venv).then(|| PythonEnv {
            python: venv_python(&venv),
            venv: Some(venv),
            created: false,
        }))
    }

    /// The interpreter to use, building keypose's environment first when it is not there.
    ///
    /// Progress (pip's own output, prefixed) goes to stderr; a build happens once per
    /// requirements text.
    pub fn ensure_python(&self) -> Result<PythonEnv, PyEnvError> {
        if let Some(found) = self.find_python()? {
            return Ok(found);
        }
        let _guard = BUILD_LOCK
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // Another thread may have finished the build while this one waited for the lock.
        if let Some(found) = self.find_python()? {
            return Ok(found);
        }
        self.build_env()
    }

    fn build_env(&self) -> Result<PythonEnv, PyEnvError> {
        let venv = self.venv_dir();
        let key = env_key(REQUIREMENTS);
        atomic_file::create_private_dir(&self.cache_dir)
            .map_err(io_error("creating", &self.cache_dir))?;
        remove_stale_builds(&self.cache_dir, &key);
        if venv.exists() && self.set_aside_incomplete(&venv, &key)? {
            return Ok(PythonEnv {
                python: venv_python(&venv),
                venv: Some(venv),
                created: false,
            });
        }
        let base = find_base_python()?;
        eprintln!(
            "keypose: building the Python environment for the harness scripts in {} \
             (once: later runs reuse it)",
            venv.display()
        );
        eprintln!(
            "keypose: with {} (Python {})",
            base.executable, base.version
        );
        self.build_and_move_into_place(&base, &venv, &key)?;
        Ok(PythonEnv {
            python: venv_python(&venv),
            venv: Some(venv),
            created: true,
        })
    }

    /// Moves an environment that is there but not ready out of the way. Returns whether it
    /// turned out ready after all (another keypose finished it meanwhile) and is back in place.
    fn set_aside_incomplete(&self, venv: &Path, key: &str) -> Result<bool, PyEnvError> {
        // There, but without its marker or with its interpreter gone (a Python upgrade
        // removes the one a venv links to): rebuild rather than fail later on an import.
        let trash = self
            .cache_dir
            .join(format!("venv-{key}.broken-{}", unique_suffix()));
        fs::rename(venv, &trash).map_err(io_error("moving aside", venv))?;
        if env_is_ready(&trash) {
            // Another keypose renamed its finished build into place after this one
            // looked: put it back and use it.
            fs::rename(&trash, venv).map_err(io_error("restoring", venv))?;
            return Ok(true);
        }
        eprintln!(
            "keypose: the Python environment {} is incomplete; rebuilding it",
            venv.display()
        );
        let _ = fs::remove_dir_all(&trash);
        Ok(false)
    }

    fn build_and_move_into_place(
        &self,
        base: &BasePython,
        venv: &Path,
        key: &str,
    ) -> Result<(), PyEnvError> {
        // Built under a private name and renamed into place only when complete, so a process
        // that races this one, or one killed half-way, never leaves a half-built environment
        // under the real name. Only `bin/python` is ever run from it, and a venv's interpreter
        // finds its site-packages relative to itself, so the rename does not break it.
        let building = self
            .cache_dir
            .join(format!("venv-{key}.tmp-{}", unique_suffix()));
        if let Err(error) = build_into(base, &building, key) {
            let _ = fs::remove_dir_all(&building);
            return Err(error);
        }
        match fs::rename(&building, venv) {
            Ok(()) => eprintln!("keypose: Python environment ready: {}", venv.display()),
            Err(rename_error) => {
                let _ = fs::remove_dir_all(&building);
                if !env_is_ready(venv) {
                    return Err(PyEnvError::Io {
                        action: "moving the new environment to",
                        path: venv.to_path_buf(),
                        source: rename_error,
                    });
                }
                eprintln!("keypose: another keypose finished the environment first; using it");
            }
        }
        Ok(())
    }
}

fn unique_suffix() -> String {
    let nanos = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    format!("{}-{nanos}", std::process::id())
}

fn venv_python(venv: &Path) -> PathBuf {
    if cfg!(windows) {
        venv.join("Scripts").join("python.exe")
    } else {
        venv.join("bin").join("python")
    }
}

pub(super) fn env_is_ready(venv: &Path) -> bool {
    // `is_file` follows the interpreter's symlink, so a venv whose base Python was removed
    // counts as not ready.
    venv.join(MARKER).is_file() && venv_python(venv).is_file()
}

fn remove_stale_builds(cache_dir: &Path, key: &str) {
    let Ok(entries) = fs::read_dir(cache_dir) else {
        return;
    };
    let prefixes = [format!("venv-{key}.tmp-"), format!("venv-{key}.broken-")];
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !prefixes
            .iter()
            .any(|prefix| name.starts_with(prefix.as_str()))
        {
            continue;
        }
        let old = entry
            .metadata()
            .and_then(|meta| meta.modified())
            .ok()
            .and_then(|modified| modified.elapsed().ok())
            .is_some_and(|age| age > STALE_BUILD);
        if old {
            let _ = fs::remove_dir_all(entry.path());
        }
    }
}

fn resolve_override(python: &Path) -> Result<PathBuf, PyEnvError> {
    let shown = python.display().to_string();
    // A bare name ("python3.11") is looked up on PATH, as a shell would.
    let bare = python.components().count() == 1 && !python.is_absolute();
    if bare && !python.exists() {
        if let Some(found) = search_path(python.as_os_str()) {
            return Ok(found);
        }
    }
    if python.is_file() {
        Ok(python.to_path_buf())
    } else {
        Err(PyEnvError::OverrideMissing(shown))
    }
}

fn search_path(name: &std::ffi::OsStr) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| candidate.is_file())
}

/// A complete environment in `building`: the venv, the pinned packages, then the marker.
fn build_into(base: &BasePython, building: &Path, key: &str) -> Result<(), PyEnvError> {
    create_venv(base, building)?;
    pip_install(building)?;
    write_marker(base, building, key)
}

fn create_venv(base: &BasePython, building: &Path) -> Result<(), PyEnvError> {
    let mut venv_cmd = Command::new(&base.executable);
    venv_cmd.arg("-m").arg("venv").arg(building);
    run_streamed(&mut venv_cmd, "  venv: ").map_err(|failure| match failure {
        StreamFailure::Spawn(source) => PyEnvError::PythonBroken {
            python: base.executable.clone(),
            detail: source.to_string(),
        },
        StreamFailure::Status { status, tail } => PyEnvError::Venv {
            python: base.executable.clone(),
            status,
            tail,
        },
    })
}

fn pip_install(building: &Path) -> Result<(), PyEnvError> {
    // The requirements go inside the environment: pip reads them from there, and they record
    // what the environment was built from.
    let requirements = building.join("keypose-requirements.txt");
    atomic_file::write(&requirements, REQUIREMENTS.as_bytes())
        .map_err(io_error("writing", &requirements))?;
    let python = venv_python(building);
    let mut pip = Command::new(&python);
    // --no-compile: compiled files would name the temporary directory in their tracebacks;
    // Python compiles on first import instead, under the final name, and keeps it
    // ([`KEEP_BYTECODE`]).
    let options = ["--no-input", "--progress-bar", "off", "--no-compile"];
    pip.args(["-m", "pip", "install"])
        .args(options)
        .arg("-r")
        .arg(&requirements)
        .env("PIP_DISABLE_PIP_VERSION_CHECK", "1")
        .env("PYTHONUNBUFFERED", "1");
    run_streamed(&mut pip, "  pip: ").map_err(|failure| match failure {
        StreamFailure::Spawn(source) => PyEnvError::PythonBroken {
            python: python.display().to_string(),
            detail: source.to_string(),
        },
        StreamFailure::Status { status, tail } => PyEnvError::Pip {
            venv: building.to_path_buf(),
            status,
            tail,
        },
    })
}

fn write_marker(base: &BasePython, building: &Path, key: &str) -> Result<(), PyEnvError> {
    let marker = building.join(MARKER);
    let record = serde_json::json!({
        "requirements_key": key,
        "base_python": base.executable,
        "python_version": base.version,
        "built_by": format!("keypose {}", env!("CARGO_PKG_VERSION")),
    });
    atomic_file::write(&marker, format!("{record:#}\n").as_bytes())
        .map_err(io_error("writing", &marker))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_override_is_reported_with_the_fix() {
        let config = PyConfig {
            python_override: Some(PathBuf::from("/no/such/python")),
            cache_dir: PathBuf::from("/tmp/unused"),
        };
        let error = config.ensure_python().expect_err("missing interpreter");
        let text = error.to_string();
        assert!(text.contains("KEYPOSE_PYTHON=/no/such/python"), "{text}");
        assert!(text.contains("unset it"), "{text}");
    }
}
