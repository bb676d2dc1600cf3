//! Servo-bus benchmark on the virtual bus: emulated servos served on a pseudo-terminal, reached
//! through the same serial code as a USB adapter.
//!
//! 1. Bus cycles: one sync write of 6 goal positions + one sync read of 6 present positions,
//!    per second, through keypose's native driver and through the vendor SDK bridge
//!    (`--driver sdk`: dynamixel_sdk / scservo_sdk in a Python process spoken to in JSON lines),
//!    for so101 (Feetech STS3215 ×6) and koch (Dynamixel X ×6). Native and SDK runs alternate,
//!    [`REPS`] times each, and the median is reported, so both see the same machine load. Beside
//!    them: the wire-time limit of the same traffic at 1 Mbps, computed from the packet sizes of
//!    docs/protocols.md §3. The pseudo-terminal has no baud rate and the virtual servos
//!    answer with no return delay, so the virtual figures measure software overhead only
//!    (driver, kernel pty, the emulator thread, and for the SDK the Python bridge and its pipe).
//! 2. Player jitter: the player streams a 10 s cubic on so101's shoulder_pan to the virtual bus
//!    with the native driver at 100 Hz and 500 Hz; from `Stats.pacing.lateness` (each cycle's start
//!    against its absolute deadline) come p50, p99 and max, and the achieved mean period. The
//!    approach ramp (≥ 0.5 s) that precedes the sequence is included. At 500 Hz the run is made
//!    with a read-back every cycle and with one every 5th cycle.
//!
//! `cargo bench --bench bus` prints a compact table on lines starting with `summary:`. Nothing is
//! asserted about timing. The SDK bridge needs python3 (3.11+, with venv) and PyPI the first
//! time: its environment is built in `target/tmp/bench_bus_cache` unless `KEYPOSE_CACHE` or
//! `KEYPOSE_PYTHON` is set. Without it the SDK figures say why they are missing.

use keypose::bus::virtual_bus::PtyServer;
use keypose::bus::{connect, BusError, Connection, Driver, ServoBus};
use keypose::plan::Trajectory;
use keypose::player::{play, Outcome, PlayOptions, StopSignal};
use keypose::robot::{Protocol, Robot};
use keypose::sequence::Sequence;
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

/// 8N1: 10 bits per byte; at 1 Mbps one byte takes 10 µs.
const BITS_PER_BYTE: f64 = 10.0;
const BAUD: f64 = 1_000_000.0;
const SERVOS: usize = 6;

/// Packet sizes in bytes for a 6-servo sync write + sync read of positions (§3 table).
struct Traffic {
    name: &'static str,
    sync_write: usize,
    sync_read_instruction: usize,
    status_each: usize,
}

impl Traffic {
    fn of(protocol: Protocol) -> Traffic {
        match protocol {
            Protocol::Dynamixel2 => Traffic {
                name: "DXL",
                // Sync Write, Goal Position (4 B) ×6: 8 + 4 + 6·5 + 2 = 44.
                sync_write: 8 + 4 + SERVOS * 5 + 2,
                // Sync Read instruction, 6 IDs: 8 + 4 + 6 + 2 = 20.
                sync_read_instruction: 8 + 4 + SERVOS + 2,
                // Status packet with 4 data bytes: 15 (×6 = 90).
                status_each: 15,
            },
            _ => Traffic {
                name: "STS",
                // Sync Write, Goal Position (2 B) ×6: 2+1+1+1+2 + 6·3 + 1 = 26.
                sync_write: 2 + 1 + 1 + 1 + 2 + SERVOS * 3 + 1,
                // Sync Read instruction, 6 IDs: 2+1+1+1+2 + 6 + 1 = 14.
                sync_read_instruction: 2 + 1 + 1 + 1 + 2 + SERVOS + 1,
                // Status packet with 2 data bytes: 8 (×6 = 48).
                status_each: 8,
            },
        }
    }

    fn bytes(&self) -> usize {
        self.sync_write + self.sync_read_instruction + SERVOS * self.status_each
    }

    /// Wire time of one cycle at 1 Mbps, seconds, with the return delay `rdt` per servo.
    fn cycle_seconds(&self, rdt: f64) -> f64 {
        self.bytes() as f64 * BITS_PER_BYTE / BAUD + SERVOS as f64 * rdt
    }

    /// The most cycles per second the wire allows (§3: DXL ≤ 650 Hz at RDT 0, ≤ 220 Hz at
    /// RDT 500 µs; STS ≤ 1140 Hz at RDT 0, ≤ 258 Hz at RDT 500 µs — §3 rounds to 2–3 digits).
    fn limit_hz(&self, rdt: f64) -> f64 {
        1.0 / self.cycle_seconds(rdt)
    }
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

/// One driver's connection with the virtual servos it talks to.
struct Link {
    /// Declared before the server so the client closes the port first.
    connection: Connection,
    _server: PtyServer,
    ids: Vec<u8>,
    goals: Vec<(u8, i64)>,
    warmed_up: bool,
    errors: u64,
    first_error: Option<String>,
}

impl Link {
    fn open(robot: &Robot, driver: Driver) -> Result<Link, String> {
        let server = PtyServer::start(robot).map_err(|e| e.to_string())?;
        let mut connection =
            connect(robot, server.path(), driver, None).map_err(|e| e.to_string())?;
        let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
        // Goals are where the servos are: the cycles move nothing, only the traffic counts.
        let ticks = connection
            .bus
            .read_positions(&ids)
            .map_err(|e| format!("first read: {e}"))?;
        let goals = ids.iter().copied().zip(ticks).collect();
        Ok(Link {
            connection,
            _server: server,
            ids,
            goals,
            warmed_up: false,
            errors: 0,
            first_error: None,
        })
    }

