//! Reading a playback log (`keypose play --log`) back, to overlay what was measured on the
//! sequence it came from.

use crate::json::{InputError, Location};
use std::path::Path;

/// Measured (sequence time, value) points of one joint.
pub type Trace = Vec<(f64, f64)>;

/// Per joint (in `joints` order), the measured points of the log's play phase; `None` for a
/// joint the log has no measurements of.
pub fn measured_traces(path: &Path, joints: &[String]) -> Result<Vec<Option<Trace>>, InputError> {
    let file = path.display().to_string();
    let text = crate::json::input_file::read_text(path, crate::json::input_file::MAX_LOG_BYTES)?;
    parse_traces(&file, &text, joints)
}

/// One joint's servo telemetry in a log: its load and what the motion needed (percent), and
/// its temperature (°C), each against sequence time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Telemetry {
    /// Load with each read-back, percent of full output.
    pub load: Trace,
    /// What the push guard judged the motion needed, percent.
    pub need: Trace,
    /// Temperature with each health reading, °C.
    pub temperature: Trace,
}

/// Per joint (in `joints` order), the servo telemetry of the log's play phase; `None` for a
/// joint whose load the log has no column of (a log from before telemetry, or a simulation's).
pub fn telemetry(path: &Path, joints: &[String]) -> Result<Vec<Option<Telemetry>>, InputError> {
    let file = path.display().to_string();
    let text = crate::json::input_file::read_text(path, crate::json::input_file::MAX_LOG_BYTES)?;
    let column = |suffix| parse_columns(&file, &text, joints, suffix);
    let (load, need, temperature) = (column("load_pct")?, column("need_pct")?, column("temp_c")?);
    Ok(load
        .into_iter()
        .zip(need)
        .zip(temperature)
        .map(|((load, need), temperature)| {
            let load = load.filter(|l| !l.is_empty())?;
            Some(Telemetry {
                load,
                need: need.unwrap_or_default(),
                temperature: temperature.unwrap_or_default(),
            })
        })
        .collect())
}

/// [`measured_traces`] of a log's text; `file` names it in errors.
pub fn parse_traces(
    file: &str,
    text: &str,
    joints: &[String],
) -> Result<Vec<Option<Trace>>, InputError> {
    parse_columns(file, text, joints, "meas")
}

/// Per joint, the points of its `<joint>_<suffix>` column in the log's play phase, against
/// sequence time; `None` for a joint without the column.
fn parse_columns(
    file: &str,
    text: &str,
    joints: &[String],
    suffix: &str,
) -> Result<Vec<Option<Trace>>, InputError> {
    let mut lines = text.lines();
    let first = lines
        .next()
        .ok_or_else(|| InputError::new(file, Location::File, "empty log: expected a CSV header"))?;
    // Column names hold joint names, quoted when they hold a comma or a quote.
    let header = crate::csv::split_record(first).map_err(|e| {
        InputError::new(
            file,
            Location::Syntax {
                line: 1,
                column: e.column,
            },
            format!("expected a CSV header: {e}"),
        )
    })?;
    let column = |name: &str| header.iter().position(|h| h == name);
    let missing = |name: &str| {
        InputError::new(
            file,
            Location::Syntax { line: 1, column: 1 },
            format!("expected a keypose playback log with a {name:?} column"),
        )
    };
    let phase = column("phase").ok_or_else(|| missing("phase"))?;
    let time = column("sequence_time").ok_or_else(|| missing("sequence_time"))?;
    let measured: Vec<Option<usize>> = joints
        .iter()
        .map(|j| column(&format!("{j}_{suffix}")))
        .collect();
    let mut traces: Vec<Trace> = vec![Vec::new(); joints.len()];
    for (index, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        // The approach and the ramps between loops are not on the sequence's time axis.
        if !matches!(
            cells.get(phase),
            Some(&"play") | Some(&"stopping") | Some(&"resuming")
        ) {
            continue;
        }
        let number = |cell: &str, col: usize| -> Result<f64, InputError> {
            cell.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    InputError::new(
                        file,
                        Location::Syntax {
                            line: index + 2,
                            column: col + 1,
                        },
                        format!(
                            "expected a number in column {:?}, found {cell:?}",
                            header[col]
                        ),
                    )
                })
        };
        let t = number(cells.get(time).copied().unwrap_or(""), time)?;
        for (trace, col) in traces.iter_mut().zip(&measured) {
            if let Some(col) = *col {
                match cells.get(col) {
                    Some(cell) if !cell.is_empty() => trace.push((t, number(cell, col)?)),
                    _ => {}
                }
            }
        }
    }
    Ok(traces
        .into_iter()
        .zip(&measured)
        .map(|(trace, col)| col.map(|_| trace))
        .collect())
}
