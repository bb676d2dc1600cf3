//! The direction check (`D`, the studio's "Direction check" button): each joint in turn is
//! jogged 5° (5 mm) through the same path as any jog — its limits, the contact check, the
//! player with its stop — and the user says whether the real joint moved the way the drawn one
//! did. A reversed joint's servo direction flips at once, for the drawn arm and every later
//! motion, and is recorded where [`DirectionRecord`] says.

use super::{bus, file, TeachState};
use crate::robot::JointKind;
use crate::teach::capture::tidy;
use crate::teach::files::FileError;
use crate::teach::keys::Key;
use crate::teach::messages::{BusCommand, Command, FileCommand};
use crate::teach::prompt::Prompt;
use std::path::PathBuf;

/// How far the check jogs a revolute joint (degrees): enough to see, small enough to be safe.
const CHECK_STEP_DEG: f64 = 5.0;
/// How far it jogs a prismatic joint (metres).
const CHECK_STEP_M: f64 = 0.005;

/// Where a reversed joint's direction is recorded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DirectionRecord {
    /// `joints[..].servo.direction` of this robot file.
    File(PathBuf),
    /// Nowhere: the correction holds for this session only, for the reason given (a built-in
    /// robot is compiled in; a LeRobot calibration's sign is LeRobot's, docs/commands.md).
    SessionOnly(String),
}

/// A direction check under way.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Check {
    /// The joint being checked (robot order).
    joint: usize,
    /// The joints found reversed so far.
    reversed: Vec<usize>,
}

impl TeachState {
    /// Where the direction check records a reversed joint (by default: nowhere, the robot
    /// being a built-in).
    pub fn set_direction_record(&mut self, record: DirectionRecord) {
        self.direction_record = record;
    }

