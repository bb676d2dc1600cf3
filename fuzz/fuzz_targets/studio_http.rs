//! The studio's request reading and routing (`studio::read_request`, then `studio::route`,
//! as a connection's thread runs them) on fuzzed connections: a
//! read-size byte, a filler byte, then the bytes of one or more connections separated by two
//! NULs. Each connection delivers its bytes in reads of that size (0: all at once) and then,
//! with a filler byte other than 0, that byte forever: a client that never stops sending.
//! The connections of one input share one studio, so a page can take control and then act.
//!
//! Properties:
//! - no panic;
//! - bounded: the reader takes at most `head + body` bytes of the limits from a connection
//!   (so an endless one ends), and allocates no more while reading than those limits allow;
//! - never an action without the token: a key, a typed line or a Stop reaching the engine (a
//!   Stop brakes the arm just before it is sent), the lease taken or let go, an event stream,
//!   or any answer but 403 to anything other than the page's static files, only for a request
//!   whose head names the server in a `Host` line and carries the token in an
//!   `X-Keypose-Token` line or a `token=` query parameter — read here from the raw bytes,
//!   independently of the parser.
//!
//! The studio has no simulator here, and its published list is empty: `/api/simulate` gets as
//! far as its control check and the "no keys" refusal.
#![no_main]

use keypose::studio::engine::{Hub, Input};
use keypose::studio::{read_request, route, Context, Guard, Lease, Limits, Reply};
use keypose_fuzz::{builtin_robot, Choices};
use libfuzzer_sys::fuzz_target;
use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Read;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, OnceLock};

const TOKEN: &str = "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";
const ADDRESS: &str = "127.0.0.1:8123";
/// The names a `Host` line may give the server by (a loopback address: `localhost` too).
const HOSTS: [&str; 2] = [ADDRESS, "localhost:8123"];
/// The page's folder in the source tree: the static files are its files, compiled in.
const WEB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../src/studio/web");

/// The bytes the process has allocated and not freed, and the most since the last reset.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        System.dealloc(p, layout);
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// What reached the engine, counted by the thread that stands in for it.
static ACTIONS: AtomicUsize = AtomicUsize::new(0);

/// One studio for the whole run (building its robot model takes longer than a request); its
/// lease is reset for each input. The engine is a thread that counts and answers actions.
fn studio() -> &'static Context {
    static STUDIO: OnceLock<Context> = OnceLock::new();
    STUDIO.get_or_init(|| {
        let (inputs, received) = mpsc::channel::<Input>();
        std::thread::spawn(move || {
            for input in received {
                ACTIONS.fetch_add(1, Ordering::SeqCst);
                if let Input::Action { reply, .. } = input {
                    let _ = reply.send(serde_json::json!({"text": "done", "error": false}));
                }
            }
        });
        let guard = Guard::new(TOKEN.to_string(), ADDRESS.parse().unwrap());
        let robot = builtin_robot(0).clone();
        Context::new(guard, Arc::new(Hub::default()), inputs, robot)
    })
}

/// A connection: its bytes in reads of `piece` (0: whole), then `filler` forever if given.
struct Connection<'a> {
    bytes: &'a [u8],
    piece: usize,
    filler: Option<u8>,
    taken: usize,
}

impl Read for Connection<'_> {
    fn read(&mut self, into: &mut [u8]) -> std::io::Result<usize> {
        let n = if !self.bytes.is_empty() {
            let n = into.len().min(self.bytes.len());
            let n = if self.piece == 0 {
                n
            } else {
                n.min(self.piece)
            };
            into[..n].copy_from_slice(&self.bytes[..n]);
            self.bytes = &self.bytes[n..];
            n
        } else if let Some(filler) = self.filler {
            let n = if self.piece == 0 {
                into.len()
            } else {
                into.len().min(self.piece)
            };
            into[..n].fill(filler);
            n
        } else {
            0
        };
        self.taken += n;
        Ok(n)
    }
}

