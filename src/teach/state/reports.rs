//! How the state takes what the drivers report: what the servos did and what the files did.
//! Each handler only records what an event confirms.

use super::*;
use crate::error::Report;
use crate::teach::files::FileError;
use crate::teach::MotionError;

impl TeachState {
    /// Applies what a driver reports; returns what must follow (a loaded list is journaled, a
    /// written one's journal removed).
    pub fn on_event(&mut self, event: Event) -> Vec<Command> {
        match event {
            Event::Reading(values) => self.present = values,
            Event::Held { joints, values } => self.held(joints, values),
            Event::Released { joints } => self.released(joints),
            Event::MotionStarted {
                kind,
                end_pose,
                joints,
            } => self.motion_started(kind, end_pose, joints),
            Event::MotionEnded {
                outcome,
                last_goals,
                warnings,
            } => return self.motion_ended(outcome, last_goals, &warnings),
            Event::BusError(message) => {
                self.fail(message);
            }
            Event::Loaded { path, result } => return self.loaded(&path, result),
            Event::Saved { path, result } => return self.saved(path, result),
            Event::DirectionWritten {
                joint,
                path,
                result,
            } => return self.direction_written(joint, &path, result),
            Event::Journaled(result) => self.journaled(result),
            Event::JournalCleared { why, result } => self.journal_cleared(why, result),
        }
        Vec::new()
    }

    // ----- what the servos did -----

    fn held(&mut self, joints: Vec<usize>, values: Vec<f64>) {
        for (&j, &v) in joints.iter().zip(&values) {
            self.torque[j] = true;
            self.goals[j] = v;
        }
        let hint = if joints.len() == self.robot.joints.len() {
            " (arrows jog; t/T release torque to move the arm by hand)"
        } else {
            ""
        };
        self.info(format!("holding {}{hint}", self.names(&joints)));
    }

    fn released(&mut self, joints: Vec<usize>) {
        for &j in &joints {
            self.torque[j] = false;
        }
        self.info(format!(
            "released {}: move by hand, then u or n captures the pose",
            self.names(&joints)
        ));
    }

    /// Where a jog goes: one joint's value, or (several joints: the tool moved, by a tool
    /// jog or target) the tool of those joints' arm, in its base frame.
    fn jog_text(&self, joints: &[usize], pose: &[f64]) -> String {
        match joints {
            [] => "nothing to jog".into(),
            [j] => {
                let joint = &self.robot.joints[*j];
                format!("{} → {}", joint.name, format::value(joint, pose[*j]))
            }
            [j, ..] => {
                let (arm, tool) = super::selected_tool(&self.robot, *j, pose);
                let arm = arm.map_or(String::new(), |a| format!(" ({a})"));
                format!("tool{arm} → ({})", crate::kinematics::mm3(tool))
            }
        }
    }

    fn motion_started(&mut self, kind: MotionKind, end_pose: Vec<f64>, joints: Vec<usize>) {
        self.info(match kind {
            MotionKind::Jog => self.jog_text(&joints, &end_pose),
            MotionKind::ToKey(i) => {
                format!("moving to {} (y or Esc stops)", self.key_label(i))
            }
            MotionKind::Play { from } => format!(
                "playing from {} at speed {:.1} (y or Esc stops)",
                self.key_label(from),
                self.speed()
            ),
        });
        self.activity = Activity::Moving {
            kind,
            end_pose,
            joints,
            stops: 0,
        };
    }

