//! Keyframe extraction (`keypose record`): keypose's search against classic
//! Ramer–Douglas–Peucker, measured in the same run on the same recordings.
//!
//! The recordings: 6 joints at 100 Hz of busy hand-like motion (five sines per joint, 0.05–0.65
//! Hz, up to 30° each), read through a 4096-tick encoder with ±0.1° jitter, 1° tolerance; 10 s
//! and 60 s long.
//!
//! The peer is the textbook Ramer–Douglas–Peucker, recursive: keep the first and the last
//! sample; find the sample between them farthest from the chord (the straight line between the
//! two kept samples); if it is beyond the tolerance keep it and simplify both halves the same
//! way. Each step looks only at the recorded samples between its two ends. For a time series the
//! distance is the vertical one, joint by joint (the tolerance is in the joints' units, as
//! keypose's is), and a sample is kept when any joint is beyond its tolerance. Its keys fit the
//! recording by construction when played back linearly; in the cubic and monotone modes they are
//! a different curve, so the table gives their largest deviation there, measured with the same
//! `curve::Track` keypose plays (`record::deviations`), and whether it is within the tolerance.
//!
//! Both sides run once untimed (warm-up), then [`REPS`] times each, interleaved; times are the
//! median and range over the repeats, and the time ratio is taken repeat by repeat. keypose's time
//! is also given as a share of the recording's length (below 1: extraction is faster than the
//! hand that made it). `cargo bench --bench record` prints the load average and lines starting
//! with `summary:`. Nothing is asserted about time: the machine is shared.

mod common;

use keypose::curve::Interp;
use keypose::record::{deviations, extract};
use std::time::Instant;

const RATE: f64 = 100.0;
const JOINTS: usize = 6;
const TOLERANCE: f64 = 1.0;
/// Timed repetitions of each side, after one untimed run; the median and range are reported.
const REPS: usize = 5;

/// SplitMix64: the same recording on every run.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn recording(seconds: f64, seed: u64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mut rng = Rng(seed);
    let n = (seconds * RATE) as usize + 1;
    let times: Vec<f64> = (0..n).map(|k| k as f64 / RATE).collect();
    let tick = 360.0 / 4096.0;
    let values = (0..JOINTS)
        .map(|_| {
            let parts: Vec<(f64, f64, f64)> = (0..5)
                .map(|_| {
                    (
                        rng.unit() * 30.0,
                        0.05 + rng.unit() * 0.6,
                        rng.unit() * std::f64::consts::TAU,
                    )
                })
                .collect();
            times
                .iter()
                .map(|&t| {
                    let x: f64 = parts
                        .iter()
                        .map(|&(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
                        .sum();
                    ((x + (rng.unit() - 0.5) * 0.2) / tick).round() * tick
                })
                .collect()
        })
        .collect();
    (times, values)
}

/// Classic Ramer–Douglas–Peucker over all joints: the kept samples, increasing.
fn rdp(times: &[f64], values: &[Vec<f64>], tolerance: f64) -> Vec<usize> {
    let last = times.len() - 1;
    let mut keys = vec![0];
    simplify(times, values, tolerance, 0, last, &mut keys);
    keys.push(last);
    keys
}

/// Pushes the samples kept strictly between `first` and `last` (both kept), in order.
fn simplify(
    times: &[f64],
    values: &[Vec<f64>],
    tolerance: f64,
    first: usize,
    last: usize,
    keys: &mut Vec<usize>,
) {
    let span = times[last] - times[first];
    let mut worst = (0.0, first);
    for k in first + 1..last {
        let along = (times[k] - times[first]) / span;
        for series in values {
            let chord = series[first] + along * (series[last] - series[first]);
            let distance = (series[k] - chord).abs();
            if distance > worst.0 {
                worst = (distance, k);
            }
        }
    }
    let (distance, at) = worst;
    if distance > tolerance {
        simplify(times, values, tolerance, first, at, keys);
        keys.push(at);
        simplify(times, values, tolerance, at, last, keys);
    }
}

fn main() {
    let session = common::Session::start("record");
    // `cargo bench` passes --bench; `cargo test --benches` runs this too: keep that quick.
    let quick = !common::is_bench_run();
    let lengths: &[f64] = if quick { &[2.0] } else { &[10.0, 60.0] };
    let reps = if quick { 1 } else { REPS };
    println!(
        "summary: | recording | mode | keypose keys | RDP keys | RDP keys' largest deviation in \
         this mode | keypose time | RDP time | time ratio keypose / RDP | keypose time / \
         recording |"
    );
    println!("summary: |---|---|---|---|---|---|---|---|---|");
    for &seconds in lengths {
        let (times, values) = recording(seconds, 11);
        let tolerances = vec![TOLERANCE; JOINTS];
        for mode in [Interp::Linear, Interp::Cubic, Interp::Monotone] {
            let ours = || extract(&times, &values, &tolerances, mode).expect("valid recording");
            let theirs = || rdp(&times, &values, TOLERANCE);
            // Warm-up, and the results (the same on every run).
            let fit = ours();
            assert!(fit.deviations.iter().all(|d| d.max <= TOLERANCE));
            let peer = theirs();
            let peer_fit = deviations(&times, &values, &peer, mode).expect("valid recording");
            let peer_worst = peer_fit.iter().map(|d| d.max).fold(0.0, f64::max);
            if mode == Interp::Linear {
                // RDP's guarantee, checked by keypose's own curve: a wrong peer is no peer.
                assert!(peer_worst <= TOLERANCE + 1e-9, "RDP: {peer_worst}");
            }
            let (mut our_times, mut their_times) = (Vec::new(), Vec::new());
            for _ in 0..reps {
                let start = Instant::now();
                std::hint::black_box(ours());
                our_times.push(start.elapsed().as_secs_f64());
                let start = Instant::now();
                std::hint::black_box(theirs());
                their_times.push(start.elapsed().as_secs_f64());
            }
            let share: Vec<f64> = our_times.iter().map(|t| t / seconds).collect();
            println!(
                "summary: | {seconds} s × {JOINTS} joints ({} samples) | {mode} | {} | {} | \
                 {peer_worst:.2}° ({}) | {} s | {} ms | {} | {} |",
                times.len(),
                fit.keys.len(),
                peer.len(),
                if peer_worst <= TOLERANCE {
                    "fits"
                } else {
                    "does not fit"
                },
                common::Spread::of(&our_times).show(3),
                common::Spread::of(&their_times.iter().map(|t| t * 1e3).collect::<Vec<_>>())
                    .show(3),
                common::Spread::ratio(&our_times, &their_times).show(0),
                common::Spread::of(&share).show(4),
            );
        }
    }
    println!(
        "summary: times: median (range) of {reps} interleaved runs after one untimed run; \
         tolerance {TOLERANCE}° on every joint; {}",
        session.load()
    );
    session.end();
}
