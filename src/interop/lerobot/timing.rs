//! The frames' times (docs/interop.md §1.5): an episode's `timestamp` column, judged against
//! itself and against meta/info.json's `fps`, or frame number over fps when there is none.
//!
//! LeRobot writes each frame's timestamp as its frame number over fps, so the timestamps of a
//! sound episode rise by 1/fps a frame (to float32 rounding). keypose refuses timestamps that
//! do not rise, an fps that the steps contradict (their median more than
//! [`FPS_TOLERANCE`] away from 1/fps: a frame rate misread, which would play the motion at
//! another speed), and a single step longer than [`MAX_STEP_PERIODS`] frame periods (frames
//! missing, or one corrupt timestamp: the keys would cross the hole with a motion nobody
//! recorded).

use super::error::{Place, Problem};
use super::LeRobotError;

/// Largest relative difference between the timestamps' median step and 1/fps.
pub const FPS_TOLERANCE: f64 = 0.05;
/// Longest step between two frames, in frame periods.
pub const MAX_STEP_PERIODS: f64 = 10.0;

/// Seconds from the episode's first frame for each of `frames` frames: from `timestamps` when
/// the data file has them (judged as above), else frame number over `fps`. `place` names the
/// episode; frame k has global index `from + k`.
pub fn frame_times(
    place: &Place,
    from: u64,
    fps: f64,
    timestamps: Option<&[f64]>,
    frames: usize,
) -> Result<Vec<f64>, LeRobotError> {
    let Some(ts) = timestamps else {
        return Ok((0..frames).map(|k| k as f64 / fps).collect());
    };
    let at = |k: usize| place.at_index(from, from + k as u64);
    // frames.rs refuses these already; judged again for frames made otherwise.
    if let Some(k) = ts.iter().position(|t| !t.is_finite()) {
        return Err(at(k).error(Problem::TimestampNotFinite {
            found: ts[k].to_string(),
        }));
    }
    for k in 1..ts.len() {
        if ts[k] <= ts[k - 1] {
            return Err(at(k).error(Problem::NotIncreasing {
                previous: ts[k - 1],
                value: ts[k],
            }));
        }
    }
    let period = 1.0 / fps;
    if let Some(median) = median_step(ts) {
        if (median - period).abs() > FPS_TOLERANCE * period {
            return Err(place.error(Problem::FpsMismatch {
                fps,
                median,
                expected: period,
                tolerance_percent: FPS_TOLERANCE * 100.0,
            }));
        }
    }
    for k in 1..ts.len() {
        let step = ts[k] - ts[k - 1];
        if step > MAX_STEP_PERIODS * period {
            return Err(at(k).error(Problem::Gap {
                previous: ts[k - 1],
                value: ts[k],
                step,
                periods: step / period,
                fps,
                max: MAX_STEP_PERIODS,
            }));
        }
    }
    Ok(ts.iter().map(|t| t - ts[0]).collect())
}

/// The median of the steps between consecutive timestamps (None for fewer than two).
fn median_step(ts: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = ts.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    let middle = steps.len() / 2;
    Some(if steps.len() % 2 == 1 {
        steps[middle]
    } else {
        (steps[middle - 1] + steps[middle]) / 2.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn place() -> Place {
        Place::episode("ds", 2).in_file("data/chunk-000/file-000.parquet")
    }

    fn times(ts: &[f64]) -> Result<Vec<f64>, LeRobotError> {
        frame_times(&place(), 100, 10.0, Some(ts), ts.len())
    }

    #[test]
    fn sound_timestamps_count_from_the_first() {
        assert_eq!(times(&[5.0, 5.1, 5.2]).unwrap().len(), 3);
        assert!((times(&[5.0, 5.1, 5.2]).unwrap()[2] - 0.2).abs() < 1e-12);
        // Without timestamps: frame number over fps.
        assert_eq!(
            frame_times(&place(), 0, 4.0, None, 3).unwrap(),
            vec![0.0, 0.25, 0.5]
        );
    }

    #[test]
    fn timestamps_that_do_not_rise_are_refused_at_their_frame() {
        for (ts, says) in [
            (
                vec![0.0, 0.1, 0.1],
                "frame 2 (index 102): timestamp 0.1 s does not come after the previous frame's 0.1 s",
            ),
            (vec![0.0, 0.1, 0.05], "frame 2 (index 102): timestamp 0.05 s"),
        ] {
            let text = times(&ts).unwrap_err().to_string();
            assert!(text.contains(says), "{text}");
        }
    }

    #[test]
    fn an_fps_the_steps_contradict_or_a_hole_is_refused() {
        // 0.2 s steps at 10 fps: twice the period.
        let text = times(&[0.0, 0.2, 0.4, 0.6]).unwrap_err().to_string();
        assert!(text.contains("median step"), "{text}");
        assert!(text.contains("fps 10 means 0.1 s"), "{text}");
        // 4 % off is within the tolerance.
        assert!(times(&[0.0, 0.104, 0.208, 0.312]).is_ok());
        // One step of 1.1 s (11 periods) among steps of 0.1 s.
        let text = times(&[0.0, 0.1, 0.2, 1.3, 1.4]).unwrap_err().to_string();
        assert!(text.contains("frame 3 (index 103)"), "{text}");
        assert!(text.contains("11.0 frame periods"), "{text}");
    }
}
