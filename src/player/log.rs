//! `--log FILE.csv`: what was commanded and what was measured, cycle by cycle.
//!
//! Columns: `time` (seconds since playback began), `phase`, `sequence_time`, then
//! `<joint>_cmd` for every joint, `<joint>_meas` for every joint (empty when not read that
//! cycle, or when the joint's arm in a cell was isolated after a fault), `lateness_ms` (how
//! late the cycle started against its deadline) and `stall_ms` (after a stall: how much longer
//! than one period the previous goal was held; empty otherwise), then the servos' telemetry
//! (see [`TELEMETRY`]): `<joint>_load_pct` with each read-back, `<joint>_current_a`,
//! `<joint>_temp_c` and `<joint>_alarms` with each health reading (empty between them).
//! `keypose plot
//! --log` overlays the measured columns on the sequence, against `sequence_time`.
//!
//! The header and the first rows are written to a temporary that is then put in place of the
//! target at once ([`AtomicFile::publish`]), so an earlier log of the same name is replaced
//! whole, never torn, and only by a log that could be written (a disk too full for the first
//! second of rows leaves the earlier log as it was); the rows then grow the file in place,
//! written whole rows at a time at least every [`PUBLISH_EVERY`], so a process killed outright
//! (SIGKILL, a crash) leaves its log under its own name, complete up to the last second before
//! the kill. A write that fails part-way (the disk full later) is cut back to the rows before
//! it: the log always ends with a whole row. However playback ends otherwise (finished,
//! stopped, a fault: [`PlaybackLog`] finishes when dropped), every row is there.
//!
//! The rows are formatted and written on a thread of their own, so the control thread only
//! copies a few numbers into a preallocated record and passes it on: a slow disk or a write
//! never delays a cycle. Records come back to the control thread for reuse.

use super::PlayError;
use crate::atomic_file::{AtomicFile, Privacy};
use crate::bus::Health;
use crate::plan::Phase;
use crate::robot::Robot;
use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::Path;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The longest rows wait on the writer thread before they are in the file: a killed playback
/// keeps its log up to this long before the kill.
pub const PUBLISH_EVERY: Duration = Duration::from_secs(1);
/// Formatted rows gathered for one write at most (whole rows: the file always ends with one).
const GATHER_BYTES: usize = 64 * 1024;

/// Records in flight between the control thread and the writer: seconds of cycles at 1 kHz,
/// allocated once. Only a writer that far behind makes the control thread wait.
const IN_FLIGHT: usize = 4096;

/// One cycle of the log.
pub struct Row<'a> {
    /// Seconds since playback started.
    pub time: f64,
    /// What the timeline was doing.
    pub phase: Phase,
    /// The timeline's sequence time, seconds.
    pub sequence_time: f64,
    /// The goals written, joint order and units.
    pub commanded: &'a [f64],
    /// The positions read back this cycle, if any.
    pub measured: Option<&'a [f64]>,
    /// Seconds the cycle started after its deadline.
    pub lateness: f64,
    /// Seconds the previous goal was held beyond its period, after a stall.
    pub stall: Option<f64>,
    /// By joint, the load read with the positions this cycle, percent (empty: none read).
    pub loads: &'a [Option<f64>],
    /// By joint, the health read this cycle (empty: none read).
    pub health: &'a [Option<Health>],
    /// By joint, the load the motion needed this cycle as the push guard judged it, percent,
    /// in the joint's direction (empty: not judged).
    pub needed: &'a [f64],
}

/// A [`Row`] copied for the writer thread.
struct Record {
    time: f64,
    phase: Phase,
    sequence_time: f64,
    commanded: Vec<f64>,
    /// Valid when `measured_now`: the buffer is kept for the next measured row.
    measured: Vec<f64>,
    measured_now: bool,
    lateness: f64,
    stall: Option<f64>,
    loads: Vec<Option<f64>>,
    health: Vec<Option<Health>>,
    needed: Vec<f64>,
}

impl Record {
    fn empty(joints: usize) -> Record {
        Record {
            time: 0.0,
            phase: Phase::Play,
            sequence_time: 0.0,
            commanded: Vec::with_capacity(joints),
            measured: Vec::with_capacity(joints),
            measured_now: false,
            lateness: 0.0,
            stall: None,
            loads: Vec::with_capacity(joints),
            health: Vec::with_capacity(joints),
            needed: Vec::with_capacity(joints),
        }
    }

