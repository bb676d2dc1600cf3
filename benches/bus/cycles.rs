//! Section 1: bus cycles per second, one sync write of 6 goals and one sync read of 6 positions,
//! by each contender on its own emulated bus, the contenders' runs interleaved.

use super::wire::{virtual_return_delay, Traffic};
use crate::common::{self, Spread};
use keypose::bus::{connect, Connection, Driver, ServoBus, WriteOffsets};
use keypose::robot::{Protocol, Robot};
use keypose::testing::{PtyServer, WireTiming};
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

/// Interleaved repetitions of each contender's timing.
pub const REPS: usize = 3;
/// Length of one timed run of bus cycles.
pub const RUN: Duration = Duration::from_secs(2);
/// Untimed cycles before the first run of each connection.
const WARMUP: Duration = Duration::from_millis(300);

/// Who drives the bus.
#[derive(Clone, Copy, PartialEq)]
pub enum Contender {
    /// keypose's own driver ([`Driver::Native`]).
    Native,
    /// The `rustypot` crate (Pollen Robotics) on the same kind of port.
    Rustypot,
    /// The vendor's Python SDK in a plain loop (`benches/sdk_direct.py`): as people run it.
    SdkDirect,
    /// The vendor's Python SDK through keypose's JSON-lines bridge ([`Driver::Sdk`]).
    SdkBridge,
}

impl Contender {
    pub const ALL: [Contender; 4] = [
        Contender::Native,
        Contender::Rustypot,
        Contender::SdkDirect,
        Contender::SdkBridge,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Contender::Native => "keypose native",
            Contender::Rustypot => "rustypot",
            Contender::SdkDirect => "vendor SDK, direct",
            Contender::SdkBridge => "vendor SDK, keypose's bridge",
        }
    }
}

/// What one timed run measured.
pub struct Timing {
    pub cycles: u64,
    pub seconds: f64,
    /// Each successful cycle's duration, seconds.
    pub durations: Vec<f64>,
    pub errors: u64,
    pub first_error: Option<String>,
}

/// Runs bus cycles (sync write of the goals, sync read of the positions).
pub trait Cycler {
    /// One cycle.
    fn cycle(&mut self) -> Result<(), String>;

    /// Cycles for `length` (at least one), each timed.
    fn run_for(&mut self, length: Duration) -> Timing {
        let mut timing = Timing {
            cycles: 0,
            seconds: 0.0,
            durations: Vec::new(),
            errors: 0,
            first_error: None,
        };
        let start = Instant::now();
        loop {
            let before = Instant::now();
            match self.cycle() {
                Ok(()) => timing.durations.push(before.elapsed().as_secs_f64()),
                Err(e) => {
                    timing.errors += 1;
                    timing.first_error.get_or_insert(e);
                }
            }
            timing.cycles += 1;
            let elapsed = start.elapsed();
            if elapsed >= length {
                timing.seconds = elapsed.as_secs_f64();
                return timing;
            }
        }
    }

    fn describe(&self) -> String;

    /// How far apart a cell's buses started their goal writes (None on one bus).
    fn write_offsets(&self) -> Option<WriteOffsets> {
        None
    }
}

/// keypose's native driver or the SDK bridge, on a [`Connection`].
pub struct KeyposeCycler {
    connection: Connection,
    ids: Vec<u8>,
    goals: Vec<(u8, i64)>,
}

impl KeyposeCycler {
    fn open(robot: &Robot, path: &str, driver: Driver) -> Result<KeyposeCycler, String> {
        let connection = connect(robot, path, driver, None).map_err(|e| e.to_string())?;
        KeyposeCycler::on(robot, connection)
    }

    /// Cycles on `connection` to `robot`'s servos (one arm's bus, or a cell's buses).
    pub fn on(robot: &Robot, mut connection: Connection) -> Result<KeyposeCycler, String> {
        let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
        // Goals are where the servos are: the cycles move nothing, only the traffic counts.
        let ticks = connection
            .bus
            .read_positions(&ids)
            .map_err(|e| format!("first read: {e}"))?;
        let goals = ids.iter().copied().zip(ticks).collect();
        Ok(KeyposeCycler {
            connection,
            ids,
            goals,
        })
    }
}

