//! Servo-bus benchmark on emulated servos served on a pseudo-terminal, reached through the same
//! serial code as a USB adapter. Wire-timed, they answer when the real wire would (bytes at the
//! robot's baud rate, 10 bits a byte, each servo's return delay; no USB latency, docs/protocols.md
//! §3); untimed, at once (only software time).
//!
//! 1. Bus cycles ([`cycles`]): one sync write of 6 goal positions + one sync read of 6 present
//!    positions, per second, for so101 (Feetech STS3215 ×6) and koch (Dynamixel X ×6), wire-timed
//!    and untimed, by four contenders, each on its own emulated servos, their runs interleaved
//!    ([`cycles::REPS`] each) so that all see the same machine load:
//!    - keypose's native driver;
//!    - the `rustypot` crate (Pollen Robotics) on the same kind of port;
//!    - the vendor SDK (dynamixel_sdk / scservo_sdk) **driven directly**, in a plain Python loop
//!      (`benches/sdk_direct.py`), as people run it;
//!    - the same SDK **through keypose's bridge** (`--driver sdk`: a Python process spoken to in
//!      JSON lines), which costs two pipe round trips a cycle on top.
//!
//!    Beside them, the wire limit of the same traffic ([`wire`]) and each contender's share of it.
//! 2. Player lateness ([`player`]): the player streams a 10 s cubic to the wire-timed bus with
//!    the native driver at 100 Hz and 500 Hz; lateness at the cycle's start (what the player
//!    reports) and at the goal write (stamped when keypose's transport returns from `write()`,
//!    [`stamps`]), repeated and interleaved.
//! 3. Software cost ([`codec`]): CPU time per cycle of the encode + decode of keypose's driver
//!    and of rustypot's, each over an in-memory port with the same canned answers.
//! 4. Two arms ([`cell`]): a cell of two so101 arms on two wire-timed buses through the cell's
//!    bus against one arm on one bus, and how far apart the two buses' goal writes were, at the
//!    cell's start gate and at the write.
//!
//! `cargo bench --bench bus` prints the load average at start and end, every figure as the
//! median and range of its repeats, and tables on lines starting with `summary:`. Nothing is
//! asserted about timing. The SDK contenders need keypose's Python environment (python3 3.11+
//! with venv, PyPI the first time), shared with the tests in the target directory unless
//! `KEYPOSE_CACHE` or `KEYPOSE_PYTHON` is set; without it their figures say why they are
//! missing.

// The bench's parts live in benches/bus/ (a bench's root is not a module file, so its
// submodules are found by path).
#[path = "bus/cell.rs"]
mod cell;
#[path = "bus/codec.rs"]
mod codec;
mod common;
#[path = "bus/cycles.rs"]
mod cycles;
#[path = "bus/player.rs"]
mod player;
#[path = "bus/stamps.rs"]
mod stamps;
#[path = "bus/steal.rs"]
mod steal;
#[path = "bus/wire.rs"]
mod wire;

use common::Spread;
use cycles::{Contender, VendorResult};

/// Robots of the bus-cycle comparison, one per vendor.
const ROBOTS: [&str; 2] = ["so101", "koch"];

/// The player configurations: rate and how often positions are read back.
const PLAYER: [player::Config; 3] = [
    player::Config {
        rate_hz: 100.0,
        readback_every: 1,
    },
    player::Config {
        rate_hz: 500.0,
        readback_every: 1,
    },
    player::Config {
        rate_hz: 500.0,
        readback_every: 5,
    },
];

fn print_cycles(vendors: &[VendorResult], timed: bool) {
    for v in vendors {
        println!("{}:", v.robot);
        for c in Contender::ALL {
            v.of(c).print(c.label());
        }
        if timed {
            let t = &v.traffic;
            println!(
                "  wire at {} baud: {} B/cycle ({} write + {} read instruction + 6×{} status) + \
                 6 × RDT {:.0} µs → {:.0} µs ≤ {:.0} Hz",
                t.wire.baud,
                t.bytes(),
                t.sync_write,
                t.sync_read_instruction,
                t.status_each,
                v.rdt * 1e6,
                t.cycle_seconds(v.rdt) * 1e6,
                t.limit_hz(v.rdt).floor(),
            );
        }
        println!("  CPU steal during the timed runs: {}", v.steal);
    }
}

