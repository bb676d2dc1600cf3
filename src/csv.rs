//! CSV fields as RFC 4180 spells them, for the CSV keypose writes (`sample`, the playback log)
//! and reads back (`plot --log`). Column names carry joint names, which come from robot files:
//! a name holding a comma or a quote is written quoted, so it stays one column.

use std::borrow::Cow;

/// `text` as one CSV field: as it is, or between double quotes (a quote inside doubled) when it
/// holds a comma, a quote or a line break (RFC 4180 §2.6, §2.7).
pub fn field(text: &str) -> Cow<'_, str> {
    if text.contains([',', '"', '\n', '\r']) {
        Cow::Owned(format!("\"{}\"", text.replace('"', "\"\"")))
    } else {
        Cow::Borrowed(text)
    }
}

/// A quoted field that does not end where it should: an unmatched or stray quote.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the quoted field at column {column} does not end with a quote before the next comma or \
     the line's end"
)]
pub(crate) struct QuoteError {
    /// Where the field starts: 1-based, in characters.
    pub column: usize,
}

/// The fields of one line (a record without line breaks), quoted ones unquoted.
pub(crate) fn split_record(line: &str) -> Result<Vec<Cow<'_, str>>, QuoteError> {
    let mut fields = Vec::new();
    let mut rest = line;
    let mut column = 1;
    loop {
        let Some(quoted) = rest.strip_prefix('"') else {
            let end = rest.find(',').unwrap_or(rest.len());
            fields.push(Cow::Borrowed(&rest[..end]));
            if end == rest.len() {
                return Ok(fields);
            }
            column += rest[..=end].chars().count();
            rest = &rest[end + 1..];
            continue;
        };
        let mut text = String::new();
        let mut inside = quoted;
        loop {
            let Some(quote) = inside.find('"') else {
                return Err(QuoteError { column });
            };
            text.push_str(&inside[..quote]);
            inside = &inside[quote + 1..];
            match inside.strip_prefix('"') {
                Some(after) => {
                    text.push('"');
                    inside = after;
                }
                None => break,
            }
        }
        fields.push(Cow::Owned(text));
        let start = column;
        column += rest[..rest.len() - inside.len()].chars().count();
        match inside.strip_prefix(',') {
            Some(after) => {
                rest = after;
                column += 1;
            }
            None if inside.is_empty() => return Ok(fields),
            None => return Err(QuoteError { column: start }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_with_commas_or_quotes_are_quoted_and_split_back() {
        assert_eq!(field("elbow_flex"), "elbow_flex");
        assert_eq!(field("a,b"), r#""a,b""#);
        assert_eq!(field(r#"say "hi""#), r#""say ""hi""""#);
        // RFC 4180's own example of a quoted field: "aaa","b""bb","ccc".
        assert_eq!(
            split_record(r#""aaa","b""bb","ccc""#).unwrap(),
            ["aaa", "b\"bb", "ccc"]
        );
        assert_eq!(split_record("time,,x").unwrap(), ["time", "", "x"]);
        assert_eq!(split_record("").unwrap(), [""]);
        let names = ["a,b", "\"", "plain", ""];
        let line: Vec<Cow<str>> = names.iter().map(|n| field(n)).collect();
        assert_eq!(split_record(&line.join(",")).unwrap(), names);
    }

    #[test]
    fn a_stray_or_unmatched_quote_is_an_error_at_its_column() {
        assert_eq!(split_record(r#"a,"b"#), Err(QuoteError { column: 3 }));
        assert_eq!(split_record(r#"a,"b"c,d"#), Err(QuoteError { column: 3 }));
    }
}