    /// `D`: starts the check at the first joint.
    pub(super) fn start_direction_check(&mut self) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        self.direction_check = Some(Check {
            joint: 0,
            reversed: Vec::new(),
        });
        self.check_joint()
    }

    /// Jogs the joint under check by the check's step (the other way at a limit or a contact).
    fn check_joint(&mut self) -> Vec<Command> {
        let Some(j) = self.direction_check.as_ref().map(|c| c.joint) else {
            return Vec::new();
        };
        let joint = &self.robot.joints[j];
        if !self.torque[j] {
            return self.end_check(format!(
                "direction check ended: {} is limp (t holds it, D starts again)",
                joint.name
            ));
        }
        let step = match joint.kind {
            JointKind::Revolute => CHECK_STEP_DEG,
            JointKind::Prismatic => CHECK_STEP_M,
        };
        let from = self.goals[j];
        let goal = [from + step, from - step]
            .into_iter()
            .map(|g| tidy(joint, g))
            .filter(|&g| (g - from).abs() > step / 2.0)
            .find(|&g| self.contact_refusal(&[(j, g)]).is_none());
        let Some(goal) = goal else {
            let name = joint.name.clone();
            return self.end_check(format!(
                "direction check ended: {name} cannot move {step} either way (limits or contact)"
            ));
        };
        self.info(format!(
            "direction check: jogging {} {}",
            joint.name,
            crate::teach::format::value(joint, goal - from)
        ));
        self.jog_to(&[(j, goal)])
    }

    /// A jog ended while a check runs: finished, the question; otherwise the check ends.
    pub(super) fn direction_jog_ended(&mut self, finished: bool) {
        let Some(check) = &self.direction_check else {
            return;
        };
        if finished {
            self.prompt = Some(Prompt::Direction { joint: check.joint });
        } else {
            self.direction_check = None;
        }
    }

    /// The answer to [`Prompt::Direction`].
    pub(super) fn answer_direction(&mut self, joint: usize, key: &Key) -> Vec<Command> {
        match key {
            Key::Char('m') => self.next_joint(),
            Key::Char('r') => self.reverse(joint),
            Key::Esc | Key::Interrupt => self.end_check("direction check ended".into()),
            _ => {
                self.prompt = Some(Prompt::Direction { joint });
                self.fail("answer m (matches) or r (reversed), or Esc")
            }
        }
    }

    /// Flips `joint`'s direction here and in the session's mapping; records it.
    fn reverse(&mut self, joint: usize) -> Vec<Command> {
        let servo = &mut self.robot.joints[joint].servo;
        servo.direction = -servo.direction;
        let direction = servo.direction as i8;
        // The servo stays at its tick; the value that tick stands for turns with the mapping.
        self.goals[joint] = -self.goals[joint];
        self.present[joint] = -self.present[joint];
        if let Some(check) = &mut self.direction_check {
            check.reversed.push(joint);
        }
        let mut commands = bus(BusCommand::Reverse { joint });
        match &self.direction_record {
            DirectionRecord::File(path) => commands.extend(file(FileCommand::WriteDirection {
                path: path.clone(),
                joint,
                name: self.robot.joints[joint].name.clone(),
                direction,
            })),
            DirectionRecord::SessionOnly(_) => commands.extend(self.next_joint()),
        }
        commands
    }

    /// The robot file was written (or not): the next joint, or the check ends on a failure.
    pub(super) fn direction_written(
        &mut self,
        joint: usize,
        path: &std::path::Path,
        result: Result<(), FileError>,
    ) -> Vec<Command> {
        match result {
            Ok(()) => {
                let name = &self.robot.joints[joint].name;
                self.info(format!("{name} reversed: written to {}", path.display()));
                self.next_joint()
            }
            Err(e) => self.end_check(format!(
                "{} (it stays reversed for this session)",
                crate::error::Report(&e)
            )),
        }
    }

    fn next_joint(&mut self) -> Vec<Command> {
        let Some(check) = &mut self.direction_check else {
            return Vec::new();
        };
        check.joint += 1;
        if check.joint < self.robot.joints.len() {
            return self.check_joint();
        }
        let reversed = std::mem::take(&mut check.reversed);
        let summary = if reversed.is_empty() {
            "every joint matches".to_string()
        } else {
            let names = self.names(&reversed);
            match &self.direction_record {
                DirectionRecord::File(path) => {
                    format!("reversed {names}, written to {}", path.display())
                }
                DirectionRecord::SessionOnly(why) => {
                    format!("reversed {names} for this session only: {why}")
                }
            }
        };
        self.end_check(format!("direction check done: {summary}"))
    }

    fn end_check(&mut self, message: String) -> Vec<Command> {
        self.direction_check = None;
        self.info(message);
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{press, session};
    use super::*;

    const ELBOW: usize = 2;

    fn prompt_joint(state: &TeachState) -> Option<usize> {
        match state.prompt() {
            Some(Prompt::Direction { joint }) => Some(*joint),
            _ => None,
        }
    }

    #[test]
    fn each_joint_is_jogged_five_degrees_and_a_reversed_one_is_flipped_and_written() {
        let dir = tempfile::tempdir().unwrap();
        let mut state = session(dir.path());
        let file = dir.path().join("arm.json");
        std::fs::write(&file, include_str!("../../../robots/so101.json")).unwrap();
        state.set_direction_record(DirectionRecord::File(file.clone()));
        let home = state.goals().to_vec();
        let n = state.robot().joints.len();
        press(&mut state, Key::Char('D'));
        for j in 0..n {
            assert_eq!(prompt_joint(&state), Some(j), "{:?}", state.status());
            // Only joint j moved, by 5° one way (away from a limit), exactly.
            let moved: Vec<f64> = (0..n).map(|k| state.goals()[k] - home[k]).collect();
            assert!((moved[j].abs() - 5.0).abs() < 1e-9, "joint {j}: {moved:?}");
            let key = if j == ELBOW { 'r' } else { 'm' };
            let before = state.goals()[j];
            press(&mut state, Key::Char(key));
            if j == ELBOW {
                // The servo stays at its tick: the value it stands for turns with the mapping.
                assert_eq!(state.goals()[j], -before);
                assert_eq!(state.robot().joints[j].servo.direction, -1.0);
            }
        }
        assert_eq!(state.prompt(), None);
        assert!(
            state
                .status()
                .text
                .starts_with("direction check done: reversed elbow_flex"),
            "{:?}",
            state.status()
        );
        let written: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        let directions: Vec<i64> = written["joints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j["servo"]["direction"].as_i64().unwrap())
            .collect();
        assert_eq!(directions, [1, 1, -1, 1, 1, 1]);
    }

    #[test]
    fn esc_ends_the_check_and_a_built_in_is_corrected_for_the_session_only() {
        let dir = tempfile::tempdir().unwrap();
        let mut state = session(dir.path());
        press(&mut state, Key::Char('D'));
        press(&mut state, Key::Char('r'));
        assert_eq!(state.robot().joints[0].servo.direction, -1.0);
        assert_eq!(prompt_joint(&state), Some(1));
        press(&mut state, Key::Char('x'));
        assert_eq!(
            prompt_joint(&state),
            Some(1),
            "a stray key keeps the question"
        );
        press(&mut state, Key::Esc);
        assert_eq!(state.prompt(), None);
        assert_eq!(state.status().text, "direction check ended");
        // Later jogs use the corrected direction: the state's robot is the one they plan with.
        assert_eq!(state.robot().joints[0].servo.direction, -1.0);
    }
}
