//! Sampling throughput of a 6-joint cubic sequence: keypose against the `splines` crate.
//!
//! Six joints share 1,000 keys at non-uniform increasing times (gaps 0.2–1.0 s) with values in
//! ±90; every joint is sampled at the same 1,000,000 times, once in increasing order and once in a
//! shuffled order of the very same times.
//!
//! What is compared with what:
//! - **Random order, both by lookup** (like for like): keypose's [`Track::sample`] and
//!   `splines`' `Spline::clamped_sample`, each a binary search over the keys per sample.
//! - **Increasing order, both by lookup** (like for like): the same two calls on the sorted
//!   times.
//! - **Increasing order, keypose's [`Cursor`]** (what playback uses: it steps from segment to
//!   segment, O(1) per sample) against the two lookups. `splines` has no cursor, so this ratio is
//!   what the cursor gains, not one library against the other; it is reported apart and never as
//!   the headline.
//!
//! `splines`' Catmull-Rom needs a key before and a key after the segment: it returns `None` in
//! the first and the last segment, and so does `clamped_sample` there, which only clamps before
//! the first key and after the last one. The sample times therefore span `[t[1], t[n-2])`, the
//! part of the key range where both libraries evaluate a real cubic, and keypose gets the same
//! times. On that range the two curves are the same: `splines` 5 uses key-time tangents
//! `(v[i+1] − v[i−1]) / (t[i+1] − t[i−1]) · (t[i+1] − t[i])`, exactly keypose's `Interp::Cubic`,
//! which the setup checks before anything is timed.
//!
//! Besides criterion's report, a benchmark run (`cargo bench --bench sampling`) prints the load
//! average and ends with a same-run timing of the five variants, interleaved, as the median and
//! range of [`SUMMARY_REPS`] repetitions, on lines starting with `summary:` (nanoseconds per
//! joint-sample).

mod common;

use criterion::{Criterion, SamplingMode, Throughput};
use keypose::curve::{Cursor, Interp, Track, TrackKey};
use splines::{Interpolation, Key, Spline};
use std::hint::black_box;
use std::time::{Duration, Instant};

const JOINTS: usize = 6;
const KEYS: usize = 1_000;
const SAMPLES: usize = 1_000_000;
/// Repetitions of each variant in the final summary; the median is reported.
const SUMMARY_REPS: usize = 7;

/// SplitMix64: a tiny deterministic generator, so the data is the same on every run.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in 0..n (multiply-high; the bias is negligible for n ≪ 2⁶⁴).
    fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }
}

struct Data {
    tracks: Vec<Track<f64>>,
    splines: Vec<Spline<f64, f64>>,
    /// Evenly spaced, increasing.
    sorted: Vec<f64>,
    /// The same times in a shuffled order.
    shuffled: Vec<f64>,
}

impl Data {
    fn new() -> Self {
        let mut rng = Rng(0x6B65_7970_6F73_6521);
        let mut times = Vec::with_capacity(KEYS);
        let mut t = 0.0;
        for _ in 0..KEYS {
            times.push(t);
            t += rng.range(0.2, 1.0);
        }
        let mut tracks = Vec::with_capacity(JOINTS);
        let mut splines = Vec::with_capacity(JOINTS);
        for _ in 0..JOINTS {
            let values: Vec<f64> = (0..KEYS).map(|_| rng.range(-90.0, 90.0)).collect();
            let keys: Vec<TrackKey<f64>> = times
                .iter()
                .zip(&values)
                .map(|(&t, &v)| TrackKey::new(t, v, Interp::Cubic))
                .collect();
            tracks.push(Track::new(&keys).expect("keys are strictly increasing"));
            splines.push(Spline::from_vec(
                times
                    .iter()
                    .zip(&values)
                    .map(|(&t, &v)| Key::new(t, v, Interpolation::CatmullRom))
                    .collect(),
            ));
        }
        // Where splines' Catmull-Rom is defined: from the second key up to (not including) the
        // second-to-last one.
        let (lo, hi) = (times[1], times[KEYS - 2]);
        let sorted: Vec<f64> = (0..SAMPLES)
            .map(|k| lo + (hi - lo) * (k as f64 / SAMPLES as f64))
            .collect();
        let mut shuffled = sorted.clone();
        for i in (1..shuffled.len()).rev() {
            let j = rng.below(i + 1);
            shuffled.swap(i, j);
        }
        Self {
            tracks,
            splines,
            sorted,
            shuffled,
        }
    }

