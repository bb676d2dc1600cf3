//! The teaching state machine: [`Key`]s and driver [`Event`]s in; edits of the keyframe list,
//! [`Command`]s for the servos and the file system, and screen state (status line, prompts)
//! out. Every rule of the session lives here, so it is tested without a terminal, servos or
//! files; the UI only draws a `TeachState` and the drivers only carry out its commands.
//!
//! The state changes what it knows of the servos (torque, goals, motion) and of the files
//! (written, journaled) only when an event confirms it, never when it merely asks: a command
//! that fails leaves the screen truthful.

use super::capture::{capture, tidy};
use super::format;
use super::history::{History, Version};
use super::journal::{Entry, Journal, Pending};
use super::keys::Key;
use super::messages::{BusCommand, Clearing, Command, Event, FileCommand};
use super::motion::{self, MotionKind, PlayRefusal};
use super::prompt::{yes_no, Field, Prompt};
use crate::plan::{self, Trajectory};
use crate::player::Outcome;
use crate::robot::{JointKind, Robot};
use crate::sequence::{KeyValue, Keyframe, KeyframeList, Sequence};
use std::path::{Path, PathBuf};

/// Jog steps: arrow keys, and with shift.
const JOG_STEP_DEG: f64 = 1.0;
const JOG_BIG_STEP_DEG: f64 = 10.0;
/// Prismatic joints jog by 1 mm (10 mm with shift): a degree's worth of care.
const JOG_STEP_M: f64 = 0.001;
const JOG_BIG_STEP_M: f64 = 0.010;
/// `+`/`-` change the time between keys by a tenth of a second, never below it, and the
/// playback speed of timed sequences by a tenth, within the range.
const INTERVAL_STEP: f64 = 0.1;
const MIN_SPEED: f64 = 0.1;
const MAX_SPEED: f64 = 4.0;

/// The last action, or an error.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Status {
    /// What the status line says.
    pub text: String,
    /// It reports a failure or a warning (drawn as one).
    pub error: bool,
}

/// What the arm is doing.
#[derive(Debug, Clone, PartialEq)]
pub enum Activity {
    /// No motion runs: the held joints hold their goals.
    Idle,
    /// The player drives the arm on its thread.
    Moving {
        /// What the motion is for.
        kind: MotionKind,
        /// The pose the motion ends at when it finishes, every joint in robot order.
        end_pose: Vec<f64>,
        /// The joints it drives (robot order).
        joints: Vec<usize>,
        /// Stop requests sent so far.
        stops: u32,
    },
}

