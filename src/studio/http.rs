//! HTTP/1.1 on the wire, for the studio's few routes: one request read from any byte source
//! within fixed [`Limits`], and one answer written back. Nothing here knows about tokens or
//! routes ([`super::routes`]) or sockets ([`super::server`]), so the fuzzer drives it with
//! plain bytes.
//!
//! Everything is bounded before any check of who is asking: the head (request line and
//! header lines) is read into one buffer of [`Limits::head`] bytes and never past it; its
//! header lines are counted; a body is read only when its declared length is within
//! [`Limits::body`]. So whatever a client sends, a request holds at most `head + body` bytes,
//! and the reader consumes no more than that from the connection. Every answer closes the
//! connection (`Connection: close`): one request per connection, no pipelining to bound.

use std::borrow::Cow;
use std::io::{self, Read, Write};
use std::time::Duration;

/// What one request may take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Request line and header lines, their line ends included.
    pub head: usize,
    /// Header lines.
    pub header_lines: usize,
    /// The body's declared length.
    pub body: usize,
    /// How long the whole request may take to arrive; enforced by the reader the socket
    /// layer gives [`read_request`] (it fails with [`io::ErrorKind::TimedOut`]), named here
    /// for the error.
    pub time: Duration,
}

impl Default for Limits {
    /// The studio's: a browser's head is about 1 KiB in some 20 lines; a key or a typed line
    /// is a few bytes of JSON.
    fn default() -> Limits {
        Limits {
            head: 16 * 1024,
            header_lines: 64,
            body: 4096,
            time: Duration::from_secs(10),
        }
    }
}

/// The methods the studio answers; any other is refused by the router.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Method {
    Get,
    Post,
    Other,
}

/// A request read whole, within the limits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request {
    pub(crate) method: Method,
    /// The request target: a path, and maybe `?` and a query.
    pub(crate) target: String,
    headers: Vec<(String, String)>,
    /// The body, as long as its Content-Length said.
    pub body: Vec<u8>,
}

impl Request {
    /// The first header called `name` (any case).
    pub(crate) fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(field, _)| field.eq_ignore_ascii_case(name))
            .map(|(_, value)| value.as_str())
    }

    /// The target's path (before any `?`).
    pub(crate) fn path(&self) -> &str {
        self.target.split_once('?').map_or(&self.target, |(p, _)| p)
    }

    /// The first query parameter called `name`, as sent (the page's values need no
    /// percent-decoding: hex tokens and letter-digit ids; anything else simply does not
    /// match).
    pub(crate) fn param(&self, name: &str) -> Option<&str> {
        let (_, query) = self.target.split_once('?')?;
        query
            .split('&')
            .filter_map(|pair| pair.split_once('='))
            .find(|(key, _)| *key == name)
            .map(|(_, value)| value)
    }
}

/// Why no request was read. Each has the status it is answered with, if any.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HttpError {
    /// Closed (or reset) before a byte arrived: nobody to answer.
    #[error("the connection closed before a request")]
    Closed,
    /// The connection closed part-way through the request (400).
    #[error("the request ended after {received} bytes, before its end")]
    Incomplete {
        /// Bytes read before it closed.
        received: usize,
    },
    /// The head did not end within [`Limits::head`] (431).
    #[error("request head over {limit} bytes (the limit; {received} read without its end)")]
    HeadTooLarge {
        /// The limit, bytes.
        limit: usize,
        /// Bytes read.
        received: usize,
    },
    /// More header lines than [`Limits::header_lines`] (431).
    #[error("{found} header lines, over the limit of {limit}")]
    TooManyHeaderLines {
        /// The limit.
        limit: usize,
        /// Header lines found.
        found: usize,
    },
    /// A Content-Length over [`Limits::body`] (413).
    #[error("request body of {declared} bytes, over the limit of {limit}")]
    BodyTooLarge {
        /// The limit, bytes.
        limit: usize,
        /// The length the request declared, bytes.
        declared: u64,
    },
    /// A body sent with a Transfer-Encoding (501).
    #[error("Transfer-Encoding is not accepted: send the body with a Content-Length")]
    TransferEncoding,
    /// Not an HTTP/1.x request as the studio reads it (400): what is wrong.
    #[error("malformed request: {0}")]
    Malformed(&'static str),
    /// The request did not arrive whole within [`Limits::time`] (408).
    #[error("the request did not arrive within {} ms ({received} bytes came)", limit.as_millis())]
    TimedOut {
        /// The time allowed.
        limit: Duration,
        /// Bytes that came in that time.
        received: usize,
    },
    /// Reading the connection failed (nobody to answer): what the system said.
    #[error("cannot read the request: {0}")]
    Io(String),
}

