//! What a playback's figures say the user must hear: stalls (the arm held a goal, so the
//! sequence ran late) and the step limiter's interventions. Worded once, here, for every
//! front end that plays — `keypose play` prints them, `teach` and the studio put them on the
//! status line instead of a plain "played to the end".

use super::Stats;
use crate::robot::JointKind;

impl Stats {
    /// The warnings of this playback, one sentence each; none for a playback on time.
    pub fn warnings(&self) -> Vec<String> {
        let pacing = &self.pacing;
        let mut warnings = Vec::new();
        if pacing.stalls > 0 {
            warnings.push(format!(
                "{} stall(s): the longest held a goal {:.0} ms beyond its period; {} deadline(s) skipped, the sequence ran {:.3} s late; largest lateness {:.1} ms",
                pacing.stalls,
                pacing.longest_stall * 1e3,
                pacing.skipped_deadlines,
                self.late,
                pacing.max_lateness * 1e3
            ));
        }
        if self.limited_goals > 0 {
            let by = match &self.limiter_joint {
                Some((joint, JointKind::Revolute)) => {
                    format!("{:.3}° ({joint})", self.largest_limiter_correction)
                }
                Some((joint, JointKind::Prismatic)) => {
                    format!("{:.3} mm ({joint})", self.largest_limiter_correction * 1e3)
                }
                None => format!("{:.3}", self.largest_limiter_correction),
            };
            warnings.push(format!(
                "the step limiter held back {} goal(s), by up to {by}, to stay within the velocity and acceleration limits",
                self.limited_goals
            ));
        }
        for (joint, hottest, limit) in &self.hot {
            warnings.push(hot_warning(joint, *hottest, *limit));
        }
        warnings.extend(self.efforts_kept.clone());
        warnings
    }
}

/// A servo near its heat protection, in words.
pub(super) fn hot_warning(joint: &str, celsius: f64, limit: f64) -> String {
    format!(
        "{joint} reached {celsius:.0} °C, {:.0} °C under its servo's {limit:.0} °C heat protection, which releases the joint: let it cool before playing again, or carry less",
        limit - celsius
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_playback_on_time_has_nothing_to_say_and_a_late_one_says_by_how_much() {
        assert!(Stats::default().warnings().is_empty());
        let mut stats = Stats::default();
        stats.pacing.stalls = 3;
        stats.pacing.longest_stall = 0.120;
        stats.pacing.skipped_deadlines = 30;
        stats.late = 3.2;
        stats.pacing.max_lateness = 0.1204;
        stats.limited_goals = 2;
        stats.largest_limiter_correction = 0.25;
        stats.limiter_joint = Some(("elbow_flex".to_string(), JointKind::Revolute));
        assert_eq!(
            stats.warnings(),
            [
                "3 stall(s): the longest held a goal 120 ms beyond its period; 30 deadline(s) \
                 skipped, the sequence ran 3.200 s late; largest lateness 120.4 ms",
                "the step limiter held back 2 goal(s), by up to 0.250° (elbow_flex), to stay \
                 within the velocity and acceleration limits"
            ]
        );
        stats.hot = vec![("elbow_flex".into(), 63.0, 70.0)];
        assert_eq!(
            stats.warnings()[2],
            "elbow_flex reached 63 °C, 7 °C under its servo's 70 °C heat protection, which \
             releases the joint: let it cool before playing again, or carry less"
        );
        stats.limiter_joint = Some(("gripper".to_string(), JointKind::Prismatic));
        stats.largest_limiter_correction = 0.0004;
        assert!(stats.warnings()[1].contains("by up to 0.400 mm (gripper)"));
    }
}
