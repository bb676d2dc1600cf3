//! A key's `"effort"`: how hard a joint may push, as a percent of its servo's stall torque,
//! until a later key sets another (100: the servo's own setting again). A lower effort applies
//! from the segment that arrives at its key (the closing of a grasp is already limited); a
//! higher one from the key itself (a release opens the jaws before the effort rises, so what
//! they held is never squeezed at full output). A gripper closing on an object with `"effort": {"gripper": 30}` holds
//! it at 30 % instead of pushing at full torque into it until the servo's overload protection
//! lets go. The player writes it into the servo's output limit (Feetech Torque_Limit, the X
//! series' Goal_PWM: docs/protocols.md §6).

use crate::json::InputError;
use crate::robot::Robot;
use crate::sequence::Sequence;

/// Full effort: the servo's own limit, as found.
pub const FULL_EFFORT: f64 = 100.0;

/// One key's effort limit on one joint.
#[derive(Debug, Clone, PartialEq)]
pub struct EffortLimit {
    /// The key that sets it.
    pub key: usize,
    /// Sequence time it applies from: for a lower effort than before, the start of the
    /// segment that arrives at the key (the end of the previous key's hold, or the first key's
    /// time); for a higher one, the key's time.
    pub from: f64,
    /// The joint, in the robot's order.
    pub joint: usize,
    /// Percent of the servo's stall torque, in (0, 100].
    pub percent: f64,
}

/// The effort limits `sequence`'s keys set, in time order; an unknown joint is an error at
/// its key's path.
pub(crate) fn effort_limits(
    sequence: &Sequence,
    robot: &Robot,
    key_times: &[f64],
) -> Result<Vec<EffortLimit>, InputError> {
    let mut limits = Vec::new();
    let mut before = vec![FULL_EFFORT; robot.joints.len()];
    for (index, key) in sequence.keyframes.iter().enumerate() {
        let arriving = match index {
            0 => key_times[0],
            _ => key_times[index - 1] + sequence.keyframes[index - 1].hold,
        };
        for (name, percent) in &key.effort {
            let joint = robot.joint_index(name).ok_or_else(|| {
                InputError::at_path(
                    &sequence.file,
                    &format!("{}.effort.{name}", sequence.key_path(index)),
                    format!(
                        "unknown joint {name:?}; expected one of: {}",
                        robot.joint_names().join(", ")
                    ),
                )
            })?;
            let from = match *percent < before[joint] {
                true => arriving,
                false => key_times[index],
            };
            before[joint] = *percent;
            limits.push(EffortLimit {
                key: index,
                from,
                joint,
                percent: *percent,
            });
        }
    }
    limits.sort_by(|a, b| a.from.total_cmp(&b.from));
    Ok(limits)
}

/// Each joint's effort at sequence time `t`, percent ([`FULL_EFFORT`] where no key limits
/// it). The first key's own apply from its time, so a playback's approach to it (which has
/// not reached the sequence's start) asks for them at the start.
pub fn efforts_at(limits: &[EffortLimit], joints: usize, t: f64) -> Vec<f64> {
    let mut efforts = vec![FULL_EFFORT; joints];
    for limit in limits.iter().filter(|l| l.from <= t) {
        efforts[limit.joint] = limit.percent;
    }
    efforts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limit(from: f64, joint: usize, percent: f64) -> EffortLimit {
        EffortLimit {
            key: 0,
            from,
            joint,
            percent,
        }
    }

    #[test]
    fn an_effort_lasts_from_its_segment_until_a_later_key_sets_another() {
        let limits = [limit(3.2, 5, 30.0), limit(7.9, 5, 100.0)];
        assert_eq!(efforts_at(&limits, 6, 1.0), [100.0; 6]);
        assert_eq!(efforts_at(&limits, 6, 3.2)[5], 30.0);
        assert_eq!(efforts_at(&limits, 6, 6.0)[5], 30.0);
        assert_eq!(efforts_at(&limits, 6, 8.0)[5], 100.0);
        // The first key's own, from its time.
        let first = [limit(0.0, 5, 40.0)];
        assert_eq!(efforts_at(&first, 6, 0.0)[5], 40.0);
    }
}
