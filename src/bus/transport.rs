//! Byte transports under the drivers: a real serial port, or an in-memory link to emulated
//! servos. Both have the same contract, so the driver code path is identical.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

/// A half-duplex byte link with deadline-bounded reads.
pub trait Transport: Send {
    /// A short description for messages (the port and its baud rate).
    fn describe(&self) -> String;
    /// Sends `bytes`, all of them.
    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Reads what is available, waiting until `deadline` at most; `Ok(0)` means nothing came.
    /// Bytes already received are read even when the deadline has passed: a caller that ran
    /// late (its thread was not scheduled) must not take an answer waiting for it for silence.
    fn read_until(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize>;
    /// Drops any bytes already received (stale answers, line noise).
    fn discard_input(&mut self) -> io::Result<()>;
}

/// A serial port through the `serialport` crate: a USB adapter, or a pseudo-terminal.
pub struct SerialTransport {
    name: String,
    baud: u32,
    port: Box<dyn serialport::SerialPort>,
}

impl SerialTransport {
    /// Opens the serial port `path` at `baud`.
    pub fn open(path: &str, baud: u32) -> io::Result<Self> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(10))
            .open()
            .map_err(|e| not_a_serial_port(path).unwrap_or_else(|| with_advice(e)))?;
        Ok(Self {
            name: path.to_string(),
            baud,
            port,
        })
    }

    /// The port's path.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// The `serialport` crate's error, with what to do where the cause is the user's to mend: a
/// port that is not there (the ones that are), a port another program holds.
fn with_advice(error: serialport::Error) -> io::Error {
    let held = error.description.contains("exclusive lock");
    let error = io::Error::from(error);
    let advice = if held {
        "another program holds the port (a LeRobot script, a serial monitor, ModemManager, \
         another keypose): close it first"
            .to_string()
    } else if error.kind() == io::ErrorKind::NotFound {
        let ports: Vec<String> = super::ports::list_ports()
            .into_iter()
            .map(|p| p.path)
            .collect();
        match ports.is_empty() {
            true => "no serial port is there: is the arm's USB adapter plugged in? \
                     (`keypose ports` lists them)"
                .to_string(),
            false => format!(
                "the serial ports there are {} (`keypose ports` says which adapter each is)",
                ports.join(", ")
            ),
        }
    } else {
        return error;
    };
    io::Error::new(error.kind(), format!("{error}: {advice}"))
}

/// Why a path that failed to open as a serial port is no serial port at all, if it is not: the
/// OS only says "Not a typewriter" (ENOTTY) when a plain file or /dev/null refuses the terminal
/// settings. `None` for a terminal (or a path that cannot be inspected): its own error stands.
fn not_a_serial_port(path: &str) -> Option<io::Error> {
    use std::io::IsTerminal;
    use std::os::unix::fs::FileTypeExt;
    let kind = std::fs::metadata(path).ok()?.file_type();
    let what = if kind.is_dir() {
        "a directory"
    } else if !kind.is_char_device() {
        "a regular file"
    } else if std::fs::File::open(path).ok()?.is_terminal() {
        return None;
    } else {
        // A character device that is not a terminal, such as /dev/null.
        "a device that is not a terminal"
    };
    Some(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("not a serial port ({what}): give the bus adapter's device, see `keypose ports`"),
    ))
}

