//! A harness script running as a child process, spoken to in JSON lines with timeouts.
//!
//! Knows nothing about what the scripts do (servos, physics) or how the interpreter was found:
//! it gets a [`PyConfig`] to start from and speaks the line protocol of `sim/PROTOCOL.md`.

use super::harness_error::clip;
use super::pipes::{self, Event, StderrTail};
use super::streamed::{describe_status, TAIL_LINES};
use super::{HarnessError, NotReady, PyConfig, PythonEnv, KEEP_BYTECODE};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// Timeouts and environment of a [`Harness`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HarnessOptions {
    /// For the ready line: the script imports its packages first.
    pub ready_timeout: Duration,
    /// For each reply, unless a request says otherwise.
    pub request_timeout: Duration,
    /// Variables set for the child on top of keypose's own (the MuJoCo harness reads
    /// `MUJOCO_GL` when it starts).
    pub env: Vec<(String, String)>,
}

impl Default for HarnessOptions {
    fn default() -> Self {
        HarnessOptions {
            ready_timeout: Duration::from_secs(60),
            request_timeout: Duration::from_secs(10),
            env: Vec::new(),
        }
    }
}

/// A successful reply and the binary payload that followed its line, if it announced one.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    /// The reply object (`"ok": true`).
    pub reply: Value,
    /// The bytes its `"payload"` member counted.
    pub payload: Option<Vec<u8>>,
}

/// A harness script running as a child process, spoken to in JSON lines.
///
/// Each request carries a `seq` number that the script echoes, so that a late reply to a
/// request given up on (timed out) is recognised and dropped instead of being taken for the
/// answer to the next one. The child is stopped when the `Harness` is dropped.
pub struct Harness {
    script: String,
    python: PathBuf,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<Event>,
    stderr: StderrTail,
    stderr_reader: Option<JoinHandle<()>>,
    ready: Value,
    seq: u64,
    request_timeout: Duration,
}

impl fmt::Debug for Harness {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Harness")
            .field("script", &self.script)
            .field("python", &self.python)
            .field("pid", &self.child.id())
            .finish_non_exhaustive()
    }
}

impl Harness {
    /// Starts an embedded script with the environment from the process's variables.
    pub(crate) fn start(name: &str) -> Result<Harness, HarnessError> {
        Harness::start_in(&PyConfig::from_env()?, name, HarnessOptions::default())
    }

    /// Starts an embedded script with the interpreter of `config`, building its environment
    /// first if needed.
    pub fn start_in(
        config: &PyConfig,
        name: &str,
        mut options: HarnessOptions,
    ) -> Result<Harness, HarnessError> {
        let env = config.ensure_python()?;
        let script = config.script_path(name)?;
        if env.venv.is_some() {
            let (name, value) = KEEP_BYTECODE;
            options.env.push((name.into(), value.into()));
        }
        Harness::spawn(&env.python, &script, options).map_err(|error| match error {
            HarnessError::NotReady {
                script,
                reason,
                stderr,
                ..
            } => HarnessError::NotReady {
                hint: not_ready_hint(config, &env),
                script,
                reason,
                stderr,
            },
            other => other,
        })
    }

    /// Starts `python script` and waits for its ready line.
    pub fn spawn(
        python: &Path,
        script: &Path,
        options: HarnessOptions,
    ) -> Result<Harness, HarnessError> {
        let script_name = script
            .file_name()
            .map(|name| name.to_string_lossy().into_owned())
            .unwrap_or_else(|| script.display().to_string());
        let mut child = child_command(python, script, &options)
            .spawn()
            .map_err(|source| HarnessError::Spawn {
                python: python.display().to_string(),
                script: script.display().to_string(),
                source,
            })?;
        let stdin = child.stdin.take();
        let (sender, lines) = mpsc::channel();
        if let Some(stdout) = child.stdout.take() {
            pipes::spawn_stdout_reader(stdout, sender);
        }
        let stderr = StderrTail::default();
        let stderr_reader = child
            .stderr
            .take()
            .map(|pipe| pipes::spawn_stderr_tail(pipe, Arc::clone(&stderr)));
        let mut harness = Harness {
            script: script_name,
            python: python.to_path_buf(),
            child,
            stdin,
            lines,
            stderr,
            stderr_reader,
            ready: Value::Null,
            seq: 0,
            request_timeout: options.request_timeout,
        };
        harness.ready = harness.wait_ready(options.ready_timeout)?;
        Ok(harness)
    }

