//! `--log FILE.csv`: what was commanded and what was measured, cycle by cycle.
//!
//! Columns: `time` (seconds since playback began), `phase`, `sequence_time`, then
//! `<joint>_cmd` for every joint, `<joint>_meas` for every joint (empty when not read that
//! cycle), `lateness_ms` (how late the cycle started against its deadline) and `stall_ms` (after
//! a stall: how much longer than one period the previous goal was held; empty otherwise).
//! `keypose plot
//! --log` overlays the measured columns on the sequence, against `sequence_time`.
//!
//! The log is streamed to a temporary file and put in place when playback ends, however it ends
//! (finished, stopped, a fault: [`PlaybackLog`] commits when dropped), so `--log` equal to an
//! earlier log never leaves a torn file. A process killed outright leaves no log, only a
//! temporary that the next write of the same log removes.

use super::PlayError;
use crate::atomic_file::{AtomicFile, Privacy};
use crate::plan::Phase;
use crate::robot::Robot;
use std::fmt::Write as _;
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
    /// `None` once committed.
    out: Option<BufWriter<AtomicFile>>,
    line: String,
}

impl PlaybackLog {
    pub fn create(path: &Path, robot: &Robot) -> Result<Self, PlayError> {
        let label = path.display().to_string();
        let file = AtomicFile::create(path, Privacy::Shared).map_err(|source| PlayError::Log {
            path: label.clone(),
            source,
        })?;
        let mut log = Self {
            path: label,
            out: Some(BufWriter::new(file)),
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

    /// Puts the log in place of the target.
    pub fn finish(&mut self) -> Result<(), PlayError> {
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        out.into_inner()
            .map_err(|e| e.into_error())
            .and_then(AtomicFile::commit)
            .map_err(|source| PlayError::Log {
                path: self.path.clone(),
                source,
            })
    }

    fn write(&mut self, text: &str) -> Result<(), PlayError> {
        let Some(out) = &mut self.out else {
            return Ok(());
        };
        out.write_all(text.as_bytes())
            .map_err(|source| PlayError::Log {
                path: self.path.clone(),
                source,
            })
    }
}

impl Drop for PlaybackLog {
    /// Playback that ends in a fault returns early: its log is the one most worth keeping.
    fn drop(&mut self) {
        let _ = self.finish();
    }
}