/// The cycles table: each contender's cycles/s (median and range), with the wire's share when
/// timed, and the ratios that compare like with like, repetition by repetition.
fn summary_cycles(vendors: &[VendorResult], timed: bool) {
    let what = if timed {
        "wire-timed emulated bus (pty, 6 servos): cycles/s, median (range) of the repeats; share of the wire limit; median cycle"
    } else {
        "untimed emulated bus (pty, 6 servos, answers at once): cycles/s, median (range) of the repeats; median cycle"
    };
    println!("summary: {what}");
    let header: Vec<&str> = Contender::ALL.iter().map(|c| c.label()).collect();
    println!(
        "summary: | robot | {}{} |",
        if timed { "wire limit | " } else { "" },
        header.join(" | ")
    );
    println!(
        "summary: |---|{}{}",
        if timed { "---|" } else { "" },
        "---|".repeat(header.len())
    );
    for v in vendors {
        let limit = v.traffic.limit_hz(v.rdt);
        let cell = |c: Contender| {
            let d = v.of(c);
            match d.rate() {
                Some(rate) if timed => format!(
                    "{} ({:.1} %; {:.0} µs)",
                    rate.show(0),
                    100.0 * rate.median / limit,
                    d.median_cycle() * 1e6
                ),
                Some(rate) => format!("{} ({:.0} µs)", rate.show(0), d.median_cycle() * 1e6),
                None => "n/a".into(),
            }
        };
        let cells: Vec<String> = Contender::ALL.iter().map(|&c| cell(c)).collect();
        let robot = format!(
            "{} ({} at {} baud, RDT {:.0} µs)",
            v.robot,
            v.traffic.name,
            v.traffic.wire.baud,
            v.rdt * 1e6
        );
        if timed {
            println!(
                "summary: | {robot} | ≤ {:.0} Hz | {} |",
                limit.floor(),
                cells.join(" | ")
            );
        } else {
            println!("summary: | {robot} | {} |", cells.join(" | "));
        }
    }
    for v in vendors {
        let ratio = |a: Contender, b: Contender| match (&v.of(a).reps, &v.of(b).reps) {
            (Ok(x), Ok(y)) => Spread::ratio(x, y).show(2),
            _ => "n/a".into(),
        };
        println!(
            "summary: {}: native / rustypot {}; native / SDK direct {}; SDK direct / SDK through \
             the bridge {}",
            v.robot,
            ratio(Contender::Native, Contender::Rustypot),
            ratio(Contender::Native, Contender::SdkDirect),
            ratio(Contender::SdkDirect, Contender::SdkBridge),
        );
    }
    println!("summary: ");
}

