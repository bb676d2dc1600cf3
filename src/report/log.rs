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

/// [`measured_traces`] of a log's text; `file` names it in errors.
pub fn parse_traces(
    file: &str,
    text: &str,
    joints: &[String],
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
        .map(|j| column(&format!("{j}_meas")))
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
