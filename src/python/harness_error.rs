//! How a harness fails, in words that name the script and what it was asked.
//!
//! Knows nothing about the child process itself; [`super::harness`] builds these.

use super::PyEnvError;
use serde_json::Value;
use std::io;

/// Why a harness script could not be started or spoken to.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// The Python side cannot be found or built.
    #[error(transparent)]
    Env(#[from] PyEnvError),
    /// The interpreter could not be started.
    #[error("cannot start {python} {script}")]
    Spawn {
        /// The interpreter.
        python: String,
        /// The script's path.
        script: String,
        /// What the system said.
        source: io::Error,
    },
    /// The script did not say it was ready.
    #[error("{script} did not start: {reason}{hint}{stderr}")]
    NotReady {
        /// The script's file name.
        script: String,
        /// Why not.
        reason: Box<NotReady>,
        /// Empty, or a sentence that starts with "; ".
        hint: String,
        /// Empty, or the child's last stderr lines on lines of their own.
        stderr: String,
    },
    /// The script exited (its output closed) while it was spoken to.
    #[error("{script} exited ({status}){stderr}")]
    Exited {
        /// The script's file name.
        script: String,
        /// How it exited.
        status: String,
        /// Empty, or its last stderr lines on lines of their own.
        stderr: String,
    },
    /// No reply within the request's time.
    #[error("{script} did not answer {op} within {waited_ms} ms")]
    Timeout {
        /// The script's file name.
        script: String,
        /// The request's operation.
        op: String,
        /// How long it waited, milliseconds.
        waited_ms: u64,
    },
    /// The script answered the request with `"ok": false`.
    #[error("{script}: {op} failed: {message}")]
    Failed {
        /// The script's file name.
        script: String,
        /// The request's operation.
        op: String,
        /// The reply's error message.
        message: String,
        /// The whole reply, for callers that map its fields (error kinds, codes) further.
        reply: Box<Value>,
    },
    /// A reply line that is not JSON, or not a reply to the request.
    #[error("{script} sent a line that is not a reply ({detail}): {line}")]
    BadReply {
        /// The script's file name.
        script: String,
        /// What is wrong with it.
        detail: String,
        /// The line, shortened to 300 bytes.
        line: String,
    },
    /// The request could not be written to the script's stdin.
    #[error("writing a request to {script}")]
    Write {
        /// The script's file name.
        script: String,
        /// What the system said.
        source: io::Error,
    },
    /// A request that is no JSON (a map with keys that are not strings): a bug of the caller.
    #[error("a request to {script} is not JSON: {detail}")]
    Request {
        /// The script's file name.
        script: String,
        /// What serde said.
        detail: String,
    },
}

/// Why a harness script did not say it was ready.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotReady {
    /// Its stdout could not be read: what the system said.
    #[error("reading its output: {0}")]
    Read(String),
    /// It said nothing in time.
    #[error("no ready line within {seconds} s")]
    Silent {
        /// The time waited, seconds.
        seconds: f64,
    },
    /// It exited first.
    #[error("it exited ({status}) before saying it was ready")]
    Exited {
        /// How it exited.
        status: String,
    },
    /// Its first line is not JSON.
    #[error("its first line is not JSON ({error}): {line}")]
    NotJson {
        /// What the JSON parser said.
        error: String,
        /// The line, shortened.
        line: String,
    },
    /// The script says what it lacks (`{"ready": false, "error": …}`).
    #[error("{0}")]
    Refused(String),
    /// Its first line is JSON without `"ready": true` or `false`.
    #[error("its first line is not a ready line: {line}")]
    NoReadyLine {
        /// The line, shortened.
        line: String,
    },
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
