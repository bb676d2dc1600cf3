//! `--log FILE.csv`: what was commanded and what was measured, cycle by cycle.
//!
//! Columns: `time` (seconds since playback began), `phase`, `sequence_time`, then
//! `<joint>_cmd` for every joint, `<joint>_meas` for every joint (empty when not read that
//! cycle), `lateness_ms` (how late the cycle started against its deadline) and `stall_ms` (after
//! a stall: how much longer than one period the previous goal was held; empty otherwise).
//! `keypose plot
//! --log` overlays the measured columns on the sequence, against `sequence_time`.

use super::{Phase, PlayError};
use crate::robot::Robot;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// One cycle of the log.
pub struct Row<'a> {
    pub time: f64,
    pub phase: Phase,
    pub sequence_time: f64,
    pub commanded: &'a [f64],
    pub measured: Option<&'a [f64]>,
    pub lateness: f64,
    /// Seconds the previous goal was held beyond its period, after a stall.
    pub stall: Option<f64>,
}

pub struct PlaybackLog {
    path: String,
    out: BufWriter<File>,
    line: String,
}

impl PlaybackLog {
    pub fn create(path: &Path, robot: &Robot) -> Result<Self, PlayError> {
        let label = path.display().to_string();
        let file = File::create(path).map_err(|source| PlayError::Log {
            path: label.clone(),
            source,
        })?;
        let mut log = Self {
            path: label,
            out: BufWriter::new(file),
            line: String::new(),
        };
        let mut header = String::from("time,phase,sequence_time");
        for suffix in ["cmd", "meas"] {
            for joint in &robot.joints {
                let _ = write!(header, ",{}_{suffix}", joint.name);
            }
        }
        header.push_str(",lateness_ms,stall_ms\n");
        log.write(&header)?;
        Ok(log)
    }

    pub fn row(&mut self, row: &Row) -> Result<(), PlayError> {
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        let _ = write!(
            line,
            "{:.6},{},{:.6}",
            row.time,
            row.phase.name(),
            row.sequence_time
        );
        for v in row.commanded {
            let _ = write!(line, ",{v:.6}");
        }
        for i in 0..row.commanded.len() {
            match row.measured {
                Some(m) => {
                    let _ = write!(line, ",{:.6}", m[i]);
                }
                None => line.push(','),
            }
        }
        let _ = write!(line, ",{:.3},", row.lateness * 1000.0);
        if let Some(stall) = row.stall {
            let _ = write!(line, "{:.3}", stall * 1000.0);
        }
        line.push('\n');
        let result = self.write(&line);
        self.line = line;
        result
    }

    pub fn finish(&mut self) -> Result<(), PlayError> {
        self.out.flush().map_err(|source| PlayError::Log {
            path: self.path.clone(),
            source,
        })
    }

    fn write(&mut self, text: &str) -> Result<(), PlayError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(|source| PlayError::Log {
                path: self.path.clone(),
                source,
            })
    }
}
