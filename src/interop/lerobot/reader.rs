//! The conversation with `sim/dataset_reader.py` (pyarrow) in keypose's Python environment:
//! parquet is read by a well-kept library, and the Rust build carries no parquet crate
//! (docs/interop.md §1.3).
//!
//! The script only gets columns out of the files keypose names (already checked to lie inside
//! the dataset, [`super::layout`]); its answers are judged by [`super::episode`] and
//! [`super::frames`].

use super::episode::EpisodeSpan;
use super::error::{Place, Problem};
use super::LeRobotError;
use crate::python::{Harness, HarnessError};
use serde_json::{json, Value};
use std::path::Path;
use std::time::Duration;

const SCRIPT: &str = "dataset_reader.py";
/// Reading a data file of LeRobot's default 100 MB takes seconds; a minute is generous.
const READ_TIMEOUT: Duration = Duration::from_secs(60);

/// The reader script, running.
pub struct Reader {
    harness: Harness,
}

impl Reader {
    pub fn start() -> Result<Reader, LeRobotError> {
        Ok(Reader {
            harness: Harness::start(SCRIPT).map_err(LeRobotError::Reader)?,
        })
    }

    /// The meta/episodes rows of `place`'s episode in `files` (relative to `dir`), as read.
    pub fn episode(
        &mut self,
        dir: &Path,
        files: &[String],
        place: &Place,
    ) -> Result<Value, LeRobotError> {
        self.ask(
            place,
            json!({
                "op": "episode",
                "root": dir.display().to_string(),
                "files": files,
                "episode": place.episode,
            }),
        )
    }

    /// The rows of `span` in the data file `file` (relative to `dir`), as read: at most one
    /// more than the span holds, so that a row too many shows.
    pub fn rows(
        &mut self,
        dir: &Path,
        file: &str,
        span: &EpisodeSpan,
        field: &str,
    ) -> Result<Value, LeRobotError> {
        self.ask(
            &Place::episode(&dir.display().to_string(), span.episode()),
            json!({
                "op": "rows",
                "root": dir.display().to_string(),
                "file": file,
                "field": field,
                "episode": span.episode(),
                "from": span.from(),
                "to": span.to(),
                "limit": span.frames() + 1,
            }),
        )
    }

    /// The answer to `request`; `place` names the episode when the files are to blame.
    fn ask(&mut self, place: &Place, request: Value) -> Result<Value, LeRobotError> {
        self.harness
            .request_within(&request, READ_TIMEOUT)
            .map_err(|e| dataset_error(place, e))
    }
}

/// A reply of kind "dataset" is the dataset's fault (bad input); anything else the reader's.
fn dataset_error(place: &Place, error: HarnessError) -> LeRobotError {
    if let HarnessError::Failed { reply, message, .. } = &error {
        if reply.get("kind").and_then(Value::as_str) == Some("dataset") {
            return place.error(Problem::Unreadable {
                message: message.clone(),
            });
        }
    }
    LeRobotError::Reader(error)
}

/// The reader's answer lacks what the protocol promises: the reader's fault, not the dataset's.
pub(super) fn bad_reply(what: &str, reply: &Value) -> LeRobotError {
    LeRobotError::Reader(HarnessError::BadReply {
        script: SCRIPT.into(),
        detail: format!("{what} missing or malformed"),
        line: reply.to_string().chars().take(200).collect(),
    })
}
