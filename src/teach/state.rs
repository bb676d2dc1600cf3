//! The teaching state machine: [`Key`]s and bus [`Event`]s in; edits of the keyframe list, bus
//! [`Command`]s and screen state (status line, prompts) out. Every rule of the session lives
//! here, so it is tested without a terminal or servos; the UI only draws a `TeachState` and the
//! session driver only carries out its commands.
//!
//! The state changes what it knows of the servos (torque, goals, motion) only when an event
//! confirms it, never when it merely asks: a command that fails leaves the screen truthful.

use super::journal::{Journal, Pending};
use super::keys::Key;
use crate::plan::{self, Trajectory};
use crate::player::{Outcome, PlayOptions};
use crate::robot::{Joint, JointKind, Robot};
use crate::sequence::{KeyValue, Keyframe, KeyframeList, Sequence};
use std::path::{Path, PathBuf};

/// Jog steps: arrow keys, and with shift.
pub const JOG_STEP_DEG: f64 = 1.0;
pub const JOG_BIG_STEP_DEG: f64 = 10.0;
/// Prismatic joints jog by 1 mm (10 mm with shift): a degree's worth of care.
pub const JOG_STEP_M: f64 = 0.001;
pub const JOG_BIG_STEP_M: f64 = 0.010;
/// `+`/`-` change the time between keys by a tenth of a second, never below it, and the
/// playback speed of timed sequences by a tenth, within the range.
pub const INTERVAL_STEP: f64 = 0.1;
pub const MIN_SPEED: f64 = 0.1;
pub const MAX_SPEED: f64 = 4.0;
/// A revolute joint whose world axis has a vertical component below this is "horizontal":
/// gravity can turn it (about 25° or more from vertical).
pub const VERTICAL_AXIS: f64 = 0.9;
/// A prismatic joint whose axis has a vertical component above this (more than 30° from
/// horizontal) slides under gravity.
pub const SLIDING_AXIS: f64 = 0.5;
/// A horizontal revolute joint carries weight only if what it moves reaches at least this far
/// from its axis (metres): a wrist roll or a gripper turns the tool about itself, while a
/// shoulder, elbow or wrist flex swings the rest of the arm.
pub const MIN_LEVER_M: f64 = 0.01;

/// A captured value is rounded to this for readability: 0.1° for revolute joints, 0.1 mm for
/// prismatic ones (well below what a hobby servo holds: one tick is 0.088°).
pub fn tidy(joint: &Joint, value: f64) -> f64 {
    let scale = match joint.kind {
        JointKind::Revolute => 10.0,
        JointKind::Prismatic => 10_000.0,
    };
    // +0.0 turns -0.0 into 0.0, which the file would otherwise show as "-0.0".
    ((value * scale).round() / scale).clamp(joint.limits.min, joint.limits.max) + 0.0
}

/// A joint value for the screen and messages: degrees, or millimetres for prismatic joints.
pub fn format_value(joint: &Joint, value: f64) -> String {
    match joint.kind {
        JointKind::Revolute => format!("{value:.1}°"),
        JointKind::Prismatic => format!("{:.1} mm", value * 1000.0),
    }
}

/// Which joints carry the arm's weight at `values`: releasing their torque lets the arm fall.
///
/// Derived from the geometry, not from a list per robot: a revolute joint carries weight when
/// its world axis is not near vertical (gravity has a lever about it) and what it moves reaches
/// away from that axis (the TCP when the TCP is beyond the joint, else the last joint's frame),
/// so shoulder, elbow and wrist flex joints do and a vertical base pan, a wrist roll or a
/// gripper do not. A prismatic joint carries weight when its axis is far from horizontal.
pub fn weight_bearing(robot: &Robot, values: &[f64]) -> Vec<bool> {
    let frames = robot.joint_frames(values);
    let axes = robot.joint_axes(values);
    let tcp = robot
        .tcp
        .as_ref()
        .and_then(|tcp| Some((tcp.parent, frames.get(tcp.parent)?.compose(&tcp.origin).t)));
    let last = frames.last().map(|f| f.t);
    robot
        .joints
        .iter()
        .zip(&axes)
        .enumerate()
        .map(|(i, (joint, &(anchor, axis)))| {
            let vertical = axis.normalize_or_zero().z.abs();
            match joint.kind {
                JointKind::Prismatic => vertical > SLIDING_AXIS,
                JointKind::Revolute => {
                    if vertical >= VERTICAL_AXIS {
                        return false;
                    }
                    let distal = match tcp {
                        Some((parent, point)) if parent >= i => point,
                        _ => last.unwrap_or(anchor),
                    };
                    let lever = (distal - anchor)
                        .reject_from(axis.normalize_or_zero())
                        .length();
                    lever >= MIN_LEVER_M
                }
            }
        })
        .collect()
}

