//! Reading JSON input files with errors that point at the problem.
//!
//! serde_json gives line and column for syntax errors. For errors of meaning (a wrong type, a
//! value out of range, an unknown joint) the useful position is the JSON path of the field, so
//! input is walked through nodes that carry their path and build [`InputError`]s.

pub(crate) mod input_file;

pub use input_file::{open_regular, MAX_INPUT_BYTES};

use serde_json::{Map, Value};
use std::fmt;
use std::path::Path;

/// Where in an input file a problem is.
#[derive(Debug, Clone, PartialEq)]
pub enum Location {
    /// The file as a whole (it cannot be read, say).
    File,
    /// A syntax error, 1-based.
    Syntax {
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        column: usize,
    },
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
    /// The file as the user named it (or the option, such as `--robot`, for a value given on
    /// the command line).
    pub file: String,
    /// Where in the file.
    pub location: Location,
    /// What is wrong, and what was expected.
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
    /// Always bad input: the user mends the file or the option.
    pub fn kind(&self) -> crate::error::ErrorKind {
        crate::error::ErrorKind::BadInput
    }

    /// The error `message` at `location` in `file`.
    pub fn new(file: &str, location: Location, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            location,
            message: message.into(),
        }
    }

    /// The error `message` at the JSON path `path` (`$.keyframes[2]`) in `file`.
    pub fn at_path(file: &str, path: &str, message: impl Into<String>) -> Self {
        Self::new(file, Location::Path(path.to_string()), message)
    }
}

/// Reads an input file (a sequence, a robot, a calibration) as UTF-8 text: a regular file of
/// at most [`MAX_INPUT_BYTES`].
pub fn read_text(path: &Path) -> Result<String, InputError> {
    crate::json::input_file::read_text(path, crate::json::input_file::MAX_INPUT_BYTES)
}

/// Parses JSON text, mapping syntax errors to line:column. An object that names a key twice is
/// refused (serde_json alone would keep the last value silently: a pasted-in second `"robot"`
/// or `"joints"` would override the first without a word).
pub(crate) fn parse(file: &str, text: &str) -> Result<Value, InputError> {
    parse_unique(text).map_err(|e| {
        let message = e.to_string();
        // serde_json appends " at line L column C"; the location is reported separately.
        let message = match message.rfind(" at line ") {
            Some(cut) => message[..cut].to_string(),
            None => message,
        };
        let message = match looks_like_yaml(file, text) {
            true => format!(
                "{message}: this looks like YAML, and keypose's files are JSON (a sequence is \
                 an object {{\"format\": \"keypose-sequence/1\", \"robot\": …, \"keyframes\": \
                 […]}}, docs/formats.md)"
            ),
            false => message,
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

/// Whether text that failed to parse as JSON is YAML: a `.yaml`/`.yml` name, or a first line
/// that is a YAML document start or a `key: value` mapping rather than JSON's `{` or `[`.
fn looks_like_yaml(file: &str, text: &str) -> bool {
    let lower = file.to_ascii_lowercase();
    if lower.ends_with(".yaml") || lower.ends_with(".yml") {
        return true;
    }
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    if first.starts_with('{') || first.starts_with('[') {
        return false;
    }
    first.starts_with("---")
        || first.split_once(':').is_some_and(|(key, _)| {
            let key = key.trim().trim_matches('"').trim_matches('\'');
            !key.is_empty()
                && key
                    .chars()
                    .all(|c| c.is_alphanumeric() || c == '_' || c == '-')
        })
}

fn parse_unique(text: &str) -> Result<Value, serde_json::Error> {
    use serde::Deserialize;
    let mut deserializer = serde_json::Deserializer::from_str(text);
    let UniqueKeys(value) = UniqueKeys::deserialize(&mut deserializer)?;
    deserializer.end()?;
    Ok(value)
}

/// A JSON value whose objects name each key once. The error is raised right after the
/// repeated key is read, so serde_json's line:column points at it.
struct UniqueKeys(Value);

impl<'de> serde::Deserialize<'de> for UniqueKeys {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer
            .deserialize_any(UniqueKeysVisitor)
            .map(UniqueKeys)
    }
}

struct UniqueKeysVisitor;

impl<'de> serde::de::Visitor<'de> for UniqueKeysVisitor {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, b: bool) -> Result<Value, E> {
        Ok(Value::Bool(b))
    }

    fn visit_i64<E>(self, n: i64) -> Result<Value, E> {
        Ok(Value::Number(n.into()))
    }

    fn visit_u64<E>(self, n: u64) -> Result<Value, E> {
        Ok(Value::Number(n.into()))
    }

    fn visit_f64<E>(self, x: f64) -> Result<Value, E> {
        Ok(serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number))
    }

    fn visit_str<E>(self, s: &str) -> Result<Value, E> {
        Ok(Value::String(s.to_string()))
    }

    fn visit_string<E>(self, s: String) -> Result<Value, E> {
        Ok(Value::String(s))
    }

    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut items = Vec::new();
        while let Some(UniqueKeys(item)) = seq.next_element()? {
            items.push(item);
        }
        Ok(Value::Array(items))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut entries: A) -> Result<Value, A::Error> {
        let mut map = Map::new();
        while let Some(key) = entries.next_key::<String>()? {
            if map.contains_key(&key) {
                return Err(serde::de::Error::custom(format!(
                    "duplicate key {key:?}; expected each key once in an object"
                )));
            }
            let UniqueKeys(value) = entries.next_value()?;
            map.insert(key, value);
        }
        Ok(Value::Object(map))
    }
}

