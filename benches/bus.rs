//! Servo-bus benchmark on the wire-timed virtual bus: emulated servos served on a
//! pseudo-terminal, reached through the same serial code as a USB adapter, answering when the
//! real wire would (bytes at the robot's baud rate, 10 bits a byte, each servo's return delay;
//! no USB latency), see docs/protocols.md §3.
//!
//! 1. Bus cycles: one sync write of 6 goal positions + one sync read of 6 present positions,
//!    per second, for so101 (Feetech STS3215 ×6) and koch (Dynamixel X ×6), through keypose's
//!    native driver, through the vendor SDK bridge (`--driver sdk`: dynamixel_sdk / scservo_sdk
//!    in a Python process spoken to in JSON lines), and through the `rustypot` crate driving the
//!    same virtual bus. The drivers alternate, [`REPS`] times each, and the median is reported,
//!    so all see the same machine load. Beside them: the wire limit of the same traffic, from
//!    the packet sizes of docs/protocols.md §3 and the servos' return delay, and each driver's
//!    share of it: 100 % is the wire's pace, the rest is software (driver, kernel pty,
//!    emulator thread).
//! 2. Player lateness: the player streams a 10 s cubic on so101's shoulder_pan to the
//!    wire-timed virtual bus with the native driver at 100 Hz and 500 Hz; from
//!    `Stats.pacing.lateness` (each cycle's start against its absolute deadline) come p50, p99
//!    and max, and the achieved mean period. The approach ramp (≥ 0.5 s) that precedes the
//!    sequence is included. At 500 Hz the run is made with a read-back every cycle and with one
//!    every 5th cycle.
//! 3. Software cost: CPU time per cycle of the native driver's encode + decode (sync write of 6
//!    goals, sync read of 6 positions) over an in-memory transport that answers with canned
//!    status packets at once: no I/O, no emulator.
//! 4. Two arms: a cell of two so101 arms, each on its own wire-timed pseudo-terminal, through
//!    the cell's bus (each arm's transactions on its own thread, goal writes released
//!    together), against one arm on one bus in the same run: cycles per second and their ratio
//!    (1 when the buses run side by side, 0.5 when one waits for the other), and how far apart
//!    the two buses started each goal write.
//!
//! `cargo bench --bench bus` prints a compact table on lines starting with `summary:`. Nothing is
//! asserted about timing. The SDK bridge needs python3 (3.11+, with venv) and PyPI the first
//! time: its environment is built in `target/tmp/bench_bus_cache` unless `KEYPOSE_CACHE` or
//! `KEYPOSE_PYTHON` is set. Without it the SDK figures say why they are missing.

use keypose::bus::{connect, connect_cell, BusOptions, Connection, Driver, ServoBus, WriteOffsets};
use keypose::plan::Trajectory;
use keypose::player::{play, Outcome, PlayOptions, StopSignal};
use keypose::robot::{Protocol, Robot};
use keypose::sequence::Sequence;
use keypose::testing::{PtyServer, WireTiming};
use std::time::{Duration, Instant};

/// Interleaved repetitions of each driver's timing; the median is reported.
const REPS: usize = 3;
/// Length of one timed run of bus cycles.
const RUN: Duration = Duration::from_secs(2);
/// Untimed cycles before the first run of each connection.
const WARMUP: Duration = Duration::from_millis(300);
/// Robots of the bus-cycle comparison, one per vendor.
const ROBOTS: [&str; 2] = ["so101", "koch"];

// ---------------------------------------------------------------------------------------------
// Wire-time budget, docs/protocols.md §3 ("Wire-time budget (6 servos, 8N1 = 10 bits per byte)").
// No byte stuffing, no firmware time, no USB latency; the return delay time (RDT) is paid once
// per answering servo.

const SERVOS: usize = 6;

/// Packet sizes in bytes for a 6-servo sync write + sync read of positions (§3 table).
struct Traffic {
    name: &'static str,
    sync_write: usize,
    sync_read_instruction: usize,
    status_each: usize,
    /// The robot's baud rate.
    wire: WireTiming,
}

