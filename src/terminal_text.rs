//! Text from input files on the user's terminal, defanged.
//!
//! Key names, descriptions, joint names and robot names come from files anyone may have
//! written. Printed as they are, an ESC or CSI inside one is a terminal escape sequence: it can
//! recolour or clear the screen, move the cursor to overwrite a warning, set the window title,
//! or on some terminals do worse; a line break can forge a line of keypose's own output, and a
//! bidirectional override can make the rest of a line read backwards. Names holding any of
//! these are refused when files are read ([`is_layout_control`] is the rule); everything
//! keypose prints that can hold file text goes through [`escape_controls`] all the same.

use std::borrow::Cow;
use std::fmt::Write as _;

/// Whether `c` steers how text is laid out instead of showing as a character: every control
/// character (C0, DEL, C1, which includes NEL), the Unicode line and paragraph separators, and
/// the bidirectional embeddings, overrides and isolates (U+202A–U+202E, U+2066–U+2069).
pub fn is_layout_control(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{2028}' | '\u{2029}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with every layout control (see [`is_layout_control`]) written as a visible escape,
/// `\x1b` or `\u{9b}`; line breaks are kept, as the lines of a report are keypose's own.
pub fn escape_controls(text: &str) -> Cow<'_, str> {
    escape_where(text, |c| is_layout_control(c) && c != '\n')
}

/// A single field (a name in a table cell): line breaks escaped too, so it stays on its line.
pub fn escape_field(text: &str) -> Cow<'_, str> {
    escape_where(text, is_layout_control)
}

/// An error message for the terminal: every layout control escaped, line breaks too (a name
/// or a path quoted in the message cannot start a line of its own), except a line break
/// followed by an indentation of two spaces. That is how a message quotes lines of another
/// program's output (pip's, a Python harness's stderr): each on a line of its own, indented,
/// so none of them can pass for a message of keypose's either.
pub fn escape_message(text: &str) -> Cow<'_, str> {
    let continued = |rest: &str| rest.starts_with("  ");
    if !text
        .char_indices()
        .any(|(i, c)| is_layout_control(c) && !(c == '\n' && continued(&text[i + 1..])))
    {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for (i, c) in text.char_indices() {
        if c == '\n' && continued(&text[i + 1..]) {
            out.push(c);
        } else {
            push_escaped(&mut out, c, is_layout_control);
        }
    }
    Cow::Owned(out)
}

/// Lines of another program's output for an error message: each on a line of its own,
/// indented by two spaces, as [`escape_message`] keeps them.
pub(crate) fn quoted_lines<'a>(lines: impl IntoIterator<Item = &'a str>) -> String {
    lines
        .into_iter()
        .map(|line| format!("\n  {line}"))
        .collect()
}

fn escape_where(text: &str, escape: impl Fn(char) -> bool) -> Cow<'_, str> {
    if !text.chars().any(&escape) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        push_escaped(&mut out, c, &escape);
    }
    Cow::Owned(out)
}

fn push_escaped(out: &mut String, c: char, escape: impl Fn(char) -> bool) {
    if !escape(c) {
        out.push(c);
    } else if (c as u32) < 0x80 {
        let _ = write!(out, "\\x{:02x}", c as u32);
    } else {
        let _ = write!(out, "\\u{{{:x}}}", c as u32);
    }
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
        // U+2028 breaks a line too; U+202E (right-to-left override) turns what follows around.
        assert_eq!(
            escape_controls("a\u{2028}b\u{202e}c\u{85}"),
            r"a\u{2028}b\u{202e}c\u{85}"
        );
    }

    #[test]
    fn an_error_message_keeps_its_quoted_lines_only() {
        // A name with a line break in it cannot start a line ("error: …" of its own).
        assert_eq!(
            escape_message("unknown joint a\nerror: all good"),
            r"unknown joint a\x0aerror: all good"
        );
        // Another program's output, quoted as keypose quotes it, keeps its lines.
        let message = format!(
            "pip failed; its last output:{}",
            quoted_lines(["ERROR: no match", "x\u{1b}[2J"])
        );
        assert_eq!(
            escape_message(&message),
            "pip failed; its last output:\n  ERROR: no match\n  x\\x1b[2J"
        );
        assert_eq!(escape_message("a\r\n b"), r"a\x0d\x0a b");
        assert!(matches!(escape_message("plain"), Cow::Borrowed(_)));
    }
}