impl Cycler for KeyposeCycler {
    fn cycle(&mut self) -> Result<(), String> {
        let bus: &mut dyn ServoBus = self.connection.bus.as_mut();
        bus.write_goals(&self.goals).map_err(|e| e.to_string())?;
        bus.read_positions(&self.ids).map_err(|e| e.to_string())?;
        Ok(())
    }

    fn describe(&self) -> String {
        self.connection.bus.describe()
    }

    fn write_offsets(&self) -> Option<WriteOffsets> {
        self.connection.bus.write_offsets()
    }
}

/// The `rustypot` crate on the same pseudo-terminal: its protocol handler (v1 framing for
/// Feetech STS, v2 for Dynamixel) with raw sync write and sync read.
struct RustypotCycler {
    port: Box<dyn serialport::SerialPort>,
    io: rustypot::DynamixelProtocolHandler,
    ids: Vec<u8>,
    goal_address: u8,
    present_address: u8,
    size: u8,
    goals: Vec<Vec<u8>>,
    describe: String,
}

/// The control table's goal and present position registers of `robot`'s servos, as rustypot
/// takes them (addresses below 256).
pub fn rustypot_registers(robot: &Robot) -> Result<(u8, u8, u8), String> {
    let table = robot.joints[0].servo.model.spec().table;
    let (goal, present) = (table.goal_position, table.present_position);
    let address = |a: u16| u8::try_from(a).map_err(|_| format!("address {a} beyond u8"));
    Ok((
        address(goal.address)?,
        address(present.address)?,
        present.size,
    ))
}

/// rustypot's handler for `robot`'s protocol.
pub fn rustypot_handler(robot: &Robot) -> rustypot::DynamixelProtocolHandler {
    match robot.bus.protocol {
        Protocol::Dynamixel2 => rustypot::DynamixelProtocolHandler::v2(),
        _ => rustypot::DynamixelProtocolHandler::v1(),
    }
}

impl RustypotCycler {
    fn open(robot: &Robot, path: &str) -> Result<RustypotCycler, String> {
        let port = serialport::new(path, robot.bus.baud)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|e| e.to_string())?;
        let (goal_address, present_address, size) = rustypot_registers(robot)?;
        let mut cycler = RustypotCycler {
            port,
            io: rustypot_handler(robot),
            ids: robot.joints.iter().map(|j| j.servo.id).collect(),
            goal_address,
            present_address,
            size,
            goals: Vec::new(),
            describe: format!("rustypot on {path} at {}", robot.bus.baud),
        };
        // Goals are where the servos are, as bytes read back.
        cycler.goals = cycler.read()?;
        Ok(cycler)
    }

    fn read(&mut self) -> Result<Vec<Vec<u8>>, String> {
        self.io
            .sync_read(
                self.port.as_mut(),
                &self.ids,
                self.present_address,
                self.size,
            )
            .map_err(|e| e.to_string())
    }
}

impl Cycler for RustypotCycler {
    fn cycle(&mut self) -> Result<(), String> {
        self.io
            .sync_write(
                self.port.as_mut(),
                &self.ids,
                self.goal_address,
                &self.goals,
            )
            .map_err(|e| e.to_string())?;
        self.read().map(|_| ())
    }

    fn describe(&self) -> String {
        self.describe.clone()
    }
}

/// The vendor SDK in its own Python loop (`benches/sdk_direct.py`), which times its cycles
/// itself: nothing of keypose between the loop and the SDK.
struct SdkDirect {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    describe: String,
}

/// One timed run as the script reports it.
#[derive(serde::Deserialize)]
struct ScriptRun {
    cycles: u64,
    seconds: f64,
    durations_us: Vec<f64>,
    errors: u64,
    first_error: Option<String>,
}