impl HttpError {
    /// The status to answer with; `None` when there is nobody to answer.
    pub(crate) fn status(&self) -> Option<u16> {
        match self {
            HttpError::Closed | HttpError::Io(_) => None,
            HttpError::Incomplete { .. } | HttpError::Malformed(_) => Some(400),
            HttpError::HeadTooLarge { .. } | HttpError::TooManyHeaderLines { .. } => Some(431),
            HttpError::BodyTooLarge { .. } => Some(413),
            HttpError::TransferEncoding => Some(501),
            HttpError::TimedOut { .. } => Some(408),
        }
    }
}

/// Reads one request from `source`, taking at most `limits.head + limits.body` bytes from it.
pub fn read_request(source: &mut impl Read, limits: &Limits) -> Result<Request, HttpError> {
    let mut buffer = vec![0u8; limits.head];
    let mut filled = 0;
    // Searched for the head's end so far (less the three bytes an end may straddle), so that a
    // head trickled a byte at a time is not searched again from its start each time.
    let mut searched = 0;
    let head_end = loop {
        if let Some(end) = head_end(&buffer[searched..filled]) {
            break searched + end;
        }
        searched = filled.saturating_sub(3);
        if filled == buffer.len() {
            return Err(HttpError::HeadTooLarge {
                limit: limits.head,
                received: filled,
            });
        }
        match read_some(source, &mut buffer[filled..], limits, filled)? {
            0 if filled == 0 => return Err(HttpError::Closed),
            0 => return Err(HttpError::Incomplete { received: filled }),
            n => filled += n,
        }
    };
    let head = std::str::from_utf8(&buffer[..head_end - 4])
        .map_err(|_| HttpError::Malformed("the head is not UTF-8 text"))?;
    let (method, target, headers) = parse_head(head, limits)?;
    let length = body_length(&headers, limits)?;
    let mut body = buffer[head_end..filled].to_vec();
    // Bytes past the declared body (a pipelined request) are not this request's: dropped, as
    // the connection closes after the answer.
    body.truncate(length);
    let mut received = filled;
    while body.len() < length {
        let start = body.len();
        body.resize(length, 0);
        match read_some(source, &mut body[start..], limits, received)? {
            0 => return Err(HttpError::Incomplete { received }),
            n => {
                body.truncate(start + n);
                received += n;
            }
        }
    }
    Ok(Request {
        method,
        target: target.to_string(),
        headers,
        body,
    })
}

/// One read, a timeout and a reset told apart from other failures.
fn read_some(
    source: &mut impl Read,
    into: &mut [u8],
    limits: &Limits,
    received: usize,
) -> Result<usize, HttpError> {
    loop {
        match source.read(into) {
            Ok(n) => return Ok(n),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                ) =>
            {
                return Err(HttpError::TimedOut {
                    limit: limits.time,
                    received,
                })
            }
            Err(e) if received == 0 && e.kind() == io::ErrorKind::ConnectionReset => {
                return Err(HttpError::Closed)
            }
            Err(e) => return Err(HttpError::Io(e.to_string())),
        }
    }
}

/// Where the head ends (just past its empty line), if it has.
fn head_end(bytes: &[u8]) -> Option<usize> {
    bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .map(|at| at + 4)
}

type Head<'a> = (Method, &'a str, Vec<(String, String)>);

/// The request line and the header lines (without the final empty line).
fn parse_head<'a>(head: &'a str, limits: &Limits) -> Result<Head<'a>, HttpError> {
    // Empty lines before the request line are allowed (RFC 9112 §2.2).
    let mut lines = head.trim_start_matches("\r\n").split("\r\n");
    let request_line = lines.next().unwrap_or("");
    let mut parts = request_line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(HttpError::Malformed("expected METHOD TARGET HTTP/1.x"));
    };
    if version != "HTTP/1.1" && version != "HTTP/1.0" {
        return Err(HttpError::Malformed("expected HTTP/1.0 or HTTP/1.1"));
    }
    if !target.starts_with('/') {
        return Err(HttpError::Malformed("the target must be a path"));
    }
    let method = match method {
        "GET" => Method::Get,
        "POST" => Method::Post,
        m if !m.is_empty() && m.bytes().all(is_token_byte) => Method::Other,
        _ => return Err(HttpError::Malformed("the method is not a token")),
    };
    // Counted before any is kept: a head of thousands of tiny lines allocates nothing more.
    let found = lines.clone().count();
    if found > limits.header_lines {
        return Err(HttpError::TooManyHeaderLines {
            limit: limits.header_lines,
            found,
        });
    }
    let headers = lines.map(parse_header).collect::<Result<_, _>>()?;
    Ok((method, target, headers))
}