/// What a name may not hold, for messages.
const NO_CONTROLS: &str = "without control characters (line breaks, tabs, escapes, \
                           bidirectional overrides)";

/// Whether `text` holds a layout control; with `text_breaks`, line breaks and tabs are allowed.
fn has_control(text: &str, text_breaks: bool) -> bool {
    text.chars().any(|c| {
        crate::terminal_text::is_layout_control(c) && !(text_breaks && matches!(c, '\n' | '\t'))
    })
}

/// A short description of a JSON value for "found …" in messages.
pub(crate) fn describe(value: &Value) -> String {
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
pub(crate) struct Node<'a> {
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

    /// A name (of a robot, a joint, a key, a motor): a string on one line that shows as it
    /// reads, so no control characters (see [`crate::terminal_text::is_layout_control`]).
    /// Names are printed, put in tables and logs, exported: a line break or an escape in one
    /// would change what they show as, or were turned into something else.
    pub fn name(&self, what: &str) -> Result<&'a str, InputError> {
        let name = self.str(what)?;
        if has_control(name, false) {
            return Err(self.expected(&format!("{what} {NO_CONTROLS}")));
        }
        Ok(name)
    }

    /// A text (a description): line breaks and tabs allowed, no other control characters.
    pub fn text(&self, what: &str) -> Result<&'a str, InputError> {
        let text = self.str(what)?;
        if has_control(text, true) {
            return Err(self.expected(&format!(
                "{what} without control characters other than line breaks and tabs"
            )));
        }
        Ok(text)
    }

    /// [`Node::entries`] of an object whose field names are names ([`Node::name`]): joints by
    /// name, motors by name.
    pub fn named_entries(&'a self, what: &str) -> Result<Vec<(&'a str, Node<'a>)>, InputError> {
        let entries = self.entries()?;
        if let Some((name, node)) = entries.iter().find(|(name, _)| has_control(name, false)) {
            return Err(node.error(format!(
                "expected {what} {NO_CONTROLS}, found the name {name:?}"
            )));
        }
        Ok(entries)
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
    fn a_duplicate_key_is_refused_at_its_line_and_column() {
        let text = "{\n  \"robot\": \"so101\",\n  \"robot\": \"koch\"\n}";
        let err = parse("f.json", text).unwrap_err();
        // Line 3, just past the second "robot" (columns 3–9).
        assert_eq!(err.location, Location::Syntax { line: 3, column: 9 });
        assert_eq!(
            err.to_string(),
            r#"f.json:3:9: invalid JSON: duplicate key "robot"; expected each key once in an object"#
        );
        // Nested objects too, and the same key in two different objects is fine.
        let nested = r#"{"keyframes":[{"joints":{"a":1}},{"joints":{"a":1,"b":2,"a":3}}]}"#;
        let err = parse("f.json", nested).unwrap_err();
        assert!(err.message.contains(r#"duplicate key "a""#), "{err}");
        assert_eq!(
            err.location,
            Location::Syntax {
                line: 1,
                column: 59
            }
        );
    }

    #[test]
    fn values_parse_as_serde_json_parses_them() {
        let text = r#"{"b":[1,-2,3.5,1e-7,18446744073709551615,true,null,"x\u00e9"],"a":{}}"#;
        let ours = parse("f.json", text).unwrap();
        let theirs: Value = serde_json::from_str(text).unwrap();
        assert_eq!(ours, theirs);
        // Key order is the file's (preserve_order).
        let keys: Vec<&String> = ours.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["b", "a"]);
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

    #[test]
    fn yaml_is_named_as_yaml_and_json_typos_are_not() {
        let yaml = "format: keypose-sequence/1\nrobot: so101\nkeyframes:\n  - time: 0\n";
        let err = parse("wave.txt", yaml).unwrap_err().to_string();
        assert!(
            err.contains("looks like YAML") && err.contains("keypose-sequence/1"),
            "{err}"
        );
        let err = parse("wave.yaml", "{").unwrap_err().to_string();
        assert!(err.contains("looks like YAML"), "{err}");
        let err = parse("wave.json", "{\"robot\": so101}")
            .unwrap_err()
            .to_string();
        assert!(!err.contains("YAML"), "{err}");
    }
}
