//! The keys' effort limits (`"effort"`, [`crate::plan::EffortLimit`]) carried out: each joint's
//! servo output cap (Feetech Torque_Limit, the X series' Goal_PWM) written as the playback
//! enters the segment a limit applies from, as a share of the cap's full value and never above
//! what the servo held before the playback (a user's lower setting stays the ceiling).
//!
//! A limit still in force when the playback ends is left in place and said: the joint may be
//! holding an object, and restoring full output would squeeze it at full torque until the
//! servo's overload protection lets go. Both caps are RAM registers, back to their EEPROM
//! ceiling at the next power-on.

use super::PlayError;
use crate::bus::{BusError, ServoBus};
use crate::plan::{efforts_at, Trajectory, FULL_EFFORT};
use crate::robot::Robot;
use crate::servo::Setting;

/// Why the keys' efforts cannot be played.
#[derive(Debug, thiserror::Error)]
pub enum EffortError {
    /// An effort at or above the servo's overload threshold: holding it would trip the
    /// protection (nothing was written).
    #[error("key {key}: {joint} effort {percent} % is at or above its servo's overload threshold ({threshold:.0} %), so holding it would trip the servo's protection; expected less than {threshold:.0} % (nothing was sent)")]
    AboveOverload {
        /// The key's label.
        key: String,
        /// The joint.
        joint: String,
        /// The effort asked, percent.
        percent: f64,
        /// The servo's threshold, percent.
        threshold: f64,
    },
    /// The bus cannot read or write the output cap.
    #[error("the keys' effort limits")]
    Bus(#[from] BusError),
}

/// The efforts in force and the caps found before the playback.
pub(super) struct Efforts {
    /// By joint: the cap's value before the playback (`None`: a joint no key limits).
    found: Vec<Option<i64>>,
    /// By joint: the effort written, percent.
    written: Vec<f64>,
}

impl Efforts {
    /// Reads the caps of the joints the keys limit and checks each limit against its servo's
    /// overload threshold (`thresholds`, percent by joint). Nothing is written yet.
    pub(super) fn start(
        bus: &mut dyn ServoBus,
        robot: &Robot,
        trajectory: &Trajectory,
        thresholds: &[f64],
    ) -> Result<Efforts, EffortError> {
        let n = robot.joints.len();
        let mut efforts = Efforts {
            found: vec![None; n],
            written: vec![FULL_EFFORT; n],
        };
        if trajectory.efforts.is_empty() {
            return Ok(efforts);
        }
        for limit in &trajectory.efforts {
            let threshold = thresholds[limit.joint];
            if limit.percent < FULL_EFFORT && limit.percent >= threshold {
                return Err(EffortError::AboveOverload {
                    key: trajectory.key_labels[limit.key].clone(),
                    joint: robot.joints[limit.joint].name.clone(),
                    percent: limit.percent,
                    threshold,
                });
            }
        }
        let mut joints: Vec<usize> = trajectory.efforts.iter().map(|l| l.joint).collect();
        joints.sort_unstable();
        joints.dedup();
        let ids: Vec<u8> = joints.iter().map(|&j| robot.joints[j].servo.id).collect();
        let caps = bus.read_setting(&ids, Setting::EffortLimit)?;
        for (&j, cap) in joints.iter().zip(caps) {
            efforts.found[j] = Some(cap);
        }
        Ok(efforts)
    }

    /// Writes the caps whose effort changes at sequence time `t`; `limited` is told which
    /// joints are held below full.
    pub(super) fn apply(
        &mut self,
        bus: &mut dyn ServoBus,
        robot: &Robot,
        trajectory: &Trajectory,
        t: f64,
        limited: &mut dyn FnMut(usize, bool),
    ) -> Result<(), BusError> {
        if trajectory.efforts.is_empty() {
            return Ok(());
        }
        let wanted = efforts_at(&trajectory.efforts, robot.joints.len(), t);
        for (j, &percent) in wanted.iter().enumerate() {
            let Some(found) = self.found[j] else {
                continue;
            };
            if percent == self.written[j] {
                continue;
            }
            let (_, full) = robot.joints[j].servo.model.spec().table.effort_limit;
            let value = match percent >= FULL_EFFORT {
                true => found,
                false => ((percent / 100.0 * full as f64).round() as i64).min(found),
            };
            bus.write_setting(&[(robot.joints[j].servo.id, value)], Setting::EffortLimit)?;
            self.written[j] = percent;
            limited(j, percent < FULL_EFFORT);
        }
        Ok(())
    }

    /// The joints still held below full effort at the end, with their effort, in words.
    pub(super) fn still_limited(&self, robot: &Robot) -> Option<String> {
        let held: Vec<String> = robot
            .joints
            .iter()
            .zip(&self.written)
            .filter(|(_, &percent)| percent < FULL_EFFORT)
            .map(|(joint, percent)| format!("{} at {percent} %", joint.name))
            .collect();
        (!held.is_empty()).then(|| {
            format!(
                "{} kept the effort limit the keys set (it may hold an object, which full output would squeeze until its overload protection lets go); a later key with effort 100, or switching the servos off and on, restores it",
                held.join(", ")
            )
        })
    }
}

impl From<EffortError> for PlayError {
    fn from(error: EffortError) -> Self {
        PlayError::Effort(error)
    }
}
