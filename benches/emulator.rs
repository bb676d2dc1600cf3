//! What the emulated servos cost the machine: CPU time of a `keypose virtual-bus` process per
//! bus cycle (one sync write of 6 goals and one sync read of 6 positions, keypose's native
//! driver) at 100 Hz, with the wire timed at the robot's baud rate and, as the peer measured in
//! the same run, answering at once (`--no-wire-timing`: no waiting at all, so the floor of what
//! serving a cycle costs). The difference is what waiting for the wire's instants costs.
//!
//! The emulator runs in a process of its own so that its CPU time (utime + stime of
//! /proc/PID/stat, in clock ticks: 10 ms over a run's 600 cycles, a resolution of about 17 µs
//! a cycle) is its alone. The two emulators alternate, [`REPS`] times each, and the median and
//! range are reported with the machine's load. Nothing is asserted.
//!
//! `cargo bench --bench emulator` prints lines starting with `summary:`.

mod common;

use common::Spread;
use keypose::bus::{connect, Driver};
use keypose::robot::Robot;
use std::io::BufRead;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

/// Interleaved repetitions of each emulator's run.
const REPS: usize = 3;
/// Cycles a second, as a player at its default rate asks.
const RATE_HZ: f64 = 100.0;
/// Cycles of one run.
const CYCLES: u32 = 600;
const ROBOTS: [&str; 2] = ["so101", "koch"];

/// A `keypose virtual-bus` process and the device it serves.
struct Emulator {
    child: Child,
    path: String,
    /// Held open: the process serves until its standard input closes.
    _stdin: ChildStdin,
    _stdout: std::io::BufReader<ChildStdout>,
}

impl Emulator {
    fn start(robot: &str, timed: bool) -> Emulator {
        let mut command = Command::new(env!("CARGO_BIN_EXE_keypose"));
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
        Emulator {
            _stdin: child.stdin.take().unwrap(),
            _stdout: stdout,
            child,
            path: line.trim().to_string(),
        }
    }

    /// CPU seconds the process has used (user + system).
    fn cpu_seconds(&self) -> f64 {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id()))
            .expect("/proc/PID/stat");
        // Fields after the command name's closing parenthesis; utime and stime are fields 14
        // and 15 of the line, 12 and 13 after it.
        let rest = &stat[stat.rfind(')').unwrap() + 2..];
        let fields: Vec<&str> = rest.split(' ').collect();
        let ticks: u64 = fields[11].parse::<u64>().unwrap() + fields[12].parse::<u64>().unwrap();
        // SAFETY: sysconf takes a plain integer.
        let per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
        ticks as f64 / per_second
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Microseconds of emulator CPU per cycle over one run at [`RATE_HZ`].
fn run(robot: &Robot, name: &str, timed: bool) -> f64 {
    let emulator = Emulator::start(name, timed);
    let mut connection = connect(robot, &emulator.path, Driver::Native, None).expect("connect");
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let home = connection.bus.read_positions(&ids).expect("read");
    let goals: Vec<(u8, i64)> = ids.iter().copied().zip(home).collect();
    let period = Duration::from_secs_f64(1.0 / RATE_HZ);
    let before = emulator.cpu_seconds();
    let start = Instant::now();
    for k in 1..=CYCLES {
        connection.bus.write_goals(&goals).expect("write");
        connection.bus.read_positions(&ids).expect("read");
        std::thread::sleep((start + period * k).saturating_duration_since(Instant::now()));
    }
    (emulator.cpu_seconds() - before) / f64::from(CYCLES) * 1e6
}

fn main() {
    let session = common::Session::start("emulator");
    println!(
        "emulator CPU per 6-servo cycle at {RATE_HZ} Hz, {CYCLES} cycles a run, {REPS} runs each"
    );
    for name in ROBOTS {
        let robot = Robot::builtin(name).expect("a built-in robot");
        let (mut timed, mut untimed) = (Vec::new(), Vec::new());
        for _ in 0..REPS {
            timed.push(run(&robot, name, true));
            untimed.push(run(&robot, name, false));
        }
        let waiting: Vec<f64> = timed.iter().zip(&untimed).map(|(t, u)| t - u).collect();
        println!(
            "summary: {name}: wire-timed {} µs, answering at once {} µs, waiting for the wire costs {} µs a cycle ({})",
            Spread::of(&timed).show(0),
            Spread::of(&untimed).show(0),
            Spread::of(&waiting).show(0),
            session.load()
        );
    }
    session.end();
}