fn parse_header(line: &str) -> Result<(String, String), HttpError> {
    let (name, value) = line
        .split_once(':')
        .ok_or(HttpError::Malformed("a header line without a colon"))?;
    // A name that is not a token includes the folded continuation lines (a leading space)
    // that RFC 9112 §5.2 says to refuse.
    if name.is_empty() || !name.bytes().all(is_token_byte) {
        return Err(HttpError::Malformed("a header name that is not a token"));
    }
    Ok((
        name.to_string(),
        value.trim_matches([' ', '\t']).to_string(),
    ))
}

/// The characters of a method or header name (RFC 9110 §5.6.2).
fn is_token_byte(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b)
}

/// The body's length: its Content-Length (every one the same), 0 without one.
fn body_length(headers: &[(String, String)], limits: &Limits) -> Result<usize, HttpError> {
    let named = |name: &'static str| {
        headers
            .iter()
            .filter(move |(field, _)| field.eq_ignore_ascii_case(name))
            .map(|(_, value)| value.as_str())
    };
    if named("Transfer-Encoding").next().is_some() {
        return Err(HttpError::TransferEncoding);
    }
    let mut length = None;
    for value in named("Content-Length") {
        if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
            return Err(HttpError::Malformed("Content-Length is not a number"));
        }
        // More digits than a u64 holds is over any limit.
        let declared = value.parse::<u64>().unwrap_or(u64::MAX);
        if length.is_some_and(|l| l != declared) {
            return Err(HttpError::Malformed(
                "Content-Length given twice, differently",
            ));
        }
        length = Some(declared);
    }
    let declared = length.unwrap_or(0);
    match usize::try_from(declared) {
        Ok(n) if n <= limits.body => Ok(n),
        _ => Err(HttpError::BodyTooLarge {
            limit: limits.body,
            declared,
        }),
    }
}

/// An answer: status, headers, body; written with its length, closing the connection.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Response {
    /// The HTTP status code.
    pub status: u16,
    pub(crate) headers: Vec<(&'static str, String)>,
    pub(crate) body: Cow<'static, [u8]>,
}

impl Response {
    pub(crate) fn new(status: u16, body: impl Into<Cow<'static, [u8]>>) -> Response {
        Response {
            status,
            headers: Vec::new(),
            body: body.into(),
        }
    }

    /// The body as it is sent.
    pub fn body(&self) -> &[u8] {
        &self.body
    }

    pub(crate) fn with_header(mut self, name: &'static str, value: impl Into<String>) -> Response {
        self.headers.push((name, value.into()));
        self
    }

    pub(crate) fn write_to(&self, out: &mut impl Write) -> io::Result<()> {
        out.write_all(&self.head(Some(self.body.len())))?;
        out.write_all(&self.body)?;
        out.flush()
    }

    /// The status line and headers; with a length, `Content-Length` (a stream has none: it
    /// ends when the connection closes).
    pub(crate) fn head(&self, length: Option<usize>) -> Vec<u8> {
        let mut head = format!("HTTP/1.1 {} {}\r\n", self.status, reason(self.status));
        for (name, value) in &self.headers {
            head.push_str(&format!("{name}: {value}\r\n"));
        }
        if let Some(length) = length {
            head.push_str(&format!("Content-Length: {length}\r\n"));
        }
        head.push_str("Connection: close\r\n\r\n");
        head.into_bytes()
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        409 => "Conflict",
        413 => "Content Too Large",
        422 => "Unprocessable Content",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Limits {
        Limits::default()
    }

    fn read(bytes: &[u8]) -> Result<Request, HttpError> {
        read_request(&mut &bytes[..], &limits())
    }

    /// A source that counts what is taken from it and never ends: `prefix`, then `fill` bytes
    /// forever.
    struct Endless<'a> {
        prefix: &'a [u8],
        fill: u8,
        taken: usize,
    }

