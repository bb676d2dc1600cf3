//! Serving a virtual bus on a pseudo-terminal, so clients reach it through a real serial port
//! path — our driver via `serialport`, the vendor SDKs via pyserial — with the code path of a
//! USB adapter.
//!
//! By default the server takes the time the real wire would ([`super::wire`]): an answer is
//! readable on the pseudo-terminal no earlier than the instruction's last byte would have
//! arrived at the robot's baud rate, plus each answering servo's return delay and its own
//! bytes' time, plus the adapter latency asked for. Without wire timing it answers at once.
//!
//! What the server costs the machine is mostly its wake-ups: each sleep and wake of a thread
//! is a pair of context switches, on a virtual machine a few tens of microseconds of CPU, far
//! more than decoding a packet or building an answer. So it wakes as little as the wire
//! allows: the answers of an exchange are handed over in as few writes as
//! [`super::wire::deliveries`] groups them into (none held more than [`super::wire::HOLD`]
//! past its instant: a sync read's six STS answers in one, when the last is due), each write
//! one `write()` call. Only the last write of an exchange, the one its client waits for, gets
//! a precise wake-up ([`Waker`]: it seldom spins, and only for as long as it woke early), the
//! others a plain absolute sleep. Between requests it sleeps in `poll()` on the
//! pseudo-terminal and on a stop request, not on a timer.

use super::wire::{self, Answer, Wire, WireTiming};
use super::{VirtualBus, VirtualServos};
use crate::bus::BusError;
use crate::pacing::precise::{sleep_roughly_until, Waker};
use crate::robot::Robot;
use serialport::{SerialPort, TTYPort};
use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd, RawFd};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often an idle server looks whether its port was made to disappear
/// ([`VirtualServos::connected`]); a request is checked at once.
const CONNECTED_CHECK: Duration = Duration::from_millis(50);
/// How long an answer waits for room in the pseudo-terminal before it is dropped (a client
/// that stopped reading, as a real adapter's buffer overflows).
const WRITE_PATIENCE: Duration = Duration::from_millis(5);

