//! The keys of the teaching session: the [`Key`] events the state machine understands, the
//! bindings shown on screen and in `--help` (one table, so the two never disagree), and the
//! tokens of a `--keys` script.

use std::path::PathBuf;
use std::time::Duration;

/// One key press, after the terminal's (or the script's) own encoding is gone.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Key {
    /// A printable character: the bindings, answers to prompts, text typed into a path prompt.
    Char(char),
    /// ↑: select the previous joint (wrapping around).
    Up,
    /// ↓: select the next joint (wrapping around).
    Down,
    /// ←: jog the selected joint 1° (1 mm) down.
    Left,
    /// →: jog the selected joint 1° (1 mm) up.
    Right,
    /// Shift + ←: jog 10° (10 mm) down.
    ShiftLeft,
    /// Shift + →: jog 10° (10 mm) up.
    ShiftRight,
    /// Enter: end a typed line.
    Enter,
    /// Esc: stop the arm, or cancel a prompt.
    Esc,
    /// Backspace: delete the last typed character.
    Backspace,
    /// Ctrl-C in raw mode: stops the arm when it moves, else asks to quit like `q`.
    Interrupt,
    /// Undo the last edit of the list (`U`; Ctrl+Z in the terminal and the page).
    Undo,
    /// Redo the edit undone last (`R`; Ctrl+Shift+Z or Ctrl+Y in the terminal and the page).
    Redo,
    /// Script only: import this file (what `i`, typing the path and Enter do on screen).
    Import(PathBuf),
    /// Script only: write to this file, which becomes the session's output.
    Write(PathBuf),
    /// The studio's list: make key `index` current (a click on it).
    SelectKey(usize),
    /// The studio's list or timeline: add key `index` to the selection, or take it out (a
    /// Ctrl-click).
    ToggleKey(usize),
    /// The studio's list or timeline: select the keys from the current one to `index` (a
    /// Shift-click).
    RangeKey(usize),
    /// Copy the selected keys (Ctrl+C in the studio; `copy` in a script).
    Copy,
    /// Paste the copied keys after the current one (Ctrl+V in the studio; `paste`).
    Paste,
    /// The studio's timeline: move every selected key this many milliseconds (a drag of one
    /// of several selected keys; negative is earlier).
    ShiftKeys(i64),
    /// The studio's easing handles: the segment from the current key speeds up over the first
    /// `out` percent of its path and slows to rest over the last `into` percent (multiples of
    /// 5; both 0: steady). Linear segments only.
    Ease {
        /// Percent of the path spent speeding up from the current key.
        out: u8,
        /// Percent of the path spent slowing down into the next key.
        into: u8,
    },
    /// The studio's joint table: select joint `index` (a click on it).
    SelectJoint(usize),
    /// The studio's timeline: move the current key to this time, in whole milliseconds (a
    /// drag; milliseconds keep the key `Eq` and the file's times short).
    KeyTime(u64),
    /// The studio's timeline: a new key from the present pose at this time, in whole
    /// milliseconds (captured where the playhead is parked), no other key moving.
    CaptureAt(u64),
    /// The studio's tool handle: move the tool point here (base frame, whole micrometres, so
    /// the key stays `Eq`), checked and solved as a tool jog is (a drag of the handle).
    ToolTarget([i64; 3]),
}

impl Key {
    /// Whether the key jogs the arm (joints, the tool, the tool handle): these may come faster
    /// than the arm moves (a held key repeats), so a session keeps the newest one only.
    pub fn is_jog(&self) -> bool {
        matches!(
            self,
            Key::Left
                | Key::Right
                | Key::ShiftLeft
                | Key::ShiftRight
                | Key::Char('x' | 'X' | 'c' | 'C' | 'z' | 'Z')
                | Key::ToolTarget(_)
        )
    }

    /// Whether the key asks the arm to stop (Esc, Ctrl-C): it wins over every key queued
    /// before it, which it drops ([`super::inputs::InputQueue`]).
    pub fn is_stop(&self) -> bool {
        matches!(self, Key::Esc | Key::Interrupt)
    }
}

/// A key binding as shown to the user.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binding {
    /// The keys, as the help and the screen write them (`"space"`, `"← →"`).
    pub keys: &'static str,
    /// For `--help`.
    pub action: &'static str,
    /// For the screen, where all of them must fit in a few lines of an 80-column terminal.
    pub short: &'static str,
}

