//! Serving a virtual bus on a pseudo-terminal, so clients reach it through a real serial port
//! path — our driver via `serialport`, the vendor SDKs via pyserial — with the code path of a
//! USB adapter.

use super::{VirtualBus, VirtualServos};
use crate::bus::BusError;
use crate::robot::Robot;
use serialport::{SerialPort, TTYPort};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

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
    /// Emulates `robot`'s servos at its home pose.
    pub fn start(robot: &Robot) -> Result<PtyServer, BusError> {
        PtyServer::serve(VirtualBus::new(VirtualServos::for_robot(robot)))
    }

    pub fn serve(bus: VirtualBus) -> Result<PtyServer, BusError> {
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
            std::thread::spawn(move || serve_loop(&mut master, &bus, &stop))
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

    pub fn bus(&self) -> &VirtualBus {
        &self.bus
    }
}

fn serve_loop(master: &mut TTYPort, bus: &VirtualBus, stop: &AtomicBool) {
    let mut buf = [0u8; 1024];
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
        let answers = bus.lock().handle(&buf[..n]);
        for (delay, bytes) in answers {
            if !delay.is_zero() {
                std::thread::sleep(delay);
            }
            if master
                .write_all(&bytes)
                .and_then(|_| master.flush())
                .is_err()
            {
                break;
            }
        }
    }
}

impl Drop for PtyServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
