//! Keyframe extraction on synthetic recordings whose answers are known by hand. The oracle for
//! every deviation is a brute-force evaluation here: the real `curve::Track` through the chosen
//! keys, sampled at every recorded time, compared with every recorded value.

use keypose::curve::{Interp, Track, TrackKey};
use keypose::record::{deviations, extract, ExtractError, Fit};
use proptest::prelude::*;

const RATE: f64 = 100.0;

/// Sample times k/RATE for k = 0 … n−1 (computed from k, so no rounding accumulates).
fn grid(n: usize) -> Vec<f64> {
    (0..n).map(|k| k as f64 / RATE).collect()
}

/// The largest |curve − sample| of each joint for the curve through `keys`, by brute force.
fn brute_force(times: &[f64], values: &[Vec<f64>], keys: &[usize], mode: Interp) -> Vec<f64> {
    values
        .iter()
        .map(|series| {
            let track_keys: Vec<_> = keys
                .iter()
                .map(|&k| TrackKey::new(times[k], series[k], mode))
                .collect();
            let track = Track::new(&track_keys).expect("keys in time order");
            times
                .iter()
                .zip(series)
                .map(|(&t, &v)| (track.sample(t) - v).abs())
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Checks the invariants every fit has: keys increasing from the first sample to the last, the
/// reported deviations equal to a brute-force recomputation, all within tolerance.
fn assert_fits(times: &[f64], values: &[Vec<f64>], tolerances: &[f64], mode: Interp, fit: &Fit) {
    assert_eq!(fit.keys.first(), Some(&0));
    assert_eq!(fit.keys.last(), Some(&(times.len() - 1)));
    assert!(fit.keys.windows(2).all(|w| w[0] < w[1]), "{:?}", fit.keys);
    let expected = brute_force(times, values, &fit.keys, mode);
    for (j, (reported, truth)) in fit.deviations.iter().zip(&expected).enumerate() {
        assert_eq!(reported.max, *truth, "joint {j}: reported vs brute force");
        assert!(
            *truth <= tolerances[j],
            "joint {j}: {truth} > tolerance {}",
            tolerances[j]
        );
        // The reported sample is where that deviation occurs.
        let at = brute_force_at(times, &values[j], &fit.keys, mode, reported.sample);
        assert_eq!(
            at, reported.max,
            "joint {j}: deviation at the reported sample"
        );
    }
}

fn brute_force_at(times: &[f64], series: &[f64], keys: &[usize], mode: Interp, k: usize) -> f64 {
    let track_keys: Vec<_> = keys
        .iter()
        .map(|&s| TrackKey::new(times[s], series[s], mode))
        .collect();
    let track = Track::new(&track_keys).expect("keys in time order");
    (track.sample(times[k]) - series[k]).abs()
}

/// A recording that is exactly the curve through `keys` (sample index, value) in `mode`.
fn keyed_recording(keys: &[(usize, f64)], mode: Interp) -> (Vec<f64>, Vec<f64>) {
    let track_keys: Vec<_> = keys
        .iter()
        .map(|&(k, v)| TrackKey::new(k as f64 / RATE, v, mode))
        .collect();
    let track = Track::new(&track_keys).expect("keys in time order");
    let times = grid(keys[keys.len() - 1].0 + 1);
    let values = times.iter().map(|&t| track.sample(t)).collect();
    (times, values)
}

/// Five-key motions of the kind taught by hand: keys 0.6–1.3 s apart, swings up to 60°.
const TAUGHT: [[(usize, f64); 5]; 4] = [
    [(0, 0.0), (100, 30.0), (200, -10.0), (300, 20.0), (400, 0.0)],
    [
        (0, -40.0),
        (80, -5.0),
        (210, 25.0),
        (290, 60.0),
        (420, 10.0),
    ],
    [
        (0, 12.5),
        (130, 70.0),
        (190, 45.0),
        (320, -20.0),
        (380, -25.0),
    ],
    [(0, 0.0), (60, 40.0), (160, 40.5), (270, -30.0), (400, 0.0)],
];

#[test]
fn a_recording_made_from_five_keys_comes_back_with_at_most_five() {
    // Hand reasoning: the five keys are samples of the recording, and the curve through them in
    // the same mode *is* the recording, so five keys fit at any tolerance; the extraction must
    // not need more.
    for mode in [Interp::Cubic, Interp::Monotone] {
        for (case, keys) in TAUGHT.iter().enumerate() {
            let (times, series) = keyed_recording(keys, mode);
            let values = vec![series];
            // The oracle's premise: the true keys reproduce the recording exactly.
            let truth: Vec<usize> = keys.iter().map(|k| k.0).collect();
            assert!(brute_force(&times, &values, &truth, mode)[0] < 1e-9);
            let fit = extract(&times, &values, &[1.0], mode).unwrap();
            assert!(
                fit.keys.len() <= 5,
                "{mode} case {case}: {} keys {:?}, expected at most 5 ({truth:?})",
                fit.keys.len(),
                fit.keys
            );
            assert_fits(&times, &values, &[1.0], mode, &fit);
        }
    }
}

#[test]
fn a_straight_line_in_linear_mode_is_two_keys() {
    let times = grid(301);
    let values = vec![times.iter().map(|t| 10.0 - 25.0 * t).collect::<Vec<_>>()];
    let fit = extract(&times, &values, &[0.1], Interp::Linear).unwrap();
    assert_eq!(fit.keys, vec![0, 300]);
    assert_fits(&times, &values, &[0.1], Interp::Linear, &fit);
}

#[test]
fn a_constant_is_two_keys_in_every_mode() {
    let times = grid(250);
    let values = vec![vec![42.0; 250], vec![-0.012; 250]];
    for mode in Interp::ALL {
        let fit = extract(&times, &values, &[1.0, 0.001], mode).unwrap();
        assert_eq!(fit.keys, vec![0, 249], "{mode}");
        assert!(fit.deviations.iter().all(|d| d.max == 0.0), "{mode}");
    }
}

#[test]
fn one_or_two_samples_are_their_own_keys() {
    let fit = extract(&[0.0], &[vec![5.0]], &[1.0], Interp::Monotone).unwrap();
    assert_eq!(fit.keys, vec![0]);
    let fit = extract(&[0.0, 0.01], &[vec![5.0, 9.0]], &[1.0], Interp::Cubic).unwrap();
    assert_eq!(fit.keys, vec![0, 1]);
}

#[test]
fn keys_are_shared_by_all_joints_and_each_joint_has_its_own_tolerance() {
    // Joint 0 moves only in the first half, joint 1 (a gripper, metres) only in the second:
    // the one key list must serve both, each within its own tolerance.
    let times = grid(401);
    let ramp = |t: f64, a: f64, b: f64| ((t - a) / (b - a)).clamp(0.0, 1.0);
    let smooth = |x: f64| x * x * (3.0 - 2.0 * x);
    let values = vec![
        times
            .iter()
            .map(|&t| 50.0 * smooth(ramp(t, 0.2, 1.8)))
            .collect::<Vec<_>>(),
        times
            .iter()
            .map(|&t| 0.02 * smooth(ramp(t, 2.2, 3.8)))
            .collect::<Vec<_>>(),
    ];
    let tolerances = [0.5, 0.0005];
    let fit = extract(&times, &values, &tolerances, Interp::Monotone).unwrap();
    assert_fits(&times, &values, &tolerances, Interp::Monotone, &fit);
    // Both motions need keys of their own: some inside each half.
    assert!(
        fit.keys.iter().any(|&k| (20..180).contains(&k)),
        "{:?}",
        fit.keys
    );
    assert!(
        fit.keys.iter().any(|&k| (220..380).contains(&k)),
        "{:?}",
        fit.keys
    );
}

#[test]
fn a_noisy_quantised_recording_fits_and_needs_far_fewer_keys_than_samples() {
    // A hand-moved joint read through a 4096-tick encoder: smooth motion, tick steps, jitter.
    let times = grid(600);
    let tick = 360.0 / 4096.0;
    let mut seed = 7u64;
    let mut noise = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.2
    };
    let values = vec![times
        .iter()
        .map(|&t| {
            let x = 35.0 * (1.3 * t).sin() + 10.0 * (3.1 * t + 1.0).sin() + noise();
            (x / tick).round() * tick
        })
        .collect::<Vec<_>>()];
    for mode in [Interp::Monotone, Interp::Cubic, Interp::Linear] {
        let fit = extract(&times, &values, &[1.0], mode).unwrap();
        assert_fits(&times, &values, &[1.0], mode, &fit);
        assert!(fit.keys.len() < 60, "{mode}: {} keys", fit.keys.len());
    }
}

#[test]
fn bad_recordings_are_refused() {
    let t = [0.0, 0.01, 0.02];
    let v = vec![vec![0.0, 1.0, 2.0]];
    let mode = Interp::Monotone;
    assert_eq!(
        extract(&[], &[vec![]], &[1.0], mode),
        Err(ExtractError::Empty)
    );
    assert_eq!(extract(&t, &[], &[], mode), Err(ExtractError::NoJoints));
    assert!(matches!(
        extract(&t, &[vec![0.0, 1.0]], &[1.0], mode),
        Err(ExtractError::LengthMismatch { joint: 0, .. })
    ));
    assert!(matches!(
        extract(&[0.0, 0.02, 0.01], &v, &[1.0], mode),
        Err(ExtractError::NotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        extract(&[0.0, f64::NAN, 0.02], &v, &[1.0], mode),
        Err(ExtractError::NonFiniteTime { index: 1 })
    ));
    assert!(matches!(
        extract(&t, &[vec![0.0, f64::INFINITY, 2.0]], &[1.0], mode),
        Err(ExtractError::NonFiniteValue { joint: 0, index: 1 })
    ));
    for tolerance in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            extract(&t, &v, &[tolerance], mode),
            Err(ExtractError::BadTolerance { joint: 0, .. })
        ));
    }
    assert!(matches!(
        extract(&t, &v, &[1.0, 1.0], mode),
        Err(ExtractError::ToleranceCount { .. })
    ));
}