    fn cycle(&mut self) -> Result<(), BusError> {
        let bus: &mut dyn ServoBus = self.connection.bus.as_mut();
        bus.write_goals(&self.goals)?;
        bus.read_positions(&self.ids)?;
        Ok(())
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
            match self.cycle() {
                Ok(()) => durations.push(before.elapsed().as_secs_f64()),
                Err(e) => {
                    self.errors += 1;
                    self.first_error.get_or_insert_with(|| e.to_string());
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
    native: DriverResult,
    sdk: DriverResult,
    /// CPU steal during the timed runs.
    steal: String,
}

fn bus_cycles(name: &str) -> VendorResult {
    let robot = Robot::builtin(name).expect("a built-in robot");
    let traffic = Traffic::of(robot.bus.protocol);
    let mut native = Link::open(&robot, Driver::Native);
    let opening = Instant::now();
    let mut sdk = Link::open(&robot, Driver::Sdk);
    let sdk_open_seconds = opening.elapsed().as_secs_f64();
    if sdk_open_seconds > 2.0 {
        println!(
            "  (opening the SDK bridge took {sdk_open_seconds:.1} s: its Python environment \
             was built or checked first)"
        );
    }
    let mut native_reps = Vec::new();
    let mut sdk_reps = Vec::new();
    let mut native_durations = Vec::new();
    let mut sdk_durations = Vec::new();
    let cpu_before = cpu_ticks();
    for _ in 0..REPS {
        if let Ok(link) = native.as_mut() {
            let (rate, durations) = link.run(RUN);
            native_reps.push(rate);
            native_durations.extend(durations);
        }
        if let Ok(link) = sdk.as_mut() {
            let (rate, durations) = link.run(RUN);
            sdk_reps.push(rate);
            sdk_durations.extend(durations);
        }
    }
    let finish = |link: Result<Link, String>, reps: Vec<f64>, durations: Vec<f64>| match link {
        Ok(link) => DriverResult {
            rate: Ok(median(&reps)),
            reps,
            durations,
            errors: link.errors,
            first_error: link.first_error.clone(),
            describe: link.connection.bus.describe(),
        },
        Err(reason) => DriverResult::missing(reason),
    };
    VendorResult {
        robot: name.to_string(),
        traffic,
        native: finish(native, native_reps, native_durations),
        sdk: finish(sdk, sdk_reps, sdk_durations),
        steal: steal_since(cpu_before),
    }
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
        "virtual bus = emulated servos on a pseudo-terminal: no baud-rate limit and no return \
         delay, so cycles/s measure software overhead (driver + pty + emulator; for the SDK also \
         the Python bridge and its JSON-lines pipe, one round trip per write and per read), not \
         wire time. The wire limits beside them are docs/protocols.md §3 at 1 Mbps."
    );

    println!("\n1. sync write (6 goals) + sync read (6 positions), {REPS}× {RUN:?} per driver, interleaved, median:");
    let mut vendors = Vec::new();
    for name in ROBOTS {
        println!("{name}:");
        let result = bus_cycles(name);
        result.native.print("native");
        result.sdk.print("sdk");
        let t = &result.traffic;
        println!(
            "  wire at 1 Mbps: {} B/cycle ({} write + {} read instruction + 6×{} status) → \
             RDT 0: {:.0} µs ≤ {:.0} Hz; RDT 500 µs: {:.0} µs ≤ {:.0} Hz{}",
            t.bytes(),
            t.sync_write,
            t.sync_read_instruction,
            t.status_each,
            t.cycle_seconds(0.0) * 1e6,
            t.limit_hz(0.0).floor(),
            t.cycle_seconds(500e-6) * 1e6,
            t.limit_hz(500e-6).floor(),
            if t.name == "STS" {
                " (STS return-delay behaviour UNVERIFIED, §3)"
            } else {
                ""
            }
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

    let load_after = load_average();
    println!(
        "\nload average at start {load_before}, at end {load_after}; bench took {:.1} s",
        bench_start.elapsed().as_secs_f64()
    );

    // The table for the README.
    println!();
    println!(
        "summary: | virtual bus (pty, 6 servos) | native cycles/s | SDK cycles/s | native/SDK \
         | wire limit at 1 Mbps, RDT 0 | RDT 500 µs | CPU steal |"
    );
    println!("summary: |---|---|---|---|---|---|---|");
    for v in &vendors {
        let rate = |r: &Result<f64, String>| match r {
            Ok(rate) => format!("{rate:.0}"),
            Err(_) => "n/a".into(),
        };
        let ratio = match (&v.native.rate, &v.sdk.rate) {
            (Ok(n), Ok(s)) => format!("{:.1}×", n / s),
            _ => "n/a".into(),
        };
        println!(
            "summary: | {} ({} sync write + sync read) | {} | {} | {} | ≤ {:.0} Hz | ≤ {:.0} Hz \
             | {} |",
            v.robot,
            v.traffic.name,
            rate(&v.native.rate),
            rate(&v.sdk.rate),
            ratio,
            v.traffic.limit_hz(0.0).floor(),
            v.traffic.limit_hz(500e-6).floor(),
            v.steal,
        );
    }
    println!("summary: ");
    println!(
        "summary: | player, so101, native, pty | cycles | lateness p50 | p99 | max | mean period \
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
    println!(
        "summary: pty has no baud-rate limit and the virtual servos no return delay: cycles/s \
         are software overhead, not wire time. Cycles include the ≥ 0.5 s approach ramp. Load \
         average {load_before} → {load_after}."
    );
}