/// What a motion on the player's thread is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    /// `space`: to key `index`, with the approach ramp.
    ToKey(usize),
    /// `y`: the sequence from key `from`.
    Play { from: usize },
}

/// A motion for the player: the approach ramp from the present pose, then `trajectory`.
#[derive(Debug, Clone)]
pub struct MotionPlan {
    pub kind: MotionKind,
    pub trajectory: Trajectory,
    pub options: PlayOptions,
    /// Where the arm is commanded at the end when the motion finishes.
    pub end_pose: Vec<f64>,
}

/// What the session asks of the servos. Joint indices are in robot order.
#[derive(Debug, Clone)]
pub enum Command {
    /// On: hold these joints where they are now (goal = present, then torque on). Off: limp.
    Torque { joints: Vec<usize>, on: bool },
    /// New goals for these joints, already inside their limits.
    Goals(Vec<(usize, f64)>),
    /// Run the player (safe approach ramp, then the trajectory) while keys are still read.
    Run(Box<MotionPlan>),
    /// Stop the running motion: the first request decelerates along the path, a second holds
    /// at once.
    Stop,
}

/// What the session reports back.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The present pose, in robot joint order.
    Reading(Vec<f64>),
    /// Torque came on; the joints hold at these values.
    Held {
        joints: Vec<usize>,
        values: Vec<f64>,
    },
    Released {
        joints: Vec<usize>,
    },
    GoalsSent(Vec<(usize, f64)>),
    MotionStarted {
        kind: MotionKind,
        end_pose: Vec<f64>,
    },
    /// The player returned; every joint has torque on. `last_goals` is the last pose it
    /// commanded, when known.
    MotionEnded {
        outcome: Result<Outcome, String>,
        last_goals: Option<Vec<f64>>,
    },
    BusError(String),
}

/// A question the session waits on.
#[derive(Debug, Clone, PartialEq)]
pub enum Prompt {
    /// A journal newer than the file was found at start.
    Recover { keys: usize },
    /// `q` with unsaved changes.
    Quit,
    /// Releasing torque on `joints`, of which `heavy` carry the arm's weight.
    Release {
        joints: Vec<usize>,
        heavy: Vec<usize>,
    },
    /// Importing over unsaved changes.
    Replace { path: PathBuf },
    /// `i`: the path to import, being typed.
    ImportPath { text: String },
}

impl Prompt {
    /// Whether `key` means something to this prompt (a script that sends anything else is
    /// wrong, and is stopped rather than have the key swallowed).
    pub fn accepts(&self, key: &Key) -> bool {
        match self {
            Prompt::ImportPath { .. } => matches!(
                key,
                Key::Char(_) | Key::Backspace | Key::Enter | Key::Esc | Key::Interrupt
            ),
            _ => yes_no(key).is_some(),
        }
    }
}

fn yes_no(key: &Key) -> Option<bool> {
    match key {
        Key::Char('y' | 'Y') => Some(true),
        Key::Char('n' | 'N') | Key::Esc | Key::Interrupt => Some(false),
        _ => None,
    }
}

/// The last action, or an error.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Status {
    pub text: String,
    pub error: bool,
}

/// What the arm is doing.
#[derive(Debug, Clone, PartialEq)]
pub enum Activity {
    Idle,
    Moving {
        kind: MotionKind,
        end_pose: Vec<f64>,
        /// Stop requests sent so far.
        stops: u32,
    },
}

#[derive(Debug)]
pub struct TeachState {
    robot: Robot,
    list: KeyframeList,
    output: PathBuf,
    journal: Option<Journal>,
    /// The list differs from the output file although the list itself is clean: imported from
    /// another file, or recovered from the journal.
    replaced: bool,
    /// Offered at start, until answered.
    recovery: Option<Sequence>,
    present: Vec<f64>,
    goals: Vec<f64>,
    torque: Vec<bool>,
    selected: usize,
    speed: f64,
    activity: Activity,
    prompt: Option<Prompt>,
    status: Status,
    quit: bool,
}

