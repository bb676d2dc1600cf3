//! A segment's timing profile (`"timing"` on the key that starts it): how fast the motion runs
//! along the curve its keys define, instead of at the pace of the key times it was shaped with.
//!
//! A segment's curve is defined by its keys and its interpolation over *path time*: the times
//! its keys had when it was shaped (the file's key times for a segment without a profile). A
//! profile keeps that curve and changes only when each point of it is reached, as an industrial
//! controller's velocity profile along a programmed path does: `path_time` says how long the
//! segment's moving part lasts in path time, `speeds` the path speed (path seconds per second)
//! at evenly spaced points of it, from the end of the key's hold to the next key. Between two
//! points the path accelerates evenly (its squared speed changes linearly along the path, as the
//! time-optimal methods discretise it), so each stretch lasts `2·Δ / (v_k + v_k+1)`. The speeds
//! give the shape: they are scaled by one factor so that the segment lasts what its key times
//! give, so rounding in the file, or moving a key, never leaves the two disagreeing.
//!
//! The other profile is the jerk-limited S-curve (`"scurve": [tj, ta, tv]`, `plan::scurve`):
//! from rest to rest, the path jerk `+J, 0, −J, 0, −J, 0, +J` over `tj, ta, tj, tv, tj, ta, tj`
//! seconds, so the path acceleration never jumps. The three times are a shape too: scaled by
//! one factor so that the segment lasts what its key times give, with the jerk `J` that covers
//! `path_time`. `retime --fastest` writes one on each segment for a robot with jerk limits,
//! and one on each hold through which a joint without a key there moves (`"hold"`: the hold's
//! path time run from rest to rest in the hold's seconds, [`HoldTiming`]).

use crate::json::{InputError, Node};
use serde_json::{json, Value};

/// Most speed samples in one segment's profile.
pub const MAX_SPEEDS: usize = 10_000;

/// How the moving part of one segment runs along its curve.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentTiming {
    /// Seconds of path time the segment's moving part spans: how long it lasted when its curve
    /// was shaped (the curve's slopes at its keys are per second of path time).
    pub path_time: f64,
    /// How the path speed changes along it.
    pub profile: TimeProfile,
    /// How the path runs during the key's hold, when a joint without a key there moves
    /// through it. None: at pace 1, its path time the hold's seconds, as without a profile.
    pub hold: Option<HoldTiming>,
}

/// A hold run on an S-curve of its own: `path_time` seconds of path time (during which the
/// joints the key names rest and the others go on along their curves) from rest to rest in the
/// key's hold seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HoldTiming {
    /// Seconds of path time the hold spans (the hold's seconds when the curve was shaped).
    pub path_time: f64,
    /// The S-curve's `[tj, ta, tv]`, a shape scaled to last the hold.
    pub scurve: [f64; 3],
}

/// The path speed along a segment.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeProfile {
    /// Path speeds at evenly spaced points of path time, the first at the start of the moving
    /// part and the last at the next key (at least two); even path acceleration between them.
    Speeds(Vec<f64>),
    /// A rest-to-rest S-curve: seconds of each jerk phase, of each constant path acceleration
    /// and of the cruise, `[tj, ta, tv]` (`tj` > 0), before scaling.
    SCurve([f64; 3]),
}

/// How finely an eased segment's ramps are placed: in twentieths of its path, so that each ramp
/// ends on one of the profile's evenly spaced points and the profile is an exact trapezoid.
pub const EASE_STEPS: usize = 20;

impl SegmentTiming {
    /// An eased segment (the studio's easing handles): from rest, the path speed rises evenly
    /// over the first `ease_out` of the path (a share, 0 … 1), runs steady, and falls evenly to
    /// rest over the last `ease_in` — a trapezoidal velocity profile, as a teach pendant's
    /// accelerate / decelerate settings give. Shares are rounded to whole steps of
    /// 1 / [`EASE_STEPS`]; `None` when both round to nothing (steady all the way: no profile)
    /// or together exceed the path.
    pub fn eased(path_time: f64, ease_out: f64, ease_in: f64) -> Option<SegmentTiming> {
        let steps = |share: f64| (share * EASE_STEPS as f64).round() as usize;
        let (up, down) = (steps(ease_out), steps(ease_in));
        if (up == 0 && down == 0) || up + down > EASE_STEPS {
            return None;
        }
        // Speed² grows linearly along the path while the speed ramps (even acceleration).
        let speed = |k: usize| {
            let rising = if up == 0 { 1.0 } else { k as f64 / up as f64 };
            let falling = if down == 0 {
                1.0
            } else {
                (EASE_STEPS - k) as f64 / down as f64
            };
            rising.min(falling).min(1.0).sqrt()
        };
        Some(SegmentTiming {
            path_time,
            profile: TimeProfile::Speeds((0..=EASE_STEPS).map(speed).collect()),
            hold: None,
        })
    }

