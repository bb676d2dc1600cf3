//! The questions a session waits on, and which keys answer them.

use super::keys::Key;
use std::path::PathBuf;

/// A question the session waits on.
#[derive(Debug, Clone, PartialEq)]
pub enum Prompt {
    /// A journal newer than the file was found at start.
    Recover {
        /// The keys the journal holds.
        keys: usize,
    },
    /// `q` or Ctrl-C with unsaved changes: write and quit (`w`), quit without them (`y`), or
    /// stay (`n`).
    Quit,
    /// Releasing torque on `joints`, of which `heavy` carry the arm's weight.
    Release {
        /// The joints to release (robot order).
        joints: Vec<usize>,
        /// Those of them that carry the arm's weight at the present pose.
        heavy: Vec<usize>,
    },
    /// Importing over unsaved changes.
    Replace {
        /// The file to import.
        path: PathBuf,
    },
    /// A line being typed: a path, a name or a number, by `field`.
    Text {
        /// What the line is for.
        field: Field,
        /// What has been typed so far.
        text: String,
    },
    /// After a typed value, with the arm held: move it to the edited key now?
    MoveThere,
    /// The direction check (`D`) jogged `joint`: does the real joint move the way the drawn
    /// one does? `m` matches, `r` reversed, Esc ends the check.
    Direction {
        /// The joint just jogged (robot order).
        joint: usize,
    },
}

/// What a [`Prompt::Text`] line is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// `i`: the file to import.
    ImportPath,
    /// The current key's name (empty clears it).
    Name,
    /// The current key's hold, in seconds (0 clears it).
    Hold,
    /// The current key's value of joint `index`, in the unit the screen shows it in.
    Value(usize),
    /// The current key's effort for joint `index`, percent of its stall torque (empty clears).
    Effort(usize),
}

impl Prompt {
    /// Whether `key` means something to this prompt (a script that sends anything else is
    /// wrong, and is stopped rather than have the key swallowed).
    pub fn accepts(&self, key: &Key) -> bool {
        match self {
            Prompt::Text { .. } => matches!(
                key,
                Key::Char(_) | Key::Backspace | Key::Enter | Key::Esc | Key::Interrupt
            ),
            Prompt::Quit => yes_no(key).is_some() || *key == Key::Char('w'),
            Prompt::Direction { .. } => {
                matches!(key, Key::Char('m' | 'r') | Key::Esc | Key::Interrupt)
            }
            _ => yes_no(key).is_some(),
        }
    }
}

/// The answer `key` gives to a yes/no question, if it is one.
pub(crate) fn yes_no(key: &Key) -> Option<bool> {
    match key {
        Key::Char('y' | 'Y') => Some(true),
        Key::Char('n' | 'N') | Key::Esc | Key::Interrupt => Some(false),
        _ => None,
    }
}

/// A typed number: finite, with `,` taken as the decimal point some keyboards give.
pub(crate) fn number(text: &str) -> Option<f64> {
    let value: f64 = text.trim().replace(',', ".").parse().ok()?;
    value.is_finite().then_some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_finite_decimals() {
        assert_eq!(number(" 1.5 "), Some(1.5));
        assert_eq!(number("0,25"), Some(0.25));
        assert_eq!(number("-3"), Some(-3.0));
        assert_eq!(number("inf"), None);
        assert_eq!(number("NaN"), None);
        assert_eq!(number(""), None);
        assert_eq!(number("1.2.3"), None);
    }
}
