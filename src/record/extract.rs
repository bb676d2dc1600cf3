//! Keyframes from a recording: the fewest keys whose interpolated curve stays within a tolerance
//! of every recorded sample, on every joint.
//!
//! # The problem
//!
//! Samples `(t_k, v_jk)`, k = 0 … N−1, joint j = 0 … J−1. The keys are a subset S of the sample
//! indices, shared by all joints (one keyframe list), that always holds the first and the last
//! sample: before the first key and after the last a track holds its end value, so there is
//! nothing to fit outside them. A key takes the recorded values and the recorded time of its
//! sample (so the file shows poses the arm really took). The curve of joint j is the real
//! [`Track`] through `(t_s, v_js)`, s ∈ S, in the chosen mode — the very curve `plan` builds from
//! the saved file — and S *fits* when `|curve_j(t_k) − v_jk| ≤ tol_j` for every j and k.
//!
//! The smallest S is a shortest path in which a segment's shape depends on four keys (a key's
//! slope depends on both neighbours; monotone limiting on the segments either side), so its
//! states are key triples: O(N⁴) for N = 6000 samples, out of reach. Instead, a local search that
//! only ever accepts key sets that fit, from the better of two starting points:
//!
//! 1. **Greedy insertion.** Add a key at the sample with the largest deviation (relative to its
//!    joint's tolerance) until every sample fits. A sample that is a key has deviation 0, so each
//!    step adds a new key and the loop ends (at worst with every sample a key, which fits).
//! 2. **Removal by priority.** Remove the key whose removal costs least (the largest deviation
//!    of the curve without it) while that cost is within tolerance.
//! 3. **Merging.** Insertion puts keys at error peaks, near but not at the best places, so two
//!    keys often do the work of one placed well: replace two neighbouring keys by the best single
//!    key between their neighbours when the curve still fits. Then removal again.
//! 4. **Removal with slides.** Remove one key, or two neighbouring ones, and let the four keys
//!    around the gap slide (coordinate descent: each moves to the sample between its neighbours
//!    that minimises the squared deviations of the segments it shapes, coarse steps then halving,
//!    three rounds); keep the result if it fits. This is what finds the keys of a recording that
//!    *is* a keyed curve: once the right number of keys sits near the right samples, sliding
//!    brings them onto the samples where the deviation vanishes.
//!
//! The starting points are the first and last sample alone, and the fewest segments *if every
//! key had the recording's own slope* (central differences): then a segment depends on its two
//! keys only, the fewest keys are a shortest path, and the farthest fitting end from each sample
//! is found by doubling then halving (exact for linear, where slopes do not matter; a good guess
//! otherwise). Each goes through steps 1–3 (greedy insertion first repairs what the guess got
//! wrong); the one with fewer keys goes on through steps 1–4, repeated until a sweep removes
//! nothing.
//!
//! Every candidate is judged only on the samples its change can reach, with a sub-track of the
//! keys around it (with enough keys of context that the slopes there are those of the whole
//! track), so a judgement costs O(J·W) for a window of W samples, not O(J·N). Monotone limiting
//! runs segment after segment, so rarely a change reaches further than its window: the final
//! judge is a full evaluation with whole tracks, and any sample out of tolerance sends the search
//! back to insertion. A failed removal-with-slides is remembered with the keys it depended on and
//! not tried again while they stay.
//!
//! # Cost
//!
//! With N samples, J joints, K keys and W ≈ 6N/K samples in a window: insertion
//! O(K·(J·W + N/64)) (block maxima find the worst sample); removal O(K·J·W + K²); a merging
//! sweep tries ~3N/K positions per pair, O(N·J·W), cut short once a candidate is worse than the
//! best so far; the slope start O(N·J·L·log L) for segments of L samples; a sweep of removals
//! with slides ~150 window judgements per key, O(K·J·W) — so all of it grows about linearly with
//! the length of the recording. Measured in a release build on 60 s at 100 Hz × 6 joints of busy
//! motion (250–450 keys at 1°): 0.9–1.4 s, under 2.5 % of the recording's length; against
//! top-down greedy insertion in the same run, about 30 % fewer keys for 4–10× its time
//! (`cargo bench --bench record`).
//!
//! It is a heuristic, not guaranteed minimal: `tests/record_extract.rs` checks that recordings
//! made from five keys come back with at most five, and that a four times looser tolerance
//! never needs more keys; between close tolerances the count can now and then go up by one.