    /// The shares of the path over which the speed rises from the start to its highest, and
    /// falls from its highest to the end: an eased segment's `ease_out` and `ease_in`; for any
    /// other profile, the ramps around its fastest stretch.
    pub fn ease_shares(&self) -> (f64, f64) {
        let speeds = match &self.profile {
            TimeProfile::Speeds(speeds) => speeds,
            // Symmetric: the speed rises over 2·tj + ta, whose path is half of that at the top
            // speed, then cruises tv at it.
            TimeProfile::SCurve([tj, ta, tv]) => {
                let ramp = 2.0 * tj + ta;
                let share = ramp / 2.0 / (ramp + tv);
                return (share, share);
            }
        };
        let top = speeds.iter().copied().fold(0.0, f64::max);
        let at_top = |v: &f64| *v >= top * (1.0 - 1e-9);
        let last = (speeds.len() - 1) as f64;
        let first_top = speeds.iter().position(at_top).unwrap_or(0) as f64;
        let last_top = speeds.iter().rposition(at_top).unwrap_or(0) as f64;
        (first_top / last, (last - last_top) / last)
    }

    /// Real seconds each stretch of the profile lasts at the speeds as written (before the
    /// scaling that makes the segment last what its key times give).
    /// (An S-curve's is its seven phases.)
    pub fn stretch_seconds(&self) -> Vec<f64> {
        match &self.profile {
            TimeProfile::Speeds(speeds) => {
                let step = self.path_time / (speeds.len() - 1) as f64;
                speeds
                    .windows(2)
                    .map(|w| 2.0 * step / (w[0] + w[1]))
                    .collect()
            }
            TimeProfile::SCurve([tj, ta, tv]) => vec![*tj, *ta, *tj, *tv, *tj, *ta, *tj],
        }
    }

    /// Real seconds the profile lasts at the speeds as written.
    pub fn seconds(&self) -> f64 {
        self.stretch_seconds().iter().sum()
    }
}

pub(super) fn parse(node: &Node) -> Result<SegmentTiming, InputError> {
    node.object()?;
    node.only_fields(&["path_time", "speeds", "scurve", "hold"])?;
    let path_time = parse_path_time(node, "seconds of path time the segment spans")?;
    let hold = match node.get("hold") {
        Some(hold) => Some(parse_hold(&hold)?),
        None => None,
    };
    if let Some(shape) = node.get("scurve") {
        if node.get("speeds").is_some() {
            return Err(node.error(
                "both \"speeds\" and \"scurve\": expected one profile, the path speeds or \
                 the S-curve's phase times",
            ));
        }
        return Ok(SegmentTiming {
            path_time,
            profile: TimeProfile::SCurve(parse_shape(&shape)?),
            hold,
        });
    }
    let speeds_node = node.require("speeds", "the path speeds along the segment")?;
    let items = speeds_node.items()?;
    if items.len() < 2 || items.len() > MAX_SPEEDS {
        return Err(speeds_node.expected(&format!(
            "2 … {MAX_SPEEDS} path speeds (one at each end of the segment at least), found {}",
            items.len()
        )));
    }
    let mut speeds = Vec::with_capacity(items.len());
    for item in &items {
        let v = item.number("a path speed (path seconds per second)")?;
        if !(0.0..=1e6).contains(&v) {
            return Err(item.expected("a path speed of 0 … 1e6 (path seconds per second)"));
        }
        if v == 0.0 && speeds.last() == Some(&0.0) {
            return Err(item.error(
                "two path speeds of 0 in a row: the motion would never get between them; \
                 expected at most one of two neighbours at 0",
            ));
        }
        speeds.push(v);
    }
    Ok(SegmentTiming {
        path_time,
        profile: TimeProfile::Speeds(speeds),
        hold,
    })
}

