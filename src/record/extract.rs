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
//! motion (250–450 keys at 1°): 0.35–1.1 s on a shared 2-core machine, 0.6–1.9 % of the
//! recording's length; against classic Ramer–Douglas–Peucker in the same run, 24 % fewer keys
//! where both fit (linear; RDP's keys do not fit the cubic and monotone curves) for 770–1500×
//! its time (`cargo bench --bench record`, docs/benchmarks.md).
//!
//! It is a heuristic, not guaranteed minimal: `tests/motion/record_extract.rs` checks that recordings
//! made from five keys come back with at most five, and that a four times looser tolerance
//! never needs more keys; between close tolerances the count can now and then go up by one.

mod measure;
mod search;

use crate::curve::{CurveError, Interp, Track, TrackKey, MIN_MOVING_TIME};
use measure::Deviation;
use search::Problem;

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

/// Why keys cannot be extracted from a recording. Joints and samples are counted from 0.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExtractError {
    /// No sample times were given.
    #[error("the recording has no samples")]
    Empty,
    /// No joint values were given.
    #[error("the recording has no joints")]
    NoJoints,
    /// A joint has not one value per sample time.
    #[error("joint {joint}: {found} values for {expected} sample times")]
    LengthMismatch {
        /// The joint.
        joint: usize,
        /// Its number of values.
        found: usize,
        /// The number of sample times.
        expected: usize,
    },
    /// A sample time is NaN or infinite.
    #[error("sample {index}: time must be a finite number of seconds")]
    NonFiniteTime {
        /// The sample.
        index: usize,
    },
    /// A sample time is not after the previous one.
    #[error("sample {index}: time {time} s is not after the previous sample's {previous} s")]
    NotIncreasing {
        /// The sample.
        index: usize,
        /// Its time, seconds.
        time: f64,
        /// The previous sample's time, seconds.
        previous: f64,
    },
    /// A value is NaN or infinite.
    #[error("joint {joint}, sample {index}: the value is not a finite number")]
    NonFiniteValue {
        /// The joint.
        joint: usize,
        /// The sample.
        index: usize,
    },
    /// A tolerance is not a finite number above 0.
    #[error("joint {joint}: the tolerance must be a finite number above 0, found {tolerance}")]
    BadTolerance {
        /// The joint.
        joint: usize,
        /// The tolerance given, in the joint's unit.
        tolerance: f64,
    },
    /// Not one tolerance per joint.
    #[error("{expected} tolerances needed (one per joint), found {found}")]
    ToleranceCount {
        /// The number of joints.
        expected: usize,
        /// The number of tolerances.
        found: usize,
    },
    /// Not one segment mode per sample.
    #[error("{expected} segment modes needed (one per sample), found {found}")]
    ModeCount {
        /// The number of samples.
        expected: usize,
        /// The number of modes.
        found: usize,
    },
    /// The keys chosen do not make a track (a bug if it happens).
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
pub(crate) fn extract_with_modes(
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
    let mut problem = Problem::new(times, values, modes, tolerances);
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
pub(crate) fn deviations_with_modes(
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
