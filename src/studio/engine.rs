//! The studio's engine: the teaching loop of `keypose teach` (driver events into the state,
//! the present pose read every 20 ms, keys pressed through [`teach::press`]) with
//! the keys coming from the page over a channel instead of from a terminal, and every change
//! published as a numbered snapshot for the event streams ([`Hub`]).
//!
//! What arrives is queued in a [`InputQueue`]: a stop (the Stop button, Esc, Ctrl-C, a lost
//! controller) drops every action queued before it, and keys wait while a jog runs. The
//! moving arm itself is braked before any of that by the HTTP thread or the signal handler,
//! through the session's [`teach::Brake`].

use super::control::Lease;
use super::snapshot::{snapshot, KeyPoses, Planned};
use crate::sequence::Sequence;
use crate::teach::InputQueue;
use crate::teach::{self, Key, Session, TeachError, TeachState};
use serde_json::Value;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// How often the present pose is read: 50 Hz, so that the page, which draws each snapshot,
/// follows the arm at well over 30 Hz (the terminal reads at 20 Hz).
pub(crate) const READ_PERIOD: Duration = Duration::from_millis(20);
/// How often the end of a jog is looked for while keys wait for it.
const WAITING_POLL: Duration = Duration::from_millis(2);

/// What the page asks the engine to do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// A key, as the terminal would get it.
    Key(Key),
    /// The answer typed into the page's box for a text prompt: replaces what the prompt holds
    /// (by Backspace), types it and presses Enter — the keys the terminal would get.
    Line(String),
    /// The Stop button: whatever the page shows, a moving arm stops (a prompt in the way is
    /// dropped first).
    Stop,
}

/// What reaches the engine from the other threads.
pub enum Input {
    /// A page's action, answered on `reply`.
    Action {
        /// What the page asks.
        action: Action,
        /// The status line after the action.
        reply: Sender<Value>,
    },
    /// Ctrl-C, SIGTERM or SIGHUP in the terminal.
    Interrupt,
    /// A fault of the server (a panic in one of its threads), which has braked the arm
    /// already: the session ends once the arm is at rest, saying this.
    Fault(String),
}

impl teach::Input for Input {
    fn is_stop(&self) -> bool {
        match self {
            Input::Interrupt | Input::Fault(_) => true,
            Input::Action { action, .. } => match action {
                Action::Stop => true,
                Action::Key(key) => key.is_stop(),
                Action::Line(_) => false,
            },
        }
    }
    fn is_jog(&self) -> bool {
        matches!(self, Input::Action { action: Action::Key(key), .. } if key.is_jog())
    }
}

/// The published state, shared with the HTTP threads.
#[derive(Debug, Default)]
pub(crate) struct Published {
    pub seq: u64,
    pub json: Arc<String>,
    /// The list as it is now, for the timeline.
    pub sequence: Option<Sequence>,
    /// The session ended: streams close.
    pub ended: bool,
    last: Value,
}

/// What the engine and the HTTP threads share.
#[derive(Debug, Default)]
pub struct Hub {
    published: Mutex<Published>,
    changed: Condvar,
    pub(crate) lease: Mutex<Lease>,
    /// The keys' poses on the trajectory, for the ghosts.
    key_poses: Mutex<KeyPoses>,
    /// The session's playhead, followed from [`run`]'s start.
    playhead: Mutex<crate::player::Playhead>,
}

/// What a stream waiting for news gets.
pub enum News {
    /// A newer snapshot: its number and its JSON text.
    Snapshot(u64, Arc<String>),
    /// Nothing new within the time waited.
    Quiet,
    /// The session has ended: the stream closes.
    Ended,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Hub {
    /// The lease of control, locked.
    pub fn lease(&self) -> MutexGuard<'_, Lease> {
        lock(&self.lease)
    }

