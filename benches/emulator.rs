//! What the emulated servos cost the machine, and how close keypose's native driver comes to
//! the wire limit on them.
//!
//! A `keypose virtual-bus` process serves the robot's servos; keypose's native driver runs bus
//! cycles on it (one sync write of 6 goals and one sync read of 6 positions) at two paces:
//! **100 Hz**, a player's default rate, and **flat out**, one cycle after the other. The
//! emulator's CPU time per cycle is the process's own CPU clock (`clock_getcpuclockid`: user
//! and system time of all its threads, to the nanosecond), read before and after each run. It
//! is measured with the wire timed at the robot's baud rate and, as the peer measured in the
//! same run, answering at once (`--no-wire-timing`: no waiting at all, the floor of what
//! serving a cycle costs). Flat out on the timed wire, the driver's cycles per second against
//! the wire limit (benches/bus/wire.rs) is the driver's share of the wire.
//!
//! `KEYPOSE_EMULATOR_PEER=PATH` adds another build's `keypose` binary as an emulator measured
//! in the same runs (an earlier commit's, for a before/after comparison); the driver is this
//! build's in every run.
//!
//! A player's own traffic is measured too ([`playback`]): `keypose play` of the robot's wave
//! example on the emulator, whose cycle is a sync read of the positions and, after the
//! player's computation, a sync write of the goals (the bench's own cycle sends the two back
//! to back); the emulator's CPU over the playback per player cycle.
//!
//! Beside them, the floor this machine sets ([`pty_floor`]): the same bytes a cycle sends and
//! receives passed through a pseudo-terminal to a thread that answers at once with nothing to
//! do, flat out. No driver can come closer to the wire limit than the wire's time plus that
//! round trip allows, whatever its own code: the round trip is the kernel's hand-over of a
//! pseudo-terminal's bytes (a worker thread each way) and two wake-ups.
//!
//! The configurations alternate, [`REPS`] times each, and each figure is reported as the
//! median and range over the repeats, with the machine's load. Nothing is asserted.
//!
//! `cargo bench --bench emulator` prints lines starting with `summary:`; `cargo test --benches`
//! makes one short run of each, to check that the bench works.

mod common;
#[path = "bus/wire.rs"]
#[allow(dead_code)]
mod wire;

use common::Spread;
use keypose::bus::{connect, Connection, Driver};
use keypose::robot::Robot;
use std::io::BufRead;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

/// Cycles a second at the paced rate, as a player at its default rate asks.
const RATE_HZ: f64 = 100.0;
const ROBOTS: [&str; 2] = ["so101", "koch"];

/// How much is run.
#[derive(Clone, Copy)]
struct Plan {
    /// Interleaved repetitions of each configuration's run.
    reps: usize,
    /// Cycles of one paced run.
    paced_cycles: u32,
    /// Length of one flat-out run.
    flat_out: Duration,
}

impl Plan {
    fn new() -> Plan {
        match common::is_bench_run() {
            true => Plan {
                reps: 3,
                paced_cycles: 600,
                flat_out: Duration::from_secs(2),
            },
            false => Plan {
                reps: 1,
                paced_cycles: 20,
                flat_out: Duration::from_millis(100),
            },
        }
    }
}

/// A `keypose virtual-bus` process and the device it serves.
struct Emulator {
    child: Child,
    path: String,
    /// The process's CPU clock.
    clock: libc::clockid_t,
    /// Held open: the process serves until its standard input closes.
    _stdin: ChildStdin,
    _stdout: std::io::BufReader<ChildStdout>,
}

impl Emulator {
    fn start(binary: &str, robot: &str, timed: bool) -> Emulator {
        let mut command = Command::new(binary);
        command.args(["virtual-bus", "--robot", robot]);
        if !timed {
            command.arg("--no-wire-timing");
        }
        let mut child = command
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start keypose virtual-bus");
        let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        stdout.read_line(&mut line).expect("the device path");
        let mut clock: libc::clockid_t = 0;
        // SAFETY: `clock` is a valid place for the clock id; the pid is our child's.
        let rc = unsafe { libc::clock_getcpuclockid(child.id() as libc::pid_t, &mut clock) };
        assert_eq!(rc, 0, "the emulator's CPU clock");
        Emulator {
            _stdin: child.stdin.take().unwrap(),
            _stdout: stdout,
            child,
            clock,
            path: line.trim().to_string(),
        }
    }

