//! An episode's joint values against the joints' limits (docs/interop.md §1.4): a value past a
//! limit by more than the fit's tolerance is refused, naming its frame, unless the user asked
//! for clipping; then it is clipped to the limit and counted.
//!
//! Within the tolerance a value is left for the fit to clamp (and to warn about): LeRobot's
//! degrees at the very ends of a calibrated range exceed keypose's by a fraction of a degree
//! (§1.4), and keys within the tolerance of every frame are what the fit promises anyway.

use super::error::{number_text, Place, Problem};
use super::LeRobotError;
use crate::robot::Joint;

/// A joint whose values were clipped into its limits (`--clip`).
#[derive(Debug, Clone, PartialEq)]
pub struct Clipped {
    /// The joint's name.
    pub joint: String,
    /// The joint's unit, `"deg"` or `"m"`.
    pub unit: &'static str,
    /// Frames whose value was outside the limits.
    pub frames: usize,
    /// The value furthest outside, in `unit`.
    pub worst: f64,
    /// Its frame number, from the episode's first.
    pub worst_frame: u64,
    /// The joint's lower limit, in `unit`.
    pub min: f64,
    /// The joint's upper limit, in `unit`.
    pub max: f64,
}

impl Clipped {
    /// "clipped shoulder_pan: 3 frames outside -110 … 110 deg, the worst 1e30 deg (frame 17)".
    pub fn notice(&self) -> String {
        format!(
            "clipped {}: {} frame(s) outside its limits {} … {} {unit}, the worst {} {unit} \
             (frame {}); the keys hold it at the limit",
            self.joint,
            self.frames,
            self.min,
            self.max,
            number_text(self.worst),
            self.worst_frame,
            unit = self.unit
        )
    }
}

/// How the values of one dataset column are judged.
#[derive(Debug, Clone, Copy)]
pub struct ColumnLimits<'a> {
    pub joint: &'a Joint,
    /// The feature (`action`) and the value's name in it (`shoulder_pan.pos`), for messages.
    pub field: &'a str,
    pub name: &'a str,
    /// How far past a limit a value may be and still be left to the fit.
    pub slack: f64,
    pub clip: bool,
}

/// Judges `values` (the joint's, in its unit, frame by frame) against the joint's limits:
/// refuses the first beyond the limits by more than the slack, or with `clip` clips every value
/// outside them and says how many and the worst. `place` names the episode; frame k has global
/// index `from + k`.
pub fn judge(
    place: &Place,
    from: u64,
    column: &ColumnLimits,
    values: &mut [f64],
) -> Result<Option<Clipped>, LeRobotError> {
    let (min, max) = (column.joint.limits.min, column.joint.limits.max);
    let unit = column.joint.kind.unit();
    let mut clipped: Option<Clipped> = None;
    for (k, v) in values.iter_mut().enumerate() {
        // The values are finite (frames.rs judged them), so a comparison says all.
        let excess = (*v - max).max(min - *v);
        if excess <= 0.0 {
            continue;
        }
        if !column.clip {
            if excess <= column.slack {
                continue;
            }
            return Err(place
                .at_index(from, from + k as u64)
                .error(Problem::OutsideLimits {
                    field: column.field.to_string(),
                    name: column.name.to_string(),
                    joint: column.joint.name.clone(),
                    value: *v,
                    min,
                    max,
                    unit,
                    slack: column.slack,
                }));
        }
        let report = clipped.get_or_insert_with(|| Clipped {
            joint: column.joint.name.clone(),
            unit,
            frames: 0,
            worst: *v,
            worst_frame: k as u64,
            min,
            max,
        });
        report.frames += 1;
        if excess > (report.worst - max).max(min - report.worst) {
            report.worst = *v;
            report.worst_frame = k as u64;
        }
        *v = v.clamp(min, max);
    }
    Ok(clipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    fn wrist_flex() -> Joint {
        let robot = Robot::builtin("so101").unwrap();
        robot.joints[robot.joint_index("wrist_flex").unwrap()].clone()
    }

    fn column(joint: &Joint, clip: bool) -> ColumnLimits<'_> {
        ColumnLimits {
            joint,
            field: "action",
            name: "wrist_flex.pos",
            slack: 1.0,
            clip,
        }
    }

    #[test]
    fn a_value_past_the_limit_beyond_the_tolerance_is_refused_at_its_frame() {
        let joint = wrist_flex();
        let max = joint.limits.max;
        let place = Place::episode("ds", 0);
        // Within the tolerance: left for the fit.
        let mut within = vec![0.0, max + 0.9, 0.0];
        assert_eq!(
            judge(&place, 50, &column(&joint, false), &mut within).unwrap(),
            None
        );
        assert_eq!(within[1], max + 0.9);
        let mut corrupt = vec![0.0, 1e30, 0.0];
        let text = judge(&place, 50, &column(&joint, false), &mut corrupt)
            .unwrap_err()
            .to_string();
        assert!(
            text.starts_with("ds: episode 0, frame 1 (index 51): action wrist_flex.pos is 1e30 deg as joint wrist_flex"),
            "{text}"
        );
        assert!(text.contains("give --clip"), "{text}");
    }

    #[test]
    fn clipping_counts_the_frames_and_keeps_the_worst() {
        let joint = wrist_flex();
        let (min, max) = (joint.limits.min, joint.limits.max);
        let mut values = vec![0.0, max + 0.5, min - 20.0, 1e30, 0.0];
        let clipped = judge(
            &Place::episode("ds", 0),
            0,
            &column(&joint, true),
            &mut values,
        )
        .unwrap()
        .unwrap();
        assert_eq!(
            (clipped.frames, clipped.worst, clipped.worst_frame),
            (3, 1e30, 3)
        );
        assert_eq!(values, vec![0.0, max, min, max, 0.0]);
    }
}
