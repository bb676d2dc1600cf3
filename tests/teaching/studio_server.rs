//! `keypose studio`'s HTTP server against hostile clients, through the real binary on emulated
//! servos (`--port virtual`), before any token: connections over the cap are refused while the
//! server keeps serving, running out of file descriptors does not stop it accepting, a huge
//! header is refused without the process growing by it, a slow client is cut off, a server
//! fault brakes the arm before the studio ends, a non-loopback `--listen` is warned about, and
//! the token is never printed nor sent on as a Referer.
//!
//! No timing thresholds: every wait is a hang guard of a minute that fails the test.

use crate::common;
use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpStream};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

/// The server's documented cap on connections open at once (docs/studio.md).
const MAX_CONNECTIONS: usize = 64;
/// The documented limit on a request's head (request line and header lines).
const MAX_HEAD: usize = 16 * 1024;
/// How long any one step may take before the test fails: a hang guard, not a timing check.
const HANG_GUARD: Duration = Duration::from_secs(60);

/// A running `keypose studio --port virtual`, killed when the test ends.
struct Studio {
    child: Child,
    addr: String,
    token: String,
    /// Standard error, line by line, as the studio writes it.
    stderr: Receiver<String>,
    /// The lines read from `stderr` so far.
    seen: Vec<String>,
}

impl Drop for Studio {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// How to start a studio.
#[derive(Default)]
struct Start<'a> {
    args: &'a [&'a str],
    env: &'a [(&'a str, &'a str)],
    /// The process's limit on open files (RLIMIT_NOFILE), set before it starts.
    open_files: Option<u64>,
}

fn start(dir: &Path, how: Start) -> Studio {
    let mut command = common::keypose();
    command
        .args(["studio", "--port", "virtual"])
        .args(how.args)
        .current_dir(dir)
        .env("KEYPOSE_CACHE", dir.join("cache"))
        .envs(how.env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(limit) = how.open_files {
        limit_open_files(&mut command, limit);
    }
    let mut child = command.spawn().expect("start keypose studio");
    let stdout = child.stdout.take().unwrap();
    let stderr = child.stderr.take().unwrap();
    let (lines, received) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            eprintln!("studio: {line}");
            if lines.send(line).is_err() {
                break;
            }
        }
    });
    let mut url = String::new();
    BufReader::new(stdout).read_line(&mut url).unwrap();
    let Some(rest) = url.trim().strip_prefix("http://") else {
        let said: Vec<String> =
            std::iter::from_fn(|| received.recv_timeout(HANG_GUARD).ok()).collect();
        panic!(
            "the first line is not the page's URL but {url:?}; standard error:\n{}",
            said.join("\n")
        );
    };
    let (addr, token) = rest.split_once("/?token=").unwrap();
    Studio {
        addr: addr.to_string(),
        token: token.to_string(),
        child,
        stderr: received,
        seen: Vec::new(),
    }
}

