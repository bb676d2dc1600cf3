//! The reader threads of a harness child's pipes: stdout as events of whole lines, stderr as
//! a bounded tail kept to explain a failure.
//!
//! Knows nothing about JSON or requests: lines are passed on as text.

use std::collections::VecDeque;
use std::io::{self, BufRead, BufReader, Read};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};

/// How many lines of a harness's stderr are kept to explain its failure.
const STDERR_LINES: usize = 200;

/// What the stdout reader passes on.
pub(super) enum Event {
    Line(String),
    ReadError(io::Error),
}

/// The lines kept of a child's stderr, shared with its reader thread.
pub(super) type StderrTail = Arc<Mutex<VecDeque<String>>>;

/// Sends each stdout line as an [`Event`] until end of file, a read error, or a receiver that
/// is gone.
pub(super) fn spawn_stdout_reader(stdout: impl Read + Send + 'static, sender: Sender<Event>) {
    thread::spawn(move || {
        let mut reader = BufReader::new(stdout);
        let mut buffer = Vec::new();
        loop {
            buffer.clear();
            let event = match reader.read_until(b'\n', &mut buffer) {
                Ok(0) => break,
                Ok(_) => Event::Line(String::from_utf8_lossy(&buffer).trim_end().to_string()),
                Err(error) => Event::ReadError(error),
            };
            let stop = matches!(event, Event::ReadError(_));
            if sender.send(event).is_err() || stop {
                break;
            }
        }
    });
}

/// Keeps the last [`STDERR_LINES`] lines of `pipe` in `kept` until end of file.
pub(super) fn spawn_stderr_tail(
    pipe: impl Read + Send + 'static,
    kept: StderrTail,
) -> JoinHandle<()> {
    thread::spawn(move || {
        let mut reader = BufReader::new(pipe);
        let mut buffer = Vec::new();
        while matches!(reader.read_until(b'\n', &mut buffer), Ok(n) if n > 0) {
            let line = String::from_utf8_lossy(&buffer).trim_end().to_string();
            buffer.clear();
            let mut kept = kept.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            if kept.len() == STDERR_LINES {
                kept.pop_front();
            }
            kept.push_back(line);
        }
    })
}

/// The lines kept so far.
pub(super) fn tail_lines(kept: &StderrTail) -> Vec<String> {
    kept.lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .iter()
        .cloned()
        .collect()
}