    /// Makes sure the benchmark measures real curves: finite values from both libraries, the
    /// cursor equal to random access bit for bit, and both libraries on the same curve.
    fn check(&self) {
        assert!(self.sorted.windows(2).all(|w| w[0] < w[1]));
        let (lo, hi) = (self.sorted[0], self.sorted[SAMPLES - 1]);
        let step = SAMPLES / 5_000;
        for (track, spline) in self.tracks.iter().zip(&self.splines) {
            let mut cursor = track.cursor();
            for &t in self.sorted.iter().step_by(step) {
                let by_cursor = cursor.sample(t);
                let by_search = track.sample(t);
                assert!(by_cursor.is_finite(), "keypose not finite at t = {t}");
                assert_eq!(
                    by_cursor.to_bits(),
                    by_search.to_bits(),
                    "cursor and random access differ at t = {t}"
                );
                let theirs = spline
                    .clamped_sample(t)
                    .unwrap_or_else(|| panic!("splines has no value at t = {t}"));
                assert!(theirs.is_finite(), "splines not finite at t = {t}");
                assert!(
                    (by_search - theirs).abs() <= 1e-9 * (1.0 + theirs.abs()),
                    "keypose {by_search} and splines {theirs} differ at t = {t}"
                );
            }
            // The shuffled order makes the cursor step back most of the time (binary search).
            let mut cursor = track.cursor();
            for &t in self.shuffled.iter().take(5_000) {
                assert!((lo..=hi).contains(&t));
                assert_eq!(cursor.sample(t).to_bits(), track.sample(t).to_bits());
            }
        }
        // The variants all accumulate the same values, up to summation order.
        let sums = [
            keypose_sequential(&self.tracks, &self.sorted),
            keypose_random(&self.tracks, &self.shuffled),
            splines_sampled(&self.splines, &self.sorted),
            splines_sampled(&self.splines, &self.shuffled),
        ];
        for s in sums {
            assert!(s.is_finite());
            assert!(
                (s - sums[0]).abs() <= 1e-6 * (1.0 + sums[0].abs()),
                "{sums:?}"
            );
        }
    }
}

/// One accumulator per joint, so the sum is six independent chains rather than one long one.
fn total(acc: [f64; JOINTS]) -> f64 {
    acc.iter().sum()
}

