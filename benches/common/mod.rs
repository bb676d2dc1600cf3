//! What every benchmark prints beside its figures, so that a figure read later can be judged: the
//! machine's load when it was measured (`/proc/loadavg`), and each figure as the median and the
//! range of its repeats rather than one run's number.
//!
//! Shared by the benches through `mod common;`; each uses a part of it.
#![allow(dead_code)]

use std::time::Instant;

/// The 1, 5 and 15 minute load averages, as `/proc/loadavg` gives them ("unknown" without it).
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|text| {
            text.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_else(|_| "unknown".into())
}

/// The load at the start of a benchmark, and how long it has run; [`Session::end`] prints both.
pub struct Session {
    name: &'static str,
    load_at_start: String,
    started: Instant,
}

impl Session {
    /// Prints the load at the start of benchmark `name`.
    pub fn start(name: &'static str) -> Session {
        let load_at_start = load_average();
        println!("{name} benchmark: load average at start {load_at_start} (1, 5, 15 min)");
        Session {
            name,
            load_at_start,
            started: Instant::now(),
        }
    }

    /// "load average A → B", for a summary line.
    pub fn load(&self) -> String {
        format!("load average {} → {}", self.load_at_start, load_average())
    }

    /// Prints the load at the end and the benchmark's wall time.
    pub fn end(&self) {
        println!(
            "{} benchmark: {}; took {:.1} s",
            self.name,
            self.load(),
            self.started.elapsed().as_secs_f64()
        );
    }
}

/// Whether `cargo bench` runs this bench (it passes `--bench`); `cargo test --benches` runs
/// benches too, without it, and gets a quick pass instead.
pub fn is_bench_run() -> bool {
    std::env::args().any(|a| a == "--bench")
}

/// The median of `values` (NaN for none).
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0,
    }
}

/// The nearest-rank quantile `q` of already sorted values (NaN for none).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// The arithmetic mean (NaN for none).
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// One figure over its repeats: the median and the range.
#[derive(Debug, Clone, Copy)]
pub struct Spread {
    /// The median over the repeats.
    pub median: f64,
    /// The smallest and the largest repeat.
    pub min: f64,
    pub max: f64,
    /// How many repeats.
    pub n: usize,
}

impl Spread {
    /// The spread of `values`, one per repeat.
    pub fn of(values: &[f64]) -> Spread {
        Spread {
            median: median(values),
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            n: values.len(),
        }
    }

    /// The spread of `f` applied to each repeat.
    pub fn over<T>(repeats: &[T], f: impl Fn(&T) -> f64) -> Spread {
        Spread::of(&repeats.iter().map(f).collect::<Vec<_>>())
    }

    /// "median (min–max)" with `decimals` decimals.
    pub fn show(&self, decimals: usize) -> String {
        if self.n == 0 {
            return "n/a".into();
        }
        if self.n == 1 {
            return format!("{:.*}", decimals, self.median);
        }
        format!(
            "{:.*} ({:.*}–{:.*})",
            decimals, self.median, decimals, self.min, decimals, self.max
        )
    }

    /// The spread of `self / other`, repeat by repeat, when both come from the same repeats
    /// (the k-th of each measured side by side).
    pub fn ratio(ours: &[f64], theirs: &[f64]) -> Spread {
        let ratios: Vec<f64> = ours.iter().zip(theirs).map(|(a, b)| a / b).collect();
        Spread::of(&ratios)
    }
}

/// Points keypose's Python environment (MuJoCo, the vendor SDKs) at the one the tests build in
/// the target directory, unless `KEYPOSE_CACHE` or `KEYPOSE_PYTHON` says otherwise: one
/// environment for every bench and test instead of one each. Call it before any thread starts.
pub fn use_shared_python_cache() {
    if std::env::var_os("KEYPOSE_CACHE").is_none() && std::env::var_os("KEYPOSE_PYTHON").is_none() {
        std::env::set_var(
            "KEYPOSE_CACHE",
            std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("python_cache"),
        );
    }
}

/// The interpreter of keypose's Python environment (built first if it is not there), for a
/// bench's own Python peer script.
pub fn python() -> Result<std::path::PathBuf, String> {
    let config = keypose::python::PyConfig::from_env().map_err(|e| e.to_string())?;
    let env = config.ensure_python().map_err(|e| e.to_string())?;
    Ok(env.python)
}

/// A script of the benches' own (`benches/NAME`), by its path in the source tree.
pub fn bench_script(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("benches")
        .join(name)
}