/// The teaching session's state: the robot, the keyframe list and where it is written, what
/// is known of the servos, the prompt and the status line.
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
    recovery: Option<Entry>,
    /// What undo and redo go back and forward to.
    history: History,
    /// The list as of the last edit (undo, redo, load), with the current key as it was when
    /// the key being handled came: what the next edit goes back to when undone.
    last: Version,
    present: Vec<f64>,
    goals: Vec<f64>,
    torque: Vec<bool>,
    selected: usize,
    speed: f64,
    activity: Activity,
    /// A jog key pressed while a jog runs: the newest only, run when that jog has finished
    /// (a held key moves the arm while held, and no more than one jog after it is let go);
    /// dropped by a stop.
    pending_jog: Option<Key>,
    prompt: Option<Prompt>,
    status: Status,
    quit: bool,
    /// The built-in models' shapes, to refuse moves into contact (`None`: not checked).
    collision: Option<crate::collision::CollisionModel>,
    /// The keys the last copy took (`Copy`), for `Paste`.
    clipboard: Vec<Keyframe>,
    /// The quit question was answered "write": quit once the file is written.
    quit_after_write: bool,
    /// The direction check under way (`D`), if any.
    direction_check: Option<direction::Check>,
    /// Where the direction check records a reversed joint.
    direction_record: DirectionRecord,
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
        let collision = crate::collision::CollisionModel::for_robot(&robot);
        let last = Version {
            sequence: list.sequence().clone(),
            current: list.current_index(),
        };
        TeachState {
            robot,
            list,
            history: History::default(),
            last,
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
            pending_jog: None,
            prompt: None,
            status: Status::default(),
            quit: false,
            collision,
            clipboard: Vec::new(),
            quit_after_write: false,
            direction_check: None,
            direction_record: DirectionRecord::SessionOnly(
                "the robot is a built-in; give --robot FILE (a copy) to record it".into(),
            ),
        }
    }

    /// The first commands: hold every joint where it is, so jogging works at once and nothing
    /// falls; `t`/`T` release joints to move them by hand.
    pub fn start(&mut self) -> Vec<Command> {
        bus(BusCommand::Torque {
            joints: (0..self.robot.joints.len()).collect(),
            on: true,
        })
    }

    /// Offers to recover a journal found at start.
    pub fn offer_recovery(&mut self, pending: Pending) {
        self.prompt = Some(Prompt::Recover {
            keys: pending.entry.list.sequence.keyframes.len(),
        });
        self.recovery = Some(pending.entry);
    }

    /// Recovers the journal at once (`--recover`).
    pub fn recover(&mut self, pending: Pending) {
        self.recovery = Some(pending.entry);
        self.confirm(Prompt::Recover { keys: 0 });
    }

    // ----- what the screen shows -----

    /// The robot being taught.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }
    /// The keyframe list being edited, with its current key.
    pub fn list(&self) -> &KeyframeList {
        &self.list
    }
    /// The file `w` writes to.
    pub fn output(&self) -> &Path {
        &self.output
    }
    /// The journal every edit is written to; `None` without a cache directory.
    pub fn journal(&self) -> Option<&Journal> {
        self.journal.as_ref()
    }
    /// The present pose as last read, per joint in robot order (degrees or metres).
    pub fn present(&self) -> &[f64] {
        &self.present
    }
    /// Each joint's goal as last confirmed (degrees or metres): what a held joint holds.
    pub fn goals(&self) -> &[f64] {
        &self.goals
    }
    /// Each joint's torque as last confirmed: on (held) or off (limp).
    pub fn torque(&self) -> &[bool] {
        &self.torque
    }
    /// The selected joint's index (robot order): what the arrows jog.
    pub fn selected(&self) -> usize {
        self.selected
    }
    /// What the arm is doing.
    pub fn activity(&self) -> &Activity {
        &self.activity
    }
    /// The question the session waits on, if any.
    pub fn prompt(&self) -> Option<&Prompt> {
        self.prompt.as_ref()
    }
    /// The status line: the last action, or an error.
    pub fn status(&self) -> &Status {
        &self.status
    }
    /// The session has ended (`q`, answered): the front end stops.
    pub fn should_quit(&self) -> bool {
        self.quit
    }
    /// A motion runs (or brakes).
    pub fn is_moving(&self) -> bool {
        self.activity != Activity::Idle
    }
    /// A jog is running (braking too): other keys wait for it ([`super::InputQueue`]).
    pub fn is_jogging(&self) -> bool {
        matches!(
            self.activity,
            Activity::Moving {
                kind: MotionKind::Jog,
                ..
            }
        )
    }
    /// The jog key waiting for the running jog to finish, if any.
    pub fn pending_jog(&self) -> Option<&Key> {
        self.pending_jog.as_ref()
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
        self.robot.weight_bearing(&self.present)
    }

    // ----- input -----

    /// Handles one key; returns what the drivers must do.
    pub fn handle_key(&mut self, key: Key) -> Vec<Command> {
        if key.is_stop() && self.is_moving() {
            return self.stop_then_ask(key);
        }
        // Only the selection changes between edits: an edit this key makes is undone to the
        // key that is current now.
        self.last.current = self.list.current_index();
        if let Some(prompt) = self.prompt.take() {
            return self.answer(prompt, key);
        }
        let jog_going_on = matches!(
            self.activity,
            Activity::Moving {
                kind: MotionKind::Jog,
                stops: 0,
                ..
            }
        );
        if key.is_jog() && jog_going_on {
            // Newest wins: a held key's repeats never pile up behind the arm.
            self.pending_jog = Some(key);
            return Vec::new();
        }
        match key {
            Key::Char(' ') => self.move_to_key(),
            Key::Char('u') => self.update_key(),
            Key::Char('n') => self.new_key(),
            Key::Char('U') | Key::Undo => self.undo(),
            Key::Char('R') | Key::Redo => self.redo(),
            Key::Char('d') => self.delete_key(),
            Key::Char('>' | '.') => self.step_key(true),
            Key::Char('<' | ',') => self.step_key(false),
            Key::Char(']') => self.move_key(1),
            Key::Char('[') => self.move_key(-1),
            Key::Char('i') => {
                let text = self.output.display().to_string();
                self.ask(Field::ImportPath, text)
            }
            Key::Import(path) => self.import(path),
            Key::Char('w') => self.write(None),
            Key::Write(path) => self.write(Some(path)),
            Key::Char('N') => self.ask_about_key(Field::Name),
            Key::Char('h') => self.ask_about_key(Field::Hold),
            Key::Char('v') => self.ask_about_key(Field::Value(self.selected)),
            Key::Char('e') => self.ask_about_key(Field::Effort(self.selected)),
            Key::Char('p') => self.cycle_interp(),
            Key::Char('y') => self.play_or_stop(),
            // `=` is `+` without shift on most layouts.
            Key::Char('+' | '=') => self.change_time(true),
            Key::Char('-') => self.change_time(false),
            Key::Char('K') => self.new_tool_key(),
            Key::Char('m') => self.mirror_key(),
            Key::Char('M') => self.mirror_sequence(),
            Key::Char('D') => self.start_direction_check(),
            Key::Char('x') => self.jog_tool(0, 1.0),
            Key::Char('X') => self.jog_tool(0, -1.0),
            Key::Char('c') => self.jog_tool(1, 1.0),
            Key::Char('C') => self.jog_tool(1, -1.0),
            Key::Char('z') => self.jog_tool(2, 1.0),
            Key::Char('Z') => self.jog_tool(2, -1.0),
            Key::ToolTarget(micrometres) => self.move_tool_to(micrometres),
            Key::Char('t') => self.toggle_torque(false),
            Key::Char('T') => self.toggle_torque(true),
            Key::SelectKey(index) => self.select_key(index),
            Key::ToggleKey(index) => self.toggle_key(index),
            Key::RangeKey(index) => self.select_range(index),
            Key::Copy => self.copy_keys(),
            Key::Paste => self.paste_keys(),
            Key::ShiftKeys(millis) => self.shift_keys(millis),
            Key::Ease { out, into } => self.ease(out, into),
            Key::SelectJoint(index) => self.select_joint(index),
            Key::KeyTime(millis) => self.set_key_time(millis),
            Key::CaptureAt(millis) => self.capture_at(millis),
            Key::Up => self.select(-1),
            Key::Down => self.select(1),
            Key::Left => self.jog(-1.0, false),
            Key::Right => self.jog(1.0, false),
            Key::ShiftLeft => self.jog(-1.0, true),
            Key::ShiftRight => self.jog(1.0, true),
            Key::Esc => self.stop(),
            Key::Char('q') | Key::Interrupt => self.request_quit(),
            Key::Char(c) => self.fail(format!("{c:?} does nothing (the keys are listed below)")),
            Key::Enter | Key::Backspace => Vec::new(),
        }
    }

    // ----- prompts -----

    fn answer(&mut self, prompt: Prompt, key: Key) -> Vec<Command> {
        if let Prompt::Text { field, text } = prompt {
            return self.type_text(field, text, key);
        }
        if let Prompt::Direction { joint } = prompt {
            return self.answer_direction(joint, &key);
        }
        if prompt == Prompt::Quit {
            if let Some(commands) = quitting::answer(self, &key) {
                return commands;
            }
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

    fn ask(&mut self, field: Field, text: String) -> Vec<Command> {
        self.prompt = Some(Prompt::Text { field, text });
        Vec::new()
    }

    /// A key typed into a text prompt: Enter hands the line to its field, Esc drops it.
    fn type_text(&mut self, field: Field, mut text: String, key: Key) -> Vec<Command> {
        match key {
            Key::Char(c) => text.push(c),
            Key::Backspace => {
                text.pop();
            }
            Key::Enter => return self.submit(field, text.trim()),
            Key::Esc | Key::Interrupt => {
                self.info(cancelled(field));
                return Vec::new();
            }
            _ => {}
        }
        self.ask(field, text)
    }

    fn submit(&mut self, field: Field, text: &str) -> Vec<Command> {
        match field {
            Field::ImportPath if text.is_empty() => {
                self.info(cancelled(field));
                Vec::new()
            }
            Field::ImportPath => self.import(PathBuf::from(text)),
            Field::Name => self.name_key(text),
            Field::Hold => self.hold_key(text),
            Field::Value(joint) => self.type_value(joint, text),
            Field::Effort(joint) => self.effort_key(joint, text),
        }
    }

    fn confirm(&mut self, prompt: Prompt) -> Vec<Command> {
        match prompt {
            Prompt::Recover { .. } => {
                if let Some(Entry { list, history }) = self.recovery.take() {
                    let keys = list.sequence.keyframes.len();
                    self.list = KeyframeList::new(list.sequence);
                    self.list.select(list.current);
                    self.history = history;
                    self.last = self.version();
                    self.replaced = true;
                    self.info(format!(
                        "recovered {keys} keys from the journal; w writes them to {}",
                        self.output.display()
                    ));
                }
                Vec::new()
            }
            Prompt::Quit => self.finish("quit without writing the changes"),
            Prompt::Release { joints, .. } => bus(BusCommand::Torque { joints, on: false }),
            Prompt::Replace { path } => file(FileCommand::Load(path)),
            Prompt::MoveThere => self.move_to_key(),
            Prompt::Text { .. } | Prompt::Direction { .. } => Vec::new(),
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
            Prompt::Replace { .. } => self.info("import cancelled"),
            Prompt::MoveThere => self.info("the arm stays where it is; space moves it to the key"),
            Prompt::Text { field, .. } => self.info(cancelled(field)),
            Prompt::Direction { .. } => self.info("direction check ended"),
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
        self.edited()
    }

    fn new_key(&mut self) -> Vec<Command> {
        let (values, note) = self.capture();
        self.list.insert_after(values);
        self.info(format!(
            "new {} from the present pose{note} ({})",
            self.key_label(self.list.current_index()),
            format::count(self.list.len())
        ));
        self.edited()
    }

    fn delete_key(&mut self) -> Vec<Command> {
        if self.list.selection().len() > 1 {
            return self.delete_keys();
        }
        let index = self.list.current_index();
        let label = self.key_label(index);
        if self.list.delete().is_none() {
            return self.fail("no key to delete");
        }
        self.info(format!(
            "deleted {label} ({} left)",
            format::count(self.list.len())
        ));
        self.edited()
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
        let direction = if delta > 0 { "later" } else { "earlier" };
        if !self.list.move_by(delta) {
            let target = self.list.current_index().checked_add_signed(delta);
            let within = target.is_some_and(|t| t < self.list.len());
            return self.fail(if within {
                format!("{label} cannot move {direction}: a hold would run into the key after it")
            } else {
                format!("{label} cannot move {direction}")
            });
        }
        self.info(format!(
            "moved {label} {direction}: it is key {} now",
            self.list.current_index()
        ));
        self.edited()
    }

    /// `+`/`-`: the time between keys of a uniform sequence, else the playback speed.
    fn change_time(&mut self, up: bool) -> Vec<Command> {
        let sign = if up { 1.0 } else { -1.0 };
        match self.list.sequence().key_interval {
            Some(interval) => self.change_interval(interval, sign),
            None => self.change_speed(sign),
        }
    }

    fn change_interval(&mut self, interval: f64, sign: f64) -> Vec<Command> {
        // Whole tenths, so repeated steps never drift off 0.1 s multiples.
        let tenths = (interval * 10.0).round() + sign;
        // Dividing whole tenths by ten gives the nearest double to the decimal (2.1, 0.3), so
        // the file shows the number the screen does.
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
        self.edited()
    }

    fn change_speed(&mut self, sign: f64) -> Vec<Command> {
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
        Vec::new()
    }

    fn import(&mut self, path: PathBuf) -> Vec<Command> {
        if self.is_dirty() {
            self.prompt = Some(Prompt::Replace { path });
            return Vec::new();
        }
        file(FileCommand::Load(path))
    }

    fn write(&mut self, to: Option<PathBuf>) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("nothing to write: n adds a key from the present pose");
        }
        file(FileCommand::Save {
            path: to.unwrap_or_else(|| self.output.clone()),
            sequence: self.list.sequence().clone(),
        })
    }

    /// What `keypose check` would say, in a few words.
    fn check_note(&self) -> String {
        match Trajectory::build(self.list.sequence(), &self.robot) {
            Err(e) => format!("but it does not play on {}: {e}", self.robot.name),
            Ok(trajectory) => {
                let report = plan::check(&trajectory, &self.robot, self.robot.control_hz);
                match format::first_violation(&report) {
                    None => "check passes".into(),
                    // A contact is the keys' to mend, not the timing's.
                    Some(first) if report.violations.is_empty() => format!("check: {first}"),
                    Some(first) => {
                        format!("check: {first} (keypose retime fixes the timing)")
                    }
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
        self.finish("quit")
    }

    /// Ends the session; the journal goes, since either nothing is unsaved or the user chose
    /// to discard it.
    fn finish(&mut self, message: &str) -> Vec<Command> {
        self.info(message);
        self.quit = true;
        match &self.journal {
            Some(journal) => clear(journal.clone(), Clearing::Quit),
            None => Vec::new(),
        }
    }

    /// The present pose as key values; the note names joints that were clamped.
    fn capture(&self) -> (Vec<(String, KeyValue)>, String) {
        let (values, clamped) = capture(&self.robot, &self.present);
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
        let index = self.list.current_index();
        match motion::to_key(&self.robot, self.list.sequence(), index) {
            Ok(plan) => match self.way_refusal(&plan.end_pose) {
                Some(touch) => self.fail(format!("refusing to move there: {touch}")),
                None => bus(BusCommand::Run(Box::new(plan))),
            },
            Err(e) => self.fail(format!("cannot move: {e}")),
        }
    }

    fn play_or_stop(&mut self) -> Vec<Command> {
        if self.is_moving() {
            return self.stop();
        }
        if self.list.is_empty() {
            return self.fail("nothing to play: n adds a key");
        }
        let speed = self.speed();
        let from = self.list.current_index();
        match motion::play(&self.robot, self.list.sequence(), from, speed) {
            Ok(plan) => {
                let first = plan.trajectory.sample(plan.trajectory.play_from(Some(from)));
                match self.way_refusal(&first) {
                    Some(touch) => self.fail(format!(
                        "refusing to play: on the approach to key {from}, {touch}"
                    )),
                    None => bus(BusCommand::Run(Box::new(plan))),
                }
            }
            Err(PlayRefusal::Unplayable(e)) => self.fail(format!("cannot play: {e}")),
            Err(PlayRefusal::Limits(report)) if report.violations.is_empty() => self.fail(format!(
                "refusing to play: {}",
                format::first_violation(&report).unwrap_or_default()
            )),
            Err(PlayRefusal::Limits(report)) => self.fail(format!(
                "refusing to play at speed {speed:.1}: {} (space the keys out with +, or keypose retime)",
                format::first_violation(&report).unwrap_or_default()
            )),
        }
    }

    /// The soft stop a front end asks for when it loses its user (a closed page): the first
    /// stop request, decelerating along the path; nothing when the arm is idle or a stop was
    /// already asked for (a second request would hold at once, which is the user's call).
    pub fn soft_stop(&mut self) -> Vec<Command> {
        match self.activity {
            Activity::Moving { stops: 0, .. } => self.stop(),
            _ => Vec::new(),
        }
    }

    fn stop(&mut self) -> Vec<Command> {
        self.pending_jog = None;
        let Activity::Moving { stops, .. } = &mut self.activity else {
            return Vec::new();
        };
        *stops += 1;
        let requests = *stops;
        let message = if requests == 1 {
            "stopping: decelerating along the path (y or Esc again holds at once)"
        } else {
            "holding at once"
        };
        self.info(message);
        bus(BusCommand::Stop { requests })
    }

    fn select(&mut self, delta: isize) -> Vec<Command> {
        let n = self.robot.joints.len() as isize;
        self.select_joint((self.selected as isize + delta).rem_euclid(n) as usize)
    }

    fn select_joint(&mut self, index: usize) -> Vec<Command> {
        if index >= self.robot.joints.len() {
            return self.fail(format!(
                "there is no joint {index}: {} has {}",
                self.robot.name,
                self.robot.joints.len()
            ));
        }
        self.selected = index;
        let joint = &self.robot.joints[self.selected];
        self.info(format!(
            "{} selected (limits {})",
            joint.name,
            format::limits(joint)
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
                format::value(joint, limit)
            ));
        }
        if let Some(touch) = self.contact_refusal(&[(j, goal)]) {
            return self.fail(format!(
                "cannot jog {} to {}: there {touch}",
                joint.name,
                format::value(joint, goal)
            ));
        }
        self.jog_to(&[(j, goal)])
    }

    /// The player's motion for a jog of these joints to these values (inside their limits).
    fn jog_to(&mut self, jogged: &[(usize, f64)]) -> Vec<Command> {
        match motion::jog(&self.robot, &self.goals, jogged) {
            Ok(plan) => bus(BusCommand::Run(Box::new(plan))),
            Err(e) => self.fail(format!("cannot jog: {e}")),
        }
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
            return bus(BusCommand::Torque {
                joints: off,
                on: true,
            });
        }
        let bearing = self.weight_bearing();
        let heavy: Vec<usize> = joints.iter().copied().filter(|&j| bearing[j]).collect();
        if heavy.is_empty() {
            bus(BusCommand::Torque { joints, on: false })
        } else {
            self.prompt = Some(Prompt::Release { joints, heavy });
            Vec::new()
        }
    }

    // ----- helpers -----

    fn key_label(&self, index: usize) -> String {
        format::key_label(self.list.sequence(), index)
    }

    fn names(&self, joints: &[usize]) -> String {
        format::joint_list(&self.robot, joints)
    }

    fn info(&mut self, text: impl Into<String>) {
        self.status = Status {
            text: text.into(),
            error: false,
        };
    }

    fn fail(&mut self, text: impl Into<String>) -> Vec<Command> {
        self.warn(text);
        Vec::new()
    }

    /// An error-coloured status for an edit that was made but deserves a second look.
    fn warn(&mut self, text: impl Into<String>) {
        self.status = Status {
            text: text.into(),
            error: true,
        };
    }
}

fn bus(command: BusCommand) -> Vec<Command> {
    vec![Command::Bus(command)]
}

fn file(command: FileCommand) -> Vec<Command> {
    vec![Command::File(command)]
}

fn clear(journal: Journal, why: Clearing) -> Vec<Command> {
    file(FileCommand::ClearJournal { journal, why })
}

/// What Esc on a text prompt leaves unchanged.
fn cancelled(field: Field) -> &'static str {
    match field {
        Field::ImportPath => "import cancelled",
        Field::Name => "name unchanged",
        Field::Hold => "hold unchanged",
        Field::Value(_) => "value unchanged",
        Field::Effort(_) => "effort unchanged",
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    absolute(a) == absolute(b)
}

mod contact;
mod direction;
mod edits;
mod mirroring;
mod quitting;
mod reports;
mod selection;
mod tool;
mod undo;
pub use direction::DirectionRecord;
pub(crate) use tool::selected_tool;
pub use tool::tool_positions;

#[cfg(test)]
mod tests;