/// Lowers the child's soft limit on open files before it runs.
fn limit_open_files(command: &mut Command, limit: u64) {
    use std::os::unix::process::CommandExt;
    // SAFETY: setrlimit is async-signal-safe, and the closure touches nothing else.
    unsafe {
        command.pre_exec(move || {
            let mut now = libc::rlimit {
                rlim_cur: 0,
                rlim_max: 0,
            };
            if libc::getrlimit(libc::RLIMIT_NOFILE, &mut now) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            now.rlim_cur = limit.min(now.rlim_max);
            if libc::setrlimit(libc::RLIMIT_NOFILE, &now) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

impl Studio {
    /// The first line of standard error that `matches`, waiting for it.
    fn wait_for_line(&mut self, matches: impl Fn(&str) -> bool) -> String {
        if let Some(line) = self.seen.iter().find(|l| matches(l)) {
            return line.clone();
        }
        let give_up = Instant::now() + HANG_GUARD;
        loop {
            let left = give_up.saturating_duration_since(Instant::now());
            let line = self.stderr.recv_timeout(left).unwrap_or_else(|_| {
                panic!(
                    "no such line on the studio's standard error; it said:\n{}",
                    self.seen.join("\n")
                )
            });
            self.seen.push(line.clone());
            if matches(&line) {
                return line;
            }
        }
    }

    /// Everything the studio wrote on standard error until it ended.
    fn rest_of_stderr(&mut self) -> String {
        while let Ok(line) = self.stderr.recv_timeout(HANG_GUARD) {
            self.seen.push(line);
        }
        self.seen.join("\n")
    }

    /// The studio's exit, waiting for it.
    fn wait_exit(&mut self) -> ExitStatus {
        let give_up = Instant::now() + HANG_GUARD;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(Instant::now() < give_up, "the studio did not end");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }

    fn connect(&self) -> TcpStream {
        let stream = TcpStream::connect(&self.addr).expect("connect to the studio");
        stream.set_read_timeout(Some(HANG_GUARD)).unwrap();
        stream
    }

    /// A request as the page's scripts send it (Host and token), as raw text.
    fn request_text(&self, method: &str, path: &str, body: &str) -> String {
        format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nX-Keypose-Token: {}\r\n\
             X-Keypose-Client: test-page\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            self.addr,
            self.token,
            body.len()
        )
    }

    /// One request with the token; the status and the JSON answer.
    fn call(&self, method: &str, path: &str, body: &str) -> (u16, Value) {
        let answer = exchange(
            self.connect(),
            self.request_text(method, path, body).as_bytes(),
        );
        (status(&answer), json_body(&answer))
    }

    /// `GET /api/state` with the token, tried until it is served (a refusal while the server
    /// frees what a test held is tried again).
    fn state_when_served(&self) -> Value {
        let give_up = Instant::now() + HANG_GUARD;
        loop {
            let (code, state) = self.call("GET", "/api/state", "");
            if code == 200 {
                return state;
            }
            assert!(
                Instant::now() < give_up,
                "the studio still answers {code}: {state}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The process's peak resident memory (VmHWM), in KiB.
    fn peak_memory_kib(&self) -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.pid())).unwrap();
        let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    }
}

/// Writes `bytes` and reads the whole answer (the studio closes every connection after its
/// answer). A write the server cut short is not an error here: its answer is what counts.
fn exchange(mut stream: TcpStream, bytes: &[u8]) -> String {
    let _ = stream.write_all(bytes);
    read_answer(stream)
}

/// What the server sent until it closed the connection (or reset it).
fn read_answer(mut stream: TcpStream) -> String {
    let mut answer = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        match stream.read(&mut chunk) {
            Ok(0) | Err(_) => break,
            Ok(n) => answer.extend_from_slice(&chunk[..n]),
        }
    }
    String::from_utf8_lossy(&answer).into_owned()
}

fn status(answer: &str) -> u16 {
    answer
        .get(9..12)
        .and_then(|code| code.parse().ok())
        .unwrap_or_else(|| panic!("not an HTTP answer: {answer:?}"))
}

fn json_body(answer: &str) -> Value {
    let body = answer.split_once("\r\n\r\n").map_or("", |(_, body)| body);
    serde_json::from_str(body).unwrap_or(Value::Null)
}

/// The header `name` of an answer.
fn header<'a>(answer: &'a str, name: &str) -> Option<&'a str> {
    let head = answer
        .split_once("\r\n\r\n")
        .map_or(answer, |(head, _)| head);
    head.lines().skip(1).find_map(|line| {
        let (field, value) = line.split_once(':')?;
        field
            .trim()
            .eq_ignore_ascii_case(name)
            .then_some(value.trim())
    })
}