impl TeachState {
    /// A session on `list`, writing to `output`, journaled to `journal` (when there is a cache
    /// directory), with the arm at `present` and every joint's torque taken as off until
    /// [`TeachState::start`]'s hold is confirmed.
    pub fn new(
        robot: Robot,
        list: KeyframeList,
        output: PathBuf,
        journal: Option<Journal>,
        present: Vec<f64>,
    ) -> TeachState {
        let n = robot.joints.len();
        let goals = robot
            .joints
            .iter()
            .zip(&present)
            .map(|(j, &v)| tidy(j, v))
            .collect();
        TeachState {
            robot,
            list,
            output,
            journal,
            replaced: false,
            recovery: None,
            present,
            goals,
            torque: vec![false; n],
            selected: 0,
            speed: 1.0,
            activity: Activity::Idle,
            prompt: None,
            status: Status::default(),
            quit: false,
        }
    }

    /// The first commands: hold every joint where it is, so jogging works at once and nothing
    /// falls; `t`/`T` release joints to move them by hand.
    pub fn start(&mut self) -> Vec<Command> {
        vec![Command::Torque {
            joints: (0..self.robot.joints.len()).collect(),
            on: true,
        }]
    }

    /// Offers to recover a journal found at start.
    pub fn offer_recovery(&mut self, pending: Pending) {
        self.prompt = Some(Prompt::Recover {
            keys: pending.sequence.keyframes.len(),
        });
        self.recovery = Some(pending.sequence);
    }

    /// Recovers the journal at once (`--recover`).
    pub fn recover(&mut self, pending: Pending) {
        self.recovery = Some(pending.sequence);
        self.confirm(Prompt::Recover { keys: 0 });
    }

    // ----- what the screen shows -----

    pub fn robot(&self) -> &Robot {
        &self.robot
    }
    pub fn list(&self) -> &KeyframeList {
        &self.list
    }
    pub fn output(&self) -> &Path {
        &self.output
    }
    pub fn journal(&self) -> Option<&Journal> {
        self.journal.as_ref()
    }
    pub fn present(&self) -> &[f64] {
        &self.present
    }
    pub fn goals(&self) -> &[f64] {
        &self.goals
    }
    pub fn torque(&self) -> &[bool] {
        &self.torque
    }
    pub fn selected(&self) -> usize {
        self.selected
    }
    pub fn activity(&self) -> &Activity {
        &self.activity
    }
    pub fn prompt(&self) -> Option<&Prompt> {
        self.prompt.as_ref()
    }
    pub fn status(&self) -> &Status {
        &self.status
    }
    pub fn should_quit(&self) -> bool {
        self.quit
    }
    pub fn is_moving(&self) -> bool {
        self.activity != Activity::Idle
    }
    /// Unsaved changes: edits since the last write, or a list that came from elsewhere.
    pub fn is_dirty(&self) -> bool {
        self.list.is_dirty() || self.replaced
    }
    /// The speed `y` plays at: adjustable for timed sequences only (uniform ones change their
    /// interval instead).
    pub fn speed(&self) -> f64 {
        if self.list.sequence().key_interval.is_some() {
            1.0
        } else {
            self.speed
        }
    }
    /// Which joints carry the arm's weight at the present pose.
    pub fn weight_bearing(&self) -> Vec<bool> {
        weight_bearing(&self.robot, &self.present)
    }

    /// The question of the pending prompt, for the screen.
    pub fn question(&self) -> Option<String> {
        let prompt = self.prompt.as_ref()?;
        Some(match prompt {
            Prompt::Recover { keys } => format!(
                "a journal of unsaved work ({keys} keys) is newer than {}: recover it? (y/n)",
                self.output.display()
            ),
            Prompt::Quit => "unsaved changes: quit without writing them? (y/n)".into(),
            Prompt::Release { heavy, .. } => format!(
                "{} carr{} the arm's weight: support the arm, then release torque? (y/n)",
                self.names(heavy),
                if heavy.len() == 1 { "ies" } else { "y" }
            ),
            Prompt::Replace { path } => format!(
                "unsaved changes: replace the list with {}? (y/n)",
                path.display()
            ),
            Prompt::ImportPath { text } => {
                format!("import file: {text}▏ (Enter: import, Esc: cancel)")
            }
        })
    }

