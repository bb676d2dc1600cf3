//! keypose's errors as Python exceptions: the class says what kind of failure it is (the
//! library's `ErrorKind`), the message is the command line's (without its `error: `), and bad
//! input carries where it is (file, JSON path or line and column) as attributes.

use crate::cli::commands::CommandError;
use keypose::error::{ErrorKind, Report};
use keypose::json::{InputError as LibInputError, Location};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

pyo3::create_exception!(
    keypose,
    Error,
    PyException,
    "Every error keypose raises: the message is what the command line prints after `error: `."
);
pyo3::create_exception!(
    keypose,
    InputError,
    Error,
    "Bad input (a file, an argument): `file`, `path` (a JSON path such as \
     `$.keyframes[2].joints.elbow_flex`, or None), `line` and `column` (of a syntax error, or \
     None) and `reason` say where and what was expected."
);
pyo3::create_exception!(
    keypose,
    HardwareError,
    Error,
    "The servos, the bus, the port or a helper process failed."
);
pyo3::create_exception!(
    keypose,
    LimitError,
    Error,
    "The motion cannot be made to keep the joints' limits (what retiming cannot mend): \
     `report` is the check that says where."
);

/// A command-line error (the verbs' loading of sequences and robots) as its exception.
pub fn command_error(py: Python<'_>, error: CommandError) -> PyErr {
    match error {
        CommandError::Input(input) => input_error(py, &input),
        other => kind_error(py, other.kind(), Report(&other).to_string()),
    }
}

/// Bad input as `InputError`, with where it is as attributes.
pub fn input_error(py: Python<'_>, error: &LibInputError) -> PyErr {
    let err = InputError::new_err(Report(error).to_string());
    let (path, line, column) = match &error.location {
        Location::File => (None, None, None),
        Location::Syntax { line, column } => (None, Some(*line), Some(*column)),
        Location::Path(path) => (Some(path.clone()), None, None),
    };
    let value = err.value(py);
    // Setting attributes on a fresh exception instance cannot fail but by memory; then the
    // exception goes without them rather than being replaced by another.
    let _ = value.setattr("file", error.file.clone());
    let _ = value.setattr("path", path);
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    let _ = value.setattr("reason", error.message.clone());
    err
}

/// Bad input that names no file (an argument): `InputError` whose `file`, `path`, `line` and
/// `column` are None.
pub fn argument_error(py: Python<'_>, message: String) -> PyErr {
    let err = InputError::new_err(message.clone());
    let value = err.value(py);
    for name in ["file", "path", "line", "column"] {
        let _ = value.setattr(name, py.None());
    }
    let _ = value.setattr("reason", message);
    err
}

/// The exception class of a kind of failure.
pub fn kind_error(py: Python<'_>, kind: ErrorKind, message: String) -> PyErr {
    match kind {
        ErrorKind::BadInput => argument_error(py, message),
        ErrorKind::Hardware => HardwareError::new_err(message),
        ErrorKind::VerdictFailed => LimitError::new_err(message),
        ErrorKind::Interrupted => Error::new_err(message),
    }
}

/// Registers the exception classes in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("Error", py.get_type::<Error>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("HardwareError", py.get_type::<HardwareError>())?;
    m.add("LimitError", py.get_type::<LimitError>())?;
    Ok(())
}