const fn bind(keys: &'static str, short: &'static str, action: &'static str) -> Binding {
    Binding {
        keys,
        action,
        short,
    }
}

/// Every binding, in the order they are shown.
pub const BINDINGS: &[Binding] = &[
    bind(
        "space",
        "go to key",
        "move the arm to the current key (safe ramp)",
    ),
    bind(
        "u",
        "update key",
        "update the current key from the present pose",
    ),
    bind(
        "n",
        "new key",
        "new key after the current one, from the present pose",
    ),
    bind(
        "K",
        "new tool key",
        "new key after the current one, the present pose as a tool key (tool xyz + rpy)",
    ),
    bind("d", "delete", "delete the current key (U undoes it)"),
    bind(
        "D",
        "direction check",
        "jog each joint 5° in turn and answer m if the real joint moved as the drawn one \
         did, r if reversed: a reversed joint's direction flips at once and is written to \
         the robot file",
    ),
    bind(
        "U R",
        "undo/redo",
        "undo the last edit / redo it (also Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y); the list only, \
         never the arm; 100 steps, kept in the journal",
    ),
    bind("> <", "next/prev", "next / previous key (also . and ,)"),
    bind("] [", "move key", "move the current key later / earlier"),
    bind(
        "N",
        "name",
        "name the current key (warns of a name another key has: play --from refuses it)",
    ),
    bind(
        "h",
        "hold",
        "hold the current key for some seconds (typed; 0 clears it)",
    ),
    bind(
        "e",
        "effort",
        "the selected joint's effort in the current key, % of its torque (a grasp; empty clears)",
    ),
    bind(
        "p",
        "interp",
        "interpolation from the current key: step → linear → cubic → smooth → monotone",
    ),
    bind(
        "v",
        "type value",
        "type the selected joint's value in the current key (then y moves the arm there)",
    ),
    bind(
        "m M",
        "mirror key/all",
        "mirror the current key / every key across the arm's vertical plane (two arms: the \
         selected joint's arm onto the other)",
    ),
    bind("i", "import", "import a sequence file (replaces the list)"),
    bind("w", "write", "write the sequence file"),
    bind("y", "play/stop", "play from the current key / stop"),
    bind(
        "+ -",
        "interval/speed",
        "time between keys ±0.1 s (timed sequences: playback speed ±0.1)",
    ),
    bind(
        "x c z",
        "tool +x/y/z (shift −)",
        "jog the tool 5 mm along the base frame's +x, +y, +z (shift: −), solving the joints",
    ),
    bind("t", "torque joint", "torque on/off, selected joint"),
    bind("T", "torque all", "torque on/off, all joints"),
    bind("↑ ↓", "select joint", "select a joint"),
    bind(
        "← →",
        "jog 1° (shift 10°)",
        "jog the selected joint 1° (shift: 10°; 1 mm / 10 mm)",
    ),
    bind("Esc", "stop/cancel", "stop the arm / cancel a prompt"),
    bind("q", "quit", "quit (asks when there are unsaved changes)"),
];

/// The bindings as text for `--help`, and the script tokens.
pub fn help_text() -> String {
    let mut text = String::from("Keys:\n");
    for b in BINDINGS {
        text.push_str(&format!("  {:<7} {}\n", b.keys, b.action));
    }
    text.push_str(
        "\nA --keys script holds tokens separated by spaces or lines (# starts a comment):\n  \
         space u n d > < ] [ N h p v m M U R i w y + - t T q, up down left right shift-left\n  \
         shift-right, enter esc backspace, undo redo (as U R), copy paste (the selected keys), yes no (answers), any single character (typed into a prompt;\n  \
         space types a space there), import:PATH, write:PATH (paths without spaces), wait:500ms or wait:2s.\n  \
         Each step waits until the arm has reached its goal; `-` as the file reads standard \
         input.",
    );
    text
}

/// One step of a `--keys` script.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Step {
    Key(Key),
    /// Pause (the arm keeps holding), e.g. to watch the virtual arm or a real one.
    Wait(Duration),
}

/// Why a script token is no step.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TokenError {
    #[error("unknown key {token:?}; expected a key name (space, up, shift-left, enter, esc, yes, no, …), a single character, import:PATH, write:PATH or wait:DURATION")]
    UnknownKey { token: String },
    #[error("{token:?}: expected a path after the colon")]
    NoPath { token: String },
    #[error("{token:?}: expected a wait like wait:500ms or wait:2s")]
    BadWait { token: String },
}