/// A running pty server; dropping it stops the server and removes the device.
pub struct PtyServer {
    path: String,
    bus: VirtualBus,
    stop: Arc<StopRequest>,
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
        let (master, slave) = TTYPort::pair().map_err(|e| port_error(e.into()))?;
        let path = slave
            .name()
            .ok_or_else(|| port_error(std::io::Error::other("the pseudo-terminal has no name")))?;
        set_nonblocking(master.as_raw_fd()).map_err(port_error)?;
        let stop = Arc::new(StopRequest::new().map_err(port_error)?);
        let thread = {
            let stop = stop.clone();
            let bus = bus.clone();
            let wire = wire.map(Wire::new);
            std::thread::spawn(move || {
                // Best effort: without the privilege the emulator runs as an ordinary thread,
                // and a loaded machine may then make it answer late.
                let _ = crate::pacing::realtime::serve_promptly();
                let mut server = Server {
                    master: master.as_raw_fd(),
                    stop: &stop,
                    bus: &bus,
                    wire,
                    waker: Waker::default(),
                    out: Vec::new(),
                };
                server.serve();
                // Closing the master (here) hangs up every client.
                drop(master);
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

/// The server thread's state: the pseudo-terminal's master side and what it serves.
struct Server<'a> {
    master: RawFd,
    stop: &'a StopRequest,
    bus: &'a VirtualBus,
    /// The wire's timing (`None`: answers at once).
    wire: Option<Wire>,
    waker: Waker,
    /// The bytes of one write, kept between writes.
    out: Vec<u8>,
}

/// What a wait for a request ended with.
enum Woken {
    Request,
    Idle,
    Stop,
}

impl Server<'_> {
    fn serve(&mut self) {
        let mut buf = [0u8; 1024];
        loop {
            let woken = self.wait_for_request();
            if matches!(woken, Woken::Stop) {
                return;
            }
            if !self.bus.lock().connected {
                // The port "disappears": the caller closes the master.
                return;
            }
            if matches!(woken, Woken::Idle) {
                continue;
            }
            let n = match read_available(self.master, &mut buf) {
                Ok(0) => continue,
                Ok(n) => n,
                // EIO while no client has the device open: wait for one.
                Err(_) => {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
            };
            // A client that hung up mid-answer: serve the next one.
            let _ = match self.wire.is_some() {
                true => self.answer_timed(&buf[..n]),
                false => self.answer_at_once(&buf[..n]),
            };
        }
    }

    /// Sleeps until a request's bytes come, a stop is asked for, or [`CONNECTED_CHECK`] passes.
    fn wait_for_request(&self) -> Woken {
        let mut fds = [
            libc::pollfd {
                fd: self.master,
                events: libc::POLLIN,
                revents: 0,
            },
            libc::pollfd {
                fd: self.stop.fd(),
                events: libc::POLLIN,
                revents: 0,
            },
        ];
        let timeout = CONNECTED_CHECK.as_millis() as libc::c_int;
        // SAFETY: `fds` is a valid array of two pollfd structures.
        let ready = unsafe { libc::poll(fds.as_mut_ptr(), 2, timeout) };
        match ready {
            _ if fds[1].revents != 0 => Woken::Stop,
            n if n > 0 && fds[0].revents != 0 => Woken::Request,
            _ => Woken::Idle,
        }
    }

    /// Each answer after its injected delay only, the answers between delays in one write.
    fn answer_at_once(&mut self, bytes: &[u8]) -> io::Result<()> {
        let answers = self.bus.lock().handle(bytes);
        self.out.clear();
        for (delay, bytes) in answers {
            if !delay.is_zero() {
                self.flush()?;
                std::thread::sleep(delay);
            }
            self.out.extend_from_slice(&bytes);
        }
        self.flush()
    }

    /// Each answer no earlier than the wire would deliver it, in as few writes as
    /// [`wire::deliveries`] allows.
    fn answer_timed(&mut self, bytes: &[u8]) -> io::Result<()> {
        // The client wrote these bytes just now (a pseudo-terminal passes them on at once).
        let written_at = Instant::now();
        let exchanges = self.bus.lock().exchanges(bytes);
        for exchange in exchanges {
            let Some(wire) = self.wire.as_mut() else {
                return Ok(());
            };
            let readable = wire.schedule(written_at, &exchange);
            let deliveries = wire::deliveries(&exchange.answers, &readable, wire::HOLD);
            let last = deliveries.len().saturating_sub(1);
            for (k, delivery) in deliveries.into_iter().enumerate() {
                match k == last {
                    true => self.waker.sleep_until(delivery.at),
                    false => sleep_roughly_until(delivery.at),
                }
                self.deliver(&exchange.answers[delivery.answers])?;
            }
        }
        Ok(())
    }

    /// Writes `answers` in one write.
    fn deliver(&mut self, answers: &[Answer]) -> io::Result<()> {
        self.out.clear();
        for answer in answers {
            self.out.extend_from_slice(&answer.bytes);
        }
        self.flush()
    }

    /// Writes what `out` holds, waiting up to [`WRITE_PATIENCE`] for room; what still does not
    /// fit is dropped.
    fn flush(&mut self) -> io::Result<()> {
        let mut rest = &self.out[..];
        let give_up = Instant::now() + WRITE_PATIENCE;
        while !rest.is_empty() {
            // SAFETY: `rest` is valid for reads of its length.
            let n = unsafe { libc::write(self.master, rest.as_ptr().cast(), rest.len()) };
            if n > 0 {
                rest = &rest[n as usize..];
                continue;
            }
            let error = match n {
                0 => io::Error::from(io::ErrorKind::WouldBlock),
                _ => io::Error::last_os_error(),
            };
            match error.kind() {
                io::ErrorKind::Interrupted => {}
                io::ErrorKind::WouldBlock if Instant::now() < give_up => {
                    wait_for_room(self.master, give_up)
                }
                _ => {
                    self.out.clear();
                    return Err(error);
                }
            }
        }
        self.out.clear();
        Ok(())
    }
}

/// Reads what the pseudo-terminal holds (non-blocking: 0 when nothing).
fn read_available(fd: RawFd, buf: &mut [u8]) -> io::Result<usize> {
    loop {
        // SAFETY: `buf` is valid for writes of its length.
        let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
        if n >= 0 {
            return Ok(n as usize);
        }
        let error = io::Error::last_os_error();
        match error.kind() {
            io::ErrorKind::Interrupted => continue,
            io::ErrorKind::WouldBlock => return Ok(0),
            _ => return Err(error),
        }
    }
}

/// Sleeps until `fd` takes more bytes, or `until`.
fn wait_for_room(fd: RawFd, until: Instant) {
    let mut pollfd = libc::pollfd {
        fd,
        events: libc::POLLOUT,
        revents: 0,
    };
    let ms = until.saturating_duration_since(Instant::now()).as_millis() as libc::c_int;
    // SAFETY: one valid pollfd.
    unsafe { libc::poll(&mut pollfd, 1, ms.max(1)) };
}

fn set_nonblocking(fd: RawFd) -> io::Result<()> {
    // SAFETY: F_GETFL / F_SETFL on an open descriptor take plain integers.
    let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    if flags < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK) } < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// A stop request the server sleeps on beside the pseudo-terminal (an eventfd): asking wakes
/// it at once, and nothing wakes it on a timer to look.
struct StopRequest(OwnedFd);

impl StopRequest {
    fn new() -> io::Result<StopRequest> {
        // SAFETY: eventfd takes plain integers; a non-negative result is a new descriptor.
        let fd = unsafe { libc::eventfd(0, libc::EFD_CLOEXEC | libc::EFD_NONBLOCK) };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: `fd` was just opened and is owned by nothing else.
        Ok(StopRequest(unsafe { OwnedFd::from_raw_fd(fd) }))
    }

    fn fd(&self) -> RawFd {
        self.0.as_raw_fd()
    }

    /// Makes the eventfd readable, for good.
    fn request(&self) {
        let one: u64 = 1;
        // SAFETY: an eventfd takes an 8-byte write.
        unsafe { libc::write(self.fd(), (&one as *const u64).cast(), 8) };
    }
}

impl Drop for PtyServer {
    fn drop(&mut self) {
        self.stop.request();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::protocol::codec;
    use crate::bus::protocol::packet::{Decoded, Direction};
    use crate::bus::transport::{SerialTransport, Transport};
    use crate::robot::Protocol;

    /// A sync read (0x82) of Present_Position (56, 2 bytes) from servos 1…6 of an SO-101 served
    /// at `baud`: each status packet with the instant its last byte was read, measured from
    /// just before the instruction was written. The answers must come from servos 1…6 in
    /// that order, as the wire carries them.
    fn sync_read_at(baud: u32) -> Vec<(u8, Duration)> {
        let robot = Robot::builtin("so101").unwrap();
        let server = PtyServer::start_timed(&robot, Some(WireTiming::at(baud))).unwrap();
        let mut port = SerialTransport::open(server.path(), baud).unwrap();
        let framing = codec(Protocol::FeetechSts).framing();
        let read = framing.encode_instruction(0xFE, 0x82, &[56, 2, 1, 2, 3, 4, 5, 6]);
        let written = Instant::now();
        port.write_all(&read).unwrap();
        let mut rx = Vec::new();
        let mut packets = Vec::new();
        let mut buf = [0u8; 256];
        // Patience only: a loaded machine makes the answers later, never earlier.
        let give_up = written + Duration::from_secs(20);
        while packets.len() < 6 && Instant::now() < give_up {
            let n = port.read_until(&mut buf, give_up).unwrap();
            let read_at = written.elapsed();
            rx.extend_from_slice(&buf[..n]);
            while let Ok(Decoded::Packet(packet)) = framing.decode(&mut rx, Direction::FromServo) {
                packets.push((packet.id, read_at));
            }
        }
        let ids: Vec<u8> = packets.iter().map(|&(id, _)| id).collect();
        assert_eq!(ids, [1, 2, 3, 4, 5, 6], "the answers in wire order");
        packets
    }

    /// When the wire delivers the `k`-th (0-based) answer of that sync read at `baud`: the
    /// instruction's 14 bytes, then k + 1 status packets of 8 bytes (STS3215: no return delay).
    fn wire_instant(baud: u32, k: usize) -> Duration {
        WireTiming::at(baud).bytes_time(14 + 8 * (k + 1))
    }

    #[test]
    fn answers_come_in_wire_order_and_none_before_the_wire_delivers_it() {
        // At 9600 baud the answers are 8.3 ms apart, far more than the emulator holds one back
        // (wire::HOLD): each comes on its own, none before its own instant.
        let baud = 9_600;
        let packets = sync_read_at(baud);
        for (k, &(id, read_at)) in packets.iter().enumerate() {
            let due = wire_instant(baud, k);
            assert!(read_at >= due, "servo {id}: read {read_at:?}, due {due:?}");
        }
    }

    #[test]
    fn a_sync_reads_answers_at_1_mbps_come_together_when_the_last_is_due() {
        // At 1 Mbps the six answers are due 80 µs apart, 220…620 µs after the write: they are
        // handed over in one write at the last one's instant, so not even the first is readable
        // before 620 µs.
        let baud = 1_000_000;
        let packets = sync_read_at(baud);
        let last_due = wire_instant(baud, 5);
        assert_eq!(last_due, Duration::from_micros(620));
        for &(id, read_at) in &packets {
            assert!(
                read_at >= last_due,
                "servo {id}: read {read_at:?}, before the last answer was due ({last_due:?})"
            );
        }
    }

    #[test]
    fn dropping_the_server_stops_it_at_once_and_hangs_up_its_clients() {
        // Not a timing check: the drop must return (the server thread wakes on the stop request
        // rather than on a timer), and a client then sees the port gone.
        let robot = Robot::builtin("so101").unwrap();
        let server = PtyServer::start_timed(&robot, None).unwrap();
        let mut port = SerialTransport::open(server.path(), robot.bus.baud).unwrap();
        drop(server);
        let mut buf = [0u8; 8];
        let deadline = Instant::now() + Duration::from_millis(100);
        assert!(port.read_until(&mut buf, deadline).is_err());
    }
}
