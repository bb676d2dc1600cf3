//! The reader threads of a harness child's pipes: stdout as events of whole lines, each with
//! the binary payload that follows it, stderr as a bounded tail kept to explain a failure.
//!
//! Knows nothing about requests: lines are passed on as text. Of JSON it knows one member, the
//! framing: a line whose object has `"payload": N` is followed by N raw bytes
//! (sim/PROTOCOL.md, "Binary payloads").

use std::collections::VecDeque;
use std::io::{self, BufRead, BufReader, Read};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};

/// How many lines of a harness's stderr are kept to explain its failure.
const STDERR_LINES: usize = 200;

/// Most bytes one payload may have: a trace of ten minutes at 1 kHz of a twelve-joint cell is
/// under a quarter of it, and a corrupt count must not allocate the machine's memory.
pub(super) const MAX_PAYLOAD: u64 = 1 << 30;

/// What the stdout reader passes on.
pub(super) enum Event {
    /// A line (without its end) and the bytes it announced, if it announced any.
    Line(String, Option<Vec<u8>>),
    ReadError(io::Error),
}

/// The framing member of a reply line; any other member, or a payload that is not a count, is
/// none of the reader's business.
#[derive(serde::Deserialize)]
struct Framing {
    payload: Option<u64>,
}

/// The payload count `line` announces, if any.
fn announced(line: &str) -> Option<u64> {
    // Most lines announce nothing: parse only those that could.
    if !line.contains("\"payload\"") {
        return None;
    }
    serde_json::from_str::<Framing>(line).ok()?.payload
}

/// The line in `buffer` and the payload it announces, read from `reader`.
fn event(buffer: &[u8], reader: &mut impl Read) -> Event {
    let line = String::from_utf8_lossy(buffer).trim_end().to_string();
    let Some(count) = announced(&line) else {
        return Event::Line(line, None);
    };
    if count > MAX_PAYLOAD {
        return Event::ReadError(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "a line announces a payload of {count} bytes, more than the {MAX_PAYLOAD} allowed"
            ),
        ));
    }
    let mut payload = vec![0; count as usize];
    match reader.read_exact(&mut payload) {
        Ok(()) => Event::Line(line, Some(payload)),
        Err(error) => Event::ReadError(io::Error::new(
            error.kind(),
            format!("the {count}-byte payload after a line was cut short: {error}"),
        )),
    }
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
                Ok(_) => event(&buffer, &mut reader),
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    /// A line and its payload, or a read error's text.
    type Seen = Result<(String, Option<Vec<u8>>), String>;

    /// The events the stdout reader passes on for `bytes`.
    fn events(bytes: &[u8]) -> Vec<Seen> {
        let (sender, receiver) = mpsc::channel();
        spawn_stdout_reader(io::Cursor::new(bytes.to_vec()), sender);
        receiver
            .iter()
            .map(|event| match event {
                Event::Line(line, payload) => Ok((line, payload)),
                Event::ReadError(error) => Err(error.to_string()),
            })
            .collect()
    }

    #[test]
    fn a_line_that_announces_a_payload_carries_its_bytes_and_the_next_line_follows() {
        let got = events(b"{\"ok\": true, \"payload\": 3}\n\x00\n\xff{\"ok\": true}\n");
        assert_eq!(
            got,
            [
                Ok((
                    "{\"ok\": true, \"payload\": 3}".to_string(),
                    Some(vec![0, b'\n', 0xff])
                )),
                Ok(("{\"ok\": true}".to_string(), None)),
            ]
        );
    }

    #[test]
    fn a_payload_cut_short_is_a_read_error_and_reading_stops() {
        let got = events(b"{\"payload\": 8}\nabc");
        assert_eq!(got.len(), 1, "{got:?}");
        let error = got[0].as_ref().unwrap_err();
        assert!(
            error.contains("8-byte payload") && error.contains("cut short"),
            "{error}"
        );
    }

    #[test]
    fn a_payload_beyond_the_bound_is_refused_unread() {
        let got = events(format!("{{\"payload\": {}}}\n", MAX_PAYLOAD + 1).as_bytes());
        let error = got[0].as_ref().unwrap_err();
        assert!(
            error.contains("more than the 1073741824 allowed"),
            "{error}"
        );
    }

    #[test]
    fn a_payload_member_that_is_no_count_is_text_like_any_other() {
        let got = events(b"{\"payload\": \"3\"}\n{\"error\": \"no \\\"payload\\\" here\"}\n");
        assert_eq!(
            got,
            [
                Ok(("{\"payload\": \"3\"}".to_string(), None)),
                Ok(("{\"error\": \"no \\\"payload\\\" here\"}".to_string(), None)),
            ]
        );
    }
}
