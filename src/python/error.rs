//! What can go wrong while finding or building the Python side, each error saying what to do.
//!
//! Knows nothing about harness processes or JSON lines ([`super::HarnessError`] wraps these).

use super::base_python::MIN_PYTHON;
use crate::terminal_text::quoted_lines;
use std::io;
use std::path::{Path, PathBuf};

/// Why keypose's Python side cannot be found or built.
#[derive(Debug, thiserror::Error)]
pub enum PyEnvError {
    /// No cache directory to build the environment in.
    #[error(
        "no cache directory for keypose's Python environment: set KEYPOSE_CACHE (or \
         XDG_CACHE_HOME or HOME), or set KEYPOSE_PYTHON to an interpreter that has the \
         packages of sim/requirements.txt"
    )]
    NoCacheDir,
    /// `KEYPOSE_PYTHON` names no file (the value given).
    #[error(
        "KEYPOSE_PYTHON={0} is not an existing file: point it at a Python {min}+ interpreter \
         that has the packages of sim/requirements.txt, or unset it to let keypose build its \
         own environment",
        min = min_python()
    )]
    OverrideMissing(String),
    /// No base interpreter to build the environment with.
    #[error(
        "python3 not found (tried {tried}): install Python {min}+ with its venv module \
         (Debian/Ubuntu: apt install python3 python3-venv), or set KEYPOSE_PYTHON to an \
         interpreter that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonNotFound {
        /// The interpreters tried, as a list for the message.
        tried: String,
    },
    /// The base interpreter is older than [`super::MIN_PYTHON`].
    #[error(
        "{python} is Python {version}, keypose needs {min}+: install a newer Python, or set \
         KEYPOSE_PYTHON to one that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonTooOld {
        /// The interpreter.
        python: String,
        /// Its version, as it says it.
        version: String,
    },
    /// The interpreter cannot be run, or does not say its version.
    #[error("{python} does not work: {detail}")]
    PythonBroken {
        /// The interpreter.
        python: String,
        /// What went wrong.
        detail: String,
    },
    /// A file or directory of the environment cannot be made, written or moved.
    #[error("{action} {path}")]
    Io {
        /// What was being done ("creating", "writing", …).
        action: &'static str,
        /// To which file or directory.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// `python -m venv` failed.
    #[error(
        "creating a virtual environment with `{python} -m venv` failed ({status}); on \
         Debian/Ubuntu install python3-venv, or set KEYPOSE_PYTHON to an interpreter that has \
         the packages of sim/requirements.txt. Its last output:{}",
        quoted_lines(tail.lines())
    )]
    Venv {
        /// The base interpreter.
        python: String,
        /// How it exited.
        status: String,
        /// Its last lines of output.
        tail: String,
    },
    /// pip could not install the pinned packages.
    #[error(
        "installing the Python packages of sim/requirements.txt into {venv} failed ({status}); \
         check access to PyPI (pip honours PIP_INDEX_URL and its config files), or set \
         KEYPOSE_PYTHON to an interpreter that has them. pip's last output:{}",
        quoted_lines(tail.lines())
    )]
    Pip {
        /// The environment being built.
        venv: PathBuf,
        /// How pip exited.
        status: String,
        /// pip's last lines of output.
        tail: String,
    },
    /// A script name that is not among the embedded scripts (a bug of the caller).
    #[error("no harness script named {name:?} is built into keypose (known: {known})")]
    UnknownScript {
        /// The name asked for.
        name: String,
        /// The embedded scripts' names, as a list.
        known: String,
    },
}

fn min_python() -> String {
    format!("{}.{}", MIN_PYTHON.0, MIN_PYTHON.1)
}

/// Maps an I/O error on `path` to [`PyEnvError::Io`], naming what was being done.
pub(super) fn io_error<'a>(
    action: &'static str,
    path: &'a Path,
) -> impl FnOnce(io::Error) -> PyEnvError + 'a {
    move |source| PyEnvError::Io {
        action,
        path: path.to_path_buf(),
        source,
    }
}
