//! What the command-line tests share: the binary, paths in the repository, a `keypose
//! virtual-bus` process.
#![allow(dead_code)] // Each test file uses its own part of this.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};

/// The built-in SO-101's joints in chain order (servo ids 1 … 6).
pub const SO101_JOINTS: [&str; 6] = [
    "shoulder_pan",
    "shoulder_lift",
    "elbow_flex",
    "wrist_flex",
    "wrist_roll",
    "gripper",
];

pub fn keypose() -> Command {
    Command::new(env!("CARGO_BIN_EXE_keypose"))
}

/// `play`'s stall bound for tests about something else than stalls. On a loaded machine (CI
/// beside busy loops) a process is kept off the CPU for over a second now and then, which the
/// default 250 ms bound rightly calls a fault; stalls have their own tests, on virtual clocks
/// (servos/player_stalls.rs) and by SIGSTOP (servos/play.rs).
pub const TOLERATED_STALL: [&str; 2] = ["--max-stall", "10000"];

/// Runs `keypose play ARGS` to the end with [`TOLERATED_STALL`].
pub fn play_patiently(args: &[&str]) -> Output {
    keypose()
        .arg("play")
        .args(args)
        .args(TOLERATED_STALL)
        .output()
        .expect("run keypose")
}

/// Options for a MuJoCo harness started by a test: the product's 10 s wait for a reply is
/// meant for an interactive user; a render beside busy loops on a 2-core machine takes longer,
/// and a test is about the reply, not how soon it comes.
pub fn patient_harness() -> keypose::python::HarnessOptions {
    keypose::python::HarnessOptions {
        request_timeout: std::time::Duration::from_secs(300),
        ..keypose::python::HarnessOptions::default()
    }
}

/// Runs `keypose ARGS` to the end.
pub fn run(args: &[&str]) -> Output {
    keypose().args(args).output().expect("run keypose")
}

/// The Python environment every suite shares (MuJoCo, the vendor SDKs, pyarrow), under
/// target/: built once, on first use, by whichever test needs it first. keypose builds it under a
/// private name and renames it into place, so tests racing to build it are safe.
pub fn python_cache() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("python_cache")
}

/// Runs `keypose ARGS` to the end with the simulation suites' Python environment.
pub fn run_sim(args: &[&str]) -> Output {
    keypose()
        .args(args)
        .env("KEYPOSE_CACHE", python_cache())
        .output()
        .expect("run keypose")
}

/// Width and height from a PNG's IHDR chunk.
pub fn png_size(path: &std::path::Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let be =
        |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    (be(16), be(20))
}

/// A path inside the repository.
pub fn repo(path: &str) -> String {
    format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// The example sequences (`sequences/*.json`), sorted by name.
pub fn examples() -> Vec<std::path::PathBuf> {
    let mut out: Vec<_> = std::fs::read_dir(repo("sequences"))
        .expect("sequences/")
        .map(|e| e.expect("an entry of sequences/").path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    out.sort();
    out
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Exit code and both streams, for an assertion message.
pub fn show(out: &Output) -> String {
    format!(
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        stdout(out),
        stderr(out)
    )
}

/// A `keypose virtual-bus` process and the device path it printed.
pub struct VirtualBusProcess {
    pub child: Child,
    pub path: String,
}

impl VirtualBusProcess {
    pub fn start(args: &[&str]) -> VirtualBusProcess {
        let mut child = keypose()
            .arg("virtual-bus")
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("start keypose virtual-bus");
        let stdout = child.stdout.take().expect("stdout");
        let mut path = String::new();
        BufReader::new(stdout)
            .read_line(&mut path)
            .expect("read the device path");
        let path = path.trim().to_string();
        assert!(
            path.starts_with("/dev/"),
            "first line is not a device path: {path:?}"
        );
        VirtualBusProcess { child, path }
    }
}

impl Drop for VirtualBusProcess {
    fn drop(&mut self) {
        // Closing standard input ends the server.
        drop(self.child.stdin.take());
        let _ = self.child.wait();
    }
}

/// A small deterministic generator (xorshift), so a failure can be replayed.
pub struct Seeded(pub u64);

impl Seeded {
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [low, high).
    pub fn between(&mut self, low: f64, high: f64) -> f64 {
        low + self.unit() * (high - low)
    }
}

/// `--robot-variant 12v` for a sequence of an SO-101 or SO-100 (or a cell of them), nothing for
/// another arm. The standard build (7.4 V servos on 5 V, kp 6 N·m/rad at LeRobot's gain) sags
/// 4–6° under the arm's weight at its home pose, more than `sim`'s 3° settling tolerance: a
/// test that needs a sequence to pass in physics simulates the 12 V build, whose stiffer
/// servos hold the arm within it (tests/simulation/cli.rs measures the 5 V sag against the
/// check's prediction).
pub fn passing_build(sequence: &str) -> Vec<&'static str> {
    let text = std::fs::read_to_string(sequence).unwrap_or_default();
    if text.contains("\"so101\"") || text.contains("\"so100\"") {
        vec!["--robot-variant", "12v"]
    } else {
        Vec::new()
    }
}
