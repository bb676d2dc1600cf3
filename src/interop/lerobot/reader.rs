//! One episode's rows out of the dataset's parquet files, read by `sim/dataset_reader.py`
//! (pyarrow) in keypose's Python environment: parquet is read by a well-kept library, and the
//! Rust build carries no parquet crate (docs/interop.md §1.3).

use super::info::DatasetInfo;
use super::LeRobotError;
use crate::python::{Harness, HarnessError};
use serde_json::{json, Value};
use std::path::Path;
use std::time::Duration;

const SCRIPT: &str = "dataset_reader.py";
/// Reading a data file of LeRobot's default 100 MB takes seconds; a minute is generous.
const READ_TIMEOUT: Duration = Duration::from_secs(60);

/// The rows of one episode, in frame order.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRows {
    /// The data file, relative to the dataset.
    pub file: String,
    /// Global frame indices [from, to).
    pub from: u64,
    pub to: u64,
    /// The column's Arrow type (`list<element: float>`, `fixed_size_list<…>[6]`).
    pub column_type: String,
    /// Seconds from the episode's start as the `timestamp` column says, if it has one.
    pub timestamps: Option<Vec<f64>>,
    /// One row of the field per frame.
    pub values: Vec<Vec<f64>>,
}

/// Reads episode `episode`'s `field` from the dataset at `dir`.
pub fn read_episode(
    dir: &Path,
    info: &DatasetInfo,
    episode: u64,
    field: &str,
) -> Result<EpisodeRows, LeRobotError> {
    let mut harness = Harness::start(SCRIPT).map_err(LeRobotError::Reader)?;
    let request = json!({
        "op": "episode",
        "root": dir.display().to_string(),
        "episode": episode,
        "field": field,
        "data_path": info.data_path,
    });
    let reply = harness
        .request_within(&request, READ_TIMEOUT)
        .map_err(|e| dataset_error(dir, e))?;
    parse_reply(&reply)
}

/// A reply of kind "dataset" is the dataset's fault (bad input); anything else the reader's.
fn dataset_error(dir: &Path, error: HarnessError) -> LeRobotError {
    if let HarnessError::Failed { reply, message, .. } = &error {
        if reply.get("kind").and_then(Value::as_str) == Some("dataset") {
            return LeRobotError::Dataset {
                dir: dir.display().to_string(),
                message: message.clone(),
            };
        }
    }
    LeRobotError::Reader(error)
}

fn parse_reply(reply: &Value) -> Result<EpisodeRows, LeRobotError> {
    let bad = |what: &str| {
        LeRobotError::Reader(HarnessError::BadReply {
            script: SCRIPT.into(),
            detail: format!("{what} missing or malformed"),
            line: reply.to_string().chars().take(200).collect(),
        })
    };
    let number = |v: &Value| v.as_f64();
    let values = reply
        .get("values")
        .and_then(Value::as_array)
        .ok_or_else(|| bad("values"))?
        .iter()
        .map(|row| {
            row.as_array()
                .and_then(|r| r.iter().map(number).collect::<Option<Vec<f64>>>())
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| bad("values"))?;
    let timestamps = match reply.get("timestamps") {
        None | Some(Value::Null) => None,
        Some(Value::Array(ts)) => Some(
            ts.iter()
                .map(number)
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| bad("timestamps"))?,
        ),
        Some(_) => return Err(bad("timestamps")),
    };
    let text = |name: &str| reply.get(name).and_then(Value::as_str).map(str::to_string);
    let index = |name: &str| reply.get(name).and_then(Value::as_u64);
    Ok(EpisodeRows {
        file: text("file").ok_or_else(|| bad("file"))?,
        from: index("from").ok_or_else(|| bad("from"))?,
        to: index("to").ok_or_else(|| bad("to"))?,
        column_type: text("column_type").ok_or_else(|| bad("column_type"))?,
        timestamps,
        values,
    })
}