    pub(crate) fn published(&self) -> MutexGuard<'_, Published> {
        lock(&self.published)
    }

    /// Publishes `state` when it differs from the last snapshot.
    pub(super) fn publish(&self, state: &TeachState, bus: &str) {
        let controlled = self.lease().is_held();
        let playhead = lock(&self.playhead).at();
        let mut key_poses = lock(&self.key_poses);
        let (poses, contacts) = key_poses.of(state.robot(), state.list().sequence());
        let planned = Planned {
            poses,
            contacts,
            playhead: playhead.as_ref(),
        };
        let value = snapshot(state, bus, controlled, &planned);
        drop(key_poses);
        let mut published = self.published();
        if value == published.last {
            return;
        }
        published.sequence = Some(state.list().sequence().clone());
        self.number(&mut published, value);
    }

    /// Sends `value` as the next snapshot.
    fn number(&self, published: &mut Published, value: Value) {
        published.seq += 1;
        let mut sent = value.clone();
        sent["seq"] = published.seq.into();
        // For the page's latency figure: when this pose left the server.
        sent["at_ms"] = unix_ms().into();
        published.json = Arc::new(sent.to_string());
        published.last = value;
        self.changed.notify_all();
    }

    fn end(&self) {
        self.published().ended = true;
        self.changed.notify_all();
    }

    /// The first snapshot after `seen`, waiting at most `timeout` for it.
    pub fn wait_news(&self, seen: u64, timeout: Duration) -> News {
        let published = self.published();
        let (published, _) = self
            .changed
            .wait_timeout_while(published, timeout, |p| p.seq <= seen && !p.ended)
            .unwrap_or_else(PoisonError::into_inner);
        if published.ended {
            News::Ended
        } else if published.seq > seen {
            News::Snapshot(published.seq, published.json.clone())
        } else {
            News::Quiet
        }
    }
}

fn unix_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// How a studio session ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ended {
    /// The page quit it (`q`).
    Quit,
    /// Ctrl-C (or SIGTERM, SIGHUP) in the terminal, once the arm was at rest.
    Interrupted,
    /// The server failed (what it said), once the arm was at rest.
    ServerFault(String),
}