/// The raw head's request line (the first line that is not empty) and header lines, up to
/// the first empty line.
fn head_lines(bytes: &[u8]) -> (String, Vec<String>) {
    let text = String::from_utf8_lossy(bytes);
    let head = text.trim_start_matches("\r\n");
    let head = head.split("\r\n\r\n").next().unwrap_or("");
    let mut lines = head.split("\r\n").map(str::to_string);
    (lines.next().unwrap_or_default(), lines.collect())
}

/// The oracle: the raw head has a `Host` line naming the server and the token in a header
/// line or in the request line's query.
fn carries_the_token(bytes: &[u8]) -> bool {
    let (request_line, header_lines) = head_lines(bytes);
    let mut host = false;
    let mut token = request_line
        .match_indices(&format!("token={TOKEN}"))
        .any(|(at, found)| {
            let after = request_line[at + found.len()..].chars().next();
            matches!(after, None | Some('&' | ' '))
        });
    for line in header_lines {
        let Some((name, value)) = line.split_once(':') else {
            continue;
        };
        let value = value.trim_matches([' ', '\t']);
        if name.eq_ignore_ascii_case("host") {
            host |= HOSTS.iter().any(|h| h.eq_ignore_ascii_case(value));
        }
        if name.eq_ignore_ascii_case("x-keypose-token") {
            token |= value == TOKEN;
        }
    }
    host && token
}

/// The file of the page's folder the request line names, if any, other than the page itself
/// (which needs the token): what may be answered without the token, byte for byte. Read from
/// the source tree, independently of the server's own list of files.
fn static_file(bytes: &[u8]) -> Option<Vec<u8>> {
    let (request_line, _) = head_lines(bytes);
    let target = request_line.split(' ').nth(1)?;
    let path = target.split('?').next()?.strip_prefix('/')?;
    let plain = path.split('/').all(|part| !matches!(part, "" | "." | ".."));
    if !plain || path == "index.html" {
        return None;
    }
    std::fs::read(std::path::Path::new(WEB).join(path)).ok()
}

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let piece = usize::from(choices.byte());
    let filler = Some(choices.byte()).filter(|&b| b != 0);
    let context = studio();
    *context.hub.lease() = Lease::default();
    let limits = Limits::default();
    for bytes in choices.rest().split(|&b| b == 0).filter(|c| !c.is_empty()) {
        serve(bytes, piece, filler, context, &limits);
    }
});

/// One connection read and routed, its properties checked.
fn serve(bytes: &[u8], piece: usize, filler: Option<u8>, context: &Context, limits: &Limits) {
    let mut connection = Connection {
        bytes,
        piece,
        filler,
        taken: 0,
    };
    let base = LIVE.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let read = read_request(&mut connection, limits);
    let held = PEAK.load(Ordering::SeqCst) - base;
    let bound = limits.head + limits.body;
    assert!(connection.taken <= bound, "took {} bytes", connection.taken);
    // The head buffer, the body, and the parsed copy of the head (header lines as strings).
    assert!(held <= 3 * bound, "held {held} bytes while reading");
    let Ok(request) = read else { return };
    assert!(request.body.len() <= limits.body);

    let allowed = carries_the_token(bytes);
    let actions = ACTIONS.load(Ordering::SeqCst);
    let held_before = context.hub.lease().is_held();
    let reply = route(&request, context);
    let mut lease = context.hub.lease();
    let lease_changed = (lease.is_held() != held_before) | lease.take_lost();
    drop(lease);
    if allowed {
        return;
    }
    assert_eq!(
        ACTIONS.load(Ordering::SeqCst),
        actions,
        "an action without the token"
    );
    assert!(!lease_changed, "control taken or let go without the token");
    match reply {
        Reply::Answer(answer) if answer.status == 403 => {}
        Reply::Answer(answer)
            if answer.status == 200 && static_file(bytes).as_deref() == Some(answer.body()) => {}
        Reply::Answer(answer) => panic!("answered {} without the token", answer.status),
        Reply::Events(_) => panic!("an event stream without the token"),
    }
}
