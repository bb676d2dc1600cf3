//! Just enough of C's translation phases to tell what a compiler takes from a header as
//! strings and as code: trigraphs (phase 1, on under `-std=c99`), line splicing (phase 2),
//! then comments and string and character literals (phase 3), each literal decoded by C's
//! escape rules (C11 §5.2.1.1, §5.1.1.2, §6.4.4.4, §6.4.5). Written from the standard, not
//! from keypose's writer, so the export target can check one against the other.

/// A header as the compiler sees it: the bytes of each string literal in order, and the text
/// with every literal's content taken out (`""`), comments kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lexed {
    pub literals: Vec<Vec<u8>>,
    pub skeleton: String,
}

/// Phases 1 to 3 over `text`; an error for a literal a compiler would refuse (a line break or
/// the end inside it, an unknown escape) or a comment left open.
pub fn lex(text: &str) -> Result<Lexed, String> {
    let text = splice_lines(&replace_trigraphs(text));
    let mut lexed = Lexed {
        literals: Vec::new(),
        skeleton: String::new(),
    };
    let mut rest = text.as_str();
    while let Some(c) = rest.chars().next() {
        if let Some(after) = rest.strip_prefix("/*") {
            let end = after.find("*/").ok_or("a comment left open")?;
            lexed.skeleton.push_str(&rest[..2 + end + 2]);
            rest = &after[end + 2..];
        } else if rest.starts_with("//") {
            let end = rest.find('\n').unwrap_or(rest.len());
            lexed.skeleton.push_str(&rest[..end]);
            rest = &rest[end..];
        } else if c == '"' || c == '\'' {
            let (bytes, after) = literal(&rest[1..], c)?;
            lexed.skeleton.extend([c, c]);
            if c == '"' {
                lexed.literals.push(bytes);
            }
            rest = after;
        } else {
            lexed.skeleton.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    Ok(lexed)
}

fn replace_trigraphs(text: &str) -> String {
    const TRIGRAPHS: [(&str, &str); 9] = [
        ("??=", "#"),
        ("??(", "["),
        ("??/", "\\"),
        ("??)", "]"),
        ("??'", "^"),
        ("??<", "{"),
        ("??!", "|"),
        ("??>", "}"),
        ("??-", "~"),
    ];
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while !rest.is_empty() {
        match TRIGRAPHS.iter().find(|(t, _)| rest.starts_with(t)) {
            Some((t, replacement)) => {
                out.push_str(replacement);
                rest = &rest[t.len()..];
            }
            None => {
                let c = rest.chars().next().unwrap();
                out.push(c);
                rest = &rest[c.len_utf8()..];
            }
        }
    }
    out
}

fn splice_lines(text: &str) -> String {
    text.replace("\\\n", "")
}

/// The bytes of a literal whose opening `quote` is already read, and the text after it.
fn literal(mut rest: &str, quote: char) -> Result<(Vec<u8>, &str), String> {
    let mut bytes = Vec::new();
    loop {
        let c = rest.chars().next().ok_or("a literal left open")?;
        rest = &rest[c.len_utf8()..];
        match c {
            '\n' => return Err("a line break inside a literal".into()),
            '\\' => rest = escape(rest, &mut bytes)?,
            c if c == quote => return Ok((bytes, rest)),
            c => bytes.extend(c.encode_utf8(&mut [0; 4]).as_bytes()),
        }
    }
}

/// One escape after its backslash: its byte into `bytes`; the text after it.
fn escape<'a>(rest: &'a str, bytes: &mut Vec<u8>) -> Result<&'a str, String> {
    let c = rest.chars().next().ok_or("a backslash at the end")?;
    let simple = match c {
        '\'' | '"' | '?' | '\\' => Some(c as u8),
        'a' => Some(7),
        'b' => Some(8),
        'f' => Some(12),
        'n' => Some(10),
        'r' => Some(13),
        't' => Some(9),
        'v' => Some(11),
        _ => None,
    };
    if let Some(byte) = simple {
        bytes.push(byte);
        return Ok(&rest[1..]);
    }
    if c.is_digit(8) {
        let digits = rest.chars().take(3).take_while(|d| d.is_digit(8)).count();
        let value = u32::from_str_radix(&rest[..digits], 8).unwrap();
        bytes.push(u8::try_from(value).map_err(|_| "an octal escape beyond a byte")?);
        return Ok(&rest[digits..]);
    }
    if c == 'x' {
        let digits = rest[1..]
            .chars()
            .take_while(char::is_ascii_hexdigit)
            .count();
        let value = u8::from_str_radix(&rest[1..1 + digits], 16)
            .map_err(|_| "a hexadecimal escape without digits or beyond a byte")?;
        bytes.push(value);
        return Ok(&rest[1 + digits..]);
    }
    Err(format!("an unknown escape \\{c}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_decode_as_a_c_compiler_reads_them() {
        let lexed = lex(r#"/* a "b" */ x = "q\042\\\n??/"", 'c'; // "d""#).unwrap();
        assert_eq!(lexed.literals, vec![b"q\"\\\n\"".to_vec()]);
        assert_eq!(lexed.skeleton, r#"/* a "b" */ x = "", ''; // "d""#);
        assert!(lex("\"open").is_err());
        assert!(lex("\"\\q\"").is_err());
    }
}