    // ----- input -----

    /// Handles one key; returns what the servos must do.
    pub fn handle_key(&mut self, key: Key) -> Vec<Command> {
        if let Some(prompt) = self.prompt.take() {
            return self.answer(prompt, key);
        }
        match key {
            Key::Char(' ') => self.move_to_key(),
            Key::Char('u') => self.update_key(),
            Key::Char('n') => self.new_key(),
            Key::Char('d') => self.delete_key(),
            Key::Char('>' | '.') => self.step_key(true),
            Key::Char('<' | ',') => self.step_key(false),
            Key::Char(']') => self.move_key(1),
            Key::Char('[') => self.move_key(-1),
            Key::Char('i') => {
                self.prompt = Some(Prompt::ImportPath {
                    text: self.output.display().to_string(),
                });
                Vec::new()
            }
            Key::Import(path) => self.import(path),
            Key::Char('w') => self.write(None),
            Key::Write(path) => self.write(Some(path)),
            Key::Char('y') => self.play_or_stop(),
            // `=` is `+` without shift on most layouts.
            Key::Char('+' | '=') => self.change_time(true),
            Key::Char('-') => self.change_time(false),
            Key::Char('t') => self.toggle_torque(false),
            Key::Char('T') => self.toggle_torque(true),
            Key::Up => self.select(-1),
            Key::Down => self.select(1),
            Key::Left => self.jog(-1.0, false),
            Key::Right => self.jog(1.0, false),
            Key::ShiftLeft => self.jog(-1.0, true),
            Key::ShiftRight => self.jog(1.0, true),
            Key::Esc => self.stop(),
            Key::Interrupt if self.is_moving() => self.stop(),
            Key::Char('q') | Key::Interrupt => self.request_quit(),
            Key::Char(c) => self.fail(format!("{c:?} does nothing (the keys are listed below)")),
            Key::Enter | Key::Backspace => Vec::new(),
        }
    }

