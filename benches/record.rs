//! Keyframe extraction (`keypose record`): keypose's search against the textbook peer, measured
//! in the same run on the same recordings.
//!
//! The recordings: 6 joints at 100 Hz of busy hand-like motion (five sines per joint, 0.05–0.65
//! Hz, up to 30° each), read through a 4096-tick encoder with ±0.1° jitter, 1° tolerance; 10 s
//! and 60 s long. The peer is top-down greedy insertion, the way a line is simplified
//! (Ramer–Douglas–Peucker generalised to curves): start from the first and last sample, add a
//! key at the worst sample and evaluate the whole curve again, until every sample fits. It uses
//! the same `curve::Track` and the same public deviation function, so both sides fit the very
//! same curve; the peer's result is checked to fit too.
//!
//! Reported per recording and mode: keys (fewer is better) and wall time of each, and their
//! ratios, plus keypose's time as a share of the recording's length (below 1 means extraction
//! is faster than the hand that made it). `cargo bench --bench record` prints lines starting
//! with `summary:`. Nothing is asserted about time: the machine is shared.

use keypose::curve::Interp;
use keypose::record::{deviations, extract};
use std::time::Instant;

const RATE: f64 = 100.0;
const JOINTS: usize = 6;
const TOLERANCE: f64 = 1.0;
/// Repetitions of the keypose side; the median is reported. The peer runs once (it is slow).
const REPS: usize = 3;

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

/// The peer: a key at the worst sample (over all joints) until all fit, whole curve each time.
fn greedy_insertion(times: &[f64], values: &[Vec<f64>], mode: Interp) -> Vec<usize> {
    let mut keys = vec![0, times.len() - 1];
    loop {
        let worst = deviations(times, values, &keys, mode).expect("valid recording");
        let joint = (0..worst.len())
            .max_by(|&a, &b| worst[a].max.total_cmp(&worst[b].max))
            .expect("joints");
        if worst[joint].max <= TOLERANCE {
            return keys;
        }
        let sample = worst[joint].sample;
        let at = keys.partition_point(|&k| k < sample);
        keys.insert(at, sample);
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` runs this too: keep that quick.
    let quick = !std::env::args().any(|a| a == "--bench");
    let lengths: &[f64] = if quick { &[2.0] } else { &[10.0, 60.0] };
    println!(
        "summary: | recording | mode | keypose keys | peer keys | keys ratio | keypose time | \
         peer time | time ratio | keypose time / recording |"
    );
    println!("summary: |---|---|---|---|---|---|---|---|---|");
    for &seconds in lengths {
        let (times, values) = recording(seconds, 11);
        let tolerances = vec![TOLERANCE; JOINTS];
        for mode in [Interp::Monotone, Interp::Cubic, Interp::Linear] {
            let mut ours = Vec::new();
            let mut keys = 0;
            for _ in 0..if quick { 1 } else { REPS } {
                let start = Instant::now();
                let fit = extract(&times, &values, &tolerances, mode).expect("valid recording");
                ours.push(start.elapsed().as_secs_f64());
                keys = fit.keys.len();
                assert!(fit.deviations.iter().all(|d| d.max <= TOLERANCE));
            }
            let ours = median(ours);
            let start = Instant::now();
            let peer = greedy_insertion(&times, &values, mode);
            let theirs = start.elapsed().as_secs_f64();
            let check = deviations(&times, &values, &peer, mode).expect("valid recording");
            assert!(check.iter().all(|d| d.max <= TOLERANCE));
            println!(
                "summary: | {seconds} s × {JOINTS} joints ({} samples) | {mode} | {keys} | {} | \
                 {:.2} | {:.3} s | {:.3} s | {:.2} | {:.3} |",
                times.len(),
                peer.len(),
                keys as f64 / peer.len() as f64,
                ours,
                theirs,
                ours / theirs,
                ours / seconds
            );
        }
    }
}
