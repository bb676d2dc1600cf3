//! Reading JSON input files with errors that point at the problem.
//!
//! serde_json gives line and column for syntax errors. For errors of meaning (a wrong type, a
//! value out of range, an unknown joint) the useful position is the JSON path of the field, so
//! input is walked through [`Node`]s that carry their path and build [`InputError`]s.

use serde_json::{Map, Value};
use std::fmt;
use std::path::Path;

/// Where in an input file a problem is.
#[derive(Debug, Clone, PartialEq)]
pub enum Location {
    /// The file as a whole (it cannot be read, say).
    File,
    /// A syntax error, 1-based.
    Syntax { line: usize, column: usize },
    /// A JSON path such as `$.keyframes[2].joints.elbow_flex`.
    Path(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => Ok(()),
            Location::Syntax { line, column } => write!(f, "{line}:{column}"),
            Location::Path(p) => f.write_str(p),
        }
    }
}

/// Bad input: which file, where in it, and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct InputError {
    pub file: String,
    pub location: Location,
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.location {
            Location::File => write!(f, "{}: {}", self.file, self.message),
            // file:line:column, as compilers print it, so editors can jump to it.
            Location::Syntax { .. } => {
                write!(f, "{}:{}: {}", self.file, self.location, self.message)
            }
            Location::Path(_) => write!(f, "{}: {}: {}", self.file, self.location, self.message),
        }
    }
}

impl InputError {
    pub fn new(file: &str, location: Location, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            location,
            message: message.into(),
        }
    }

    pub fn at_path(file: &str, path: &str, message: impl Into<String>) -> Self {
        Self::new(file, Location::Path(path.to_string()), message)
    }
}