impl SdkDirect {
    fn open(robot: &Robot, path: &str) -> Result<SdkDirect, String> {
        let python = common::python()?;
        let table = robot.joints[0].servo.model.spec().table;
        let (goal, present) = (table.goal_position, table.present_position);
        let ids: Vec<String> = robot
            .joints
            .iter()
            .map(|j| j.servo.id.to_string())
            .collect();
        let mut child = Command::new(&python)
            .arg(common::bench_script("sdk_direct.py"))
            .arg(path)
            .arg(robot.bus.baud.to_string())
            .arg(robot.bus.protocol.name())
            .args([goal.address, u16::from(goal.size)].map(|v| v.to_string()))
            .args([present.address, u16::from(present.size)].map(|v| v.to_string()))
            .arg(ids.join(","))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("{}: {e}", python.display()))?;
        let stdin = child.stdin.take().expect("piped");
        let mut stdout = BufReader::new(child.stdout.take().expect("piped"));
        let mut ready = String::new();
        stdout.read_line(&mut ready).map_err(|e| e.to_string())?;
        let ready: serde_json::Value = serde_json::from_str(ready.trim())
            .map_err(|_| format!("sdk_direct.py did not start (said {ready:?})"))?;
        Ok(SdkDirect {
            child,
            stdin,
            stdout,
            describe: format!(
                "{} in a Python loop on {path} at {}",
                ready["sdk"].as_str().unwrap_or("?"),
                robot.bus.baud
            ),
        })
    }
}