use crate::curve::{CurveError, Interp, Track, TrackKey, MIN_MOVING_TIME};
use std::collections::HashSet;

/// Samples per block of the deviation maxima used to find the worst sample.
const BLOCK: usize = 64;
/// Sweeps of steps 2–4 at most; each sweep that changes something removes a key, so this only
/// bounds pathological inputs.
const MAX_SWEEPS: usize = 50;
/// Rounds of slides of the keys around a removal.
const SLIDE_ROUNDS: usize = 3;
/// Keys on either side of the gap that slide after a removal.
const SLIDE_BEFORE: usize = 2;
const SLIDE_AFTER: usize = 2;
/// Longest segment, in samples, that the second starting point tries: long stills are then
/// split, and removal joins them again.
const MAX_START_SPAN: usize = 256;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExtractError {
    #[error("the recording has no samples")]
    Empty,
    #[error("the recording has no joints")]
    NoJoints,
    #[error("joint {joint}: {found} values for {expected} sample times")]
    LengthMismatch {
        joint: usize,
        found: usize,
        expected: usize,
    },
    #[error("sample {index}: time must be a finite number of seconds")]
    NonFiniteTime { index: usize },
    #[error("sample {index}: time {time} s is not after the previous sample's {previous} s")]
    NotIncreasing {
        index: usize,
        time: f64,
        previous: f64,
    },
    #[error("joint {joint}, sample {index}: the value is not a finite number")]
    NonFiniteValue { joint: usize, index: usize },
    #[error("joint {joint}: the tolerance must be a finite number above 0, found {tolerance}")]
    BadTolerance { joint: usize, tolerance: f64 },
    #[error("{expected} tolerances needed (one per joint), found {found}")]
    ToleranceCount { expected: usize, found: usize },
    #[error("{expected} segment modes needed (one per sample), found {found}")]
    ModeCount { expected: usize, found: usize },
    #[error("the curve through the keys cannot be built: {0}")]
    Curve(#[from] CurveError),
}

/// How far one joint's curve strays from its recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDeviation {
    /// Largest |curve − sample|, in the joint's unit.
    pub max: f64,
    /// Index of the sample where it occurs (the first one if several tie).
    pub sample: usize,
}

/// The keys chosen for a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Sample indices of the keys, increasing, from the first sample to the last.
    pub keys: Vec<usize>,
    /// Each joint's largest deviation, from a full evaluation with whole tracks.
    pub deviations: Vec<JointDeviation>,
    /// The joint whose largest deviation is the largest share of its tolerance.
    pub worst_joint: usize,
}

/// The fewest keys (by the method above) whose curve in `mode` stays within `tolerances[j]` of
/// `values[j][k]` at `times[k]` for every joint j and sample k.
pub fn extract(
    times: &[f64],
    values: &[Vec<f64>],
    tolerances: &[f64],
    mode: Interp,
) -> Result<Fit, ExtractError> {
    extract_with_modes(times, values, tolerances, &vec![mode; times.len()])
}

/// As [`extract`], with the mode of each segment given by the sample its first key sits on:
/// `modes[k]` is the mode of the segment after a key at sample k.
pub fn extract_with_modes(
    times: &[f64],
    values: &[Vec<f64>],
    tolerances: &[f64],
    modes: &[Interp],
) -> Result<Fit, ExtractError> {
    validate(times, values, modes)?;
    if tolerances.len() != values.len() {
        return Err(ExtractError::ToleranceCount {
            expected: values.len(),
            found: tolerances.len(),
        });
    }
    for (joint, &tolerance) in tolerances.iter().enumerate() {
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(ExtractError::BadTolerance { joint, tolerance });
        }
    }
    let mut problem = Problem {
        times,
        values,
        modes,
        inv_tolerance: tolerances.iter().map(|t| 1.0 / t).collect(),
        window: Window::for_modes(modes),
        scratch: Vec::new(),
        failed: HashSet::new(),
    };
    let n = times.len();
    let mut deviation = Deviation::new(n);
    let ends = if n == 1 { vec![0] } else { vec![0, n - 1] };
    // Two starting points through the cheap steps; the one with fewer keys goes on.
    let from_ends = problem.search(ends, false, &mut deviation)?;
    let start = problem.start_from_slopes();
    let from_slopes = problem.search(start, false, &mut deviation)?;
    let start = if from_slopes.len() < from_ends.len() {
        from_slopes
    } else {
        from_ends
    };
    let keys = problem.search(start, true, &mut deviation)?;
    let deviations = deviations_with_modes(times, values, &keys, modes)?;
    // The first joint among equals, so a still recording names the first joint.
    let mut worst_joint = 0;
    for (j, d) in deviations.iter().enumerate() {
        if d.max / tolerances[j] > deviations[worst_joint].max / tolerances[worst_joint] {
            worst_joint = j;
        }
    }
    Ok(Fit {
        keys,
        deviations,
        worst_joint,
    })
}

