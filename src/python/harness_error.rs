//! How a harness fails, in words that name the script and what it was asked.
//!
//! Knows nothing about the child process itself; [`super::harness`] builds these.

use super::PyEnvError;
use serde_json::Value;
use std::io;

#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    #[error(transparent)]
    Env(#[from] PyEnvError),
    #[error("cannot start {python} {script}")]
    Spawn {
        python: String,
        script: String,
        source: io::Error,
    },
    #[error("{script} did not start: {reason}{hint}{stderr}")]
    NotReady {
        script: String,
        reason: Box<NotReady>,
        /// Empty, or a sentence that starts with "; ".
        hint: String,
        /// Empty, or the child's last stderr lines on lines of their own.
        stderr: String,
    },
    #[error("{script} exited ({status}){stderr}")]
    Exited {
        script: String,
        status: String,
        stderr: String,
    },
    #[error("{script} did not answer {op} within {waited_ms} ms")]
    Timeout {
        script: String,
        op: String,
        waited_ms: u64,
    },
    #[error("{script}: {op} failed: {message}")]
    Failed {
        script: String,
        op: String,
        message: String,
        /// The whole reply, for callers that map its fields (error kinds, codes) further.
        reply: Box<Value>,
    },
    #[error("{script} sent a line that is not a reply ({detail}): {line}")]
    BadReply {
        script: String,
        detail: String,
        line: String,
    },
    #[error("writing a request to {script}")]
    Write { script: String, source: io::Error },
    /// A request that is no JSON (a map with keys that are not strings): a bug of the caller.
    #[error("a request to {script} is not JSON: {detail}")]
    Request { script: String, detail: String },
}

/// Why a harness script did not say it was ready.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotReady {
    #[error("reading its output: {0}")]
    Read(String),
    #[error("no ready line within {seconds} s")]
    Silent { seconds: f64 },
    #[error("it exited ({status}) before saying it was ready")]
    Exited { status: String },
    #[error("its first line is not JSON ({error}): {line}")]
    NotJson { error: String, line: String },
    /// The script says what it lacks (`{"ready": false, "error": …}`).
    #[error("{0}")]
    Refused(String),
    #[error("its first line is not a ready line: {line}")]
    NoReadyLine { line: String },
}

impl HarnessError {
    /// The reply of a request that the script answered with `"ok": false`.
    pub fn reply(&self) -> Option<&Value> {
        match self {
            HarnessError::Failed { reply, .. } => Some(reply),
            _ => None,
        }
    }
}

/// `line` shortened to 300 bytes for a message, on a character boundary.
pub(super) fn clip(line: &str) -> String {
    const MAX: usize = 300;
    if line.len() <= MAX {
        return line.to_string();
    }
    let mut end = MAX;
    while !line.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}…", &line[..end])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Report;

    /// Each layer says its own part; the report says the cause once, after it.
    #[test]
    fn an_io_failure_is_said_once_after_what_was_being_done() {
        let spawn = HarnessError::Spawn {
            python: "/usr/bin/python3".into(),
            script: "sdk_bridge.py".into(),
            source: io::Error::other("permission denied"),
        };
        assert_eq!(
            spawn.to_string(),
            "cannot start /usr/bin/python3 sdk_bridge.py"
        );
        assert_eq!(
            Report(&spawn).to_string(),
            "cannot start /usr/bin/python3 sdk_bridge.py: permission denied"
        );
        let write = HarnessError::Write {
            script: "sim_harness.py".into(),
            source: io::Error::other("broken pipe"),
        };
        assert_eq!(write.to_string(), "writing a request to sim_harness.py");
        let io = HarnessError::Env(PyEnvError::Io {
            action: "writing",
            path: "/cache/keypose/sim/requirements.txt".into(),
            source: io::Error::other("disk full"),
        });
        assert_eq!(
            Report(&io).to_string(),
            "writing /cache/keypose/sim/requirements.txt: disk full"
        );
    }
}