/// Runs the session until the page quits it (`q`), or Ctrl-C or a server fault ends it with
/// the arm at rest.
pub fn run(
    state: &mut TeachState,
    session: &mut Session,
    hub: &Arc<Hub>,
    received: Receiver<Input>,
) -> Result<Ended, TeachError> {
    let bus = session.describe().to_string();
    *lock(&hub.playhead) = session.playhead();
    let mut queue = InputQueue::default();
    let mut waiting_jog = WaitingJog::default();
    let mut next_read = Instant::now();
    // Set by Ctrl-C or a fault: the session ends so once the arm is at rest.
    let mut ending: Option<Ended> = None;
    let result = loop {
        follow_the_drivers(state, session, hub, &mut queue)?;
        if Instant::now() >= next_read {
            teach::refresh(state, session);
            next_read = Instant::now() + READ_PERIOD;
        }
        while let Some(input) = queue.next(state.is_jogging()) {
            let ends = carry_out(state, session, input, &mut waiting_jog, &|state| {
                hub.publish(state, &bus)
            });
            // A fault is what the session ends with, whatever else asked it to end.
            if !matches!(ending, Some(Ended::ServerFault(_))) {
                ending = ends.or(ending);
            }
        }
        hub.publish(state, &bus);
        waiting_jog.answer_when_taken(state);
        hub.publish(state, &bus);
        if state.should_quit() {
            break Ok(Ended::Quit);
        }
        if let Some(ended) = ending.as_ref().filter(|_| !state.is_moving()) {
            break Ok(ended.clone());
        }
        let mut timeout = next_read.saturating_duration_since(Instant::now());
        if !queue.is_empty() {
            timeout = timeout.min(WAITING_POLL);
        }
        match received.recv_timeout(timeout) {
            Ok(input) => {
                take(&mut queue, input);
                // Whatever else has arrived meanwhile, so that a stop behind it is seen now.
                while let Ok(input) = received.try_recv() {
                    take(&mut queue, input);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) if queue.is_empty() => break Ok(Ended::Quit),
            Err(RecvTimeoutError::Disconnected) => {}
        }
    };
    hub.end();
    result
}

/// Queues `input`; what it drops (a stop drops everything before it) is answered as dropped.
fn take(queue: &mut InputQueue<Input>, input: Input) {
    let why = if teach::Input::is_stop(&input) {
        "dropped: a stop came after it".to_string()
    } else {
        format!(
            "refused: {} actions are waiting already",
            teach::MAX_WAITING
        )
    };
    answer_dropped(queue.push(input), &why);
}

fn answer_dropped(dropped: Vec<Input>, why: &str) {
    for input in dropped {
        if let Input::Action { reply, .. } = input {
            let _ = reply.send(serde_json::json!({"text": why, "error": true}));
        }
    }
}

/// The answer owed to the jog that waits behind the running one: given when the state takes
/// it (it starts, or is refused, or a stop drops it), so that the page learns what became of
/// it — and, waiting for it, sends no more than one jog ahead of the arm.
#[derive(Default)]
struct WaitingJog(Option<Sender<Value>>);

impl WaitingJog {
    fn wait(&mut self, reply: Sender<Value>) {
        if let Some(replaced) = self.0.replace(reply) {
            let _ = replaced.send(serde_json::json!({
                "text": "replaced by a newer jog",
                "error": false,
            }));
        }
    }

    fn answer_when_taken(&mut self, state: &TeachState) {
        if state.pending_jog().is_none() {
            if let Some(reply) = self.0.take() {
                let _ = reply.send(status(state));
            }
        }
    }
}

fn status(state: &TeachState) -> Value {
    serde_json::json!({
        "text": state.status().text,
        "error": state.status().error,
    })
}

/// Hands one input to the state and publishes what it did before answering it (whoever asks
/// for the state once answered sees what the action did); for an interruption or a fault,
/// how the session is to end (once the arm is at rest).
fn carry_out(
    state: &mut TeachState,
    session: &mut Session,
    input: Input,
    waiting_jog: &mut WaitingJog,
    publish: &dyn Fn(&TeachState),
) -> Option<Ended> {
    match input {
        Input::Action { action, reply } => {
            let jog = match &action {
                Action::Key(key) if key.is_jog() => Some(key.clone()),
                _ => None,
            };
            act(state, session, action);
            publish(state);
            if jog.is_some() && state.pending_jog() == jog.as_ref() {
                waiting_jog.wait(reply);
            } else {
                let _ = reply.send(status(state));
            }
            waiting_jog.answer_when_taken(state);
            None
        }
        Input::Interrupt => {
            interrupt(state, session);
            publish(state);
            Some(Ended::Interrupted)
        }
        Input::Fault(what) => {
            interrupt(state, session);
            publish(state);
            Some(Ended::ServerFault(what))
        }
    }
}

/// What happens between keys: a finished motion's end, and the soft stop when the
/// controlling page is gone — also one that went silent (no heartbeat, no broken stream to
/// tell), let go here whether or not any page asks for anything. A lost page's queued keys
/// go with it.
fn follow_the_drivers(
    state: &mut TeachState,
    session: &mut Session,
    hub: &Hub,
    queue: &mut InputQueue<Input>,
) -> Result<(), TeachError> {
    if let Some(event) = session.poll()? {
        let follow = state.on_event(event);
        teach::apply(state, session, follow);
    }
    let lost = {
        let mut lease = hub.lease();
        lease.expire(Instant::now());
        lease.take_lost()
    };
    if lost {
        session.brake().soft_stop();
        answer_dropped(queue.drop_all(), "dropped: the page lost control");
        let stop = state.soft_stop();
        teach::apply(state, session, stop);
    }
    Ok(())
}

fn act(state: &mut TeachState, session: &mut Session, action: Action) {
    match action {
        Action::Key(key) => {
            teach::press(state, session, key);
        }
        Action::Stop => interrupt(state, session),
        Action::Line(text) => {
            let Some(teach::Prompt::Text { text: now, .. }) = state.prompt() else {
                // Not asked for (the page was behind): typed as keys, the line would run as
                // commands, so it is dropped.
                return;
            };
            let typed = now.chars().count();
            let keys = std::iter::repeat_n(Key::Backspace, typed)
                .chain(text.chars().map(Key::Char))
                .chain([Key::Enter]);
            for key in keys {
                teach::press(state, session, key);
            }
        }
    }
}

/// Ctrl-C and the Stop button: the prompt (if any) is dropped and a moving arm stopped, by the keys that do it on
/// the terminal — the first stop decelerates along the path, a second holds at once. The loop
/// ends once the arm is at rest, holding.
fn interrupt(state: &mut TeachState, session: &mut Session) {
    if state.prompt().is_some() {
        teach::press(state, session, Key::Esc);
    }
    if state.is_moving() {
        teach::press(state, session, Key::Esc);
    }
}

/// Why a token of the page is no key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum PageKeyError {
    #[error(transparent)]
    Token(#[from] teach::TokenError),
    #[error("{token:?}: expected {what} after the colon")]
    NoNumber { token: String, what: &'static str },
    #[error("{token:?}: expected three numbers in millimetres, X,Y,Z, after the colon")]
    NoToolTarget { token: String },
    #[error("{token:?} is for --keys scripts, not the page")]
    ScriptOnly { token: String },
}

/// A key of the page, in the tokens of a `--keys` script (`space`, `shift-left`, `u`, …)
/// plus the page's own: `select-key:N`, `toggle-key:N` (Ctrl-click), `range-key:N`
/// (Shift-click), `shift-keys:±MS` (the selection dragged in time), `ease:OUT,IN` (the easing
/// handles, percent), `select-joint:N`,
/// `key-time:MS`, `capture-at:MS` and
/// `tool-target:X,Y,Z` (the tool handle, millimetres in the base frame). The script's
/// `import:`, `write:` and `wait:` are refused: the page imports through the `i` prompt, and
/// writes where the session writes.
pub(crate) fn parse_key(token: &str) -> Result<Key, PageKeyError> {
    let number = |rest: &str, what: &'static str| {
        rest.parse::<u64>().map_err(|_| PageKeyError::NoNumber {
            token: token.to_string(),
            what,
        })
    };
    if let Some(rest) = token.strip_prefix("select-key:") {
        return number(rest, "a key index").map(|i| Key::SelectKey(i as usize));
    }
    if let Some(rest) = token.strip_prefix("toggle-key:") {
        return number(rest, "a key index").map(|i| Key::ToggleKey(i as usize));
    }
    if let Some(rest) = token.strip_prefix("range-key:") {
        return number(rest, "a key index").map(|i| Key::RangeKey(i as usize));
    }
    if let Some(rest) = token.strip_prefix("shift-keys:") {
        return (rest.parse::<i64>().ok())
            .filter(|ms| ms.unsigned_abs() <= MAX_SHIFT_MS)
            .map(Key::ShiftKeys)
            .ok_or_else(|| PageKeyError::NoNumber {
                token: token.to_string(),
                what: "a signed number of whole milliseconds",
            });
    }
    if let Some(rest) = token.strip_prefix("ease:") {
        return ease(rest).ok_or_else(|| PageKeyError::NoNumber {
            token: token.to_string(),
            what: "two whole percentages, OUT,IN",
        });
    }
    if let Some(rest) = token.strip_prefix("select-joint:") {
        return number(rest, "a joint index").map(|i| Key::SelectJoint(i as usize));
    }
    if let Some(rest) = token.strip_prefix("key-time:") {
        return number(rest, "a time in whole milliseconds").map(Key::KeyTime);
    }
    if let Some(rest) = token.strip_prefix("capture-at:") {
        return number(rest, "a time in whole milliseconds").map(Key::CaptureAt);
    }
    if let Some(rest) = token.strip_prefix("tool-target:") {
        return tool_target(rest).ok_or_else(|| PageKeyError::NoToolTarget {
            token: token.to_string(),
        });
    }
    match teach::parse_token(token)? {
        teach::Step::Key(Key::Import(_) | Key::Write(_)) | teach::Step::Wait(_) => {
            Err(PageKeyError::ScriptOnly {
                token: token.to_string(),
            })
        }
        teach::Step::Key(key) => Ok(key),
    }
}

/// `OUT,IN` in whole percent as a [`Key::Ease`] (the state judges the values).
fn ease(text: &str) -> Option<Key> {
    let (out, into) = text.split_once(',')?;
    Some(Key::Ease {
        out: out.trim().parse().ok()?,
        into: into.trim().parse().ok()?,
    })
}

/// The longest move in time a page may ask for: beyond a day no key can be (the list's own
/// bound refuses it anyway), and the bound keeps the conversion to seconds exact.
const MAX_SHIFT_MS: u64 = 86_400_000;

/// `X,Y,Z` in millimetres as a [`Key::ToolTarget`] in whole micrometres; ten metres or more
/// from the base is no arm's (and keeps the conversion far from overflowing).
fn tool_target(text: &str) -> Option<Key> {
    let mm: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.abs() < 10_000.0))
        .collect::<Option<_>>()?;
    let [x, y, z] = mm[..] else { return None };
    Some(Key::ToolTarget(
        [x, y, z].map(|v| (v * 1000.0).round() as i64),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_keys_are_the_script_tokens_and_the_studio_ones() {
        assert_eq!(parse_key("space"), Ok(Key::Char(' ')));
        assert_eq!(parse_key("shift-right"), Ok(Key::ShiftRight));
        assert_eq!(parse_key(">"), Ok(Key::Char('>')));
        assert_eq!(parse_key("select-key:3"), Ok(Key::SelectKey(3)));
        assert_eq!(parse_key("select-joint:0"), Ok(Key::SelectJoint(0)));
        assert_eq!(parse_key("toggle-key:2"), Ok(Key::ToggleKey(2)));
        assert_eq!(parse_key("range-key:4"), Ok(Key::RangeKey(4)));
        assert_eq!(parse_key("shift-keys:-250"), Ok(Key::ShiftKeys(-250)));
        assert_eq!(parse_key("copy"), Ok(Key::Copy));
        assert_eq!(parse_key("ease:20,35"), Ok(Key::Ease { out: 20, into: 35 }));
        assert!(parse_key("ease:20").is_err());
        assert!(parse_key("ease:300,0").is_err());
        assert_eq!(parse_key("paste"), Ok(Key::Paste));
        assert!(parse_key("shift-keys:1.5").is_err());
        assert!(parse_key("shift-keys:99999999999").is_err());
        assert_eq!(parse_key("key-time:2500"), Ok(Key::KeyTime(2500)));
        assert!(parse_key("key-time:-1").is_err());
        assert!(parse_key("key-time:1.5").is_err());
        assert_eq!(parse_key("capture-at:1250"), Ok(Key::CaptureAt(1250)));
        assert!(parse_key("capture-at:x").is_err());
        assert!(parse_key("write:/etc/passwd").is_err());
        assert!(parse_key("import:x.json").is_err());
        assert!(parse_key("wait:1s").is_err());
        assert!(parse_key("jump").is_err());
        assert_eq!(
            parse_key("tool-target:250.5,-10,0.0004"),
            Ok(Key::ToolTarget([250_500, -10_000, 0]))
        );
        for bad in ["1,2", "1,2,3,4", "a,2,3", "1,2,NaN", "1,2,1e9", ""] {
            assert!(parse_key(&format!("tool-target:{bad}")).is_err(), "{bad}");
        }
    }
}