impl Cycler for SdkDirect {
    fn cycle(&mut self) -> Result<(), String> {
        let timing = self.run_for(Duration::ZERO);
        match timing.first_error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    fn run_for(&mut self, length: Duration) -> Timing {
        let asked =
            writeln!(self.stdin, "{}", length.as_secs_f64()).and_then(|_| self.stdin.flush());
        let mut line = String::new();
        let run = asked
            .map_err(|e| e.to_string())
            .and_then(|_| self.stdout.read_line(&mut line).map_err(|e| e.to_string()))
            .and_then(|_| {
                serde_json::from_str::<ScriptRun>(line.trim())
                    .map_err(|_| format!("sdk_direct.py stopped (said {line:?})"))
            });
        match run {
            Ok(run) => Timing {
                cycles: run.cycles,
                seconds: run.seconds,
                durations: run.durations_us.iter().map(|us| us * 1e-6).collect(),
                errors: run.errors,
                first_error: run.first_error,
            },
            Err(e) => Timing {
                cycles: 1,
                seconds: length.as_secs_f64(),
                durations: Vec::new(),
                errors: 1,
                first_error: Some(e),
            },
        }
    }

    fn describe(&self) -> String {
        self.describe.clone()
    }
}

impl Drop for SdkDirect {
    fn drop(&mut self) {
        // The script ends at the end of its input.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One contender's connection with the emulated servos it talks to.
pub struct Link {
    /// Declared before the servers so the client closes the port first.
    pub cycler: Box<dyn Cycler>,
    _servers: Vec<PtyServer>,
    warmed_up: bool,
    errors: u64,
    first_error: Option<String>,
}

impl Link {
    /// `contender` on its own emulated servos of `robot`, timed as `wire` says (None: answers
    /// at once).
    fn open(robot: &Robot, contender: Contender, wire: Option<WireTiming>) -> Result<Link, String> {
        let server = PtyServer::start_timed(robot, wire).map_err(|e| e.to_string())?;
        let path = server.path();
        let cycler: Box<dyn Cycler> = match contender {
            Contender::Native => Box::new(KeyposeCycler::open(robot, path, Driver::Native)?),
            Contender::SdkBridge => Box::new(KeyposeCycler::open(robot, path, Driver::Sdk)?),
            Contender::Rustypot => Box::new(RustypotCycler::open(robot, path)?),
            Contender::SdkDirect => Box::new(SdkDirect::open(robot, path)?),
        };
        Ok(Link::of(cycler, vec![server]))
    }

    pub fn of(cycler: Box<dyn Cycler>, servers: Vec<PtyServer>) -> Link {
        Link {
            cycler,
            _servers: servers,
            warmed_up: false,
            errors: 0,
            first_error: None,
        }
    }

    /// Cycles for `length`; returns cycles per second and every successful cycle's duration.
    fn run(&mut self, length: Duration) -> (f64, Vec<f64>) {
        if !self.warmed_up {
            self.warmed_up = true;
            self.cycler.run_for(WARMUP);
        }
        let timing = self.cycler.run_for(length);
        self.errors += timing.errors;
        if self.first_error.is_none() {
            self.first_error = timing.first_error;
        }
        (timing.cycles as f64 / timing.seconds, timing.durations)
    }
}

/// `contender` on its own wire-timed emulated servos of `robot`.
pub fn open(robot: &Robot, contender: Contender) -> Result<Link, String> {
    Link::open(robot, contender, Some(WireTiming::at(robot.bus.baud)))
}

/// What a contender's runs measured, or why there are none.
pub struct DriverResult {
    /// Cycles per second of each repetition.
    pub reps: Result<Vec<f64>, String>,
    pub durations: Vec<f64>,
    pub errors: u64,
    pub first_error: Option<String>,
    pub describe: String,
}

impl DriverResult {
    /// The median and range of the cycles per second.
    pub fn rate(&self) -> Option<Spread> {
        self.reps.as_ref().ok().map(|r| Spread::of(r))
    }

    /// The median cycle, seconds.
    pub fn median_cycle(&self) -> f64 {
        common::median(&self.durations)
    }

    pub fn print(&self, label: &str) {
        match &self.reps {
            Ok(reps) => {
                let mut sorted = self.durations.clone();
                sorted.sort_by(f64::total_cmp);
                println!(
                    "  {label:<28} {} cycles/s, cycle p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs, \
                     failed cycles {}{}",
                    Spread::of(reps).show(0),
                    common::quantile(&sorted, 0.5) * 1e6,
                    common::quantile(&sorted, 0.99) * 1e6,
                    sorted.last().copied().unwrap_or(f64::NAN) * 1e6,
                    self.errors,
                    self.first_error
                        .as_ref()
                        .map(|e| format!(" (first: {e})"))
                        .unwrap_or_default(),
                );
                println!("  {:<28} {}", "", self.describe);
            }
            Err(reason) => println!("  {label:<28} unavailable: {reason}"),
        }
    }
}

/// One contender's link and what its runs measured.
pub struct Runs {
    pub link: Result<Link, String>,
    reps: Vec<f64>,
    durations: Vec<f64>,
}

impl Runs {
    pub fn of(link: Result<Link, String>) -> Runs {
        Runs {
            link,
            reps: Vec::new(),
            durations: Vec::new(),
        }
    }

    pub fn run(&mut self) {
        if let Ok(link) = self.link.as_mut() {
            let (rate, durations) = link.run(RUN);
            self.reps.push(rate);
            self.durations.extend(durations);
        }
    }

    pub fn finish(self) -> DriverResult {
        match self.link {
            Ok(link) => DriverResult {
                reps: Ok(self.reps),
                durations: self.durations,
                errors: link.errors,
                first_error: link.first_error.clone(),
                describe: link.cycler.describe(),
            },
            Err(reason) => DriverResult {
                reps: Err(reason),
                durations: Vec::new(),
                errors: 0,
                first_error: None,
                describe: String::new(),
            },
        }
    }
}

/// Every contender's runs on one robot's emulated bus.
pub struct VendorResult {
    pub robot: String,
    pub traffic: Traffic,
    /// The emulated servos' return delay, seconds.
    pub rdt: f64,
    /// In [`Contender::ALL`]'s order.
    pub results: Vec<DriverResult>,
    /// CPU steal during the timed runs.
    pub steal: String,
}

impl VendorResult {
    pub fn of(&self, contender: Contender) -> &DriverResult {
        let at = Contender::ALL
            .iter()
            .position(|&c| c == contender)
            .expect("every contender");
        &self.results[at]
    }
}

/// Every contender on `name`'s emulated servos, wire-timed or answering at once.
pub fn bus_cycles(name: &str, timed: bool) -> VendorResult {
    let robot = Robot::builtin(name).expect("a built-in robot");
    let traffic = Traffic::of(&robot);
    let wire = timed.then(|| WireTiming::at(robot.bus.baud));
    let opening = Instant::now();
    let mut runs: Vec<Runs> = Contender::ALL
        .iter()
        .map(|&c| Runs::of(Link::open(&robot, c, wire)))
        .collect();
    let open_seconds = opening.elapsed().as_secs_f64();
    if open_seconds > 10.0 {
        println!(
            "  (opening the connections took {open_seconds:.1} s: the Python environment was \
             built or checked first)"
        );
    }
    let cpu_before = super::steal::cpu_ticks();
    for _ in 0..REPS {
        for r in &mut runs {
            r.run();
        }
    }
    VendorResult {
        robot: name.to_string(),
        traffic,
        rdt: virtual_return_delay(&robot),
        results: runs.into_iter().map(Runs::finish).collect(),
        steal: super::steal::steal_since(cpu_before),
    }
}
