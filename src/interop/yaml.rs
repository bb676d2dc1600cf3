//! The little YAML the exports write, by hand: block mappings, flow lists of numbers and names,
//! quoted strings. Deterministic, and every float keeps a decimal point so that YAML 1.1
//! readers (PyYAML, which ROS 2's tools use) read a float, not an integer or a string.

use std::fmt::Write;

/// Decimals written: 1e-12 rad is far below any encoder.
const DECIMALS: usize = 12;

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

/// A single-quoted scalar (YAML doubles a quote inside one).
pub fn quoted(text: &str) -> String {
    let clean: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    format!("'{}'", clean.replace('\'', "''"))
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
        assert_eq!(quoted("it's"), "'it''s'");
        assert_eq!(name_list(["a", "b"]), "['a', 'b']");
    }
}
