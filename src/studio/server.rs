//! The studio's sockets: one thread accepts, one thread per connection reads one request
//! ([`http::read_request`]), answers it ([`routes::route`]) and closes (an event stream keeps
//! its thread while the page is open).
//!
//! What a client can take is bounded before any token is checked, so that no client — a
//! flood of half-open connections, a slow one, a huge header — can stop the server answering
//! the page that holds the arm (its heartbeat keeps the lease; a lapsed lease stops the arm):
//! - at most [`MAX_CONNECTIONS`] connections at once; the next ones are answered 503 at once
//!   and closed, by the accepting thread, which reads nothing from them;
//! - each request within [`http::Limits`]: its head, its header lines and its body in size,
//!   and the whole request in time (a deadline from the moment it is accepted, however
//!   slowly its bytes trickle in); answers must be taken within [`WRITE_TIMEOUT`];
//! - accepting that fails (no file descriptor left: EMFILE, ENFILE; or anything else) is
//!   retried with a growing pause, said once on standard error, and never ends the loop.
//!
//! A panic in any server thread is a fault ([`Context::fault`]): the arm is braked and the
//! session ends once it is at rest. (An allocation failure aborts a Rust process without
//! unwinding, and nothing can brake then; the bounds above are what keep a client from
//! causing one: nothing the server holds grows with what a client sends.)

use super::http::{self, HttpError, Limits};
use super::routes::{self, Context, Reply};
use serde_json::json;
use std::io::{self, Read};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Connections open at once. A page uses a few (its requests, its heartbeat, its event
/// stream), and at most [`routes::MAX_STREAMS`] pages stream at once.
pub(crate) const MAX_CONNECTIONS: usize = 64;
/// How long an answer (or a part of an event stream) may wait for the client to take it.
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);
/// First and longest pause after a failed accept.
const BACKOFF: (Duration, Duration) = (Duration::from_millis(5), Duration::from_secs(1));
/// After refusing a request, what is still read (and dropped) for at most this long and this
/// many bytes, so that the client can read the refusal before the connection closes (closing
/// with unread bytes would reset it).
const LINGER: (Duration, usize) = (Duration::from_secs(1), 64 * 1024);

/// Serves `listener` on a thread of its own until the process ends.
pub(crate) fn spawn(listener: TcpListener, context: Context, limits: Limits) {
    let context = Arc::new(context);
    let spawned = std::thread::Builder::new()
        .name("keypose-studio-accept".into())
        .spawn({
            let context = context.clone();
            move || {
                fault_on_panic(&context, "the thread that accepts connections", || {
                    accept_loop(&listener, &context, limits)
                })
            }
        });
    if let Err(e) = spawned {
        context.fault(format!(
            "cannot start the thread that accepts connections: {e}"
        ));
    }
}

/// Runs `work`; a panic in it is a server fault (the panic hook has printed it already).
fn fault_on_panic(context: &Context, thread: &str, work: impl FnOnce()) {
    if let Err(panic) = std::panic::catch_unwind(AssertUnwindSafe(work)) {
        let message = crate::teach::panic_message(panic.as_ref());
        context.fault(format!("{thread} panicked: {message}"));
    }
}

fn accept_loop(listener: &TcpListener, context: &Arc<Context>, limits: Limits) {
    let open = Arc::new(AtomicUsize::new(0));
    let mut pause: Option<Duration> = None;
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                pause = None;
                if context.accept_fault_armed.load(Ordering::SeqCst) {
                    panic!("test fault: a panic in the accept loop (KEYPOSE_STUDIO_TEST_FAULT)");
                }
                admit(stream, context, &open, limits);
            }
            Err(e) => {
                // Said once per run of failures: a flood must not flood the terminal too.
                if pause.is_none() {
                    eprintln!("studio: cannot accept a connection ({e}); trying again");
                }
                let next = pause.map_or(BACKOFF.0, |p| (p * 2).min(BACKOFF.1));
                pause = Some(next);
                std::thread::sleep(next);
            }
        }
    }
}

