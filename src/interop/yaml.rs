//! The little YAML the exports write, by hand: block mappings, flow lists of numbers and names,
//! quoted strings. Deterministic, and every float keeps a decimal point so that YAML 1.1
//! readers (PyYAML, which ROS 2's tools use) read a float, not an integer or a string.
//!
//! Names and texts come from files and options anyone may have written, so every one is
//! written double-quoted with escapes ([`quoted`]): a quote, a `#`, a `: `, a backslash, a line
//! break or any other character reads back as itself, never as YAML structure, in YAML 1.1
//! (PyYAML, libyaml) and 1.2 readers alike.

use std::fmt::Write;

/// Decimals written: 1e-12 rad is far below any encoder.
const DECIMALS: usize = 12;

/// The longest key, in bytes, written as an implicit `key:`: YAML readers look at most 1024
/// characters ahead for the `:` of such a key (PyYAML and libyaml refuse a longer one; libyaml
/// as Rust's serde_norway has it counts bytes), so a longer key is written as an explicit
/// `? key` entry. Found by the `export_yaml` fuzz target: a key of 956 characters in 1 100
/// bytes was refused.
const MAX_IMPLICIT_KEY: usize = 1000;

/// `x` with up to 12 decimals, trailing zeros trimmed but one decimal kept: `0.0`, `1.5`,
/// `-0.000000000001`.
pub fn float(x: f64) -> String {
    let s = format!("{x:.DECIMALS$}");
    let s = s.trim_end_matches('0');
    let s = if s.ends_with('.') {
        format!("{s}0")
    } else {
        s.to_string()
    };
    if s == "-0.0" {
        "0.0".into()
    } else {
        s
    }
}

/// `[a, b, c]` of floats.
pub fn float_list(values: impl IntoIterator<Item = f64>) -> String {
    let items: Vec<String> = values.into_iter().map(float).collect();
    format!("[{}]", items.join(", "))
}

/// A double-quoted scalar that reads back as `text`, whatever it holds: `"` and `\` escaped,
/// and every character YAML does not take as printable text (controls, NEL, the line and
/// paragraph separators, a byte-order mark, U+FFFE and U+FFFF) as its `\x` or `\u` escape;
/// the rest, non-ASCII letters too, as it is.
pub fn quoted(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c if is_plain_printable(c) => out.push(c),
            c if (c as u32) <= 0xff => {
                let _ = write!(out, "\\x{:02X}", c as u32);
            }
            // Every character YAML does not print is in the Basic Multilingual Plane.
            c => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
        }
    }
    out.push('"');
    out
}

/// YAML 1.1's printable characters (1.2's are the same) less those it reads as line breaks
/// (NEL, U+2028, U+2029) and the byte-order mark, which a reader may drop.
fn is_plain_printable(c: char) -> bool {
    matches!(c as u32,
        0x20..=0x7e | 0xa0..=0xd7ff | 0xe000..=0xfffd | 0x10000..=0x10ffff)
        && !matches!(c, '\u{2028}' | '\u{2029}' | '\u{feff}')
}

/// `[a, b]` of names, each quoted.
pub fn name_list<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    let items: Vec<String> = names.into_iter().map(quoted).collect();
    format!("[{}]", items.join(", "))
}

/// Appends `indent` spaces, `key: value` and a newline.
pub fn line(out: &mut String, indent: usize, key: &str, value: &str) {
    let _ = writeln!(out, "{:indent$}{key}: {value}", "");
}

/// Appends `indent` spaces and `key:` opening a nested mapping.
pub fn open(out: &mut String, indent: usize, key: &str) {
    let _ = writeln!(out, "{:indent$}{key}:", "");
}

/// Opens a nested mapping under a key that is a name (a motion's): quoted, so that `on`, `null`
/// or `12` stay strings; a key too long to be a plain key (see [`MAX_IMPLICIT_KEY`]) becomes
/// an explicit `? "key"` entry, which means the same to every reader.
pub fn open_named(out: &mut String, indent: usize, name: &str) {
    let key = quoted(name);
    if key.len() <= MAX_IMPLICIT_KEY {
        open(out, indent, &key);
    } else {
        let _ = writeln!(out, "{:indent$}? {key}\n{:indent$}:", "", "");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_keep_a_decimal_point_and_names_are_quoted() {
        assert_eq!(float(0.0), "0.0");
        assert_eq!(float(-0.0), "0.0");
        assert_eq!(float(2.0), "2.0");
        assert_eq!(float(-1.25), "-1.25");
        assert_eq!(float(1e-13), "0.0");
        assert_eq!(name_list(["a", "b"]), r#"["a", "b"]"#);
    }

    #[test]
    fn names_are_escaped_the_way_the_yaml_spec_spells_escapes() {
        // YAML 1.2 §5.7 (and 1.1 §5.6): \" \\ \t \n \r \xXX \uXXXX.
        assert_eq!(quoted(r#"it's "q" \ # : -"#), r#""it's \"q\" \\ # : -""#);
        assert_eq!(
            quoted("a\nb\tc\rd\u{1b}e\u{85}f"),
            r#""a\nb\tc\rd\x1Be\x85f""#
        );
        assert_eq!(
            quoted("épaule\u{2028}\u{feff}\u{ffff}🦾"),
            r#""épaule\u2028\uFEFF\uFFFF🦾""#
        );
    }

    #[test]
    fn a_named_key_of_any_length_reads_back_as_itself() {
        // Readers give up on an implicit key after 1024 characters (libyaml: bytes), and read
        // `on` unquoted as a boolean; 400 U+FFFD are 400 characters but 1200 bytes (found by
        // the export_yaml fuzz target).
        let wide = "\u{fffd}".repeat(400);
        for name in [
            "on",
            "12",
            &"a".repeat(998),
            &"a".repeat(999),
            &wide,
            &"x".repeat(3000),
        ] {
            let mut out = String::from("motions:\n");
            open_named(&mut out, 2, name);
            line(&mut out, 4, "joints", &name_list([name]));
            let read: serde_norway::Value = serde_norway::from_str(&out)
                .unwrap_or_else(|e| panic!("{} characters: {e}", name.chars().count()));
            let motions = read["motions"].as_mapping().unwrap();
            let (key, motion) = motions.iter().next().unwrap();
            assert_eq!(key.as_str(), Some(name));
            assert_eq!(motion["joints"][0].as_str(), Some(name));
        }
        let mut out = String::new();
        open_named(&mut out, 2, "on");
        assert_eq!(out, "  \"on\":\n");
    }
}