/// Reads a file as UTF-8 text.
pub fn read_text(path: &Path) -> Result<String, InputError> {
    let label = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| InputError::new(&label, Location::File, format!("cannot read: {e}")))?;
    String::from_utf8(bytes).map_err(|e| {
        InputError::new(
            &label,
            Location::File,
            format!(
                "expected UTF-8 JSON text, found invalid UTF-8 at byte {}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Parses JSON text, mapping syntax errors to line:column.
pub fn parse(file: &str, text: &str) -> Result<Value, InputError> {
    serde_json::from_str(text).map_err(|e| {
        let message = e.to_string();
        // serde_json appends " at line L column C"; the location is reported separately.
        let message = match message.rfind(" at line ") {
            Some(cut) => message[..cut].to_string(),
            None => message,
        };
        InputError::new(
            file,
            Location::Syntax {
                line: e.line(),
                column: e.column(),
            },
            format!("invalid JSON: {message}"),
        )
    })
}

/// A short description of a JSON value for "found …" in messages.
pub fn describe(value: &Value) -> String {
    match value {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("{b}"),
        Value::Number(n) => format!("{n}"),
        Value::String(s) if s.chars().count() > 40 => {
            format!("{:?}…", s.chars().take(40).collect::<String>())
        }
        Value::String(s) => format!("{s:?}"),
        Value::Array(a) => format!("an array of {}", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// A value in a document together with its JSON path.
#[derive(Debug, Clone, Copy)]
pub struct Node<'a> {
    pub value: &'a Value,
    file: &'a str,
    path: PathRef<'a>,
}

/// Paths are built lazily from parent links: most nodes never report an error.
#[derive(Debug, Clone, Copy)]
enum PathRef<'a> {
    Root,
    Field(&'a Node<'a>, &'a str),
    Index(&'a Node<'a>, usize),
}

impl<'a> Node<'a> {
    pub fn root(file: &'a str, value: &'a Value) -> Self {
        Self {
            value,
            file,
            path: PathRef::Root,
        }
    }

    pub fn file(&self) -> &'a str {
        self.file
    }

    pub fn path(&self) -> String {
        match self.path {
            PathRef::Root => "$".to_string(),
            PathRef::Field(parent, name) => {
                let simple = !name.is_empty()
                    && name
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
                if simple {
                    format!("{}.{name}", parent.path())
                } else {
                    format!("{}[{name:?}]", parent.path())
                }
            }
            PathRef::Index(parent, i) => format!("{}[{i}]", parent.path()),
        }
    }

    pub fn error(&self, message: impl Into<String>) -> InputError {
        InputError::at_path(self.file, &self.path(), message)
    }

    /// "expected …, found …" at this node.
    pub fn expected(&self, what: &str) -> InputError {
        self.error(format!("expected {what}, found {}", describe(self.value)))
    }

    pub fn object(&self) -> Result<&'a Map<String, Value>, InputError> {
        self.value
            .as_object()
            .ok_or_else(|| self.expected("an object"))
    }

    /// Rejects fields outside `allowed`: a misspelt field would otherwise be silently ignored.
    pub fn only_fields(&self, allowed: &[&str]) -> Result<(), InputError> {
        for name in self.object()?.keys() {
            if !allowed.contains(&name.as_str()) {
                return Err(self.error(format!(
                    "unknown field {name:?}; expected one of: {}",
                    allowed.join(", ")
                )));
            }
        }
        Ok(())
    }

    pub fn get(&'a self, name: &'a str) -> Option<Node<'a>> {
        let value = self.value.as_object()?.get(name)?;
        Some(Node {
            value,
            file: self.file,
            path: PathRef::Field(self, name),
        })
    }

    pub fn require(&'a self, name: &'a str, what: &str) -> Result<Node<'a>, InputError> {
        self.object()?;
        self.get(name)
            .ok_or_else(|| self.error(format!("missing field {name:?} ({what})")))
    }

    /// The (name, value) pairs of an object, in file order.
    pub fn entries(&'a self) -> Result<Vec<(&'a str, Node<'a>)>, InputError> {
        Ok(self
            .object()?
            .iter()
            .map(|(name, value)| {
                (
                    name.as_str(),
                    Node {
                        value,
                        file: self.file,
                        path: PathRef::Field(self, name.as_str()),
                    },
                )
            })
            .collect())
    }

    pub fn items(&'a self) -> Result<Vec<Node<'a>>, InputError> {
        let array = self
            .value
            .as_array()
            .ok_or_else(|| self.expected("an array"))?;
        Ok(array
            .iter()
            .enumerate()
            .map(|(i, value)| Node {
                value,
                file: self.file,
                path: PathRef::Index(self, i),
            })
            .collect())
    }

    pub fn str(&self, what: &str) -> Result<&'a str, InputError> {
        self.value.as_str().ok_or_else(|| self.expected(what))
    }

    /// A finite number. JSON cannot spell NaN or infinity, but numbers too large for f64 and
    /// strings such as "NaN" still reach here, and both must be refused.
    pub fn number(&self, what: &str) -> Result<f64, InputError> {
        match self.value.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(self.expected(&format!("a finite number ({what})"))),
        }
    }

    pub fn integer(&self, what: &str, min: i64, max: i64) -> Result<i64, InputError> {
        match self.value.as_i64() {
            Some(x) if (min..=max).contains(&x) => Ok(x),
            _ => Err(self.expected(&format!("an integer from {min} to {max} ({what})"))),
        }
    }

    pub fn bool(&self, what: &str) -> Result<bool, InputError> {
        self.value.as_bool().ok_or_else(|| self.expected(what))
    }

    /// An array of exactly N finite numbers.
    pub fn numbers<const N: usize>(&'a self, what: &str) -> Result<[f64; N], InputError> {
        let items = self.items()?;
        if items.len() != N {
            return Err(self.expected(&format!("an array of {N} numbers ({what})")));
        }
        let mut out = [0.0; N];
        for (slot, item) in out.iter_mut().zip(&items) {
            *slot = item.number(what)?;
        }
        Ok(out)
    }

    /// Checks the `format` field against the one this loader reads.
    pub fn check_format(&'a self, expected: &str) -> Result<(), InputError> {
        let node = self.require("format", &format!("must be {expected:?}"))?;
        match node.value.as_str() {
            Some(s) if s == expected => Ok(()),
            _ => Err(node.expected(&format!("{expected:?}"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_name_fields_and_indices() {
        let value: Value =
            serde_json::from_str(r#"{"keyframes":[{"joints":{"a b":"x"}}]}"#).unwrap();
        let root = Node::root("f.json", &value);
        let frames = root.get("keyframes").unwrap();
        let items = frames.items().unwrap();
        let joints = items[0].get("joints").unwrap();
        let entries = joints.entries().unwrap();
        let err = entries[0].1.number("degrees").unwrap_err();
        assert_eq!(
            err.to_string(),
            r#"f.json: $.keyframes[0].joints["a b"]: expected a finite number (degrees), found "x""#
        );
    }

    #[test]
    fn syntax_errors_carry_line_and_column() {
        let err = parse("f.json", "{\n  \"a\": 1,\n  oops\n}").unwrap_err();
        assert_eq!(err.location, Location::Syntax { line: 3, column: 3 });
        assert!(
            err.to_string().starts_with("f.json:3:3: invalid JSON"),
            "{err}"
        );
    }
}
