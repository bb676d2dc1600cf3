//! Text from input files on the user's terminal, defanged.
//!
//! Key names, descriptions, joint names and robot names come from files anyone may have
//! written. Printed as they are, an ESC or CSI inside one is a terminal escape sequence: it can
//! recolour or clear the screen, move the cursor to overwrite a warning, set the window title,
//! or on some terminals do worse. Everything keypose prints that can hold file text goes through
//! [`escape_controls`].

use std::borrow::Cow;
use std::fmt::Write as _;

/// `text` with every control character (C0, DEL, C1) written as a visible escape, `\x1b` or
/// `\u{9b}`; line breaks are kept, as the lines of a report are keypose's own.
pub fn escape_controls(text: &str) -> Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if !needs_escape(c) {
            out.push(c);
        } else if (c as u32) < 0x80 {
            let _ = write!(out, "\\x{:02x}", c as u32);
        } else {
            let _ = write!(out, "\\u{{{:x}}}", c as u32);
        }
    }
    Cow::Owned(out)
}

/// A single field (a name in a table cell): line breaks escaped too, so it stays on its line.
pub fn escape_field(text: &str) -> Cow<'_, str> {
    if text.contains('\n') {
        Cow::Owned(escape_controls(text).replace('\n', "\\x0a"))
    } else {
        escape_controls(text)
    }
}

fn needs_escape(c: char) -> bool {
    c.is_control() && c != '\n'
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_sequences_become_visible_text() {
        // ESC [ 2 J clears the screen; BEL, CR, DEL and the 8-bit CSI (U+009B) too.
        assert_eq!(
            escape_controls("a\u{1b}[2Jb\u{7}\r\u{7f}\u{9b}31m"),
            r"a\x1b[2Jb\x07\x0d\x7f\u{9b}31m"
        );
        assert_eq!(escape_controls("line 1\nline 2"), "line 1\nline 2");
        assert_eq!(escape_field("two\nlines"), r"two\x0alines");
        assert!(matches!(escape_controls("plain °/s"), Cow::Borrowed(_)));
    }
}