#[test]
fn connections_over_the_cap_are_refused_at_once_and_the_server_keeps_serving() {
    let dir = tempfile::tempdir().unwrap();
    // Idle connections are held for ten minutes, so that none of them is let go by the read
    // timeout while the test holds them.
    let mut studio = start(
        dir.path(),
        Start {
            args: &["new.json"],
            env: &[("KEYPOSE_STUDIO_READ_TIMEOUT_MS", "600000")],
            ..Start::default()
        },
    );
    // The cap's worth of connections that send nothing (half-open, as a flood leaves them)...
    let held: Vec<TcpStream> = (0..MAX_CONNECTIONS).map(|_| studio.connect()).collect();
    // ... then every connection more is answered 503 at once, without sending anything.
    for _ in 0..8 {
        let answer = read_answer(studio.connect());
        assert_eq!(status(&answer), 503, "{answer}");
        assert!(
            json_body(&answer)["error"]
                .as_str()
                .unwrap()
                .contains(&format!("{MAX_CONNECTIONS} connections")),
            "{answer}"
        );
    }
    // So is a request with the token, while the flood holds every place.
    assert_eq!(studio.call("GET", "/api/state", "").0, 503);
    // Let go of the flood: the same server serves again.
    drop(held);
    let state = studio.state_when_served();
    assert_eq!(state["activity"]["kind"], "idle", "{state}");
    let said = studio.rest_of_stderr_so_far();
    assert!(
        !said.contains(&studio.token),
        "the token was printed:\n{said}"
    );
}

impl Studio {
    /// What the studio has written on standard error by now (without waiting for more).
    fn rest_of_stderr_so_far(&mut self) -> String {
        while let Ok(line) = self.stderr.try_recv() {
            self.seen.push(line);
        }
        self.seen.join("\n")
    }
}

#[test]
fn the_server_accepts_again_after_running_out_of_file_descriptors() {
    let dir = tempfile::tempdir().unwrap();
    let mut studio = start(
        dir.path(),
        Start {
            args: &["new.json"],
            env: &[("KEYPOSE_STUDIO_READ_TIMEOUT_MS", "600000")],
            open_files: Some(32),
        },
    );
    // Fewer connections than the cap, more than the 32 descriptors leave (the studio holds
    // about ten of its own): the process runs out of descriptors, and accepting fails.
    let held: Vec<TcpStream> = (0..48).map(|_| studio.connect()).collect();
    let said = studio.wait_for_line(|l| l.contains("cannot accept"));
    assert!(said.contains("Too many open files"), "{said}");
    // The connections close; the server accepts the ones still waiting, and new ones.
    drop(held);
    let state = studio.state_when_served();
    assert_eq!(state["activity"]["kind"], "idle", "{state}");
    // Still the same server, still accepting.
    assert_eq!(studio.call("GET", "/api/state", "").0, 200);
}

#[test]
fn a_huge_header_is_refused_with_431_and_the_process_does_not_grow_by_it() {
    const LINE: usize = 8 << 20;
    let dir = tempfile::tempdir().unwrap();
    let studio = start(
        dir.path(),
        Start {
            args: &["new.json"],
            ..Start::default()
        },
    );
    // One request first, so that what serving any request costs is in the peak already.
    assert_eq!(studio.call("GET", "/api/state", "").0, 200);
    let before = studio.peak_memory_kib();

    // An 8 MiB header line, after the token (which does not help it).
    let mut request = studio
        .request_text("GET", "/api/state", "")
        .trim_end()
        .to_string()
        .into_bytes();
    request.extend_from_slice(b"\r\nX-Fill: ");
    request.resize(request.len() + LINE, b'a');
    request.extend_from_slice(b"\r\n\r\n");
    let stream = studio.connect();
    let mut writer = stream.try_clone().unwrap();
    let sender = std::thread::spawn(move || {
        let _ = writer.write_all(&request);
        let _ = writer.shutdown(Shutdown::Write);
    });
    let answer = read_answer(stream);
    sender.join().unwrap();
    let after = studio.peak_memory_kib();
    eprintln!("peak resident memory {before} KiB before, {after} KiB after an 8 MiB header");
    assert_eq!(status(&answer), 431, "{}", &answer[..answer.len().min(300)]);
    let error = json_body(&answer)["error"].as_str().unwrap().to_string();
    assert!(error.contains(&MAX_HEAD.to_string()), "{error}");
    // The peak grew by far less than the line: the server never held it.
    assert!(
        after < before + 1024,
        "the process grew from {before} KiB to {after} KiB"
    );

    // Too many header lines, each short, are refused the same way.
    let mut many = studio
        .request_text("GET", "/api/state", "")
        .trim_end()
        .to_string();
    for i in 0..200 {
        many.push_str(&format!("\r\nX-{i}: 1"));
    }
    many.push_str("\r\n\r\n");
    let answer = exchange(studio.connect(), many.as_bytes());
    assert_eq!(status(&answer), 431, "{answer}");

    // A body announced over the limit is refused before it is read.
    let huge = format!(
        "POST /api/key HTTP/1.1\r\nHost: {}\r\nX-Keypose-Token: {}\r\n\
         Content-Length: 1000000000\r\n\r\n{{",
        studio.addr, studio.token
    );
    let answer = exchange(studio.connect(), huge.as_bytes());
    assert_eq!(status(&answer), 413, "{answer}");
    assert_eq!(studio.call("GET", "/api/state", "").0, 200);
}

