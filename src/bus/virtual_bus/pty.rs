//! Serving a virtual bus on a pseudo-terminal, so clients reach it through a real serial port
//! path — our driver via `serialport`, the vendor SDKs via pyserial — with the code path of a
//! USB adapter.
//!
//! By default the server takes the time the real wire would ([`super::wire`]): an answer is
//! written to the pseudo-terminal no earlier than the instruction's last byte would have
//! arrived at the robot's baud rate, plus each answering servo's return delay and its own
//! bytes' time, plus the adapter latency asked for. Without wire timing it answers at once.
//!
//! Only the last answer of an exchange is what its client waits for (a sync read is complete
//! with its last status packet), so only that one gets a precise wake-up; the others are
//! written when a plain sleep ends, a few microseconds late at most on an idle machine. A
//! precise wake-up for each would spin before every answer and cost the emulator most of its
//! CPU time.

use super::wire::{Wire, WireTiming};
use super::{VirtualBus, VirtualServos};
use crate::bus::BusError;
use crate::pacing::precise::{sleep_roughly_until, Waker};
use crate::robot::Robot;
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A running pty server; dropping it stops the server and removes the device.
pub struct PtyServer {
    path: String,
    bus: VirtualBus,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// Held open so the pty does not hang up between clients: with no slave open, the master
    /// side reads EIO. `pair()` takes no lock on it, so clients can still open it exclusively.
    _slave: TTYPort,
}

impl PtyServer {
    /// Emulates `robot`'s servos at its home pose, on a wire timed at the robot's baud rate.
    pub fn start(robot: &Robot) -> Result<PtyServer, BusError> {
        PtyServer::start_timed(robot, Some(WireTiming::at(robot.bus.baud)))
    }

    /// Emulates `robot`'s servos at its home pose on a wire timed as `wire` says (`None`:
    /// answers come at once, only software time).
    pub fn start_timed(robot: &Robot, wire: Option<WireTiming>) -> Result<PtyServer, BusError> {
        PtyServer::serve(VirtualBus::new(VirtualServos::for_robot(robot)), wire)
    }

    /// Serves `bus` on a new pseudo-terminal, on a thread of its own, with the wire timed as
    /// `wire` says (`None`: answers come at once).
    pub fn serve(bus: VirtualBus, wire: Option<WireTiming>) -> Result<PtyServer, BusError> {
        let port_error = |source: std::io::Error| BusError::Port {
            port: "pseudo-terminal".into(),
            source,
        };
        let (mut master, slave) = TTYPort::pair().map_err(|e| port_error(e.into()))?;
        let path = slave
            .name()
            .ok_or_else(|| port_error(std::io::Error::other("the pseudo-terminal has no name")))?;
        master
            .set_timeout(Duration::from_millis(5))
            .map_err(|e| port_error(e.into()))?;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            let bus = bus.clone();
            let mut wire = wire.map(Wire::new);
            std::thread::spawn(move || {
                // Best effort: without the privilege the emulator runs as an ordinary thread,
                // and a loaded machine may then make it answer late.
                let _ = crate::pacing::realtime::serve_promptly();
                serve_loop(&mut master, &bus, &stop, wire.as_mut())
            })
        };
        Ok(PtyServer {
            path,
            bus,
            stop,
            thread: Some(thread),
            _slave: slave,
        })
    }

    /// The device path clients open.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The emulated servos it serves.
    pub fn bus(&self) -> &VirtualBus {
        &self.bus
    }
}

fn serve_loop(
    master: &mut TTYPort,
    bus: &VirtualBus,
    stop: &AtomicBool,
    mut wire: Option<&mut Wire>,
) {
    let mut buf = [0u8; 1024];
    let mut waker = Waker::default();
    while !stop.load(Ordering::Relaxed) {
        if !bus.lock().connected {
            // The port "disappears": closing the master hangs up every client.
            return;
        }
        let n = match master.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            // EIO while no client has the device open: wait for one.
            Err(_) => {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            }
        };
        // A client that hung up mid-answer: serve the next one.
        let _ = match wire.as_deref_mut() {
            Some(wire) => answer_timed(master, bus, wire, &mut waker, &buf[..n]),
            None => answer_at_once(master, bus, &buf[..n]),
        };
    }
}

/// The old behaviour: each answer after its injected delay only.
fn answer_at_once(master: &mut TTYPort, bus: &VirtualBus, bytes: &[u8]) -> std::io::Result<()> {
    let answers = bus.lock().handle(bytes);
    for (delay, bytes) in answers {
        if !delay.is_zero() {
            std::thread::sleep(delay);
        }
        master.write_all(&bytes).and_then(|_| master.flush())?;
    }
    Ok(())
}

/// Each answer when the wire would have delivered it.
fn answer_timed(
    master: &mut TTYPort,
    bus: &VirtualBus,
    wire: &mut Wire,
    waker: &mut Waker,
    bytes: &[u8],
) -> std::io::Result<()> {
    // The client wrote these bytes just now (a pseudo-terminal passes them on at once).
    let written_at = Instant::now();
    let exchanges = bus.lock().exchanges(bytes);
    for exchange in exchanges {
        let readable = wire.schedule(written_at, &exchange);
        let last = readable.len().saturating_sub(1);
        for (k, (answer, at)) in exchange.answers.iter().zip(readable).enumerate() {
            match k == last {
                true => waker.sleep_until(at),
                false => sleep_roughly_until(at),
            }
            master
                .write_all(&answer.bytes)
                .and_then(|_| master.flush())?;
        }
    }
    Ok(())
}

impl Drop for PtyServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