/// `path_time` of a segment's profile or a hold's, in seconds.
fn parse_path_time(node: &Node, what: &str) -> Result<f64, InputError> {
    let path_node = node.require("path_time", what)?;
    let path_time = path_node.number("seconds")?;
    if !(super::MIN_GAP..=super::MAX_TIME).contains(&path_time) {
        return Err(path_node.expected(&format!(
            "a path time of {} … {} s",
            super::MIN_GAP,
            super::MAX_TIME
        )));
    }
    Ok(path_time)
}

/// `{"path_time": s, "scurve": [tj, ta, tv]}`: how a key's hold runs.
fn parse_hold(node: &Node) -> Result<HoldTiming, InputError> {
    node.object()?;
    node.only_fields(&["path_time", "scurve"])?;
    let path_time = parse_path_time(node, "seconds of path time the hold spans")?;
    let shape = node.require("scurve", "the S-curve the hold runs on, [tj, ta, tv]")?;
    Ok(HoldTiming {
        path_time,
        scurve: parse_shape(&shape)?,
    })
}

/// `[tj, ta, tv]`: three times in seconds, tj above 0 (a jerk phase of no time is a jump of
/// the acceleration), the others 0 or more.
fn parse_shape(node: &Node) -> Result<[f64; 3], InputError> {
    const WHAT: &str = "the S-curve's phase times [tj, ta, tv] in seconds";
    let items = node.items()?;
    if items.len() != 3 {
        return Err(node.expected(&format!("{WHAT}, three numbers; found {}", items.len())));
    }
    let mut shape = [0.0; 3];
    for (k, item) in items.iter().enumerate() {
        let x = item.number("seconds")?;
        let least = if k == 0 { "above 0" } else { "0 or more" };
        let ok = if k == 0 { x > 0.0 } else { x >= 0.0 };
        if !ok || x > super::MAX_TIME {
            return Err(item.expected(&format!(
                "seconds {least}, up to {} ({WHAT})",
                super::MAX_TIME
            )));
        }
        shape[k] = x;
    }
    Ok(shape)
}

pub(super) fn to_value(timing: &SegmentTiming) -> Value {
    let mut value = match &timing.profile {
        TimeProfile::Speeds(speeds) => json!({ "path_time": timing.path_time, "speeds": speeds }),
        TimeProfile::SCurve(shape) => json!({ "path_time": timing.path_time, "scurve": shape }),
    };
    if let Some(hold) = timing.hold {
        value["hold"] = json!({ "path_time": hold.path_time, "scurve": hold.scurve });
    }
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_eased_segment_is_a_trapezoid_whose_ramps_read_back() {
        let timing = SegmentTiming::eased(2.0, 0.2, 0.3).unwrap();
        let TimeProfile::Speeds(speeds) = &timing.profile else {
            panic!("speeds")
        };
        assert_eq!(speeds.len(), EASE_STEPS + 1);
        // From rest; 2 of the 4 steps up: v² = ½; steady from step 4 to 14; at rest at 20.
        assert_eq!(speeds[0], 0.0);
        assert!((speeds[2] - 0.5f64.sqrt()).abs() < 1e-15);
        assert!(speeds[4..=14].iter().all(|&v| v == 1.0));
        assert!(speeds[15] < 1.0 && speeds[20] == 0.0);
        let (out, into) = timing.ease_shares();
        assert!((out - 0.2).abs() < 1e-12 && (into - 0.3).abs() < 1e-12);
        assert_eq!(SegmentTiming::eased(2.0, 0.01, 0.0), None, "rounds to none");
        assert_eq!(
            SegmentTiming::eased(2.0, 0.6, 0.5),
            None,
            "more than the path"
        );
    }

    #[test]
    fn a_stretch_lasts_its_path_time_over_its_mean_speed() {
        // 2 s of path time in two stretches of 1 s: from rest to 1 (mean 0.5: 2 s), then from
        // 1 to 3 (mean 2: 0.5 s).
        let timing = SegmentTiming {
            path_time: 2.0,
            profile: TimeProfile::Speeds(vec![0.0, 1.0, 3.0]),
            hold: None,
        };
        assert_eq!(timing.stretch_seconds(), vec![2.0, 0.5]);
        assert_eq!(timing.seconds(), 2.5);
    }
}