impl Transport for SerialTransport {
    fn describe(&self) -> String {
        format!("{} at {} baud", self.name, self.baud)
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn read_until(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize> {
        loop {
            // serialport's timeout is per read call; keep it within the caller's deadline. Past
            // the deadline it is zero: one look at what is already there.
            let left = deadline.saturating_duration_since(Instant::now());
            self.port.set_timeout(left.min(Duration::from_millis(50)))?;
            match self.port.read(buf) {
                Ok(0) => {
                    return Err(io::Error::new(
                        io::ErrorKind::BrokenPipe,
                        "the port closed (device unplugged?)",
                    ))
                }
                Ok(n) => return Ok(n),
                Err(e) if e.kind() == io::ErrorKind::TimedOut => {
                    if Instant::now() >= deadline {
                        return Ok(0);
                    }
                }
                // Interrupted before it looked: look again.
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
        }
    }

    fn discard_input(&mut self) -> io::Result<()> {
        self.port
            .clear(serialport::ClearBuffer::Input)
            .map_err(io::Error::from)
    }
}

/// Something that answers bytes with bytes: the in-process side of a [`MemoryTransport`].
pub trait Responder: Send {
    /// Takes the bytes a driver wrote and returns the answer bytes, each chunk with the delay
    /// after which it becomes readable.
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)>;
    /// False once the emulated port has "disappeared".
    fn connected(&self) -> bool {
        true
    }
}

/// An in-memory transport: no serial port, no thread; answers become readable after their
/// delay, so late answers and timeouts behave as on a wire.
pub struct MemoryTransport<R: Responder> {
    responder: R,
    pending: Vec<(Instant, Vec<u8>)>,
    /// Each answer when it is due, before earlier answers still to come; otherwise in order.
    as_due: bool,
}

impl<R: Responder> MemoryTransport<R> {
    /// Answers in the order they were produced, each no earlier than its delay: an adapter that
    /// holds back what follows a late answer.
    pub fn new(responder: R) -> Self {
        Self {
            responder,
            pending: Vec::new(),
            as_due: false,
        }
    }

    /// Each answer as soon as it is due, whatever was produced before it for earlier packets: on
    /// a shared line a servo that answers late does so after the answers other servos give to
    /// later requests.
    pub fn as_due(responder: R) -> Self {
        Self {
            as_due: true,
            ..Self::new(responder)
        }
    }

    /// What answers the bytes written (the emulated servos).
    pub fn responder(&mut self) -> &mut R {
        &mut self.responder
    }

    fn gone() -> io::Error {
        io::Error::new(io::ErrorKind::BrokenPipe, "the port disappeared")
    }
}

impl<R: Responder> Transport for MemoryTransport<R> {
    fn describe(&self) -> String {
        "in-process virtual bus".into()
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if !self.responder.connected() {
            return Err(Self::gone());
        }
        // The answers to one packet follow each other on the line: none before the one ahead.
        let now = Instant::now();
        let mut at = now;
        for (delay, chunk) in self.responder.respond(bytes) {
            at = at.max(now + delay);
            self.pending.push((at, chunk));
        }
        Ok(())
    }

    fn read_until(&mut self, buf: &mut [u8], deadline: Instant) -> io::Result<usize> {
        if !self.responder.connected() {
            return Err(Self::gone());
        }
        // The next chunk: the first produced, or the first due (the first produced among equals).
        let next = match self.as_due {
            false => self.pending.first().map(|_| 0),
            true => (0..self.pending.len()).min_by_key(|&i| self.pending[i].0),
        };
        let Some(next) = next else {
            let now = Instant::now();
            if deadline > now {
                std::thread::sleep(deadline - now);
            }
            return Ok(0);
        };
        let ready_at = self.pending[next].0;
        let now = Instant::now();
        if ready_at > now {
            std::thread::sleep(ready_at.min(deadline) - now);
            if ready_at > deadline {
                return Ok(0);
            }
        }
        let (_, chunk) = &mut self.pending[next];
        let n = chunk.len().min(buf.len());
        buf[..n].copy_from_slice(&chunk[..n]);
        chunk.drain(..n);
        if chunk.is_empty() {
            self.pending.remove(next);
        }
        Ok(n)
    }

    fn discard_input(&mut self) -> io::Result<()> {
        let now = Instant::now();
        self.pending.retain(|(ready_at, _)| *ready_at > now);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serialport::{SerialPort, TTYPort};

    #[test]
    fn an_answer_already_received_is_read_even_past_the_deadline() {
        // A pseudo-terminal as the port; the answer is written on the other side.
        let (mut master, slave) = TTYPort::pair().unwrap();
        let path = slave.name().unwrap();
        let mut port = SerialTransport::open(&path, 1_000_000).unwrap();
        master.write_all(b"answer").unwrap();
        // Wait until the bytes are in the port's input (a readiness check, not a time).
        while slave.bytes_to_read().unwrap() < 6 {
            std::thread::sleep(Duration::from_millis(1));
        }
        // The reading thread comes to it only after its deadline (it was not scheduled): the
        // answer waiting there is still the answer, not silence.
        let mut buf = [0u8; 16];
        let past = Instant::now() - Duration::from_millis(5);
        let n = port.read_until(&mut buf, past).unwrap();
        assert_eq!(&buf[..n], b"answer");
        // And with nothing there, past the deadline is nothing at once.
        assert_eq!(port.read_until(&mut buf, past).unwrap(), 0);
    }
}