    fn wait_ready(&mut self, timeout: Duration) -> Result<Value, HarnessError> {
        self.ready_line(timeout)
            .and_then(|line| parse_ready(&line))
            .map_err(|reason| HarnessError::NotReady {
                script: self.script.clone(),
                reason: Box::new(reason),
                hint: String::new(),
                stderr: self.stderr_block(),
            })
    }

    /// The child's first line, or why there is none.
    fn ready_line(&mut self, timeout: Duration) -> Result<String, NotReady> {
        match self.lines.recv_timeout(timeout) {
            Ok(Event::Line(line, _)) => Ok(line),
            Ok(Event::ReadError(error)) => Err(NotReady::Read(error.to_string())),
            Err(RecvTimeoutError::Timeout) => Err(NotReady::Silent {
                seconds: timeout.as_secs_f64(),
            }),
            Err(RecvTimeoutError::Disconnected) => Err(NotReady::Exited {
                status: self.exit_status(),
            }),
        }
    }

    /// The script's ready line (`{"ready": true, …versions}`).
    pub fn ready(&self) -> &Value {
        &self.ready
    }

    /// The interpreter running the script.
    pub fn python(&self) -> &Path {
        &self.python
    }

    /// The child process's id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// The script's file name, for messages.
    pub(crate) fn script(&self) -> &str {
        &self.script
    }

    /// How long each request waits for its reply from now on.
    pub fn set_request_timeout(&mut self, timeout: Duration) {
        self.request_timeout = timeout;
    }

    /// The last lines the script wrote to its stderr.
    pub(crate) fn stderr_tail(&self) -> Vec<String> {
        pipes::tail_lines(&self.stderr)
    }

    /// Sends one request (an object with an `op` member) and waits for its reply, with the
    /// default timeout.
    ///
    /// A reply with `"ok": false` is [`HarnessError::Failed`], carrying the script's message
    /// and the whole reply.
    pub fn request(&mut self, request: &impl Serialize) -> Result<Value, HarnessError> {
        self.request_within(request, self.request_timeout)
    }

    /// Sends one request and waits at most `timeout` for its reply.
    pub fn request_within(
        &mut self,
        request: &impl Serialize,
        timeout: Duration,
    ) -> Result<Value, HarnessError> {
        Ok(self.request_reply(request, timeout)?.reply)
    }

    /// Sends one request and returns its reply with the binary payload that followed it, if
    /// it announced one (`"payload": N`; sim/PROTOCOL.md), with the default timeout.
    pub fn request_with_payload(
        &mut self,
        request: &impl Serialize,
    ) -> Result<Reply, HarnessError> {
        self.request_reply(request, self.request_timeout)
    }

    fn request_reply(
        &mut self,
        request: &impl Serialize,
        timeout: Duration,
    ) -> Result<Reply, HarnessError> {
        self.seq += 1;
        let seq = self.seq;
        let mut request = serde_json::to_value(request).map_err(|error| HarnessError::Request {
            script: self.script.clone(),
            detail: error.to_string(),
        })?;
        let op = Envelope::deserialize(&request)
            .ok()
            .and_then(|envelope| envelope.op)
            .unwrap_or_else(|| "a request".to_string());
        if let Value::Object(fields) = &mut request {
            fields.insert("seq".to_string(), Value::from(seq));
        }
        let Reply { reply, payload } =
            self.exchange(&request.to_string(), &op, Some(seq), timeout)?;
        match Envelope::deserialize(&reply).unwrap_or_default() {
            Envelope { ok: Some(true), .. } => Ok(Reply { reply, payload }),
            Envelope {
                ok: Some(false),
                error,
                ..
            } => Err(HarnessError::Failed {
                script: self.script.clone(),
                op,
                message: error.unwrap_or_else(|| "no message".to_string()),
                reply: Box::new(reply),
            }),
            _ => Err(HarnessError::BadReply {
                script: self.script.clone(),
                detail: "no \"ok\" member".to_string(),
                line: clip(&reply.to_string()),
            }),
        }
    }

