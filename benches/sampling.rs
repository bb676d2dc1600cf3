//! Sampling throughput of a 6-joint cubic sequence: keypose against the `splines` crate.
//!
//! Six joints share 1,000 keys at non-uniform increasing times (gaps 0.2–1.0 s) with values in
//! ±90; every joint is sampled at the same 1,000,000 times, once in increasing order and once in a
//! shuffled order of the very same times. keypose samples with a [`Cursor`] per joint
//! (sequential) or [`Track::sample`] (random); `splines` has no cursor, so both of its variants
//! call `Spline::clamped_sample` and differ only in the order of the times.
//!
//! `splines`' Catmull-Rom needs a key before and a key after the segment: it returns `None` in
//! the first and the last segment, and so does `clamped_sample` there, which only clamps before
//! the first key and after the last one. The sample times therefore span `[t[1], t[n-2])`, the
//! part of the key range where both libraries evaluate a real cubic, and keypose gets the same
//! times. On that range the two curves are the same: `splines` 5 uses key-time tangents
//! `(v[i+1] − v[i−1]) / (t[i+1] − t[i−1]) · (t[i+1] − t[i])`, exactly keypose's `Interp::Cubic`,
//! which the setup checks before anything is timed.
//!
//! Besides criterion's report, a benchmark run (`cargo bench --bench sampling`) ends with a
//! same-run timing of the four variants (median of a few interleaved repetitions) printed on
//! lines starting with `summary:`, in nanoseconds per joint-sample.

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

/// keypose, binary search per sample.
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

/// Same-run timing of the four variants with `Instant`: the repetitions are interleaved so that
/// a noisy neighbour on a shared machine slows every variant alike; the median is reported.
fn summary(data: &Data) {
    type Variant<'a> = (&'a str, Box<dyn Fn() -> f64 + 'a>);
    let variants: [Variant<'_>; 4] = [
        (
            "keypose sequential",
            Box::new(|| keypose_sequential(black_box(&data.tracks), black_box(&data.sorted))),
        ),
        (
            "keypose random",
            Box::new(|| keypose_random(black_box(&data.tracks), black_box(&data.shuffled))),
        ),
        (
            "splines sequential",
            Box::new(|| splines_sampled(black_box(&data.splines), black_box(&data.sorted))),
        ),
        (
            "splines random",
            Box::new(|| splines_sampled(black_box(&data.splines), black_box(&data.shuffled))),
        ),
    ];
    let mut runs: Vec<Vec<Duration>> = vec![Vec::with_capacity(SUMMARY_REPS); variants.len()];
    for (_, run) in &variants {
        black_box(run()); // warm caches and page in the data
    }
    for _ in 0..SUMMARY_REPS {
        for ((_, run), durations) in variants.iter().zip(&mut runs) {
            let start = Instant::now();
            let sum = black_box(run());
            durations.push(start.elapsed());
            assert!(sum.is_finite());
        }
    }
    let per_sample: Vec<f64> = runs
        .iter_mut()
        .map(|durations| {
            durations.sort();
            durations[durations.len() / 2].as_secs_f64() * 1e9 / (JOINTS * SAMPLES) as f64
        })
        .collect();
    println!();
    println!(
        "summary: {JOINTS} joints x {KEYS} cubic keys, {SAMPLES} times, \
         median of {SUMMARY_REPS} interleaved runs"
    );
    println!("summary: {:<20} {:>16}", "variant", "ns/joint-sample");
    for ((name, _), ns) in variants.iter().zip(&per_sample) {
        println!("summary: {name:<20} {ns:>16.2}");
    }
    println!(
        "summary: {:<20} {:>16.2}",
        "keypose/splines seq",
        per_sample[0] / per_sample[2]
    );
    println!(
        "summary: {:<20} {:>16.2}",
        "keypose/splines rnd",
        per_sample[1] / per_sample[3]
    );
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
        summary(&data);
    }
}