#[test]
fn a_slow_client_is_cut_off_by_the_read_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let studio = start(
        dir.path(),
        Start {
            args: &["new.json"],
            env: &[("KEYPOSE_STUDIO_READ_TIMEOUT_MS", "1000")],
            ..Start::default()
        },
    );
    // A header trickled a byte at a time, forever: each byte comes well within the timeout,
    // the whole request never does.
    let stream = studio.connect();
    let mut writer = stream.try_clone().unwrap();
    let host = studio.addr.clone();
    let trickle = std::thread::spawn(move || {
        let start = format!("GET /api/state HTTP/1.1\r\nHost: {host}\r\nX-Slow: ");
        writer.write_all(start.as_bytes())?;
        loop {
            std::thread::sleep(Duration::from_millis(20));
            writer.write_all(b"a")?;
        }
        #[allow(unreachable_code)]
        Ok::<(), std::io::Error>(())
    });
    let answer = read_answer(stream);
    assert_eq!(status(&answer), 408, "{answer}");
    // The server closed the connection: the trickle's writes fail from then on.
    assert!(trickle.join().unwrap().is_err());
    // A request sent whole is served. (Tried again should this machine be so busy that even
    // it took the whole second, between connecting and sending.)
    let state = studio.state_when_served();
    assert_eq!(state["activity"]["kind"], "idle", "{state}");
}

/// A sequence of two keys twenty seconds apart: the pan from 0° to 60°, a playback that is
/// still moving whenever the test stops it.
fn write_slow_sweep(dir: &Path) {
    let sequence = serde_json::json!({
        "format": "keypose-sequence/1",
        "robot": "so101",
        "interpolation": "cubic",
        "key_interval": 20.0,
        "keyframes": [
            {"joints": {"shoulder_pan": 0}},
            {"joints": {"shoulder_pan": 60}},
        ],
    });
    std::fs::write(dir.join("sweep.json"), sequence.to_string()).unwrap();
}