    impl Read for Endless<'_> {
        fn read(&mut self, into: &mut [u8]) -> io::Result<usize> {
            let n = if self.prefix.is_empty() {
                into.fill(self.fill);
                into.len()
            } else {
                let n = self.prefix.len().min(into.len());
                into[..n].copy_from_slice(&self.prefix[..n]);
                self.prefix = &self.prefix[n..];
                n
            };
            self.taken += n;
            Ok(n)
        }
    }

    #[test]
    fn a_request_is_its_method_target_headers_and_body() {
        let request =
            read(b"POST /api/key?token=ab&client=p-1 HTTP/1.1\r\nHost: h:1\r\nx-keypose-token:  t \r\nContent-Length: 12\r\n\r\n{\"key\": \"u\"}")
                .unwrap();
        assert_eq!(request.method, Method::Post);
        assert_eq!(request.path(), "/api/key");
        assert_eq!(request.param("token"), Some("ab"));
        assert_eq!(request.param("client"), Some("p-1"));
        assert_eq!(request.param("other"), None);
        assert_eq!(request.header("HOST"), Some("h:1"));
        assert_eq!(request.header("X-Keypose-Token"), Some("t"));
        assert_eq!(request.body, br#"{"key": "u"}"#);
        let get = read(b"GET / HTTP/1.0\r\n\r\n").unwrap();
        assert_eq!(
            (get.method, get.path(), get.body.len()),
            (Method::Get, "/", 0)
        );
    }

    #[test]
    fn a_head_that_never_ends_is_refused_at_the_limit_having_read_no_more() {
        let mut source = Endless {
            prefix: b"GET / HTTP/1.1\r\nX-Fill: ",
            fill: b'a',
            taken: 0,
        };
        let error = read_request(&mut source, &limits()).unwrap_err();
        assert_eq!(
            error,
            HttpError::HeadTooLarge {
                limit: 16384,
                received: 16384
            }
        );
        assert_eq!(error.status(), Some(431));
        assert_eq!(source.taken, 16384);
    }

    #[test]
    fn header_lines_over_the_count_are_refused() {
        let mut text = String::from("GET / HTTP/1.1\r\n");
        text.push_str(&"A: b\r\n".repeat(65));
        text.push_str("\r\n");
        let error = read(text.as_bytes()).unwrap_err();
        assert_eq!(
            error,
            HttpError::TooManyHeaderLines {
                limit: 64,
                found: 65
            }
        );
        assert_eq!(error.status(), Some(431));
    }

    #[test]
    fn a_body_over_the_limit_is_refused_before_it_is_read() {
        for length in ["4097", "1000000000", "99999999999999999999999"] {
            let head = format!("POST / HTTP/1.1\r\nContent-Length: {length}\r\n\r\n");
            let mut source = Endless {
                prefix: head.as_bytes(),
                fill: b'x',
                taken: 0,
            };
            let error = read_request(&mut source, &limits()).unwrap_err();
            assert!(
                matches!(error, HttpError::BodyTooLarge { limit: 4096, .. }),
                "{error}"
            );
            assert_eq!(error.status(), Some(413));
            assert!(source.taken <= 16384, "{}", source.taken);
        }
        // 4096 is within.
        let mut source = Endless {
            prefix: b"POST / HTTP/1.1\r\nContent-Length: 4096\r\n\r\n",
            fill: b'x',
            taken: 0,
        };
        let request = read_request(&mut source, &limits()).unwrap();
        assert_eq!(request.body.len(), 4096);
    }

    #[test]
    fn what_is_not_http_is_malformed_and_a_chunked_body_refused() {
        for bad in [
            &b"GET /\r\n\r\n"[..],
            b"GET / HTTP/2\r\n\r\n",
            b"GET http://x/ HTTP/1.1\r\n\r\n",
            b"GET  / HTTP/1.1\r\n\r\n",
            b"G(T / HTTP/1.1\r\n\r\n",
            b"GET / HTTP/1.1\r\nNo colon\r\n\r\n",
            b"GET / HTTP/1.1\r\nA: b\r\n folded\r\n\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: -1\r\n\r\n",
            b"GET / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\nab",
            b"GET / HTTP/1.1\r\nX: \xff\r\n\r\n",
        ] {
            let error = read(bad).unwrap_err();
            assert!(matches!(error, HttpError::Malformed(_)), "{bad:?}: {error}");
            assert_eq!(error.status(), Some(400));
        }
        let chunked = read(b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n");
        assert_eq!(chunked, Err(HttpError::TransferEncoding));
    }

    #[test]
    fn a_request_cut_short_is_incomplete_and_nothing_at_all_is_closed() {
        assert_eq!(read(b""), Err(HttpError::Closed));
        assert_eq!(
            read(b"GET / HTTP/1.1\r\nHost"),
            Err(HttpError::Incomplete { received: 20 })
        );
        assert_eq!(
            read(b"POST / HTTP/1.1\r\nContent-Length: 5\r\n\r\nab"),
            Err(HttpError::Incomplete { received: 40 })
        );
    }

    #[test]
    fn a_timeout_of_the_source_is_the_time_limit() {
        struct Slow;
        impl Read for Slow {
            fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
                Err(io::ErrorKind::WouldBlock.into())
            }
        }
        let error = read_request(&mut Slow, &limits()).unwrap_err();
        assert_eq!(
            error,
            HttpError::TimedOut {
                limit: Duration::from_secs(10),
                received: 0
            }
        );
        assert_eq!(error.status(), Some(408));
    }

    #[test]
    fn an_answer_has_its_length_and_closes() {
        let mut out = Vec::new();
        Response::new(404, &b"{}"[..])
            .with_header("Content-Type", "application/json")
            .write_to(&mut out)
            .unwrap();
        assert_eq!(
            out,
            b"HTTP/1.1 404 Not Found\r\nContent-Type: application/json\r\n\
              Content-Length: 2\r\nConnection: close\r\n\r\n{}"
        );
    }
}