    /// CPU seconds the process has used (user + system, all threads).
    fn cpu_seconds(&self) -> f64 {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `t` is a valid, writable timespec.
        let rc = unsafe { libc::clock_gettime(self.clock, &mut t) };
        assert_eq!(rc, 0, "the emulator's CPU clock");
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Whose emulator, and how it times the wire.
#[derive(Clone)]
struct Setup {
    label: String,
    binary: String,
    timed: bool,
}

/// What one run measured.
#[derive(Clone, Copy)]
struct Run {
    /// Emulator CPU per cycle, µs.
    cpu_us: f64,
    /// Cycles per second.
    rate: f64,
    /// The median cycle, µs.
    median_cycle_us: f64,
}

/// One run of `setup`'s emulator for `robot`: paced at [`RATE_HZ`] or flat out.
fn run(robot: &Robot, name: &str, setup: &Setup, plan: Plan, paced: bool) -> Run {
    let emulator = Emulator::start(&setup.binary, name, setup.timed);
    let mut connection = connect(robot, &emulator.path, Driver::Native, None).expect("connect");
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let home = connection.bus.read_positions(&ids).expect("read");
    let goals: Vec<(u8, i64)> = ids.iter().copied().zip(home).collect();
    let period = Duration::from_secs_f64(1.0 / RATE_HZ);
    let cycle = |connection: &mut Connection| {
        let before = Instant::now();
        connection.bus.write_goals(&goals).expect("write");
        connection.bus.read_positions(&ids).expect("read");
        before.elapsed().as_secs_f64()
    };
    // A few cycles first: the emulator's and the driver's first touches of their memory.
    for _ in 0..20 {
        cycle(&mut connection);
    }
    let mut durations = Vec::new();
    let cpu_before = emulator.cpu_seconds();
    let start = Instant::now();
    loop {
        durations.push(cycle(&mut connection));
        let k = durations.len() as u32;
        if paced {
            if k == plan.paced_cycles {
                break;
            }
            std::thread::sleep((start + period * k).saturating_duration_since(Instant::now()));
        } else if start.elapsed() >= plan.flat_out {
            break;
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let cpu = emulator.cpu_seconds() - cpu_before;
    let cycles = durations.len() as f64;
    Run {
        cpu_us: cpu / cycles * 1e6,
        rate: cycles / seconds,
        median_cycle_us: common::median(&durations) * 1e6,
    }
}

/// The emulator's CPU per player cycle over a `keypose play` of `sequence` on it, and the
/// player's cycles.
fn playback(name: &str, sequence: &str, timed: bool) -> (f64, u64) {
    let binary = env!("CARGO_BIN_EXE_keypose");
    let emulator = Emulator::start(binary, name, timed);
    let path = format!("{}/sequences/{sequence}", env!("CARGO_MANIFEST_DIR"));
    let cpu_before = emulator.cpu_seconds();
    let out = Command::new(binary)
        .args(["play", &path, "--port", &emulator.path])
        .output()
        .expect("run keypose play");
    let cpu = emulator.cpu_seconds() - cpu_before;
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "keypose play failed:\n{log}");
    // The summary line: "done: 932 cycles, approach …".
    let cycles: u64 = log
        .split("done: ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("the player's summary line");
    (cpu / cycles as f64 * 1e6, cycles)
}

/// The round trip of a cycle's bytes through a pseudo-terminal with nothing done on either
/// side, flat out for `length`: the client writes the sync write and then the sync read (two
/// writes, as the driver does) and waits for all the answers' bytes, which a thread on the
/// other side (scheduled as the emulator's server) writes back in one write as soon as the
/// requests' bytes are all in. Returns the median round trip in µs.
fn pty_floor(traffic: &wire::Traffic, length: Duration) -> f64 {
    use serialport::SerialPort;
    use std::io::{Read, Write};
    let (mut client, mut server) = serialport::TTYPort::pair().expect("a pseudo-terminal");
    for port in [&mut client, &mut server] {
        port.set_timeout(Duration::from_secs(1)).expect("a timeout");
    }
    let request = traffic.sync_write + traffic.sync_read_instruction;
    let reply = vec![0u8; traffic.status_each * wire::SERVOS];
    let mut back = vec![0u8; reply.len()];
    let echo = std::thread::spawn(move || {
        // Scheduled as the emulator's server thread is.
        let _ = keypose::pacing::realtime::serve_promptly();
        let mut buf = [0u8; 256];
        loop {
            let mut got = 0;
            while got < request {
                match server.read(&mut buf[..request - got]) {
                    Ok(0) | Err(_) => return,
                    Ok(n) => got += n,
                }
            }
            if server.write_all(&reply).is_err() {
                return;
            }
        }
    });
    let write = vec![0u8; traffic.sync_write];
    let read = vec![0u8; traffic.sync_read_instruction];
    let mut trips = Vec::new();
    let start = Instant::now();
    while start.elapsed() < length {
        let before = Instant::now();
        client.write_all(&write).expect("write");
        client.write_all(&read).expect("write");
        client.read_exact(&mut back).expect("the answers");
        trips.push(before.elapsed().as_secs_f64() * 1e6);
    }
    drop(client);
    let _ = echo.join();
    common::median(&trips)
}

/// How an emulator answers, as the summary lines name it.
fn answering(timed: bool) -> &'static str {
    match timed {
        true => "wire-timed",
        false => "at once",
    }
}

/// The emulators measured: this build's, and a peer build's when given.
fn setups() -> Vec<Setup> {
    let mut binaries = vec![("", env!("CARGO_BIN_EXE_keypose").to_string())];
    if let Ok(peer) = std::env::var("KEYPOSE_EMULATOR_PEER") {
        binaries.push(("peer ", peer));
    }
    let mut setups = Vec::new();
    for (prefix, binary) in binaries {
        for timed in [true, false] {
            setups.push(Setup {
                label: format!("{prefix}{}", answering(timed)),
                binary: binary.clone(),
                timed,
            });
        }
    }
    setups
}

fn main() {
    let session = common::Session::start("emulator");
    let setups = setups();
    let plan = Plan::new();
    println!(
        "emulator CPU per 6-servo cycle (sync write of 6 goals + sync read of 6 positions, \
         keypose's native driver): {RATE_HZ} Hz ({} cycles a run) and flat out ({} s a run), \
         {} interleaved runs each",
        plan.paced_cycles,
        plan.flat_out.as_secs_f64(),
        plan.reps
    );
    for name in ROBOTS {
        let robot = Robot::builtin(name).expect("a built-in robot");
        let traffic = wire::Traffic::of(&robot);
        let limit = traffic.limit_hz(wire::virtual_return_delay(&robot));
        // runs[setup][pace] over the repeats; pace 0 paced, 1 flat out.
        let mut runs = vec![[Vec::new(), Vec::new()]; setups.len()];
        let mut floors = Vec::new();
        for _ in 0..plan.reps {
            floors.push(pty_floor(&traffic, plan.flat_out));
            for (s, setup) in setups.iter().enumerate() {
                for (p, paced) in [true, false].into_iter().enumerate() {
                    runs[s][p].push(run(&robot, name, setup, plan, paced));
                }
            }
        }
        for (setup, [paced, flat]) in setups.iter().zip(&runs) {
            let cpu = |runs: &[Run]| Spread::over(runs, |r| r.cpu_us).show(0);
            let mut line = format!(
                "summary: {name}: {}: emulator CPU {} µs a cycle at {RATE_HZ} Hz, {} µs flat out; \
                 flat out {} cycles/s, median cycle {} µs",
                setup.label,
                cpu(paced),
                cpu(flat),
                Spread::over(flat, |r| r.rate).show(0),
                Spread::over(flat, |r| r.median_cycle_us).show(0),
            );
            if setup.timed {
                line += &format!(
                    ", {} % of the wire limit ({limit:.0} Hz)",
                    Spread::over(flat, |r| r.rate / limit * 100.0).show(1)
                );
            }
            println!("{line} ({})", session.load());
        }
        let sequence = format!("{name}_wave.json");
        let timings = [true, false];
        let mut plays = [Vec::new(), Vec::new()];
        for _ in 0..plan.reps {
            for (t, timed) in timings.into_iter().enumerate() {
                plays[t].push(playback(name, &sequence, timed));
            }
        }
        for (timed, plays) in timings.into_iter().zip(&plays) {
            println!(
                "summary: {name}: {}: a player's traffic (keypose play {sequence}, {} cycles): \
                 emulator CPU {} µs a player cycle ({})",
                answering(timed),
                plays[0].1,
                Spread::over(plays, |p| p.0).show(0),
                session.load()
            );
        }
        let wire_us = 1e6 / limit;
        let reachable = |trip: &f64| wire_us / (wire_us + trip) * 100.0;
        println!(
            "summary: {name}: the floor: a pseudo-terminal round trip of a cycle's bytes with \
             nothing done on either side {} µs; with the wire's {wire_us:.0} µs no driver can \
             pass {} % of the wire limit here ({})",
            Spread::of(&floors).show(0),
            Spread::over(&floors, reachable).show(1),
            session.load()
        );
    }
    session.end();
}
