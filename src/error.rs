//! What kind of failure an error is, and the one way an error and its causes are written out.
//!
//! Every error of the library says what kind of failure it is ([`ErrorKind`], through a
//! `kind()` method): the command line turns that into its exit code, and a caller deciding
//! whether to retry or to ask the user reads it the same way. Each error's message says only
//! its own part; where it wraps a cause that [`std::error::Error::source`] returns, the cause is
//! not repeated in the message, and [`Report`] joins the chain for a person to read.

use std::error::Error;
use std::fmt;

/// What kind of failure an error is: who has to act on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The input is wrong (a file, an argument, a calibration made on another arm): the user
    /// mends it; nothing was sent to a servo because of it.
    BadInput,
    /// The servos, the bus, the port or a helper process failed.
    Hardware,
    /// The command ran to its end and judged the motion: the verdict is "fails".
    VerdictFailed,
    /// A stop the user asked for ended the command.
    Interrupted,
}

/// An error followed by its causes, each after ": " — what a person is shown. A cause whose
/// words the text already holds is not said again: some errors say their cause within their
/// own sentence (a bus error inside "joint: … (at 1.2 s)"), and still return it as their
/// source.
///
/// ```
/// # use keypose::error::Report;
/// let io = std::io::Error::other("disk full");
/// assert_eq!(Report(&io).to_string(), "disk full");
/// ```
pub struct Report<'a>(pub &'a (dyn Error + 'static));

impl fmt::Display for Report<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut text = self.0.to_string();
        let mut cause = self.0.source();
        while let Some(error) = cause {
            let said = error.to_string();
            if !text.contains(&said) {
                text.push_str(": ");
                text.push_str(&said);
            }
            cause = error.source();
        }
        f.write_str(&text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot write log out.csv")]
    struct Outer(#[source] std::io::Error);

    #[derive(Debug, thiserror::Error)]
    #[error("serial port /dev/ttyUSB0: {0}")]
    struct Saying(#[source] std::io::Error);

    #[test]
    fn a_cause_said_within_the_message_is_not_said_again() {
        let error = Saying(std::io::Error::other("disk full"));
        assert_eq!(
            Report(&error).to_string(),
            "serial port /dev/ttyUSB0: disk full"
        );
    }

    #[test]
    fn a_report_writes_each_cause_once_after_its_effect() {
        let error = Outer(std::io::Error::other("disk full"));
        assert_eq!(
            Report(&error).to_string(),
            "cannot write log out.csv: disk full"
        );
    }
}
