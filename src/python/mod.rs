//! The Python side's environment and its long-lived scripts.
//!
//! keypose runs its Python helpers (`sim/*.py`: the vendor-SDK bridge, the MuJoCo harness)
//! with:
//! - `KEYPOSE_PYTHON`, an interpreter that must already have the packages of
//!   `sim/requirements.txt`; keypose installs nothing into it;
//! - otherwise a virtual environment that keypose builds once in its cache directory
//!   (`$KEYPOSE_CACHE`, else `$XDG_CACHE_HOME/keypose`, else `~/.cache/keypose`) from the
//!   requirements embedded in the binary. Its directory name carries a hash of the
//!   requirements text, so a changed pin builds a new environment beside the old one.
//!
//! The scripts are embedded too and written to `<cache>/sim/` when used, so the binary works
//! from any directory and always runs the scripts it was built with.
//!
//! A [`Harness`] is one such script running as a child process, spoken to in JSON lines: its
//! first line says it is ready (with the versions it runs), then one request line gets one
//! reply line.
//!
//! One file per job: `config` (where things live), `requirements` (the pins and the
//! environment's key), `scripts` (the embedded scripts on disk), `base_python` and
//! `venv` (finding and building the interpreter), `streamed` (running pip and venv),
//! `harness` with `pipes` (the child process and its JSON lines), `doctor` (the report).

mod base_python;
mod config;
mod doctor;
mod error;
mod harness;
mod harness_error;
mod pipes;
mod requirements;
mod scripts;
mod streamed;
mod venv;

pub use base_python::MIN_PYTHON;
pub use config::PyConfig;
pub use doctor::doctor_report;
use error::io_error;
pub use error::PyEnvError;
pub use harness::{Harness, HarnessOptions, Reply};
pub use harness_error::{HarnessError, NotReady};
pub use requirements::{env_key, pinned_versions, REQUIREMENTS};
pub use venv::{PythonEnv, KEEP_BYTECODE};