#[test]
fn deviations_of_given_keys_match_brute_force() {
    let times = grid(200);
    let values = vec![times
        .iter()
        .map(|t| 20.0 * (2.0 * t).sin())
        .collect::<Vec<_>>()];
    let keys = [0, 40, 120, 199];
    for mode in Interp::ALL {
        let reported = deviations(&times, &values, &keys, mode).unwrap();
        assert_eq!(
            reported[0].max,
            brute_force(&times, &values, &keys, mode)[0]
        );
    }
}

fn sine(n: usize, amplitude: f64, frequency: f64, phase: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let times = grid(n);
    let series = times
        .iter()
        .map(|&t| amplitude * (std::f64::consts::TAU * frequency * t + phase).sin())
        .collect();
    (times, vec![series])
}

fn smooth_mode() -> impl Strategy<Value = Interp> {
    prop_oneof![
        Just(Interp::Monotone),
        Just(Interp::Cubic),
        Just(Interp::Linear)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// A sine wave fits within tolerance, its reported deviation is the brute-force one, and a
    /// four times looser tolerance never needs more keys. (The search is a heuristic, not an
    /// exact minimum, so between close tolerances the count can now and then go up by one; at a
    /// factor of four the curve needs about a third fewer keys, far more than that slack.)
    #[test]
    fn sine_waves_fit_and_a_looser_tolerance_needs_no_more_keys(
        amplitude in 5.0f64..90.0,
        frequency in 0.2f64..2.0,
        phase in 0.0f64..6.3,
        n in 150usize..350,
        tolerance in 0.2f64..2.0,
        mode in smooth_mode(),
    ) {
        let (times, values) = sine(n, amplitude, frequency, phase);
        let tight = extract(&times, &values, &[tolerance], mode).unwrap();
        assert_fits(&times, &values, &[tolerance], mode, &tight);
        let loose = extract(&times, &values, &[4.0 * tolerance], mode).unwrap();
        assert_fits(&times, &values, &[4.0 * tolerance], mode, &loose);
        prop_assert!(
            loose.keys.len() <= tight.keys.len(),
            "{} keys at {}°, {} at {}°",
            loose.keys.len(), 4.0 * tolerance, tight.keys.len(), tolerance
        );
    }

    /// Several joints of random smooth motion with noise: every reported deviation is the
    /// brute-force one and within that joint's tolerance.
    #[test]
    fn reported_deviations_are_the_brute_force_ones(
        seeds in prop::collection::vec((1.0f64..60.0, 0.1f64..1.5, 0.0f64..6.3), 1..4),
        tolerance in 0.3f64..2.0,
        n in 100usize..300,
        mode in smooth_mode(),
    ) {
        let times = grid(n);
        let values: Vec<Vec<f64>> = seeds
            .iter()
            .enumerate()
            .map(|(j, &(a, f, p))| {
                times
                    .iter()
                    .enumerate()
                    .map(|(k, &t)| {
                        // A deterministic jitter of ±0.15: not smooth at the sample scale.
                        let jitter = 0.15 * ((k * 7 + j * 13) % 11) as f64 / 10.0 - 0.075;
                        a * (std::f64::consts::TAU * f * t + p).sin() + jitter
                    })
                    .collect()
            })
            .collect();
        let tolerances: Vec<f64> = (0..values.len()).map(|j| tolerance * (1.0 + j as f64)).collect();
        let fit = extract(&times, &values, &tolerances, mode).unwrap();
        assert_fits(&times, &values, &tolerances, mode, &fit);
    }
}