    /// Takes in `row`, reusing this record's buffers.
    fn fill(&mut self, row: &Row) {
        self.time = row.time;
        self.phase = row.phase;
        self.sequence_time = row.sequence_time;
        self.lateness = row.lateness;
        self.stall = row.stall;
        self.commanded.clear();
        self.commanded.extend_from_slice(row.commanded);
        self.measured.clear();
        self.measured
            .extend_from_slice(row.measured.unwrap_or_default());
        self.measured_now = row.measured.is_some();
        self.loads.clear();
        self.loads.extend_from_slice(row.loads);
        self.health.clear();
        self.health.extend_from_slice(row.health);
        self.needed.clear();
        self.needed.extend_from_slice(row.needed);
    }
}

/// The `--log` CSV of a playback, one row per cycle, written by a thread of its own so that the
/// control loop never waits on the disk; the file appears atomically.
pub struct PlaybackLog {
    path: String,
    /// `None` once finished.
    records: Option<SyncSender<Record>>,
    spare: Receiver<Record>,
    writer: Option<JoinHandle<io::Result<AtomicFile>>>,
    joints: usize,
}

impl PlaybackLog {
    /// Starts the log at `path` with a header naming `robot`'s joints.
    pub fn create(path: &Path, robot: &Robot) -> Result<Self, PlayError> {
        let label = path.display().to_string();
        let log_error = |source| PlayError::Log {
            path: label.clone(),
            source,
        };
        let mut out = AtomicFile::create(path, Privacy::Shared).map_err(log_error)?;
        let header = header(robot);
        out.write_all(header.as_bytes()).map_err(log_error)?;
        let whole = header.len() as u64;
        let joints = robot.joints.len();
        let (records, inbox) = mpsc::sync_channel(IN_FLIGHT);
        let (give_back, spare) = mpsc::sync_channel(IN_FLIGHT);
        for _ in 0..IN_FLIGHT {
            let _ = give_back.try_send(Record::empty(joints));
        }
        let writer = std::thread::Builder::new()
            .name("playback log".into())
            .spawn(move || write_records(out, whole, &inbox, &give_back))
            .map_err(log_error)?;
        Ok(Self {
            path: label,
            records: Some(records),
            spare,
            writer: Some(writer),
            joints,
        })
    }

    /// Hands the row to the writer thread. A write that already failed is reported here.
    pub fn row(&mut self, row: &Row) -> Result<(), PlayError> {
        let Some(records) = &self.records else {
            return Ok(());
        };
        let mut record = self
            .spare
            .try_recv()
            .unwrap_or_else(|_| Record::empty(self.joints));
        record.fill(row);
        if records.send(record).is_err() {
            // The writer stopped on an error: finishing reports it.
            return self.finish();
        }
        Ok(())
    }

    /// Waits for the writer, then puts the log in place of the target.
    pub fn finish(&mut self) -> Result<(), PlayError> {
        self.records = None;
        let Some(writer) = self.writer.take() else {
            return Ok(());
        };
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(io::Error::other("the log writer panicked")));
        written
            .and_then(AtomicFile::commit)
            .map_err(|source| PlayError::Log {
                path: self.path.clone(),
                source,
            })
    }
}

fn header(robot: &Robot) -> String {
    let mut header = String::from("time,phase,sequence_time");
    for suffix in ["cmd", "meas"] {
        for joint in &robot.joints {
            let column = format!("{}_{suffix}", joint.name);
            let _ = write!(header, ",{}", crate::csv::field(&column));
        }
    }
    header.push_str(",lateness_ms,stall_ms");
    for suffix in TELEMETRY {
        for joint in &robot.joints {
            let column = format!("{}_{suffix}", joint.name);
            let _ = write!(header, ",{}", crate::csv::field(&column));
        }
    }
    header.push('\n');
    header
}

/// The telemetry columns' suffixes, after `stall_ms`: load with every read-back (percent of
/// full output, signed as the servo reports it), what the motion needed as the push guard
/// judged it (percent, in the joint's direction), then from each health reading current (A),
/// temperature (°C) and the alarms raised (their names joined by `|`, empty for none).
const TELEMETRY: [&str; 5] = ["load_pct", "need_pct", "current_a", "temp_c", "alarms"];