/// Each joint's largest deviation between its recording and the curve through `keys` (sample
/// indices, increasing) in `mode`: a full evaluation with whole tracks.
pub fn deviations(
    times: &[f64],
    values: &[Vec<f64>],
    keys: &[usize],
    mode: Interp,
) -> Result<Vec<JointDeviation>, ExtractError> {
    deviations_with_modes(times, values, keys, &vec![mode; times.len()])
}

/// As [`deviations`], with per-sample segment modes as in [`extract_with_modes`].
pub fn deviations_with_modes(
    times: &[f64],
    values: &[Vec<f64>],
    keys: &[usize],
    modes: &[Interp],
) -> Result<Vec<JointDeviation>, ExtractError> {
    validate(times, values, modes)?;
    let mut out = Vec::with_capacity(values.len());
    for series in values {
        let track = joint_track(times, series, modes, keys)?;
        let mut cursor = track.cursor();
        let mut worst = JointDeviation {
            max: 0.0,
            sample: keys.first().copied().unwrap_or(0),
        };
        for (k, (&t, &v)) in times.iter().zip(series).enumerate() {
            let d = (cursor.sample(t) - v).abs();
            if d > worst.max {
                worst = JointDeviation { max: d, sample: k };
            }
        }
        out.push(worst);
    }
    Ok(out)
}

fn validate(times: &[f64], values: &[Vec<f64>], modes: &[Interp]) -> Result<(), ExtractError> {
    if times.is_empty() {
        return Err(ExtractError::Empty);
    }
    if values.is_empty() {
        return Err(ExtractError::NoJoints);
    }
    if modes.len() != times.len() {
        return Err(ExtractError::ModeCount {
            expected: times.len(),
            found: modes.len(),
        });
    }
    for (index, &time) in times.iter().enumerate() {
        if !time.is_finite() {
            return Err(ExtractError::NonFiniteTime { index });
        }
        // Samples closer than a track's shortest moving time could not both be keys.
        let too_close = index > 0 && (time - times[index - 1] < MIN_MOVING_TIME);
        if too_close {
            return Err(ExtractError::NotIncreasing {
                index,
                time,
                previous: times[index - 1],
            });
        }
    }
    for (joint, series) in values.iter().enumerate() {
        if series.len() != times.len() {
            return Err(ExtractError::LengthMismatch {
                joint,
                found: series.len(),
                expected: times.len(),
            });
        }
        if let Some(index) = series.iter().position(|v| !v.is_finite()) {
            return Err(ExtractError::NonFiniteValue { joint, index });
        }
    }
    Ok(())
}

fn joint_track(
    times: &[f64],
    series: &[f64],
    modes: &[Interp],
    keys: &[usize],
) -> Result<Track<f64>, CurveError> {
    let keys: Vec<TrackKey<f64>> = keys
        .iter()
        .map(|&s| TrackKey::new(times[s], series[s], modes[s]))
        .collect();
    Track::new(&keys)
}

/// The largest deviation of every sample over all joints, as a share of the joint's tolerance,
/// with per-block maxima so that the worst sample is found in O(N/BLOCK + BLOCK).
struct Deviation {
    values: Vec<f64>,
    block_max: Vec<f64>,
}