impl Traffic {
    fn of(robot: &Robot) -> Traffic {
        let wire = WireTiming::at(robot.bus.baud);
        match robot.bus.protocol {
            Protocol::Dynamixel2 => Traffic {
                name: "DXL",
                // Sync Write, Goal Position (4 B) ×6: 8 + 4 + 6·5 + 2 = 44.
                sync_write: 8 + 4 + SERVOS * 5 + 2,
                // Sync Read instruction, 6 IDs: 8 + 4 + 6 + 2 = 20.
                sync_read_instruction: 8 + 4 + SERVOS + 2,
                // Status packet with 4 data bytes: 15 (×6 = 90).
                status_each: 15,
                wire,
            },
            _ => Traffic {
                name: "STS",
                // Sync Write, Goal Position (2 B) ×6: 2+1+1+1+2 + 6·3 + 1 = 26.
                sync_write: 2 + 1 + 1 + 1 + 2 + SERVOS * 3 + 1,
                // Sync Read instruction, 6 IDs: 2+1+1+1+2 + 6 + 1 = 14.
                sync_read_instruction: 2 + 1 + 1 + 1 + 2 + SERVOS + 1,
                // Status packet with 2 data bytes: 8 (×6 = 48).
                status_each: 8,
                wire,
            },
        }
    }

    fn bytes(&self) -> usize {
        self.sync_write + self.sync_read_instruction + SERVOS * self.status_each
    }

    /// Wire time of one cycle, seconds, with the return delay `rdt` per servo.
    fn cycle_seconds(&self, rdt: f64) -> f64 {
        self.wire.bytes_time(self.bytes()).as_secs_f64() + SERVOS as f64 * rdt
    }

    /// The most cycles per second the wire allows (§3: DXL ≤ 650 Hz at RDT 0, ≤ 220 Hz at
    /// RDT 500 µs; STS ≤ 1140 Hz at RDT 0 — §3 rounds to 2–3 digits).
    fn limit_hz(&self, rdt: f64) -> f64 {
        1.0 / self.cycle_seconds(rdt)
    }
}

/// The return delay the emulated servos of `robot` apply (the same for all, seconds).
fn virtual_return_delay(robot: &Robot) -> f64 {
    let servos = keypose::testing::VirtualServos::for_robot(robot);
    let first = robot.joints[0].servo.id;
    servos.return_delay(first).map_or(0.0, |d| d.as_secs_f64())
}

// ---------------------------------------------------------------------------------------------
// Small statistics.

fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
    }
}

/// Nearest-rank quantile of already sorted values.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Cumulative (total, steal) CPU time from the first line of /proc/stat, in clock ticks.
/// Steal is time the hypervisor gave this machine's CPUs to someone else: on a shared virtual
/// machine it is what turns a 100 µs bus cycle into a 10 ms one now and then.
fn cpu_ticks() -> Option<(u64, u64)> {
    let text = std::fs::read_to_string("/proc/stat").ok()?;
    let fields: Vec<u64> = text
        .lines()
        .next()?
        .split_whitespace()
        .skip(1)
        .filter_map(|f| f.parse().ok())
        .collect();
    // user nice system idle iowait irq softirq steal (guest time is already inside user).
    let total = fields.iter().take(8).sum();
    Some((total, *fields.get(7)?))
}