    /// The player returned: what the arm holds now, and a jog that waited for this one.
    fn motion_ended(
        &mut self,
        outcome: Result<Outcome, MotionError>,
        last_goals: Option<Vec<f64>>,
        warnings: &[String],
    ) -> Vec<Command> {
        let Activity::Moving {
            kind,
            end_pose,
            joints,
            ..
        } = std::mem::replace(&mut self.activity, Activity::Idle)
        else {
            return Vec::new();
        };
        // The player turns torque on for every joint it drives before it moves (a jog drives
        // held joints only). After a fault that may not have happened (or a servo in shutdown
        // dropped it), so the screen keeps what it knew rather than claim a hold.
        if outcome.is_ok() {
            for &j in &joints {
                self.torque[j] = true;
            }
        }
        let stopped_at = last_goals.as_deref().unwrap_or(&self.present);
        for &j in &joints {
            self.goals[j] = match outcome {
                // The exact pose it was sent to, so that jogs from there stay on round values.
                Ok(Outcome::Finished) => end_pose[j],
                _ => tidy(&self.robot.joints[j], stopped_at[j]),
            };
        }
        let pending = self.pending_jog.take();
        if kind == MotionKind::Jog {
            self.direction_jog_ended(matches!(outcome, Ok(Outcome::Finished)));
        }
        match outcome {
            Ok(Outcome::Finished) => match kind {
                MotionKind::ToKey(i) => self.info(format!("at {}", self.key_label(i))),
                MotionKind::Play { .. } => self.info("played to the end; holding the last pose"),
                MotionKind::Jog => {
                    let text = self.jog_text(&joints, &self.goals);
                    self.info(text);
                    if let Some(key) = pending {
                        return self.handle_key(key);
                    }
                }
            },
            Ok(Outcome::Stopped) => {
                self.info("stopped: the arm decelerated along its path and holds there")
            }
            Ok(Outcome::Held) => self.info("held at once where the arm was"),
            Err(e) => {
                self.fail(Report(&e).to_string());
            }
        }
        if !warnings.is_empty() && matches!(kind, MotionKind::Play { .. }) {
            // Said as `keypose play` says it, beside what happened: a playback that ran late
            // did not simply play "to the end". A jog or a move to a key keeps no timing, so
            // its stalls are nothing to warn of.
            let text = format!("{}; but: {}", self.status.text, warnings.join("; "));
            self.warn(text);
        }
        Vec::new()
    }

    // ----- what the files did -----

    fn loaded(&mut self, path: &Path, result: Result<Sequence, FileError>) -> Vec<Command> {
        let sequence = match result {
            Ok(s) => s,
            Err(e) => return self.fail(Report(&e).to_string()),
        };
        // What cannot be played on this robot is refused here rather than at `space` or `y`.
        if let Err(e) = Trajectory::build(&sequence, &self.robot) {
            return self.fail(format!("cannot import: {e}"));
        }
        let other_robot = if sequence.robot == self.robot.name {
            String::new()
        } else {
            format!(" (it names robot {})", sequence.robot)
        };
        let keys = sequence.keyframes.len();
        self.list = KeyframeList::new(sequence);
        self.replaced = !same_file(path, &self.output);
        self.info(format!(
            "imported {} ({}){other_robot}",
            path.display(),
            format::count(keys)
        ));
        self.edited()
    }

    fn saved(&mut self, path: PathBuf, result: Result<(), FileError>) -> Vec<Command> {
        let quit = std::mem::take(&mut self.quit_after_write);
        if let Err(e) = result {
            return self.fail(Report(&e).to_string());
        }
        self.mark_written(&path);
        self.replaced = false;
        let mut commands = Vec::new();
        if !same_file(&path, &self.output) {
            // Save-as: the new file is the target from now on, and so is its journal.
            if let Some(journal) = self.journal.take() {
                self.journal = Some(journal.for_other_target(&path));
                commands.extend(clear(journal, Clearing::Moved));
            }
            self.output = path.clone();
        }
        let verdict = self.check_note();
        self.info(format!(
            "wrote {} ({}); {verdict}",
            path.display(),
            format::count(self.list.len())
        ));
        if let Some(journal) = &self.journal {
            commands.extend(clear(journal.clone(), Clearing::Written));
        }
        if quit {
            let said = self.status.text.clone();
            self.quit = true;
            self.info(format!("{said}; quit"));
        }
        commands
    }

    /// What [`KeyframeList::save`] leaves once the driver has written the file: a clean list
    /// that names it, on the same key.
    fn mark_written(&mut self, path: &Path) {
        let current = self.list.current_index();
        let mut sequence = self.list.sequence().clone();
        sequence.file = path.display().to_string();
        // What the driver wrote: the next `w` keeps its layout.
        let written = sequence.to_text();
        sequence.mark_written(&written);
        self.list = KeyframeList::new(sequence);
        self.list.select(current);
    }

    fn journaled(&mut self, result: Result<(), FileError>) {
        let (Err(e), Some(journal)) = (result, &self.journal) else {
            return;
        };
        // The file system's words in brackets, inside the sentence the session says.
        let cause = match std::error::Error::source(&e) {
            Some(cause) => Report(cause).to_string(),
            None => e.to_string(),
        };
        let message = format!(
            "{}; but the journal {} cannot be written ({cause}): w saves your work",
            self.status.text,
            journal.path().display()
        );
        self.fail(message);
    }

    fn journal_cleared(&mut self, why: Clearing, result: Result<(), FileError>) {
        let Err(e) = result else {
            return;
        };
        let said = Report(&e);
        match why {
            Clearing::Written => self.status.text.push_str(&format!(" ({said})")),
            Clearing::Moved => {}
            Clearing::Quit => {
                let message = format!("{}; {said}", self.status.text);
                self.fail(message);
            }
        }
    }
}