/// Whether a section is to run: those named after `--` (`cargo bench --bench bus -- codec
/// player`; sections: cycles, player, codec, cell), or all.
fn wanted(section: &str) -> bool {
    let named: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    named.is_empty() || named.iter().any(|n| n == section)
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` runs this too: keep that quick.
    if !common::is_bench_run() {
        println!("bus benchmark: run with `cargo bench --bench bus`");
        return;
    }
    // Before any thread exists.
    common::use_shared_python_cache();
    let session = common::Session::start("bus");
    println!(
        "emulated bus = emulated servos on a pseudo-terminal. Wire-timed: answers come when the \
         wire would deliver them (bytes at the robot's baud rate, return delays, no USB \
         latency); a contender's share of the wire limit is wire time / its cycle time, the rest \
         is software (driver + pty + emulator; for the SDKs also Python, and for the bridge its \
         JSON-lines pipe). Untimed: answers at once, only software time."
    );

    let modes = wanted("cycles").then(|| {
        let mut modes = Vec::new();
        for timed in [true, false] {
            println!(
                "\n1{}. sync write (6 goals) + sync read (6 positions), {}, {}× {:?} per contender, \
                 interleaved:",
                if timed { "a" } else { "b" },
                if timed { "wire-timed" } else { "untimed" },
                cycles::REPS,
                cycles::RUN
            );
            let vendors: Vec<VendorResult> = ROBOTS
                .iter()
                .map(|name| cycles::bus_cycles(name, timed))
                .collect();
            print_cycles(&vendors, timed);
            modes.push((timed, vendors));
        }

        modes
    });

    let playbacks = wanted("player").then(|| {
        println!(
            "\n2. player on so101, native driver, wire-timed, 10 s cubic on shoulder_pan after the \
             approach ramp, {}× each, interleaved:",
            player::REPS
        );
        let playbacks = player::playbacks(&PLAYER, player::REPS);
        for (config, runs) in PLAYER.iter().zip(&playbacks) {
            for run in runs {
                match run {
                    Ok(r) => println!(
                        "  {:<26} {} cycles in {:.2} s; lateness at start p50 {:.3} ms, p99 {:.3} ms, \
                         max {:.3} ms; at the write p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms; start → \
                         write p50 {:.1} µs, p99 {:.1} µs; write call p50 {:.1} µs, p99 {:.1} µs; {} \
                         cycles written > 1 period late; {} unmatched; CPU steal {}",
                        config.label(),
                        r.cycles,
                        r.wall_seconds,
                        r.at_start.p50,
                        r.at_start.p99,
                        r.at_start.max,
                        r.at_write.p50,
                        r.at_write.p99,
                        r.at_write.max,
                        r.start_to_write.p50 * 1e3,
                        r.start_to_write.p99 * 1e3,
                        r.write_call.p50 * 1e3,
                        r.write_call.p99 * 1e3,
                        r.late_by_a_period,
                        r.unmatched,
                        r.steal,
                    ),
                    Err(reason) => println!("  {:<26} ended: {reason}", config.label()),
                }
            }
        }

        playbacks
    });

    let costs = wanted("codec").then(|| {
        println!(
            "\n3. CPU time per cycle of encode + decode (sync write of 6 goals, sync read of 6 \
             positions), no I/O, keypose's native driver and rustypot, interleaved:"
        );
        let costs: Vec<(&str, Result<codec::CodecCost, String>)> = ROBOTS
            .iter()
            .map(|&name| (name, codec::codec_cost(name)))
            .collect();
        for (name, cost) in &costs {
            match cost {
                Ok(c) => println!(
                    "  {name}: keypose {} µs, rustypot {} µs, keypose / rustypot {}",
                    Spread::of(&c.keypose).show(2),
                    Spread::of(&c.rustypot).show(2),
                    c.ratio().show(2)
                ),
                Err(e) => println!("  {name}: failed: {e}"),
            }
        }

        costs
    });

    let cell = wanted("cell").then(|| {
        println!(
            "\n4. two so101 arms, each on its own wire-timed bus, through the cell's bus (12 goals + \
             12 positions a cycle), against one arm on one bus, {}× {:?} each, interleaved:",
            cycles::REPS,
            cycles::RUN
        );
        let cells = cell::cell_cycles();
        cells.one.print("1 arm");
        cells.cell.print("2 arms");
        let cell_ratio = match (&cells.one.reps, &cells.cell.reps) {
            (Ok(one), Ok(two)) => Some(Spread::ratio(two, one)),
            _ => None,
        };
        if let Some(ratio) = cell_ratio {
            println!(
                "  two arms' cycles/s over one arm's: {} (1: the buses ran side by side; 0.5: one \
                 after the other)",
                ratio.show(2)
            );
        }
        let at_gate = cells.at_gate.map(|o| {
            format!(
                "median {:.0} µs, p99 {:.0} µs, max {:.0} µs over {} cycles",
                o.median.as_secs_f64() * 1e6,
                o.p99.as_secs_f64() * 1e6,
                o.max.as_secs_f64() * 1e6,
                o.cycles
            )
        });
        let at_write = cell::show_offsets(&cells.at_write);
        println!(
            "  goal writes apart, at the start gate (as the cell records them): {}",
            at_gate.as_deref().unwrap_or("n/a")
        );
        println!(
            "  goal writes apart, at the write (stamped when write() returned): {at_write}; goal \
             writes {} left, {} right",
            cells.writes[0], cells.writes[1]
        );

        (cells, cell_ratio, at_gate, at_write)
    });

    println!();
    session.end();

    // The tables for docs/benchmarks.md.
    println!();
    println!("summary: {}", session.load());
    if let Some(modes) = &modes {
        for (timed, vendors) in modes {
            summary_cycles(vendors, *timed);
        }
    }
    if let Some(costs) = &costs {
        println!(
            "summary: encode + decode, CPU µs per cycle, no I/O, median (range) of the runs: | robot \
             | keypose | rustypot | keypose / rustypot |"
        );
        println!("summary: |---|---|---|---|");
        for (name, cost) in costs.iter() {
            if let Ok(c) = cost {
                println!(
                    "summary: | {name} | {} | {} | {} |",
                    Spread::of(&c.keypose).show(2),
                    Spread::of(&c.rustypot).show(2),
                    c.ratio().show(2)
                );
            }
        }
    }
    if let Some(playbacks) = &playbacks {
        println!("summary: ");
        println!(
            "summary: | player, so101, native, wire-timed pty | cycles | lateness at the cycle's \
             start p50 / p99 / max | at the goal write p50 / p99 / max | start → write p50 / p99 | \
             cycles written > 1 period late |"
        );
        println!("summary: |---|---|---|---|---|---|");
        for (config, runs) in PLAYER.iter().zip(playbacks.iter()) {
            let (done, failed, reason) = player::finished(runs);
            let ended = match reason {
                Some(reason) => format!(
                    "; {failed} of {} playbacks ended early: {}",
                    runs.len(),
                    reason.split(';').next().unwrap_or(reason)
                ),
                None => String::new(),
            };
            if done.is_empty() {
                println!(
                    "summary: | {} | none finished{ended} | | | | |",
                    config.label()
                );
                continue;
            }
            println!(
                "summary: | {} | {} | {} | {} | {} / {} µs | {}{ended} |",
                config.label(),
                Spread::over(&done, |r| r.cycles as f64).show(0),
                player::show_tail(&done, |r| r.at_start),
                player::show_tail(&done, |r| r.at_write),
                Spread::over(&done, |r| r.start_to_write.p50 * 1e3).show(1),
                Spread::over(&done, |r| r.start_to_write.p99 * 1e3).show(1),
                Spread::over(&done, |r| r.late_by_a_period as f64).show(0),
            );
        }
    }
    if let Some((cells, cell_ratio, at_gate, at_write)) = &cell {
        if let (Some(ratio), Some(one), Some(two)) =
            (*cell_ratio, cells.one.rate(), cells.cell.rate())
        {
            println!("summary: ");
            println!(
                "summary: two so101 arms on two wire-timed buses through the cell's bus: {} cycles/s, \
                 one arm on one bus {} cycles/s: ratio {}; goal writes apart at the start gate: {}; \
                 at the write: {at_write}",
                two.show(0),
                one.show(0),
                ratio.show(2),
                at_gate.as_deref().unwrap_or("n/a"),
            );
        }
    }
    println!(
        "summary: the wire-timed bus takes the wire's time at the robot's baud rate with the \
         servos' return delay; 100 % of the limit is the wire's own pace. Player cycles include \
         the ≥ 0.5 s approach ramp; the write's stamp is taken when keypose's transport returns \
         from write()."
    );
}