impl Deviation {
    fn new(n: usize) -> Self {
        Self {
            values: vec![0.0; n],
            block_max: vec![0.0; n.div_ceil(BLOCK)],
        }
    }

    /// Replaces the values from sample `start` on.
    fn set(&mut self, start: usize, values: &[f64]) {
        if values.is_empty() {
            return;
        }
        self.values[start..start + values.len()].copy_from_slice(values);
        for block in start / BLOCK..=(start + values.len() - 1) / BLOCK {
            let end = ((block + 1) * BLOCK).min(self.values.len());
            self.block_max[block] = self.values[block * BLOCK..end]
                .iter()
                .copied()
                .fold(0.0, f64::max);
        }
    }

    /// The worst sample and its deviation.
    fn worst(&self) -> (usize, f64) {
        let mut best_block = 0;
        for (b, &m) in self.block_max.iter().enumerate() {
            if m > self.block_max[best_block] {
                best_block = b;
            }
        }
        let start = best_block * BLOCK;
        let end = (start + BLOCK).min(self.values.len());
        let mut best = (start, self.values[start]);
        for k in start..end {
            if self.values[k] > best.1 {
                best = (k, self.values[k]);
            }
        }
        best
    }
}

/// How far a change of keys reaches, in segments and keys.
#[derive(Debug, Clone, Copy)]
struct Window {
    /// Segments before and after the keys whose neighbours changed that can change shape.
    before: usize,
    after: usize,
    /// Keys of context beyond the judged segments, so that their keys get the slopes of the
    /// whole track.
    context: usize,
}

impl Window {
    fn for_modes(modes: &[Interp]) -> Window {
        if modes.contains(&Interp::Monotone) {
            // A key whose neighbour changed gets a new slope; monotone limiting of the segments
            // on either side of it can then scale the slopes of the keys beyond, which shape one
            // more segment on each side (and limiting runs left to right, so the slope of the key
            // before the judged segments depends on the segment before it too).
            Window {
                before: 2,
                after: 1,
                context: 2,
            }
        } else {
            // Catmull-Rom: a key's slope depends on its two neighbours only.
            Window {
                before: 1,
                after: 0,
                context: 1,
            }
        }
    }

    /// The segments to judge after the keys at positions `lo..=hi` of a list of `len` keys got
    /// new neighbours: (first, last), or None when there is no segment.
    fn segments(&self, len: usize, lo: usize, hi: usize) -> Option<(usize, usize)> {
        if len < 2 {
            return None;
        }
        Some((
            lo.saturating_sub(self.before),
            (hi + self.after).min(len - 2),
        ))
    }

    /// The keys (first, last positions) of the sub-track that judges segments `first..=last`.
    fn keys(&self, len: usize, first: usize, last: usize) -> (usize, usize) {
        (
            first.saturating_sub(self.context),
            (last + 1 + self.context).min(len - 1),
        )
    }

    /// Keys on either side of a removal-with-slides that its outcome depends on: the sliding
    /// keys, the segments their moves reach, and context.
    fn slide_depends(&self) -> usize {
        SLIDE_BEFORE.max(SLIDE_AFTER) + 2 + self.before.max(self.after) + self.context
    }
}

/// Largest and sum of squared normalised deviations over a window.
#[derive(Debug, Clone, Copy)]
struct Score {
    max: f64,
    squares: f64,
}

/// When a judgement may stop: once the largest deviation or the sum of squares passes these.
#[derive(Debug, Clone, Copy)]
struct Bound {
    max: f64,
    squares: f64,
}

impl Bound {
    const NONE: Bound = Bound {
        max: f64::INFINITY,
        squares: f64::INFINITY,
    };

    fn max(max: f64) -> Bound {
        Bound {
            max,
            squares: f64::INFINITY,
        }
    }

    fn squares(squares: f64) -> Bound {
        Bound {
            max: f64::INFINITY,
            squares,
        }
    }
}

struct Problem<'a> {
    times: &'a [f64],
    values: &'a [Vec<f64>],
    modes: &'a [Interp],
    inv_tolerance: Vec<f64>,
    window: Window,
    /// Per-sample deviations of the window being judged (reused between calls).
    scratch: Vec<f64>,
    /// Removals with slides that failed, by the keys they depended on: the same keys fail
    /// again, so later sweeps skip them.
    failed: HashSet<Vec<usize>>,
}