    /// Applies what the session reports.
    pub fn on_event(&mut self, event: Event) {
        match event {
            Event::Reading(values) => self.present = values,
            Event::Held { joints, values } => {
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
            Event::Released { joints } => {
                for &j in &joints {
                    self.torque[j] = false;
                }
                self.info(format!(
                    "released {}: move by hand, then u or n captures the pose",
                    self.names(&joints)
                ));
            }
            Event::GoalsSent(goals) => {
                for &(j, v) in &goals {
                    self.goals[j] = v;
                }
                if let Some(&(j, v)) = goals.last() {
                    let joint = &self.robot.joints[j];
                    self.info(format!("{} → {}", joint.name, format_value(joint, v)));
                }
            }
            Event::MotionStarted { kind, end_pose } => {
                self.info(match kind {
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
                    stops: 0,
                };
            }
            Event::MotionEnded {
                outcome,
                last_goals,
            } => self.motion_ended(outcome, last_goals),
            Event::BusError(message) => {
                self.fail(message);
            }
        }
    }

    fn motion_ended(&mut self, outcome: Result<Outcome, String>, last_goals: Option<Vec<f64>>) {
        let Activity::Moving { kind, end_pose, .. } =
            std::mem::replace(&mut self.activity, Activity::Idle)
        else {
            return;
        };
        // The player turns torque on for every joint before it moves. After a fault that may
        // not have happened (or a servo in shutdown dropped it), so the screen keeps what it
        // knew rather than claim a hold.
        if outcome.is_ok() {
            self.torque.iter_mut().for_each(|t| *t = true);
        }
        let stopped_at = last_goals.as_deref().unwrap_or(&self.present);
        self.goals = match outcome {
            // The exact pose it was sent to, so that jogs from there stay on round values.
            Ok(Outcome::Finished) => end_pose,
            _ => self
                .robot
                .joints
                .iter()
                .zip(stopped_at)
                .map(|(j, &v)| tidy(j, v))
                .collect(),
        };
        match outcome {
            Ok(Outcome::Finished) => self.info(match kind {
                MotionKind::ToKey(i) => format!("at {}", self.key_label(i)),
                MotionKind::Play { .. } => "played to the end; holding the last pose".into(),
            }),
            Ok(Outcome::Stopped) => {
                self.info("stopped: the arm decelerated along its path and holds there")
            }
            Ok(Outcome::Held) => self.info("held at once where the arm was"),
            Err(message) => {
                self.fail(message);
            }
        }
    }

    // ----- prompts -----

    fn answer(&mut self, prompt: Prompt, key: Key) -> Vec<Command> {
        if let Prompt::ImportPath { mut text } = prompt {
            match key {
                Key::Char(c) => text.push(c),
                Key::Backspace => {
                    text.pop();
                }
                Key::Enter if !text.trim().is_empty() => {
                    return self.import(PathBuf::from(text.trim()));
                }
                Key::Enter | Key::Esc | Key::Interrupt => {
                    self.info("import cancelled");
                    return Vec::new();
                }
                _ => {}
            }
            self.prompt = Some(Prompt::ImportPath { text });
            return Vec::new();
        }
        match yes_no(&key) {
            Some(true) => self.confirm(prompt),
            Some(false) => {
                self.decline(prompt);
                Vec::new()
            }
            None => {
                self.prompt = Some(prompt);
                self.fail("answer y or n")
            }
        }
    }

    fn confirm(&mut self, prompt: Prompt) -> Vec<Command> {
        match prompt {
            Prompt::Recover { .. } => {
                if let Some(sequence) = self.recovery.take() {
                    let keys = sequence.keyframes.len();
                    self.list = KeyframeList::new(sequence);
                    self.replaced = true;
                    self.info(format!(
                        "recovered {keys} keys from the journal; w writes them to {}",
                        self.output.display()
                    ));
                }
                Vec::new()
            }
            Prompt::Quit => {
                self.finish("quit without writing the changes");
                Vec::new()
            }
            Prompt::Release { joints, .. } => vec![Command::Torque { joints, on: false }],
            Prompt::Replace { path } => self.load_file(&path),
            Prompt::ImportPath { .. } => Vec::new(),
        }
    }

    fn decline(&mut self, prompt: Prompt) {
        match prompt {
            Prompt::Recover { .. } => {
                self.recovery = None;
                self.info("journal not recovered (the next edit replaces it)");
            }
            Prompt::Quit => self.info("not quitting"),
            Prompt::Release { .. } => self.info("torque stays on"),
            Prompt::Replace { .. } | Prompt::ImportPath { .. } => self.info("import cancelled"),
        }
    }

    // ----- the list -----

    fn update_key(&mut self) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no key to update: n adds one");
        }
        let (values, note) = self.capture();
        self.list.update(values);
        self.info(format!(
            "updated {} from the present pose{note}",
            self.key_label(self.list.current_index())
        ));
        self.edited();
        Vec::new()
    }

    fn new_key(&mut self) -> Vec<Command> {
        let (values, note) = self.capture();
        self.list.insert_after(values);
        self.info(format!(
            "new {} from the present pose{note} ({})",
            self.key_label(self.list.current_index()),
            count(self.list.len())
        ));
        self.edited();
        Vec::new()
    }

    fn delete_key(&mut self) -> Vec<Command> {
        let index = self.list.current_index();
        let label = self.key_label(index);
        if self.list.delete().is_none() {
            return self.fail("no key to delete");
        }
        self.info(format!("deleted {label} ({} left)", count(self.list.len())));
        self.edited();
        Vec::new()
    }

    fn step_key(&mut self, forward: bool) -> Vec<Command> {
        let moved = if forward {
            self.list.next_key()
        } else {
            self.list.previous_key()
        };
        if self.list.is_empty() {
            return self.fail("no keys yet: n adds one from the present pose");
        }
        let label = self.key_label(self.list.current_index());
        if moved {
            self.info(format!("{label} (space moves the arm there)"));
        } else {
            self.info(format!(
                "{label} is the {} key",
                if forward { "last" } else { "first" }
            ));
        }
        Vec::new()
    }

