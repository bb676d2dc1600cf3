//! Text metrics (estimated widths, fitting with an ellipsis) and short numbers for labels.
//!
//! Knows nothing about SVG or positions.

/// Estimated advance width of `s` at `size` px, from rough DejaVu Sans glyph widths (the widest
/// of the fonts we ask for, so Helvetica/Arial only come out narrower). Used to space and
/// truncate labels, since SVG has no layout engine and `textLength` is not honoured everywhere.
pub(super) fn text_width(s: &str, size: f64) -> f64 {
    let em: f64 = s
        .chars()
        .map(|c| match c {
            'i' | 'j' | 'l' | '.' | ',' | ':' | ';' | '\'' | '|' | '!' => 0.28,
            'f' | 't' | 'r' | ' ' | '(' | ')' | '[' | ']' | '-' | '/' | '#' => 0.4,
            'm' | 'w' | 'M' | 'W' | '…' | '%' => 0.95,
            'A'..='Z' => 0.72,
            _ => 0.63,
        })
        .sum();
    em * size
}

/// `s` cut with an ellipsis so it fits in `max_w` px at `size` px (user-chosen joint and key
/// names can be arbitrarily long and would otherwise run into neighbouring labels).
pub(super) fn fit_text(s: &str, max_w: f64, size: f64) -> String {
    if text_width(s, size) <= max_w {
        return s.to_string();
    }
    let budget = max_w - text_width("…", size);
    let mut out = String::new();
    let mut used = 0.0;
    for c in s.chars() {
        let cw = text_width(c.encode_utf8(&mut [0; 4]), size);
        if used + cw > budget {
            break;
        }
        used += cw;
        out.push(c);
    }
    out.push('…');
    out
}

/// A data value for human-readable annotations (limits, peaks): three significant digits, since
/// "peak 44.999" reads worse than "peak 45" and says nothing more.
pub(super) fn short(v: f64) -> String {
    if !v.is_finite() {
        return "?".to_string();
    }
    let a = v.abs();
    let s = if a != 0.0 && !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        }
    } else {
        // a is 0 or within [1e-3, 1e5) here, so the logarithm is finite or zero is special.
        let decimals = if a == 0.0 {
            0
        } else {
            (2 - a.log10().floor() as i64).clamp(0, 4) as usize
        };
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if s == "-0" {
        "0".to_string()
    } else {
        s
    }
}
