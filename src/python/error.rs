//! What can go wrong while finding or building the Python side, each error saying what to do.
//!
//! Knows nothing about harness processes or JSON lines ([`super::HarnessError`] wraps these).

use super::base_python::MIN_PYTHON;
use crate::terminal_text::quoted_lines;
use std::io;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum PyEnvError {
    #[error(
        "no cache directory for keypose's Python environment: set KEYPOSE_CACHE (or \
         XDG_CACHE_HOME or HOME), or set KEYPOSE_PYTHON to an interpreter that has the \
         packages of sim/requirements.txt"
    )]
    NoCacheDir,
    #[error(
        "KEYPOSE_PYTHON={0} is not an existing file: point it at a Python {min}+ interpreter \
         that has the packages of sim/requirements.txt, or unset it to let keypose build its \
         own environment",
        min = min_python()
    )]
    OverrideMissing(String),
    #[error(
        "python3 not found (tried {tried}): install Python {min}+ with its venv module \
         (Debian/Ubuntu: apt install python3 python3-venv), or set KEYPOSE_PYTHON to an \
         interpreter that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonNotFound { tried: String },
    #[error(
        "{python} is Python {version}, keypose needs {min}+: install a newer Python, or set \
         KEYPOSE_PYTHON to one that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonTooOld { python: String, version: String },
    #[error("{python} does not work: {detail}")]
    PythonBroken { python: String, detail: String },
    #[error("{action} {path}")]
    Io {
        action: &'static str,
        path: PathBuf,
        source: io::Error,
    },
    #[error(
        "creating a virtual environment with `{python} -m venv` failed ({status}); on \
         Debian/Ubuntu install python3-venv, or set KEYPOSE_PYTHON to an interpreter that has \
         the packages of sim/requirements.txt. Its last output:{}",
        quoted_lines(tail.lines())
    )]
    Venv {
        python: String,
        status: String,
        tail: String,
    },
    #[error(
        "installing the Python packages of sim/requirements.txt into {venv} failed ({status}); \
         check access to PyPI (pip honours PIP_INDEX_URL and its config files), or set \
         KEYPOSE_PYTHON to an interpreter that has them. pip's last output:{}",
        quoted_lines(tail.lines())
    )]
    Pip {
        venv: PathBuf,
        status: String,
        tail: String,
    },
    #[error("no harness script named {name:?} is built into keypose (known: {known})")]
    UnknownScript { name: String, known: String },
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
