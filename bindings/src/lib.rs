//! keypose's Python package: the native module `keypose._keypose`, which `keypose/__init__.py`
//! re-exports (bindings/keypose/_keypose.pyi types it).
//!
//! It mirrors the library, not the command line: a sequence on its robot (`Sequence`: samples,
//! the exact check, retiming, saving), a robot (`Robot`: limits, forward and inverse
//! kinematics), errors as exceptions by kind. Loading goes through the command line's own
//! functions, compiled in, so a bad file is refused with the message `keypose check` prints.

use pyo3::prelude::*;

mod errors;
mod keys;
mod lerobot;
mod report;
mod robot;
mod sequence;

// The command line, compiled in: the console script runs it, and the API loads sequences,
// robots and calibrations through its verbs' functions. What the package does not call of it
// (its `main`, most verbs) is not dead in the binary.
#[allow(dead_code)]
#[path = "../../src/main.rs"]
mod cli;

/// Runs the `keypose` command line with `argv` (the program's name first) and returns its exit
/// code: the `keypose` console script.
#[pyfunction]
fn cli_main(py: Python<'_>, argv: Vec<std::ffi::OsString>) -> u8 {
    py.detach(|| cli::run(argv))
}

#[pymodule]
fn _keypose(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(cli_main, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::load, m)?)?;
    m.add_class::<sequence::Sequence>()?;
    m.add_class::<report::Report>()?;
    m.add_class::<report::Violation>()?;
    m.add_class::<report::Contact>()?;
    m.add_class::<report::JointSummary>()?;
    m.add_class::<robot::Robot>()?;
    m.add_class::<robot::Limits>()?;
    m.add_class::<robot::ToolPose>()?;
    m.add_class::<lerobot::StopRequests>()?;
    m.add_function(wrap_pyfunction!(lerobot::play_lerobot, m)?)?;
    errors::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
