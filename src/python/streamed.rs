//! A command run to completion with its output echoed, prefixed, to our stderr (pip, venv),
//! keeping the last lines to explain a failure.
//!
//! Knows nothing about Python: any command runs here.

use std::collections::VecDeque;
use std::io::{self, BufRead, BufReader, Read};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::thread::{self, JoinHandle};

/// How many lines of a failed command's output (or a harness's stderr) an error shows.
pub(super) const TAIL_LINES: usize = 25;

pub(super) enum StreamFailure {
    Spawn(io::Error),
    Status { status: String, tail: String },
}

/// Runs a command, echoing its stdout and stderr lines to our stderr with a prefix, and keeps
/// the last lines to explain a failure.
pub(super) fn run_streamed(command: &mut Command, prefix: &str) -> Result<(), StreamFailure> {
    let mut child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(StreamFailure::Spawn)?;
    let (sender, lines) = mpsc::channel::<String>();
    let mut readers = Vec::new();
    if let Some(stdout) = child.stdout.take() {
        readers.push(spawn_line_reader(stdout, sender.clone()));
    }
    if let Some(stderr) = child.stderr.take() {
        readers.push(spawn_line_reader(stderr, sender.clone()));
    }
    drop(sender);
    let mut tail: VecDeque<String> = VecDeque::new();
    // Printed from this thread, so that a test harness capturing this thread's output sees it.
    for line in lines {
        eprintln!("{prefix}{line}");
        if tail.len() == TAIL_LINES {
            tail.pop_front();
        }
        tail.push_back(line);
    }
    for reader in readers {
        let _ = reader.join();
    }
    let status = child.wait().map_err(StreamFailure::Spawn)?;
    if status.success() {
        Ok(())
    } else {
        Err(StreamFailure::Status {
            status: describe_status(status),
            tail: tail.into_iter().collect::<Vec<_>>().join("\n"),
        })
    }
}

fn spawn_line_reader(
    stream: impl Read + Send + 'static,
    sender: mpsc::Sender<String>,
) -> JoinHandle<()> {
    thread::spawn(move || {
        let mut reader = BufReader::new(stream);
        let mut buffer = Vec::new();
        loop {
            buffer.clear();
            match reader.read_until(b'\n', &mut buffer) {
                Ok(0) | Err(_) => break,
                Ok(_) => {
                    let line = String::from_utf8_lossy(&buffer).trim_end().to_string();
                    if sender.send(line).is_err() {
                        break;
                    }
                }
            }
        }
    })
}

pub(super) fn describe_status(status: ExitStatus) -> String {
    match status.code() {
        Some(code) => format!("exit code {code}"),
        None => format!("{status}"),
    }
}
