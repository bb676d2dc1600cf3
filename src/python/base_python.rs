//! The base interpreter a virtual environment is created from: the first `python3`-like
//! command on PATH that is new enough and has the venv module.
//!
//! Knows nothing about keypose's cache or the packages installed later.

use super::PyEnvError;
use std::io;
use std::process::{Command, Stdio};

/// The oldest Python the scripts and their packages are used with: MuJoCo 4 needs 3.11.
pub const MIN_PYTHON: (u32, u32) = (3, 11);

pub(super) struct BasePython {
    pub(super) executable: String,
    pub(super) version: String,
}

/// Prints the interpreter's real path (not a pyenv shim's) and version, and fails without the
/// venv module.
const PROBE: &str = "import sys, venv; print(sys.executable); \
                     print('%d.%d.%d' % sys.version_info[:3])";

pub(super) fn find_base_python() -> Result<BasePython, PyEnvError> {
    // `python3` first, as users expect; the versioned names rescue systems whose default
    // python3 is older than MIN_PYTHON but that have a newer one installed beside it.
    let candidates = [
        "python3",
        "python",
        "python3.14",
        "python3.13",
        "python3.12",
        "python3.11",
        "python3.10",
    ];
    let mut first_problem: Option<PyEnvError> = None;
    for candidate in candidates {
        match probe(candidate) {
            Probed::Usable(base) => return Ok(base),
            Probed::Absent => {}
            Probed::Unusable(problem) => {
                first_problem.get_or_insert(problem);
            }
        }
    }
    Err(first_problem.unwrap_or_else(|| PyEnvError::PythonNotFound {
        tried: candidates.join(", "),
    }))
}

/// What running [`PROBE`] with one candidate command found.
enum Probed {
    Usable(BasePython),
    /// No such command.
    Absent,
    /// There, but broken, without venv or too old: the first such problem is reported when no
    /// candidate is usable.
    Unusable(PyEnvError),
}

fn probe(candidate: &str) -> Probed {
    let output = match Command::new(candidate)
        .args(["-c", PROBE])
        .stdin(Stdio::null())
        .output()
    {
        Ok(output) => output,
        Err(error) if error.kind() == io::ErrorKind::NotFound => return Probed::Absent,
        Err(error) => {
            return Probed::Unusable(PyEnvError::PythonBroken {
                python: candidate.to_string(),
                detail: error.to_string(),
            })
        }
    };
    if !output.status.success() {
        let detail = last_lines(&String::from_utf8_lossy(&output.stderr), 5);
        return Probed::Unusable(PyEnvError::PythonBroken {
            python: candidate.to_string(),
            detail: if detail.contains("venv") {
                format!("{detail} (Debian/Ubuntu: apt install python3-venv)")
            } else {
                detail
            },
        });
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let mut lines = stdout.lines();
    let executable = lines.next().unwrap_or(candidate).trim().to_string();
    let version = lines.next().unwrap_or("").trim().to_string();
    if !version_at_least(&version, MIN_PYTHON) {
        return Probed::Unusable(PyEnvError::PythonTooOld {
            python: candidate.to_string(),
            version,
        });
    }
    Probed::Usable(BasePython {
        executable: if executable.is_empty() {
            candidate.to_string()
        } else {
            executable
        },
        version,
    })
}

fn version_at_least(version: &str, (major, minor): (u32, u32)) -> bool {
    let mut parts = version.split('.').map(|part| part.parse::<u32>().ok());
    match (parts.next().flatten(), parts.next().flatten()) {
        (Some(have_major), Some(have_minor)) => (have_major, have_minor) >= (major, minor),
        _ => false,
    }
}

fn last_lines(text: &str, count: usize) -> String {
    let lines: Vec<&str> = text
        .lines()
        .filter(|line| !line.trim().is_empty())
        .collect();
    // Lines of their own under the message, as an error quotes another program's output.
    crate::terminal_text::quoted_lines(lines[lines.len().saturating_sub(count)..].iter().copied())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_compare_by_major_and_minor() {
        assert!(version_at_least("3.11.7", (3, 10)));
        assert!(version_at_least("3.10.0", (3, 10)));
        assert!(!version_at_least("3.9.18", (3, 10)));
        assert!(version_at_least("4.0.0", (3, 10)));
        assert!(!version_at_least("", (3, 10)));
    }
}