    fn move_key(&mut self, delta: isize) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no keys yet: n adds one from the present pose");
        }
        let label = self.key_label(self.list.current_index());
        if !self.list.move_by(delta) {
            return self.fail(format!(
                "{label} cannot move {}",
                if delta > 0 { "later" } else { "earlier" }
            ));
        }
        self.info(format!(
            "moved {label} {}: it is key {} now",
            if delta > 0 { "later" } else { "earlier" },
            self.list.current_index()
        ));
        self.edited();
        Vec::new()
    }

    fn change_time(&mut self, up: bool) -> Vec<Command> {
        let sign = if up { 1.0 } else { -1.0 };
        match self.list.sequence().key_interval {
            Some(interval) => {
                // Whole tenths, so repeated steps never drift off 0.1 s multiples.
                let tenths = (interval * 10.0).round() + sign;
                // Dividing whole tenths by ten gives the nearest double to the decimal (2.1,
                // 0.3), so the file shows the number the screen does.
                let new = tenths / 10.0;
                if tenths < 1.0 {
                    return self.fail(format!("{INTERVAL_STEP:.1} s between keys is the shortest"));
                }
                if !self.list.set_key_interval(new) {
                    return self.fail(format!(
                        "cannot space keys {new:.1} s apart: a key's hold is longer"
                    ));
                }
                self.info(format!("{new:.1} s between keys"));
                self.edited();
            }
            None => {
                let tenths = (self.speed * 10.0).round() + sign;
                let new = (tenths / 10.0).clamp(MIN_SPEED, MAX_SPEED);
                if (new - self.speed).abs() < 1e-9 {
                    return self.fail(format!(
                        "playback speed stays within {MIN_SPEED} … {MAX_SPEED}"
                    ));
                }
                self.speed = new;
                self.info(format!(
                    "playback speed ×{new:.1} (keys carry their own times)"
                ));
            }
        }
        Vec::new()
    }

    fn import(&mut self, path: PathBuf) -> Vec<Command> {
        if self.is_dirty() {
            self.prompt = Some(Prompt::Replace { path });
            return Vec::new();
        }
        self.load_file(&path)
    }

    fn load_file(&mut self, path: &Path) -> Vec<Command> {
        let sequence = match Sequence::load(path) {
            Ok(s) => s,
            Err(e) => return self.fail(format!("cannot import: {e}")),
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
            count(keys)
        ));
        self.edited();
        Vec::new()
    }

    fn write(&mut self, to: Option<PathBuf>) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("nothing to write: n adds a key from the present pose");
        }
        let path = to.unwrap_or_else(|| self.output.clone());
        if let Err(e) = self.list.save(&path) {
            return self.fail(format!("not written: {e}"));
        }
        self.replaced = false;
        if !same_file(&path, &self.output) {
            // Save-as: the new file is the target from now on, and so is its journal.
            if let Some(journal) = self.journal.take() {
                // The old target's journal holds nothing the new file lacks.
                let _ = journal.remove();
                self.journal = Some(journal.for_other_target(&path));
            }
            self.output = path.clone();
        }
        let journal_note = match self.journal.as_ref().map(Journal::remove) {
            Some(Err(e)) => format!(" (cannot remove the journal: {e})"),
            _ => String::new(),
        };
        let verdict = self.check_note();
        self.info(format!(
            "wrote {} ({}); {verdict}{journal_note}",
            path.display(),
            count(self.list.len())
        ));
        Vec::new()
    }

    /// What `keypose check` would say, in a few words.
    fn check_note(&self) -> String {
        match Trajectory::build(self.list.sequence(), &self.robot) {
            Err(e) => format!("but it does not play on {}: {e}", self.robot.name),
            Ok(trajectory) => {
                let report = plan::check(&trajectory, &self.robot, self.robot.control_hz);
                match report.violations.first() {
                    None => "check passes".into(),
                    Some(v) => format!(
                        "check: {} limit violation(s), first {} {} in {} (keypose retime fixes the timing)",
                        report.violations.len(),
                        v.joint,
                        v.kind.name(),
                        v.segment_label
                    ),
                }
            }
        }
    }

    fn request_quit(&mut self) -> Vec<Command> {
        if self.is_moving() {
            return self.fail("the arm is moving: y or Esc stops it first");
        }
        if self.is_dirty() {
            self.prompt = Some(Prompt::Quit);
            return Vec::new();
        }
        self.finish("quit");
        Vec::new()
    }

    /// Ends the session; the journal goes, since either nothing is unsaved or the user chose
    /// to discard it.
    fn finish(&mut self, message: &str) {
        if let Some(Err(e)) = self.journal.as_ref().map(Journal::remove) {
            self.fail(format!("{message}; cannot remove the journal: {e}"));
        } else {
            self.info(message);
        }
        self.quit = true;
    }

    /// After every edit: the journal gets the whole list, so a crash loses nothing.
    fn edited(&mut self) {
        let Some(journal) = &self.journal else {
            return;
        };
        if let Err(e) = journal.save(self.list.sequence()) {
            self.fail(format!(
                "{}; but the journal {} cannot be written ({e}): w saves your work",
                self.status.text,
                journal.path().display()
            ));
        }
    }

    /// The present pose as key values, rounded for readability and inside the limits; the
    /// note names joints that were outside (calibration or backlash) and were clamped.
    fn capture(&self) -> (Vec<(String, KeyValue)>, String) {
        let mut clamped = Vec::new();
        let values = self
            .robot
            .joints
            .iter()
            .zip(&self.present)
            .map(|(joint, &v)| {
                let value = tidy(joint, v);
                // Within a tick of a limit is quantisation, not worth a word.
                let outside = (joint.limits.min - v).max(v - joint.limits.max);
                if outside > joint.servo.units_per_tick.abs() {
                    clamped.push(joint.name.as_str());
                }
                (joint.name.clone(), KeyValue::Joint(value))
            })
            .collect();
        let note = if clamped.is_empty() {
            String::new()
        } else {
            format!(" ({} clamped into its limits)", clamped.join(", "))
        };
        (values, note)
    }

    // ----- the servos -----

    fn refuse_while_moving(&mut self) -> Option<Vec<Command>> {
        self.is_moving()
            .then(|| self.fail("the arm is moving: y or Esc stops it"))
    }

    fn move_to_key(&mut self) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        if self.list.is_empty() {
            return self.fail("no key to move to: n adds one");
        }
        let trajectory = match Trajectory::build(self.list.sequence(), &self.robot) {
            Ok(t) => t,
            Err(e) => return self.fail(format!("cannot move: {e}")),
        };
        let index = self.list.current_index();
        let time = self.list.sequence().key_time(index);
        // The pose playback passes through at this key (joints the key does not name follow
        // their own tracks), evaluated on the tracks so that control keys are reached too.
        let pose: Vec<f64> = trajectory
            .tracks()
            .iter()
            .zip(&self.robot.joints)
            .map(|(track, joint)| track.sample(time).clamp(joint.limits.min, joint.limits.max))
            .collect();
        let mut sequence = Sequence::new(&self.robot.name);
        sequence.file = format!("<{}>", self.key_label(index));
        sequence.keyframes.push(Keyframe::new(
            self.robot
                .joints
                .iter()
                .zip(&pose)
                .map(|(j, &v)| (j.name.clone(), KeyValue::Joint(v)))
                .collect(),
        ));
        // One key: the player's approach ramp is the whole motion.
        let target = match Trajectory::build(&sequence, &self.robot) {
            Ok(t) => t,
            Err(e) => return self.fail(format!("cannot move: {e}")),
        };
        vec![Command::Run(Box::new(MotionPlan {
            kind: MotionKind::ToKey(index),
            trajectory: target,
            options: PlayOptions {
                progress: false,
                ..PlayOptions::new(self.robot.control_hz)
            },
            end_pose: pose,
        }))]
    }

    fn play_or_stop(&mut self) -> Vec<Command> {
        if self.is_moving() {
            return self.stop();
        }
        if self.list.is_empty() {
            return self.fail("nothing to play: n adds a key");
        }
        let trajectory = match Trajectory::build(self.list.sequence(), &self.robot) {
            Ok(t) => t,
            Err(e) => return self.fail(format!("cannot play: {e}")),
        };
        let speed = self.speed();
        let rate = self.robot.control_hz;
        // The same refusal as `keypose play`: nothing beyond the limits at this speed.
        let report = plan::check_at_speed(&trajectory, &self.robot, rate, speed);
        if let Some(v) = report.violations.first() {
            return self.fail(format!(
                "refusing to play at speed {speed:.1}: {} limit violation(s), first {} {} in {} (space the keys out with +, or keypose retime)",
                report.violations.len(),
                v.joint,
                v.kind.name(),
                v.segment_label
            ));
        }
        let end_pose = trajectory.sample(trajectory.end);
        let from = self.list.current_index();
        vec![Command::Run(Box::new(MotionPlan {
            kind: MotionKind::Play { from },
            trajectory,
            options: PlayOptions {
                speed,
                from_key: Some(from),
                progress: false,
                ..PlayOptions::new(rate)
            },
            end_pose,
        }))]
    }

    fn stop(&mut self) -> Vec<Command> {
        let Activity::Moving { stops, .. } = &mut self.activity else {
            return Vec::new();
        };
        *stops += 1;
        let message = if *stops == 1 {
            "stopping: decelerating along the path (y or Esc again holds at once)"
        } else {
            "holding at once"
        };
        self.info(message);
        vec![Command::Stop]
    }

    fn select(&mut self, delta: isize) -> Vec<Command> {
        let n = self.robot.joints.len() as isize;
        self.selected = (self.selected as isize + delta).rem_euclid(n) as usize;
        let joint = &self.robot.joints[self.selected];
        let unit = match joint.kind {
            JointKind::Revolute => "°",
            JointKind::Prismatic => " m",
        };
        self.info(format!(
            "{} selected (limits {}{unit} … {}{unit})",
            joint.name, joint.limits.min, joint.limits.max
        ));
        Vec::new()
    }

    fn jog(&mut self, sign: f64, big: bool) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        let j = self.selected;
        let joint = &self.robot.joints[j];
        if !self.torque[j] {
            return self.fail(format!(
                "{} is limp (torque off): move it by hand, or t holds it for jogging",
                joint.name
            ));
        }
        let step = match (joint.kind, big) {
            (JointKind::Revolute, false) => JOG_STEP_DEG,
            (JointKind::Revolute, true) => JOG_BIG_STEP_DEG,
            (JointKind::Prismatic, false) => JOG_STEP_M,
            (JointKind::Prismatic, true) => JOG_BIG_STEP_M,
        };
        let goal = tidy(joint, self.goals[j] + sign * step);
        if (goal - self.goals[j]).abs() < 1e-12 {
            let limit = if sign > 0.0 {
                joint.limits.max
            } else {
                joint.limits.min
            };
            return self.fail(format!(
                "{} is at its limit {}",
                joint.name,
                format_value(joint, limit)
            ));
        }
        vec![Command::Goals(vec![(j, goal)])]
    }

    fn toggle_torque(&mut self, all: bool) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        let joints: Vec<usize> = if all {
            (0..self.robot.joints.len()).collect()
        } else {
            vec![self.selected]
        };
        // Mixed states resolve towards holding, the safe direction.
        if !joints.iter().all(|&j| self.torque[j]) {
            let off: Vec<usize> = joints.into_iter().filter(|&j| !self.torque[j]).collect();
            return vec![Command::Torque {
                joints: off,
                on: true,
            }];
        }
        let bearing = self.weight_bearing();
        let heavy: Vec<usize> = joints.iter().copied().filter(|&j| bearing[j]).collect();
        if heavy.is_empty() {
            vec![Command::Torque { joints, on: false }]
        } else {
            self.prompt = Some(Prompt::Release { joints, heavy });
            Vec::new()
        }
    }

    // ----- helpers -----

    fn key_label(&self, index: usize) -> String {
        match self.list.sequence().keyframes.get(index) {
            Some(key) => match &key.name {
                Some(name) => format!("key {index} ({name})"),
                None => format!("key {index}"),
            },
            None => format!("key {index}"),
        }
    }

    fn names(&self, joints: &[usize]) -> String {
        if joints.len() == self.robot.joints.len() && joints.len() > 1 {
            return "all joints".into();
        }
        joints
            .iter()
            .filter_map(|&j| self.robot.joints.get(j).map(|joint| joint.name.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn info(&mut self, text: impl Into<String>) {
        self.status = Status {
            text: text.into(),
            error: false,
        };
    }

    fn fail(&mut self, text: impl Into<String>) -> Vec<Command> {
        self.status = Status {
            text: text.into(),
            error: true,
        };
        Vec::new()
    }
}

/// "1 key", "3 keys".
fn count(keys: usize) -> String {
    if keys == 1 {
        "1 key".into()
    } else {
        format!("{keys} keys")
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    absolute(a) == absolute(b)
}

#[cfg(test)]
mod tests;