/// Parses one script token.
pub(crate) fn parse_token(token: &str) -> Result<Step, TokenError> {
    let key = match token {
        "space" => Key::Char(' '),
        "up" => Key::Up,
        "down" => Key::Down,
        "left" => Key::Left,
        "right" => Key::Right,
        "shift-left" => Key::ShiftLeft,
        "shift-right" => Key::ShiftRight,
        "enter" => Key::Enter,
        "esc" => Key::Esc,
        "backspace" => Key::Backspace,
        "undo" => Key::Undo,
        "redo" => Key::Redo,
        "copy" => Key::Copy,
        "paste" => Key::Paste,
        "yes" => Key::Char('y'),
        "no" => Key::Char('n'),
        _ => {
            if let Some(path) = token.strip_prefix("import:") {
                Key::Import(non_empty_path(token, path)?)
            } else if let Some(path) = token.strip_prefix("write:") {
                Key::Write(non_empty_path(token, path)?)
            } else if let Some(duration) = token.strip_prefix("wait:") {
                return parse_duration(duration).map(Step::Wait).ok_or_else(|| {
                    TokenError::BadWait {
                        token: token.to_string(),
                    }
                });
            } else {
                let mut chars = token.chars();
                match (chars.next(), chars.next()) {
                    (Some(c), None) => Key::Char(c),
                    _ => {
                        return Err(TokenError::UnknownKey {
                            token: token.to_string(),
                        })
                    }
                }
            }
        }
    };
    Ok(Step::Key(key))
}

fn non_empty_path(token: &str, path: &str) -> Result<PathBuf, TokenError> {
    if path.is_empty() {
        Err(TokenError::NoPath {
            token: token.to_string(),
        })
    } else {
        Ok(PathBuf::from(path))
    }
}

/// "500ms", "2s", "1.5s".
fn parse_duration(text: &str) -> Option<Duration> {
    let (number, scale) = if let Some(ms) = text.strip_suffix("ms") {
        (ms, 1e-3)
    } else {
        (text.strip_suffix('s')?, 1.0)
    };
    let value: f64 = number.parse().ok()?;
    // An hour is far more than any pause a script needs; beyond it is a typo.
    (value.is_finite() && value >= 0.0 && value * scale <= 3600.0)
        .then(|| Duration::from_secs_f64(value * scale))
}

/// The steps of one script line, with their tokens (for the echo); `#` starts a comment.
pub(crate) fn parse_line(line: &str) -> Result<Vec<(String, Step)>, TokenError> {
    let code = line.split('#').next().unwrap_or("");
    code.split_whitespace()
        .map(|token| parse_token(token).map(|step| (token.to_string(), step)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_map_to_keys() {
        let steps = parse_line("space u n > < ] [ + - t T q yes no shift-right # comment y")
            .expect("parses");
        let keys: Vec<Step> = steps.into_iter().map(|(_, s)| s).collect();
        assert_eq!(keys[0], Step::Key(Key::Char(' ')));
        assert_eq!(keys[12], Step::Key(Key::Char('y')));
        assert_eq!(keys[13], Step::Key(Key::Char('n')));
        assert_eq!(keys[14], Step::Key(Key::ShiftRight));
        assert_eq!(keys.len(), 15, "the comment is ignored");
    }

    #[test]
    fn paths_and_waits() {
        assert_eq!(
            parse_token("import:a/b.json"),
            Ok(Step::Key(Key::Import("a/b.json".into())))
        );
        assert_eq!(
            parse_token("write:out.json"),
            Ok(Step::Key(Key::Write("out.json".into())))
        );
        assert_eq!(
            parse_token("wait:500ms"),
            Ok(Step::Wait(Duration::from_millis(500)))
        );
        assert_eq!(
            parse_token("wait:1.5s"),
            Ok(Step::Wait(Duration::from_millis(1500)))
        );
        assert!(parse_token("wait:soon").is_err());
        assert!(parse_token("write:").is_err());
        assert!(parse_token("jump").is_err());
    }

    #[test]
    fn help_lists_every_binding() {
        let help = help_text();
        for b in BINDINGS {
            assert!(help.contains(b.action), "{} missing", b.keys);
        }
    }
}