    /// Sends `line` exactly as given (no `seq` added) and returns the next reply object as it
    /// is, `"ok": false` included: for diagnostics and for testing how the script takes
    /// malformed input.
    pub fn send_raw_line(&mut self, line: &str) -> Result<Value, HarnessError> {
        let timeout = self.request_timeout;
        Ok(self
            .exchange(line.trim_end(), "a raw line", None, timeout)?
            .reply)
    }

    fn exchange(
        &mut self,
        line: &str,
        op: &str,
        seq: Option<u64>,
        timeout: Duration,
    ) -> Result<Reply, HarnessError> {
        self.send(line)?;
        let deadline = Instant::now() + timeout;
        loop {
            let (line, payload) = self.next_line(op, deadline, timeout)?;
            let reply = self.parse_reply(&line)?;
            let answers = Envelope::deserialize(&reply).unwrap_or_default().seq;
            match (seq, answers) {
                // The late answer to a request that timed out: already given up on.
                (Some(wanted), Some(got)) if got < wanted => continue,
                (Some(wanted), Some(got)) if got > wanted => {
                    return Err(HarnessError::BadReply {
                        script: self.script.clone(),
                        detail: format!("answers request {got}, but {wanted} is the latest"),
                        line: clip(&line),
                    })
                }
                _ => return Ok(Reply { reply, payload }),
            }
        }
    }

    /// The next stdout line before `deadline`, with its payload; `timeout` is the whole wait,
    /// for the message.
    fn next_line(
        &mut self,
        op: &str,
        deadline: Instant,
        timeout: Duration,
    ) -> Result<(String, Option<Vec<u8>>), HarnessError> {
        let left = deadline.saturating_duration_since(Instant::now());
        match self.lines.recv_timeout(left) {
            Ok(Event::Line(line, payload)) => Ok((line, payload)),
            Ok(Event::ReadError(error)) => Err(HarnessError::BadReply {
                script: self.script.clone(),
                detail: format!("reading it failed: {error}"),
                line: String::new(),
            }),
            Err(RecvTimeoutError::Timeout) => Err(HarnessError::Timeout {
                script: self.script.clone(),
                op: op.to_string(),
                waited_ms: timeout.as_millis().try_into().unwrap_or(u64::MAX),
            }),
            Err(RecvTimeoutError::Disconnected) => Err(self.exited()),
        }
    }

    /// A reply line as a JSON object.
    fn parse_reply(&self, line: &str) -> Result<Value, HarnessError> {
        let reply: Value = serde_json::from_str(line).map_err(|error| HarnessError::BadReply {
            script: self.script.clone(),
            detail: format!("not JSON: {error}"),
            line: clip(line),
        })?;
        if !reply.is_object() {
            return Err(HarnessError::BadReply {
                script: self.script.clone(),
                detail: "not a JSON object".to_string(),
                line: clip(line),
            });
        }
        Ok(reply)
    }