/// The writer thread: formats each record until the sender is gone, returning each record for
/// reuse, and writes the rows gathered whenever [`PUBLISH_EVERY`] has passed (rows or not: a
/// control loop held up in a bus read must not hold back the rows before it) or
/// [`GATHER_BYTES`] are waiting; stops at the first write error.
fn write_records(
    mut out: AtomicFile,
    mut whole: u64,
    inbox: &Receiver<Record>,
    give_back: &SyncSender<Record>,
) -> io::Result<AtomicFile> {
    // Started by a real-time control thread, this thread would inherit its priority.
    crate::pacing::realtime::leave();
    let mut rows = String::with_capacity(GATHER_BYTES);
    let mut written_at = Instant::now();
    loop {
        match inbox.recv_timeout(PUBLISH_EVERY.saturating_sub(written_at.elapsed())) {
            Ok(record) => {
                format_row(&mut rows, &record);
                let _ = give_back.try_send(record);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if rows.len() >= GATHER_BYTES || written_at.elapsed() >= PUBLISH_EVERY {
            append_rows(&mut out, &mut whole, &rows)?;
            if !out.published() {
                out.publish()?;
            }
            rows.clear();
            written_at = Instant::now();
        }
    }
    append_rows(&mut out, &mut whole, &rows)?;
    Ok(out)
}

/// Writes `rows` (whole lines) after the `whole` bytes written so far; a write that fails
/// part-way is cut back to them.
fn append_rows(out: &mut AtomicFile, whole: &mut u64, rows: &str) -> io::Result<()> {
    match out.write_all(rows.as_bytes()) {
        Ok(()) => {
            *whole += rows.len() as u64;
            Ok(())
        }
        Err(e) => {
            let _ = out.truncate(*whole);
            Err(e)
        }
    }
}

/// Appends `row` as one line.
fn format_row(line: &mut String, row: &Record) {
    let _ = write!(
        line,
        "{:.6},{},{:.6}",
        row.time,
        row.phase.name(),
        row.sequence_time
    );
    for v in &row.commanded {
        let _ = write!(line, ",{v:.6}");
    }
    for i in 0..row.commanded.len() {
        // Not a number: a joint of an arm isolated after a fault, not read.
        match row
            .measured
            .get(i)
            .filter(|m| row.measured_now && m.is_finite())
        {
            Some(m) => {
                let _ = write!(line, ",{m:.6}");
            }
            None => line.push(','),
        }
    }
    let _ = write!(line, ",{:.3},", row.lateness * 1000.0);
    if let Some(stall) = row.stall {
        let _ = write!(line, "{:.3}", stall * 1000.0);
    }
    let joints = row.commanded.len();
    let cell = |line: &mut String, value: Option<f64>, digits: usize| match value {
        Some(v) if v.is_finite() => {
            let _ = write!(line, ",{v:.digits$}");
        }
        _ => line.push(','),
    };
    for j in 0..joints {
        cell(line, row.loads.get(j).copied().flatten(), 1);
    }
    for j in 0..joints {
        cell(line, row.needed.get(j).copied(), 1);
    }
    let health = |j: usize| row.health.get(j).copied().flatten();
    for j in 0..joints {
        cell(line, health(j).and_then(|h| h.current_a), 3);
    }
    for j in 0..joints {
        cell(line, health(j).map(|h| h.temperature_c), 1);
    }
    for j in 0..joints {
        line.push(',');
        if let Some(h) = health(j) {
            line.push_str(&h.alarms.names().join("|"));
        }
    }
    line.push('\n');
}

impl Drop for PlaybackLog {
    /// Playback that ends in a fault returns early: its log is the one most worth keeping.
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Joint names with a comma and a quote stay one column each: what the log writes, `plot
    /// --log` reads back (split at every comma, they were three columns under other names).
    #[test]
    fn measured_values_of_joints_named_with_commas_and_quotes_read_back() {
        let mut robot = Robot::builtin("so101").unwrap();
        robot.joints[0].name = "pan, base".into();
        robot.joints[1].name = "lift \"1\"".into();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        let mut log = PlaybackLog::create(&path, &robot).unwrap();
        let commanded = [0.0; 6];
        for (k, measured) in [
            [1.5, -2.25, 0.0, 0.0, 0.0, 0.0],
            [3.0, 4.5, 0.0, 0.0, 0.0, 0.0],
        ]
        .iter()
        .enumerate()
        {
            log.row(&Row {
                time: k as f64 * 0.01,
                phase: Phase::Play,
                sequence_time: k as f64 * 0.01,
                commanded: &commanded,
                measured: Some(measured),
                lateness: 0.0,
                stall: None,
                loads: &[],
                health: &[],
                needed: &[],
            })
            .unwrap();
        }
        log.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("time,phase,sequence_time,\"pan, base_cmd\",\"lift \"\"1\"\"_cmd\","),
            "{text}"
        );
        let names: Vec<String> = robot.joint_names().iter().map(|n| n.to_string()).collect();
        let traces = crate::report::log::measured_traces(&path, &names).unwrap();
        assert_eq!(traces[0], Some(vec![(0.0, 1.5), (0.01, 3.0)]));
        assert_eq!(traces[1], Some(vec![(0.0, -2.25), (0.01, 4.5)]));
    }
}
