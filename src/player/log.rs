//! `--log FILE.csv`: what was commanded and what was measured, cycle by cycle.
//!
//! Columns: `time` (seconds since playback began), `phase`, `sequence_time`, then
//! `<joint>_cmd` for every joint, `<joint>_meas` for every joint (empty when not read that
//! cycle), and `lateness_ms` (how late the cycle started against its deadline). `keypose plot
//! --log` overlays the measured columns on the sequence, against `sequence_time`.

use super::{Phase, PlayError};
use crate::robot::Robot;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

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
        header.push_str(",lateness_ms\n");
        log.write(&header)?;
        Ok(log)
    }

    pub fn row(
        &mut self,
        time: f64,
        phase: Phase,
        sequence_time: f64,
        commanded: &[f64],
        measured: Option<&[f64]>,
        lateness: f64,
    ) -> Result<(), PlayError> {
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        let _ = write!(line, "{time:.6},{},{sequence_time:.6}", phase.name());
        for v in commanded {
            let _ = write!(line, ",{v:.6}");
        }
        for i in 0..commanded.len() {
            match measured {
                Some(m) => {
                    let _ = write!(line, ",{:.6}", m[i]);
                }
                None => line.push(','),
            }
        }
        let _ = writeln!(line, ",{:.3}", lateness * 1000.0);
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
