//! The questions a session waits on, and which keys answer them.

use super::keys::Key;
use std::path::PathBuf;

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

/// The answer `key` gives to a yes/no question, if it is one.
pub fn yes_no(key: &Key) -> Option<bool> {
    match key {
        Key::Char('y' | 'Y') => Some(true),
        Key::Char('n' | 'N') | Key::Esc | Key::Interrupt => Some(false),
        _ => None,
    }
}