impl Problem<'_> {
    /// Judges segments `first..=last` of the curve through `local` (a run of keys that, beyond
    /// the judged segments, carries context keys or reaches the true ends). Stops early once the
    /// score passes `bound`; with `store`, never stops and leaves every sample's deviation (over
    /// all joints) in `self.scratch`.
    fn score(
        &mut self,
        local: &[usize],
        first: usize,
        last: usize,
        bound: Bound,
        store: bool,
    ) -> Result<Score, CurveError> {
        let (from, to) = (local[first], local[last + 1]);
        if store {
            self.scratch.clear();
            self.scratch.resize(to - from + 1, 0.0);
        }
        let mut score = Score {
            max: 0.0,
            squares: 0.0,
        };
        for (j, series) in self.values.iter().enumerate() {
            let track = joint_track(self.times, series, self.modes, local)?;
            let mut cursor = track.cursor();
            let scale = self.inv_tolerance[j];
            let samples = self.times[from..=to].iter().zip(&series[from..=to]);
            for (i, (&t, &v)) in samples.enumerate() {
                let d = (cursor.sample(t) - v).abs() * scale;
                score.squares += d * d;
                score.max = score.max.max(d);
                if store {
                    let slot = &mut self.scratch[i];
                    *slot = slot.max(d);
                }
            }
            if !store && (score.max > bound.max || score.squares > bound.squares) {
                break;
            }
        }
        Ok(score)
    }

    /// Judges segments `first..=last` of the curve through all of `keys`, on a sub-track.
    fn score_keys(
        &mut self,
        keys: &[usize],
        first: usize,
        last: usize,
        bound: Bound,
    ) -> Result<Score, CurveError> {
        let (a, b) = self.window.keys(keys.len(), first, last);
        self.score(&keys[a..=b], first - a, last - a, bound, false)
    }

    /// The largest deviation of the curve in which `keys[from..to]` are replaced by
    /// `replacement` (samples strictly between `keys[from - 1]` and `keys[to]`), over the samples
    /// the change can reach. Stops early once past `bound`.
    fn trial(
        &mut self,
        keys: &[usize],
        from: usize,
        to: usize,
        replacement: &[usize],
        bound: f64,
    ) -> Result<f64, CurveError> {
        let len = keys.len() - (to - from) + replacement.len();
        let Some((first, last)) =
            self.window
                .segments(len, from.saturating_sub(1), from + replacement.len())
        else {
            return Ok(0.0);
        };
        let (lo, hi) = self.window.keys(len, first, last);
        let local: Vec<usize> = (lo..=hi)
            .map(|i| {
                if i < from {
                    keys[i]
                } else if i < from + replacement.len() {
                    replacement[i - from]
                } else {
                    keys[i - from - replacement.len() + to]
                }
            })
            .collect();
        Ok(self
            .score(&local, first - lo, last - lo, Bound::max(bound), false)?
            .max)
    }

    /// Every sample against the whole tracks into `deviation`; returns the largest deviation.
    fn evaluate_all(
        &mut self,
        keys: &[usize],
        deviation: &mut Deviation,
    ) -> Result<f64, CurveError> {
        if keys.len() < 2 {
            return Ok(0.0);
        }
        self.score(keys, 0, keys.len() - 2, Bound::NONE, true)?;
        deviation.set(0, &self.scratch);
        Ok(deviation.worst().1)
    }

    /// Step 1: a key at the worst sample until every sample fits (as far as windows tell).
    fn insert_until_fit(
        &mut self,
        keys: &mut Vec<usize>,
        deviation: &mut Deviation,
    ) -> Result<(), CurveError> {
        self.evaluate_all(keys, deviation)?;
        loop {
            let (sample, worst) = deviation.worst();
            if worst <= 1.0 {
                return Ok(());
            }
            let p = keys.partition_point(|&k| k < sample);
            keys.insert(p, sample);
            let Some((first, last)) = self.window.segments(keys.len(), p.saturating_sub(1), p + 1)
            else {
                return Ok(());
            };
            let (a, b) = self.window.keys(keys.len(), first, last);
            self.score(&keys[a..=b], first - a, last - a, Bound::NONE, true)?;
            deviation.set(keys[first], &self.scratch);
        }
    }

    /// Steps 1–3 (`slides` false) or 1–4 from `keys`, repeated until a sweep removes nothing and
    /// the whole tracks fit. After MAX_SWEEPS sweeps only insertion runs: a removal judged on a
    /// window that the whole tracks then reject could otherwise alternate with its repair.
    fn search(
        &mut self,
        mut keys: Vec<usize>,
        slides: bool,
        deviation: &mut Deviation,
    ) -> Result<Vec<usize>, CurveError> {
        let mut sweeps = 0;
        loop {
            self.insert_until_fit(&mut keys, deviation)?;
            let mut changed = false;
            if sweeps < MAX_SWEEPS {
                let before = keys.len();
                self.remove_while_fit(&mut keys)?;
                self.merge_pairs(&mut keys)?;
                self.remove_while_fit(&mut keys)?;
                if slides {
                    self.remove_with_slides(&mut keys, 1)?;
                    self.remove_with_slides(&mut keys, 2)?;
                }
                // Every accepted move removes a key, so the same count means the same keys.
                changed = keys.len() != before;
                sweeps += 1;
            }
            // The whole tracks are the judge: windows are exact except where monotone limiting
            // carries a change further, which insertion then repairs.
            if self.evaluate_all(&keys, deviation)? <= 1.0 && !changed {
                return Ok(keys);
            }
        }
    }

    /// The recording's own slope at every sample of every joint (central differences; zero at
    /// the ends, where the curve rests).
    fn slopes(&self) -> Vec<Vec<f64>> {
        let t = self.times;
        let n = t.len();
        self.values
            .iter()
            .map(|v| {
                (0..n)
                    .map(|k| {
                        if k == 0 || k + 1 >= n {
                            0.0
                        } else {
                            (v[k + 1] - v[k - 1]) / (t[k + 1] - t[k - 1])
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Whether one segment from sample a to sample b, shaped with the recording's own slopes,
    /// stays within tolerance of the samples between.
    fn segment_fits(&self, slopes: &[Vec<f64>], a: usize, b: usize) -> bool {
        let (ta, h) = (self.times[a], self.times[b] - self.times[a]);
        let mode = self.modes[a];
        for (j, v) in self.values.iter().enumerate() {
            let c = match mode {
                Interp::Step => [v[a], 0.0, 0.0, 0.0],
                Interp::Linear => [v[a], v[b] - v[a], 0.0, 0.0],
                Interp::Cubic | Interp::Monotone => {
                    let (da, db) = (slopes[j][a] * h, slopes[j][b] * h);
                    let delta = v[b] - v[a];
                    [
                        v[a],
                        da,
                        3.0 * delta - 2.0 * da - db,
                        -2.0 * delta + da + db,
                    ]
                }
            };
            for (&t, &value) in self.times[a + 1..b].iter().zip(&v[a + 1..b]) {
                let f = (t - ta) / h;
                let x = c[0] + f * (c[1] + f * (c[2] + f * c[3]));
                if (x - value).abs() * self.inv_tolerance[j] > 1.0 {
                    return false;
                }
            }
        }
        true
    }

    /// A second starting point: the fewest segments when every key had the recording's own
    /// slope, so that a segment depends on its two keys only and the fewest keys are a shortest
    /// path. Assumes (as holds nearly always) that if a segment from a fits, so do the shorter
    /// ones: then the farthest end from each a, found by doubling then halving, is all it needs.
    fn start_from_slopes(&self) -> Vec<usize> {
        let n = self.times.len();
        if n <= 2 {
            return (0..n).collect();
        }
        let slopes = self.slopes();
        // Count of segments to reach each sample, and from where.
        let mut count = vec![usize::MAX; n];
        let mut from = vec![0usize; n];
        count[0] = 0;
        for a in 0..n - 1 {
            if count[a] == usize::MAX {
                continue;
            }
            let limit = (n - 1).min(a + MAX_START_SPAN);
            let mut fits = a + 1;
            let mut step = 1;
            let mut fails = None;
            while fits < limit {
                let b = (a + 2 * step).min(limit);
                if self.segment_fits(&slopes, a, b) {
                    fits = b;
                    step *= 2;
                } else {
                    fails = Some(b);
                    break;
                }
            }
            if let Some(mut bad) = fails {
                while bad - fits > 1 {
                    let mid = fits + (bad - fits) / 2;
                    if self.segment_fits(&slopes, a, mid) {
                        fits = mid;
                    } else {
                        bad = mid;
                    }
                }
            }
            for b in a + 1..=fits {
                if count[a] + 1 < count[b] {
                    count[b] = count[a] + 1;
                    from[b] = a;
                }
            }
        }
        let mut keys = vec![n - 1];
        let mut k = n - 1;
        while k > 0 {
            k = from[k];
            keys.push(k);
        }
        keys.reverse();
        keys
    }

    /// The largest deviation without interior key `p` (infinite for the end keys).
    fn removal_cost(&mut self, keys: &[usize], p: usize) -> Result<f64, CurveError> {
        if p == 0 || p + 1 >= keys.len() {
            return Ok(f64::INFINITY);
        }
        self.trial(keys, p, p + 1, &[], f64::INFINITY)
    }

    /// Step 2: remove the key whose removal costs least, while the curve still fits.
    fn remove_while_fit(&mut self, keys: &mut Vec<usize>) -> Result<(), CurveError> {
        let mut cost = Vec::with_capacity(keys.len());
        for p in 0..keys.len() {
            cost.push(self.removal_cost(keys, p)?);
        }
        // A key's cost depends on the keys its window and context span.
        let radius = self.window.before + self.window.after + 2 * self.window.context + 3;
        loop {
            let Some((p, &c)) = cost.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)) else {
                return Ok(());
            };
            if c > 1.0 {
                return Ok(());
            }
            keys.remove(p);
            cost.remove(p);
            let (lo, hi) = (p.saturating_sub(radius), (p + radius).min(keys.len()));
            for (q, slot) in cost.iter_mut().enumerate().take(hi).skip(lo) {
                *slot = self.removal_cost(keys, q)?;
            }
        }
    }

    /// Step 3: one sweep replacing two neighbouring interior keys by the single key between
    /// their neighbours that fits best, where one fits.
    fn merge_pairs(&mut self, keys: &mut Vec<usize>) -> Result<(), CurveError> {
        let mut p = 1;
        while p + 2 < keys.len() {
            let (left, right) = (keys[p - 1], keys[p + 2]);
            let mut best: Option<(usize, f64)> = None;
            for s in left + 1..right {
                let bound = best.map_or(1.0, |b| b.1);
                let d = self.trial(keys, p, p + 2, &[s], bound)?;
                if d <= bound && best.is_none_or(|b| d < b.1) {
                    best = Some((s, d));
                }
            }
            if let Some((s, _)) = best {
                keys.splice(p..p + 2, [s]);
            }
            p += 1;
        }
        Ok(())
    }

    /// Moves interior key `q` to the sample between its neighbours that minimises the squared
    /// deviations of the segments it shapes (the others do not change as it moves): coarse
    /// steps first, then halving around the best. Returns whether it moved.
    fn slide(&mut self, keys: &mut [usize], q: usize) -> Result<bool, CurveError> {
        let (left, right) = (keys[q - 1], keys[q + 1]);
        let current = keys[q];
        let Some((first, last)) = self.window.segments(keys.len(), q - 1, q + 1) else {
            return Ok(false);
        };
        if right - left < 3 {
            return Ok(false);
        }
        let mut best = (
            self.score_keys(keys, first, last, Bound::NONE)?.squares,
            current,
        );
        let mut step = ((right - left) / 8).max(1);
        let mut s = left + 1;
        while s < right {
            self.try_slide(keys, q, s, (first, last), &mut best)?;
            s += step;
        }
        while step > 1 {
            step = step.div_ceil(2);
            let centre = best.1;
            for s in [centre.saturating_sub(step), centre + step] {
                if s > left && s < right {
                    self.try_slide(keys, q, s, (first, last), &mut best)?;
                }
            }
            if step == 1 {
                break;
            }
        }
        keys[q] = best.1;
        Ok(best.1 != current)
    }

    /// Key `q` at sample `s`: the new best (squares, sample) if it beats `best`.
    fn try_slide(
        &mut self,
        keys: &mut [usize],
        q: usize,
        s: usize,
        (first, last): (usize, usize),
        best: &mut (f64, usize),
    ) -> Result<(), CurveError> {
        keys[q] = s;
        let e = self
            .score_keys(keys, first, last, Bound::squares(best.0))?
            .squares;
        if e < best.0 {
            *best = (e, s);
        }
        Ok(())
    }

    /// Step 4: remove `count` neighbouring keys and let the keys around the gap slide to take up
    /// their work; keep the result if it fits. Tries every interior key once, cheapest plain
    /// removal first.
    fn remove_with_slides(
        &mut self,
        keys: &mut Vec<usize>,
        count: usize,
    ) -> Result<(), CurveError> {
        let mut order: Vec<(f64, usize)> = Vec::new();
        for p in 1..keys.len().saturating_sub(1) {
            order.push((self.removal_cost(keys, p)?, keys[p]));
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let depends = self.window.slide_depends();
        for (_, sample) in order {
            let Ok(p) = keys.binary_search(&sample) else {
                continue;
            };
            if p == 0 || p + count >= keys.len() {
                continue;
            }
            // The move itself first: near the ends, several moves share one run of keys.
            let mut signature = vec![count, keys[p]];
            signature.extend_from_slice(
                &keys[p.saturating_sub(depends)..(p + count + depends).min(keys.len())],
            );
            if self.failed.contains(&signature) {
                continue;
            }
            let mut trial = keys.clone();
            trial.drain(p..p + count);
            // Sliding keys, by their new positions: the gap is between p − 1 and p.
            let sliding: Vec<usize> = (p.saturating_sub(SLIDE_BEFORE)..p + SLIDE_AFTER)
                .filter(|&q| q >= 1 && q + 1 < trial.len())
                .collect();
            let Some((first, last)) = self.window.segments(
                trial.len(),
                p.saturating_sub(SLIDE_BEFORE + 1),
                (p + SLIDE_AFTER).min(trial.len() - 1),
            ) else {
                continue;
            };
            for _ in 0..SLIDE_ROUNDS {
                let mut moved = false;
                for &q in &sliding {
                    moved |= self.slide(&mut trial, q)?;
                }
                if !moved {
                    break;
                }
            }
            if self.score_keys(&trial, first, last, Bound::max(1.0))?.max <= 1.0 {
                *keys = trial;
            } else {
                self.failed.insert(signature);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_sample_is_found_across_blocks() {
        let mut d = Deviation::new(200);
        d.set(0, &[0.5; 200]);
        d.set(130, &[0.7, 2.0, 0.1]);
        assert_eq!(d.worst(), (131, 2.0));
        d.set(131, &[0.0]);
        assert_eq!(d.worst(), (130, 0.7));
    }

    #[test]
    fn a_trial_judges_the_replaced_keys() {
        // A line with one sample 3 above it, in linear mode: without a key there, or with the
        // key beside it, that sample is 3 off.
        let times: Vec<f64> = (0..11).map(f64::from).collect();
        let line: Vec<f64> = times.iter().map(|t| 2.0 * t).collect();
        let mut bent = line.clone();
        bent[5] += 3.0;
        let values = vec![bent];
        let modes = vec![Interp::Linear; 11];
        let mut problem = Problem {
            times: &times,
            values: &values,
            modes: &modes,
            inv_tolerance: vec![1.0],
            window: Window::for_modes(&modes),
            scratch: Vec::new(),
            failed: HashSet::new(),
        };
        let keys = [0, 5, 10];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        let without_middle = problem.trial(&keys, 1, 2, &[], f64::INFINITY).unwrap();
        assert!(close(without_middle, 3.0), "{without_middle}");
        let moved = problem.trial(&keys, 1, 2, &[4], f64::INFINITY).unwrap();
        assert!(close(moved, 3.0), "{moved}");
        // A key on the bent sample pulls its neighbours off the line: 4/5 · 13 − 8 = 2.4.
        let inserted = problem.trial(&[0, 10], 1, 1, &[5], f64::INFINITY).unwrap();
        assert!(close(inserted, 2.4), "{inserted}");
    }
}