/// A fault in the server (a panic in a request's thread, or in the thread that accepts
/// connections) mid-playback: the arm is braked along its path, and the studio ends once it
/// is at rest, saying why (exit 3), instead of leaving the arm playing with no page able to
/// reach it.
fn a_server_fault_brakes_the_arm_and_ends_the_studio(fault: &str) {
    let dir = tempfile::tempdir().unwrap();
    write_slow_sweep(dir.path());
    let mut studio = start(
        dir.path(),
        Start {
            args: &["sweep.json"],
            env: &[("KEYPOSE_STUDIO_TEST_FAULT", fault)],
            ..Start::default()
        },
    );
    assert_eq!(studio.call("POST", "/api/control", "{}").0, 200);
    let (code, answer) = studio.call("POST", "/api/key", r#"{"key": "y"}"#);
    assert_eq!(code, 200, "{answer}");
    assert!(
        answer["status"]["text"]
            .as_str()
            .unwrap()
            .contains("playing"),
        "{answer}"
    );
    // The test hook: /api/fault (with the token) panics in its own thread, or makes the
    // accept thread panic on the next connection.
    let answer = exchange(
        studio.connect(),
        studio.request_text("POST", "/api/fault", "{}").as_bytes(),
    );
    if fault == "accept" {
        assert_eq!(status(&answer), 200, "{answer}");
        let _ = TcpStream::connect(&studio.addr);
    } else {
        assert_eq!(answer, "", "the request's thread died without an answer");
    }
    let exit = studio.wait_exit();
    let said = studio.rest_of_stderr();
    assert_eq!(exit.code(), Some(3), "{said}");
    assert!(said.contains("the studio's server failed"), "{said}");
    // Braked along its path: by the fault — or, on a machine so loaded that the player's own
    // stall bound (250 ms) tripped first, by the player, which brakes along the path too.
    assert!(
        said.contains("decelerated along its path")
            || said.contains("braked to rest along the path"),
        "{said}"
    );
    assert!(
        !said.contains(&studio.token),
        "the token was printed:\n{said}"
    );
}

#[test]
fn a_panic_in_a_request_brakes_the_arm_and_ends_the_studio() {
    a_server_fault_brakes_the_arm_and_ends_the_studio("handler");
}

#[test]
fn a_panic_in_the_accept_thread_brakes_the_arm_and_ends_the_studio() {
    a_server_fault_brakes_the_arm_and_ends_the_studio("accept");
}

/// This machine's first IPv4 address that is not a loopback one.
fn non_loopback_address() -> std::net::Ipv4Addr {
    let mut found = None;
    // SAFETY: getifaddrs fills a list that freeifaddrs releases; only its IPv4 entries are
    // read, as sockaddr_in.
    unsafe {
        let mut list: *mut libc::ifaddrs = std::ptr::null_mut();
        assert_eq!(libc::getifaddrs(&mut list), 0, "getifaddrs failed");
        let mut entry = list;
        while !entry.is_null() {
            let addr = (*entry).ifa_addr;
            if !addr.is_null() && i32::from((*addr).sa_family) == libc::AF_INET {
                let v4 = &*(addr as *const libc::sockaddr_in);
                let ip = std::net::Ipv4Addr::from(u32::from_be(v4.sin_addr.s_addr));
                if !ip.is_loopback() && found.is_none() {
                    found = Some(ip);
                }
            }
            entry = (*entry).ifa_next;
        }
        libc::freeifaddrs(list);
    }
    found.expect("this test needs a network interface with an IPv4 address besides loopback")
}

#[test]
fn listening_beyond_loopback_warns_that_the_token_travels_in_clear() {
    let dir = tempfile::tempdir().unwrap();
    let listen = format!("{}:0", non_loopback_address());
    let mut studio = start(
        dir.path(),
        Start {
            args: &["new.json", "--listen", &listen],
            ..Start::default()
        },
    );
    let warning = studio.wait_for_line(|l| l.contains("WARNING"));
    assert!(
        warning.contains("not a loopback address") && warning.contains("in clear"),
        "{warning}"
    );
    // On loopback, no warning.
    let dir = tempfile::tempdir().unwrap();
    let mut local = start(
        dir.path(),
        Start {
            args: &["new.json"],
            ..Start::default()
        },
    );
    local.wait_for_line(|l| l.contains("open the URL above"));
    let said = local.rest_of_stderr_so_far();
    assert!(!said.contains("WARNING"), "{said}");
}

#[test]
fn the_page_tells_the_browser_to_send_no_referrer() {
    let dir = tempfile::tempdir().unwrap();
    let studio = start(
        dir.path(),
        Start {
            args: &["new.json"],
            ..Start::default()
        },
    );
    let answer = exchange(
        studio.connect(),
        studio.request_text("GET", "/", "").as_bytes(),
    );
    assert_eq!(status(&answer), 200);
    assert_eq!(header(&answer, "Referrer-Policy"), Some("no-referrer"));
    // Also in the page itself, for whatever reads it without the headers.
    assert!(
        answer.contains(r#"<meta name="referrer" content="no-referrer">"#),
        "{answer}"
    );
}