    fn send(&mut self, line: &str) -> Result<(), HarnessError> {
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(self.exited());
        };
        let written = stdin
            .write_all(line.as_bytes())
            .and_then(|()| stdin.write_all(b"\n"))
            .and_then(|()| stdin.flush());
        match written {
            Ok(()) => Ok(()),
            Err(error) if error.kind() == io::ErrorKind::BrokenPipe => Err(self.exited()),
            Err(source) => Err(HarnessError::Write {
                script: self.script.clone(),
                source,
            }),
        }
    }

    fn exited(&mut self) -> HarnessError {
        let status = self.exit_status();
        HarnessError::Exited {
            script: self.script.clone(),
            status,
            stderr: self.stderr_block(),
        }
    }

    /// The child's exit status, waiting a moment for it: its stdout closes just before it
    /// exits.
    fn exit_status(&mut self) -> String {
        let deadline = Instant::now() + Duration::from_secs(2);
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return describe_status(status),
                Ok(None) if Instant::now() < deadline => thread::sleep(Duration::from_millis(10)),
                Ok(None) => return "still running, with its output closed".to_string(),
                Err(error) => return format!("status unknown: {error}"),
            }
        }
    }

    /// The stderr tail as lines of their own under a heading, or nothing.
    fn stderr_block(&mut self) -> String {
        // The reader may still be draining the pipe of a child that just exited.
        if let Some(reader) = &self.stderr_reader {
            let deadline = Instant::now() + Duration::from_millis(500);
            while !reader.is_finished() && Instant::now() < deadline {
                thread::sleep(Duration::from_millis(5));
            }
        }
        let lines = self.stderr_tail();
        let lines = &lines[lines.len().saturating_sub(TAIL_LINES)..];
        if lines.is_empty() {
            String::new()
        } else {
            format!(
                "; its stderr ends with:{}",
                crate::terminal_text::quoted_lines(lines.iter().map(String::as_str))
            )
        }
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        // End of input asks the script to close its port and exit; kill only if it does not.
        drop(self.stdin.take());
        let deadline = Instant::now() + Duration::from_millis(500);
        loop {
            match self.child.try_wait() {
                Ok(Some(_)) => return,
                Ok(None) if Instant::now() < deadline => thread::sleep(Duration::from_millis(5)),
                _ => break,
            }
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `python script` with piped standard streams, unbuffered UTF-8 output and `options.env`.
fn child_command(python: &Path, script: &Path, options: &HarnessOptions) -> Command {
    let mut command = Command::new(python);
    command
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .env("PYTHONUNBUFFERED", "1")
        .env("PYTHONIOENCODING", "utf-8")
        .envs(options.env.iter().map(|(name, value)| (name, value)));
    #[cfg(unix)]
    {
        // Its own process group: Ctrl-C in the terminal then reaches keypose only, which
        // may still need the script (to hold or release the arm) while it stops.
        use std::os::unix::process::CommandExt;
        command.process_group(0);
    }
    command
}

/// The members every line of the protocol (sim/PROTOCOL.md) may carry, whatever the script:
/// a request's `op`, a reply's `ok`, `error` and echoed `seq`, the first line's `ready`. A
/// member of another type counts as missing.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
struct Envelope {
    #[serde(deserialize_with = "lenient")]
    op: Option<String>,
    #[serde(deserialize_with = "lenient")]
    ok: Option<bool>,
    #[serde(deserialize_with = "lenient")]
    ready: Option<bool>,
    #[serde(deserialize_with = "lenient")]
    error: Option<String>,
    #[serde(deserialize_with = "lenient")]
    seq: Option<u64>,
}

/// A member as `T`, or `None` when it is of another type.
fn lenient<'de, D, T>(deserializer: D) -> Result<Option<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: serde::de::DeserializeOwned,
{
    let value = Value::deserialize(deserializer)?;
    Ok(T::deserialize(value).ok())
}

/// The ready line (`{"ready": true, …}`), or why `line` is not one.
fn parse_ready(line: &str) -> Result<Value, NotReady> {
    let ready: Value = serde_json::from_str(line).map_err(|error| NotReady::NotJson {
        error: error.to_string(),
        line: clip(line),
    })?;
    match Envelope::deserialize(&ready).unwrap_or_default() {
        Envelope {
            ready: Some(true), ..
        } => Ok(ready),
        Envelope {
            ready: Some(false),
            error,
            ..
        } => Err(NotReady::Refused(
            error.unwrap_or_else(|| "it says it is not ready".to_string()),
        )),
        _ => Err(NotReady::NoReadyLine { line: clip(line) }),
    }
}

fn not_ready_hint(config: &PyConfig, env: &PythonEnv) -> String {
    match (&config.python_override, &env.venv) {
        (Some(python), _) => {
            let requirements = config
                .requirements_path()
                .map(|path| path.display().to_string())
                .unwrap_or_else(|_| "sim/requirements.txt".to_string());
            format!(
                "; KEYPOSE_PYTHON={} lacks it: run `{} -m pip install -r {}`, or unset \
                 KEYPOSE_PYTHON to let keypose build its own environment",
                python.display(),
                env.python.display(),
                requirements
            )
        }
        (None, Some(venv)) => format!(
            "; keypose's environment {} seems damaged: delete that directory and keypose \
             rebuilds it on the next run",
            venv.display()
        ),
        (None, None) => String::new(),
    }
}