/// keypose, a cursor per joint, times in increasing order (a playback loop).
fn keypose_sequential(tracks: &[Track<f64>], times: &[f64]) -> f64 {
    let mut cursors: [Cursor<'_, f64>; JOINTS] = std::array::from_fn(|j| tracks[j].cursor());
    let mut acc = [0.0; JOINTS];
    for &t in times {
        for (a, cursor) in acc.iter_mut().zip(cursors.iter_mut()) {
            *a += cursor.sample(t);
        }
    }
    total(acc)
}

/// keypose, binary search per sample (in whatever order `times` come).
fn keypose_random(tracks: &[Track<f64>], times: &[f64]) -> f64 {
    let tracks: &[Track<f64>; JOINTS] = tracks.try_into().expect("six joints");
    let mut acc = [0.0; JOINTS];
    for &t in times {
        for (a, track) in acc.iter_mut().zip(tracks) {
            *a += track.sample(t);
        }
    }
    total(acc)
}

/// splines: every sample is a binary search over the keys, whatever the order of the times.
fn splines_sampled(splines: &[Spline<f64, f64>], times: &[f64]) -> f64 {
    let splines: &[Spline<f64, f64>; JOINTS] = splines.try_into().expect("six joints");
    let mut acc = [0.0; JOINTS];
    for &t in times {
        for (a, spline) in acc.iter_mut().zip(splines) {
            *a += spline.clamped_sample(t).unwrap_or(f64::NAN);
        }
    }
    total(acc)
}

fn configure_group(group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    // One iteration is six million samples (tens to hundreds of milliseconds): flat sampling
    // keeps the run short instead of scaling the iteration count up to 10× per sample.
    group
        .sampling_mode(SamplingMode::Flat)
        .throughput(Throughput::Elements((JOINTS * SAMPLES) as u64));
}

fn bench_sequential(c: &mut Criterion, data: &Data) {
    let mut group = c.benchmark_group("sequential");
    configure_group(&mut group);
    group.bench_function("keypose_cursor", |b| {
        b.iter(|| keypose_sequential(black_box(&data.tracks), black_box(&data.sorted)))
    });
    group.bench_function("keypose_lookup", |b| {
        b.iter(|| keypose_random(black_box(&data.tracks), black_box(&data.sorted)))
    });
    group.bench_function("splines_catmull_rom", |b| {
        b.iter(|| splines_sampled(black_box(&data.splines), black_box(&data.sorted)))
    });
    group.finish();
}

fn bench_random(c: &mut Criterion, data: &Data) {
    let mut group = c.benchmark_group("random");
    configure_group(&mut group);
    group.bench_function("keypose_sample", |b| {
        b.iter(|| keypose_random(black_box(&data.tracks), black_box(&data.shuffled)))
    });
    group.bench_function("splines_catmull_rom", |b| {
        b.iter(|| splines_sampled(black_box(&data.splines), black_box(&data.shuffled)))
    });
    group.finish();
}

/// Same-run timing of the five variants with `Instant`: the repetitions are interleaved so that
/// a noisy neighbour on a shared machine slows every variant alike. Each figure is the median and
/// the range over the repetitions; each ratio is taken repetition by repetition (the two sides
/// ran back to back) before its median and range.
fn summary(data: &Data, session: &common::Session) {
    type Variant<'a> = (&'a str, Box<dyn Fn() -> f64 + 'a>);
    let variants: [Variant<'_>; 5] = [
        (
            "keypose cursor",
            Box::new(|| keypose_sequential(black_box(&data.tracks), black_box(&data.sorted))),
        ),
        (
            "keypose lookup",
            Box::new(|| keypose_random(black_box(&data.tracks), black_box(&data.sorted))),
        ),
        (
            "splines lookup",
            Box::new(|| splines_sampled(black_box(&data.splines), black_box(&data.sorted))),
        ),
        (
            "keypose lookup",
            Box::new(|| keypose_random(black_box(&data.tracks), black_box(&data.shuffled))),
        ),
        (
            "splines lookup",
            Box::new(|| splines_sampled(black_box(&data.splines), black_box(&data.shuffled))),
        ),
    ];
    let mut runs: Vec<Vec<f64>> = vec![Vec::with_capacity(SUMMARY_REPS); variants.len()];
    for (_, run) in &variants {
        black_box(run()); // warm caches and page in the data
    }
    for _ in 0..SUMMARY_REPS {
        for ((_, run), ns) in variants.iter().zip(&mut runs) {
            let start = Instant::now();
            let sum = black_box(run());
            ns.push(start.elapsed().as_secs_f64() * 1e9 / (JOINTS * SAMPLES) as f64);
            assert!(sum.is_finite());
        }
    }
    let [cursor, seq_lookup, seq_splines, rnd_lookup, rnd_splines] = &runs[..] else {
        unreachable!("five variants")
    };
    let row = |what: &str, ns: &[f64]| {
        println!(
            "summary: | {what} | {} ns |",
            common::Spread::of(ns).show(2)
        );
    };
    let ratio = |what: &str, ours: &[f64], theirs: &[f64]| {
        println!(
            "summary: | {what} | {} |",
            common::Spread::ratio(ours, theirs).show(2)
        );
    };
    println!();
    println!(
        "summary: {JOINTS} joints x {KEYS} cubic keys, {SAMPLES} times; ns per joint-sample, \
         median (range) of {SUMMARY_REPS} interleaved runs; {}",
        session.load()
    );
    println!("summary: | variant | ns per joint-sample |");
    println!("summary: |---|---|");
    println!("summary: | **random order: both look each time up (like for like)** | |");
    row("keypose `Track::sample` (binary search)", rnd_lookup);
    row("splines `clamped_sample` (binary search)", rnd_splines);
    ratio("ratio keypose / splines, random", rnd_lookup, rnd_splines);
    println!("summary: | **increasing order: both look each time up (like for like)** | |");
    row("keypose `Track::sample`", seq_lookup);
    row("splines `clamped_sample`", seq_splines);
    ratio(
        "ratio keypose / splines, increasing",
        seq_lookup,
        seq_splines,
    );
    println!(
        "summary: | **increasing order, keypose's cursor (playback) against splines' lookup: \
         not like for like, splines has no cursor** | |"
    );
    row("keypose `Cursor::sample`", cursor);
    ratio("ratio cursor / keypose's own lookup", cursor, seq_lookup);
    ratio("ratio cursor / splines' lookup", cursor, seq_splines);
}

/// Whether criterion will measure (rather than test or list), by the same rule criterion uses.
fn is_benchmark_run() -> bool {
    let args: Vec<String> = std::env::args().collect();
    let has = |flag: &str| args.iter().any(|a| a == flag);
    has("--bench")
        && !has("--test")
        && !has("--list")
        && !args.iter().any(|a| a.starts_with("--profile-time"))
}

fn main() {
    let session = common::Session::start("sampling");
    let data = Data::new();
    data.check();
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5))
        .configure_from_args();
    bench_sequential(&mut c, &data);
    bench_random(&mut c, &data);
    c.final_summary();
    if is_benchmark_run() {
        summary(&data, &session);
    }
    session.end();
}