/// A connection's place among [`MAX_CONNECTIONS`], given back when dropped.
struct Place(Arc<AtomicUsize>);

impl Place {
    fn take(open: &Arc<AtomicUsize>) -> Option<Place> {
        let taken = open.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
            (n < MAX_CONNECTIONS).then_some(n + 1)
        });
        taken.ok().map(|_| Place(open.clone()))
    }
}

impl Drop for Place {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A thread for `stream`, or a refusal when every place is taken. (When no thread can
/// start, the connection closes unanswered.)
fn admit(stream: TcpStream, context: &Arc<Context>, open: &Arc<AtomicUsize>, limits: Limits) {
    let Some(place) = Place::take(open) else {
        let error = format!("more than {MAX_CONNECTIONS} connections are open; try again");
        return refuse_at_once(stream, &error);
    };
    let deadline = Instant::now() + limits.time;
    let context = context.clone();
    let _ = std::thread::Builder::new()
        .name("keypose-studio-http".into())
        .spawn(move || {
            let _place = place;
            fault_on_panic(&context, "a request's thread", || {
                serve(stream, &context, limits, deadline)
            });
        });
}

/// Answers 503 without reading, from the accepting thread, which must not wait: the socket
/// is non-blocking, and what does not fit in its buffer at once is not sent.
fn refuse_at_once(mut stream: TcpStream, error: &str) {
    let _ = stream.set_nonblocking(true);
    let answer = routes::json_response(503, &json!({ "error": error }));
    let _ = answer.write_to(&mut stream);
    let _ = stream.shutdown(Shutdown::Write);
}

/// One connection: its request read by `deadline`, answered, closed.
fn serve(stream: TcpStream, context: &Context, limits: Limits, deadline: Instant) {
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let mut source = Deadline {
        stream: &stream,
        deadline,
    };
    let request = match http::read_request(&mut source, &limits) {
        Ok(request) => request,
        Err(error) => return refuse(&stream, &error),
    };
    let mut out = &stream;
    match routes::route(&request, context) {
        Reply::Answer(answer) => {
            let _ = answer.write_to(&mut out);
        }
        Reply::Events(events) => routes::stream_events(events, &mut out, context),
    }
}

/// Answers a request that could not be read (if anyone is there to answer), then lets the
/// client read it.
fn refuse(stream: &TcpStream, error: &HttpError) {
    let Some(status) = error.status() else { return };
    let answer = routes::json_response(status, &json!({ "error": error.to_string() }));
    let _ = answer.write_to(&mut &*stream);
    let _ = stream.shutdown(Shutdown::Write);
    linger(stream);
}

/// Reads and drops what the client still sends, within [`LINGER`], in a small buffer.
fn linger(mut stream: &TcpStream) {
    let until = Instant::now() + LINGER.0;
    let mut scratch = [0u8; 4096];
    let mut dropped = 0;
    while dropped < LINGER.1 {
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() || stream.set_read_timeout(Some(left)).is_err() {
            return;
        }
        match stream.read(&mut scratch) {
            Ok(0) | Err(_) => return,
            Ok(n) => dropped += n,
        }
    }
}

/// A connection read against a deadline for the whole request: each read waits at most
/// until then, so a client that trickles a byte at a time cannot hold its place longer.
struct Deadline<'a> {
    stream: &'a TcpStream,
    deadline: Instant,
}

impl Read for Deadline<'_> {
    fn read(&mut self, into: &mut [u8]) -> io::Result<usize> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        // A zero timeout means none at all to the socket; past the deadline, what is already
        // there is still taken (the request may have arrived whole while this thread waited
        // for the processor), but nothing is waited for.
        self.stream
            .set_read_timeout(Some(left.max(Duration::from_millis(1))))?;
        self.stream.read(into)
    }
}