/// Steal as a share of all CPU time since `since`, as text ("12 %", or "?" without /proc).
fn steal_since(since: Option<(u64, u64)>) -> String {
    match (since, cpu_ticks()) {
        (Some((total0, steal0)), Some((total1, steal1))) if total1 > total0 => format!(
            "{:.0} %",
            100.0 * (steal1 - steal0) as f64 / (total1 - total0) as f64
        ),
        _ => "?".into(),
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|text| {
            text.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|_| "unknown".into())
}

// ---------------------------------------------------------------------------------------------
// 1. Bus cycles.

/// Which code drives the bus.
#[derive(Clone, Copy, PartialEq)]
enum Contender {
    Keypose(Driver),
    Rustypot,
}

/// One bus cycle (sync write of the goals, sync read of the positions) by one driver.
trait Cycler {
    fn cycle(&mut self) -> Result<(), String>;
    fn describe(&self) -> String;
    /// How far apart a cell's buses started their goal writes (None on one bus).
    fn write_offsets(&self) -> Option<WriteOffsets> {
        None
    }
}

/// keypose's native driver or the SDK bridge, through [`connect`].
struct KeyposeCycler {
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
    fn on(robot: &Robot, mut connection: Connection) -> Result<KeyposeCycler, String> {
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

/// The `rustypot` crate (Pollen Robotics) on the same pseudo-terminal: its protocol handler
/// (v1 framing for Feetech STS, v2 for Dynamixel) with raw sync write and sync read.
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

impl RustypotCycler {
    fn open(robot: &Robot, path: &str) -> Result<RustypotCycler, String> {
        let port = serialport::new(path, robot.bus.baud)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|e| e.to_string())?;
        let table = robot.joints[0].servo.model.spec().table;
        let (goal, present) = (table.goal_position, table.present_position);
        let io = match robot.bus.protocol {
            Protocol::Dynamixel2 => rustypot::DynamixelProtocolHandler::v2(),
            _ => rustypot::DynamixelProtocolHandler::v1(),
        };
        let address = |a: u16| u8::try_from(a).map_err(|_| format!("address {a} beyond u8"));
        let mut cycler = RustypotCycler {
            port,
            io,
            ids: robot.joints.iter().map(|j| j.servo.id).collect(),
            goal_address: address(goal.address)?,
            present_address: address(present.address)?,
            size: present.size,
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

/// One driver's connection with the virtual servos it talks to.
struct Link {
    /// Declared before the servers so the client closes the port first.
    cycler: Box<dyn Cycler>,
    _servers: Vec<PtyServer>,
    warmed_up: bool,
    errors: u64,
    first_error: Option<String>,
}

impl Link {
    fn open(robot: &Robot, contender: Contender) -> Result<Link, String> {
        let server = PtyServer::start(robot).map_err(|e| e.to_string())?;
        let cycler: Box<dyn Cycler> = match contender {
            Contender::Keypose(driver) => {
                Box::new(KeyposeCycler::open(robot, server.path(), driver)?)
            }
            Contender::Rustypot => Box::new(RustypotCycler::open(robot, server.path())?),
        };
        Ok(Link::of(cycler, vec![server]))
    }

    fn of(cycler: Box<dyn Cycler>, servers: Vec<PtyServer>) -> Link {
        Link {
            cycler,
            _servers: servers,
            warmed_up: false,
            errors: 0,
            first_error: None,
        }
    }

    /// A cell of `cell`'s arms, each arm's emulated servos on a wire-timed pseudo-terminal of
    /// their own, through [`CellBus`](keypose::bus::CellBus) and the native driver.
    fn cell(cell: &Robot) -> Result<Link, String> {
        let servers = cell
            .arms
            .iter()
            .map(|arm| PtyServer::start(&arm.robot).map_err(|e| e.to_string()))
            .collect::<Result<Vec<_>, _>>()?;
        let paths: Vec<&str> = servers.iter().map(|s| s.path()).collect();
        let connection =
            connect_cell(cell, &paths, &BusOptions::default()).map_err(|e| e.to_string())?;
        let cycler = KeyposeCycler::on(cell, connection)?;
        Ok(Link::of(Box::new(cycler), servers))
    }

    /// Cycles for `length`; returns cycles per second and every successful cycle's duration.
    fn run(&mut self, length: Duration) -> (f64, Vec<f64>) {
        if !self.warmed_up {
            self.warmed_up = true;
            let _ = self.run(WARMUP);
            self.errors = 0;
            self.first_error = None;
        }
        let mut durations = Vec::new();
        let start = Instant::now();
        let mut cycles = 0u64;
        loop {
            let before = Instant::now();
            match self.cycler.cycle() {
                Ok(()) => durations.push(before.elapsed().as_secs_f64()),
                Err(e) => {
                    self.errors += 1;
                    self.first_error.get_or_insert(e);
                }
            }
            cycles += 1;
            let elapsed = start.elapsed();
            if elapsed >= length {
                return (cycles as f64 / elapsed.as_secs_f64(), durations);
            }
        }
    }
}

struct DriverResult {
    /// Median cycles per second over the repetitions, or why there is none.
    rate: Result<f64, String>,
    reps: Vec<f64>,
    durations: Vec<f64>,
    errors: u64,
    first_error: Option<String>,
    describe: String,
}

impl DriverResult {
    fn missing(reason: String) -> DriverResult {
        DriverResult {
            rate: Err(reason),
            reps: Vec::new(),
            durations: Vec::new(),
            errors: 0,
            first_error: None,
            describe: String::new(),
        }
    }

    fn print(&self, label: &str) {
        match &self.rate {
            Ok(rate) => {
                let mut sorted = self.durations.clone();
                sorted.sort_by(f64::total_cmp);
                let reps: Vec<String> = self.reps.iter().map(|r| format!("{r:.0}")).collect();
                println!(
                    "  {label:<6} {rate:>8.0} cycles/s (runs: {}), cycle p50 {:.1} µs, p99 {:.1} µs, \
                     max {:.1} µs, failed cycles {}{}",
                    reps.join(", "),
                    quantile(&sorted, 0.5) * 1e6,
                    quantile(&sorted, 0.99) * 1e6,
                    sorted.last().copied().unwrap_or(f64::NAN) * 1e6,
                    self.errors,
                    self.first_error
                        .as_ref()
                        .map(|e| format!(" (first: {e})"))
                        .unwrap_or_default(),
                );
                println!("         {}", self.describe);
            }
            Err(reason) => println!("  {label:<6} unavailable: {reason}"),
        }
    }
}

struct VendorResult {
    robot: String,
    traffic: Traffic,
    /// The emulated servos' return delay, seconds.
    rdt: f64,
    native: DriverResult,
    sdk: DriverResult,
    rustypot: DriverResult,
    /// CPU steal during the timed runs.
    steal: String,
}

/// One contender's link and what its runs measured.
struct Runs {
    link: Result<Link, String>,
    reps: Vec<f64>,
    durations: Vec<f64>,
}

impl Runs {
    fn run(&mut self) {
        if let Ok(link) = self.link.as_mut() {
            let (rate, durations) = link.run(RUN);
            self.reps.push(rate);
            self.durations.extend(durations);
        }
    }

    fn finish(self) -> DriverResult {
        match self.link {
            Ok(link) => DriverResult {
                rate: Ok(median(&self.reps)),
                reps: self.reps,
                durations: self.durations,
                errors: link.errors,
                first_error: link.first_error.clone(),
                describe: link.cycler.describe(),
            },
            Err(reason) => DriverResult::missing(reason),
        }
    }
}

fn bus_cycles(name: &str) -> VendorResult {
    let robot = Robot::builtin(name).expect("a built-in robot");
    let traffic = Traffic::of(&robot);
    let open = |contender| Runs {
        link: Link::open(&robot, contender),
        reps: Vec::new(),
        durations: Vec::new(),
    };
    let mut native = open(Contender::Keypose(Driver::Native));
    let opening = Instant::now();
    let mut sdk = open(Contender::Keypose(Driver::Sdk));
    let sdk_open_seconds = opening.elapsed().as_secs_f64();
    if sdk_open_seconds > 2.0 {
        println!(
            "  (opening the SDK bridge took {sdk_open_seconds:.1} s: its Python environment \
             was built or checked first)"
        );
    }
    let mut rustypot = open(Contender::Rustypot);
    let cpu_before = cpu_ticks();
    for _ in 0..REPS {
        native.run();
        sdk.run();
        rustypot.run();
    }
    VendorResult {
        robot: name.to_string(),
        traffic,
        rdt: virtual_return_delay(&robot),
        native: native.finish(),
        sdk: sdk.finish(),
        rustypot: rustypot.finish(),
        steal: steal_since(cpu_before),
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Software cost without I/O.

/// Answers the driver's sync read at once with canned status packets (encoded once, up front,
/// handed over as one chunk) and its sync write with nothing: the driver's own encoding and
/// decoding is nearly all that runs.
struct Canned {
    answers: Vec<u8>,
    /// The driver writes the sync write, then the sync read: every second write is answered.
    writes: u64,
}

impl keypose::testing::Responder for Canned {
    fn respond(&mut self, _written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        self.writes += 1;
        if self.writes % 2 == 1 {
            return Vec::new();
        }
        vec![(Duration::ZERO, self.answers.clone())]
    }
}

/// CPU time of this thread, seconds.
fn thread_cpu_seconds() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// CPU microseconds per cycle (sync write of 6 goals + sync read of 6 positions) of the native
/// driver over [`Canned`], median of 5 runs of 20 000 cycles.
fn software_cost(name: &str) -> Result<f64, String> {
    use keypose::bus::protocol::codec;
    let robot = Robot::builtin(name).ok_or_else(|| format!("no built-in robot {name}"))?;
    let framing = codec(robot.bus.protocol).framing();
    let table = robot.joints[0].servo.model.spec().table;
    let size = usize::from(table.present_position.size);
    // Each servo answers with its position at 2048 ticks (any value decodes the same way).
    let answers = robot
        .joints
        .iter()
        .map(|j| {
            let data = table
                .encode(&table.present_position, 2048)
                .map_err(|e| e.to_string())?;
            debug_assert_eq!(data.len(), size);
            framing
                .try_encode_status(j.servo.id, 0, &data)
                .map_err(|e| e.to_string())
        })
        .collect::<Result<Vec<_>, String>>()?;
    let transport = keypose::testing::MemoryTransport::new(Canned {
        answers: answers.concat(),
        writes: 0,
    });
    let servos = robot.servos();
    let mut bus = keypose::bus::NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let goals: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 2048)).collect();
    let mut cycle = || -> Result<(), String> {
        bus.write_goals(&goals).map_err(|e| e.to_string())?;
        bus.read_positions(&ids).map_err(|e| e.to_string())?;
        Ok(())
    };
    for _ in 0..2000 {
        cycle()?;
    }
    const CYCLES: usize = 20_000;
    let mut runs = Vec::new();
    for _ in 0..5 {
        let before = thread_cpu_seconds();
        for _ in 0..CYCLES {
            cycle()?;
        }
        runs.push((thread_cpu_seconds() - before) / CYCLES as f64 * 1e6);
    }
    Ok(median(&runs))
}

// ---------------------------------------------------------------------------------------------
// 2. Player jitter.

/// A slow cubic on one joint, 10 s long, well inside so101's limits (±110°, 115°/s): 0 → 30°
/// → 0 on shoulder_pan. The arm starts at home (0), so the approach ramp is the minimum 0.5 s.
const SLOW_PAN: &str = r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic",
  "keyframes":[{"time":0,"joints":{"shoulder_pan":0}},{"time":5,"joints":{"shoulder_pan":30}},
  {"time":10,"joints":{"shoulder_pan":0}}]}"#;

struct JitterResult {
    label: String,
    outcome: Result<JitterFigures, String>,
}

struct JitterFigures {
    rate_hz: f64,
    cycles: u64,
    approach_seconds: f64,
    p50_ms: f64,
    p99_ms: f64,
    max_ms: f64,
    mean_period_ms: f64,
    /// Cycles that started more than one period late.
    late_by_a_period: usize,
    /// Largest lateness of a cycle that follows a health read, and of the others (ms).
    max_after_health_ms: f64,
    max_after_other_ms: f64,
    wall_seconds: f64,
    /// CPU steal during the playback.
    steal: String,
}

fn jitter(rate_hz: f64, readback_every: u32) -> JitterResult {
    let label = format!("{rate_hz:.0} Hz, read-back every {readback_every}");
    let outcome = (|| {
        let robot = Robot::builtin("so101").expect("so101 is built in");
        let sequence = Sequence::from_json("slow_pan.json", SLOW_PAN).map_err(|e| e.to_string())?;
        let trajectory = Trajectory::build(&sequence, &robot).map_err(|e| e.to_string())?;
        let server = PtyServer::start(&robot).map_err(|e| e.to_string())?;
        let mut connection =
            connect(&robot, server.path(), Driver::Native, None).map_err(|e| e.to_string())?;
        let mut options = PlayOptions::new(rate_hz);
        options.progress = false;
        options.readback_every = Some(readback_every);
        let started = Instant::now();
        let cpu_before = cpu_ticks();
        let (outcome, stats) = play(
            connection.bus.as_mut(),
            &robot,
            &trajectory,
            &options,
            &StopSignal::default(),
        )
        .map_err(|e| format!("playback failed: {e}"))?;
        let wall_seconds = started.elapsed().as_secs_f64();
        let steal = steal_since(cpu_before);
        drop(connection);
        drop(server);
        if outcome != Outcome::Finished {
            return Err(format!("playback ended {outcome:?}"));
        }
        let late = &stats.pacing.lateness;
        if late.len() < 2 {
            return Err("fewer than two cycles".into());
        }
        let period = 1.0 / rate_hz;
        // Cycle k started at k·period + late[k] (the last entry is the start of the check that
        // found the sequence over), so the achieved mean period follows from the first and last.
        let mean_period = period + (late[late.len() - 1] - late[0]) / (late.len() - 1) as f64;
        let mut sorted = late.clone();
        sorted.sort_by(f64::total_cmp);
        // The player reads health on cycles k > 0 with k % health_every == 0; its cost shows in
        // the lateness of cycle k + 1.
        let health_every = options.health_every as usize;
        let (mut after_health, mut after_other) = (0.0f64, 0.0f64);
        for (k, &l) in late.iter().enumerate().skip(1) {
            if (k - 1) > 0 && (k - 1) % health_every == 0 {
                after_health = after_health.max(l);
            } else {
                after_other = after_other.max(l);
            }
        }
        Ok(JitterFigures {
            rate_hz,
            cycles: stats.cycles,
            approach_seconds: stats.approach_seconds,
            p50_ms: quantile(&sorted, 0.5) * 1e3,
            p99_ms: quantile(&sorted, 0.99) * 1e3,
            max_ms: sorted[sorted.len() - 1] * 1e3,
            mean_period_ms: mean_period * 1e3,
            late_by_a_period: late.iter().filter(|&&l| l > period).count(),
            max_after_health_ms: after_health * 1e3,
            max_after_other_ms: after_other * 1e3,
            wall_seconds,
            steal,
        })
    })();
    JitterResult { label, outcome }
}

// ---------------------------------------------------------------------------------------------

/// Two SO-101 arms on two wire-timed buses through the cell's bus, against one arm on one bus,
/// interleaved: the cell's cycles per second over one bus's (1: the two buses' transactions ran
/// side by side; 0.5: one after the other), and the goal writes' offsets.
struct CellResult {
    one: DriverResult,
    cell: DriverResult,
    offsets: Option<WriteOffsets>,
}

fn cell_cycles() -> CellResult {
    let so101 = Robot::builtin("so101").expect("a built-in robot");
    let arm = |name: &str, y: f64| {
        let base = keypose::pose::RigidTransform::new(
            glam::DVec3::new(0.0, y, 0.0),
            glam::DQuat::IDENTITY,
        );
        (name.to_string(), so101.clone(), base)
    };
    let cell = Robot::cell(vec![arm("left", 0.25), arm("right", -0.25)]).expect("two arms");
    let mut one = Runs {
        link: Link::open(&so101, Contender::Keypose(Driver::Native)),
        reps: Vec::new(),
        durations: Vec::new(),
    };
    let mut two = Runs {
        link: Link::cell(&cell),
        reps: Vec::new(),
        durations: Vec::new(),
    };
    for _ in 0..REPS {
        one.run();
        two.run();
    }
    let offsets = two
        .link
        .as_ref()
        .ok()
        .and_then(|l| l.cycler.write_offsets());
    CellResult {
        one: one.finish(),
        cell: two.finish(),
        offsets,
    }
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` runs this too: keep that quick.
    let args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--bench") {
        println!("bus benchmark: run with `cargo bench --bench bus`");
        return;
    }
    if std::env::var_os("KEYPOSE_CACHE").is_none() && std::env::var_os("KEYPOSE_PYTHON").is_none() {
        // Before any thread exists. The tests keep their environment under target/ too.
        std::env::set_var(
            "KEYPOSE_CACHE",
            std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench_bus_cache"),
        );
    }
    let bench_start = Instant::now();
    let load_before = load_average();
    println!("bus benchmark: load average at start {load_before}");
    println!(
        "virtual bus = emulated servos on a pseudo-terminal, wire-timed: answers come when the \
         wire would deliver them (bytes at the robot's baud rate, return delays, no USB \
         latency). A driver's share of the wire limit is wire time / its cycle time; the rest \
         is software (driver + pty + emulator; for the SDK also the Python bridge and its \
         JSON-lines pipe)."
    );

    println!("\n1. sync write (6 goals) + sync read (6 positions), {REPS}× {RUN:?} per driver, interleaved, median:");
    let mut vendors = Vec::new();
    for name in ROBOTS {
        println!("{name}:");
        let result = bus_cycles(name);
        result.native.print("native");
        result.sdk.print("sdk");
        result.rustypot.print("rustypot");
        let t = &result.traffic;
        println!(
            "  wire at {} baud: {} B/cycle ({} write + {} read instruction + 6×{} status) + 6 × \
             RDT {:.0} µs → {:.0} µs ≤ {:.0} Hz",
            t.wire.baud,
            t.bytes(),
            t.sync_write,
            t.sync_read_instruction,
            t.status_each,
            result.rdt * 1e6,
            t.cycle_seconds(result.rdt) * 1e6,
            t.limit_hz(result.rdt).floor(),
        );
        println!("  CPU steal during the timed runs: {}", result.steal);
        vendors.push(result);
    }

    println!(
        "\n2. player on so101, native driver, 10 s cubic on shoulder_pan after the approach ramp:"
    );
    let runs = [jitter(100.0, 1), jitter(500.0, 1), jitter(500.0, 5)];
    for run in &runs {
        match &run.outcome {
            Ok(f) => println!(
                "  {:<26} {} cycles (approach {:.2} s) in {:.2} s wall; lateness p50 {:.3} ms, \
                 p99 {:.3} ms, max {:.3} ms; mean period {:.4} ms (nominal {:.4}); {} cycles \
                 started > 1 period late; max lateness after a health-read cycle {:.3} ms, after \
                 other cycles {:.3} ms; CPU steal {}",
                run.label,
                f.cycles,
                f.approach_seconds,
                f.wall_seconds,
                f.p50_ms,
                f.p99_ms,
                f.max_ms,
                f.mean_period_ms,
                1e3 / f.rate_hz,
                f.late_by_a_period,
                f.max_after_health_ms,
                f.max_after_other_ms,
                f.steal,
            ),
            Err(reason) => println!("  {:<26} failed: {reason}", run.label),
        }
    }

    println!("\n3. CPU time per cycle of the native driver's encode + decode, no I/O (median of 5 × 20 000 cycles):");
    let costs: Vec<(&str, Result<f64, String>)> = ROBOTS
        .iter()
        .map(|&name| (name, software_cost(name)))
        .collect();
    for (name, cost) in &costs {
        match cost {
            Ok(us) => println!("  {name}: {us:.2} µs"),
            Err(e) => println!("  {name}: failed: {e}"),
        }
    }

    println!("\n4. two so101 arms, each on its own wire-timed bus, through the cell's bus (12 goals + 12 positions a cycle), against one arm on one bus, {REPS}× {RUN:?} each, interleaved, median:");
    let cells = cell_cycles();
    cells.one.print("1 arm");
    cells.cell.print("2 arms");
    let cell_ratio = match (&cells.one.rate, &cells.cell.rate) {
        (Ok(one), Ok(two)) => Some(two / one),
        _ => None,
    };
    if let Some(ratio) = cell_ratio {
        println!(
            "  two arms' cycles/s over one arm's: {ratio:.2} (1: the buses ran side by side; 0.5: one after the other)"
        );
    }
    if let Some(o) = &cells.offsets {
        println!(
            "  goal writes apart by: median {:.0} µs, p99 {:.0} µs, max {:.0} µs over {} cycles",
            o.median.as_secs_f64() * 1e6,
            o.p99.as_secs_f64() * 1e6,
            o.max.as_secs_f64() * 1e6,
            o.cycles
        );
    }

    let load_after = load_average();
    println!(
        "\nload average at start {load_before}, at end {load_after}; bench took {:.1} s",
        bench_start.elapsed().as_secs_f64()
    );

    // The table for the README.
    println!();
    println!(
        "summary: | wire-timed virtual bus (pty, 6 servos) | wire limit | native cycles/s (share \
         of the limit; median cycle, wire share of it) | rustypot | SDK | CPU steal |"
    );
    println!("summary: |---|---|---|---|---|---|");
    for v in &vendors {
        let limit = v.traffic.limit_hz(v.rdt);
        let wire = v.traffic.cycle_seconds(v.rdt);
        // Cycles/s as a share of the limit (what a run achieved, tail latencies included), and
        // the wire time as a share of the median cycle (the cost of a typical cycle).
        let rate = |d: &DriverResult| match &d.rate {
            Ok(rate) => {
                let mut sorted = d.durations.clone();
                sorted.sort_by(f64::total_cmp);
                format!(
                    "{rate:.0} ({:.1} %; median cycle {:.0} µs, {:.1} %)",
                    100.0 * rate / limit,
                    quantile(&sorted, 0.5) * 1e6,
                    100.0 * wire / quantile(&sorted, 0.5)
                )
            }
            Err(_) => "n/a".into(),
        };
        println!(
            "summary: | {} ({} at {} baud, RDT {:.0} µs) | ≤ {:.0} Hz | {} | {} | {} | {} |",
            v.robot,
            v.traffic.name,
            v.traffic.wire.baud,
            v.rdt * 1e6,
            limit.floor(),
            rate(&v.native),
            rate(&v.rustypot),
            rate(&v.sdk),
            v.steal,
        );
    }
    println!("summary: ");
    for (name, cost) in &costs {
        if let Ok(us) = cost {
            println!("summary: encode + decode, native driver, {name}: {us:.2} µs CPU per cycle");
        }
    }
    println!("summary: ");
    println!(
        "summary: | player, so101, native, wire-timed pty | cycles | lateness p50 | p99 | max | mean period \
         | cycles > 1 period late | CPU steal |"
    );
    println!("summary: |---|---|---|---|---|---|---|---|");
    for run in &runs {
        match &run.outcome {
            Ok(f) => println!(
                "summary: | {} | {} | {:.3} ms | {:.3} ms | {:.3} ms | {:.4} ms | {} | {} |",
                run.label,
                f.cycles,
                f.p50_ms,
                f.p99_ms,
                f.max_ms,
                f.mean_period_ms,
                f.late_by_a_period,
                f.steal
            ),
            Err(reason) => println!("summary: | {} | failed: {reason} | | | | | | |", run.label),
        }
    }
    if let (Some(ratio), Ok(one), Ok(two)) = (cell_ratio, &cells.one.rate, &cells.cell.rate) {
        println!("summary: ");
        println!(
            "summary: two so101 arms on two wire-timed buses through the cell's bus: {two:.0} cycles/s, \
             one arm on one bus {one:.0} cycles/s: ratio {ratio:.2}{}",
            cells
                .offsets
                .map(|o| format!(
                    "; goal writes apart by median {:.0} µs, p99 {:.0} µs, max {:.0} µs",
                    o.median.as_secs_f64() * 1e6,
                    o.p99.as_secs_f64() * 1e6,
                    o.max.as_secs_f64() * 1e6
                ))
                .unwrap_or_default()
        );
    }
    println!(
        "summary: the virtual bus takes the wire's time at the robot's baud rate with the \
         servos' return delay; 100 % of the limit is the wire's own pace. Player cycles include \
         the ≥ 0.5 s approach ramp. Load average {load_before} → {load_after}."
    );
}
