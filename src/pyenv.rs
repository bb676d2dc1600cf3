//! The Python side's environment and its long-lived scripts.
//!
//! keypose runs its Python helpers (`sim/*.py`: the vendor-SDK bridge, the MuJoCo harness)
//! with:
//! - `KEYPOSE_PYTHON`, an interpreter that must already have the packages of
//!   `sim/requirements.txt`; keypose installs nothing into it;
//! - otherwise a virtual environment that keypose builds once in its cache directory
//!   (`$KEYPOSE_CACHE`, else `$XDG_CACHE_HOME/keypose`, else `~/.cache/keypose`) from the
//!   requirements embedded in the binary. Its directory name carries a hash of the
//!   requirements text, so a changed pin builds a new environment beside the old one.
//!
//! The scripts are embedded too and written to `<cache>/sim/` when used, so the binary works
//! from any directory and always runs the scripts it was built with.
//!
//! A [`Harness`] is one such script running as a child process, spoken to in JSON lines: its
//! first line says it is ready (with the versions it runs), then one request line gets one
//! reply line.

use crate::atomic_file;
use serde_json::{Map, Value};
use std::collections::VecDeque;
use std::ffi::OsString;
use std::fmt;
use std::fs;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant, SystemTime};

/// The pinned requirements the environment is built from (`sim/requirements.txt`).
pub const REQUIREMENTS: &str = include_str!("../sim/requirements.txt");

/// The harness scripts, by file name, as embedded in the binary.
const SCRIPTS: &[(&str, &str)] = &[
    ("sdk_bridge.py", include_str!("../sim/sdk_bridge.py")),
    ("sim_harness.py", include_str!("../sim/sim_harness.py")),
];

/// Modules the harness scripts import, written beside them.
const SUPPORT: &[(&str, &str)] = &[("harness_io.py", include_str!("../sim/harness_io.py"))];

/// The oldest Python the scripts and their packages are used with: MuJoCo 4 needs 3.11.
pub const MIN_PYTHON: (u32, u32) = (3, 11);

/// Written into a finished environment; an environment without it is not used.
const MARKER: &str = "keypose-env.json";

/// Temporary environments older than this are leftovers of a killed build.
const STALE_BUILD: Duration = Duration::from_secs(6 * 3600);

/// How many lines of a failed command's output an error shows.
const TAIL_LINES: usize = 25;

/// How many lines of a harness's stderr are kept to explain its failure.
const STDERR_LINES: usize = 200;

#[derive(Debug, thiserror::Error)]
pub enum PyEnvError {
    #[error(
        "no cache directory for keypose's Python environment: set KEYPOSE_CACHE (or \
         XDG_CACHE_HOME or HOME), or set KEYPOSE_PYTHON to an interpreter that has the \
         packages of sim/requirements.txt"
    )]
    NoCacheDir,
    #[error(
        "KEYPOSE_PYTHON={0} is not an existing file: point it at a Python {min}+ interpreter \
         that has the packages of sim/requirements.txt, or unset it to let keypose build its \
         own environment",
        min = min_python()
    )]
    OverrideMissing(String),
    #[error(
        "python3 not found (tried {tried}): install Python {min}+ with its venv module \
         (Debian/Ubuntu: apt install python3 python3-venv), or set KEYPOSE_PYTHON to an \
         interpreter that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonNotFound { tried: String },
    #[error(
        "{python} is Python {version}, keypose needs {min}+: install a newer Python, or set \
         KEYPOSE_PYTHON to one that has the packages of sim/requirements.txt",
        min = min_python()
    )]
    PythonTooOld { python: String, version: String },
    #[error("{python} does not work: {detail}")]
    PythonBroken { python: String, detail: String },
    #[error("{action} {path}: {source}")]
    Io {
        action: &'static str,
        path: PathBuf,
        source: io::Error,
    },
    #[error(
        "creating a virtual environment with `{python} -m venv` failed ({status}); on \
         Debian/Ubuntu install python3-venv, or set KEYPOSE_PYTHON to an interpreter that has \
         the packages of sim/requirements.txt. Its last output:\n{tail}"
    )]
    Venv {
        python: String,
        status: String,
        tail: String,
    },
    #[error(
        "installing the Python packages of sim/requirements.txt into {venv} failed ({status}); \
         check access to PyPI (pip honours PIP_INDEX_URL and its config files), or set \
         KEYPOSE_PYTHON to an interpreter that has them. pip's last output:\n{tail}"
    )]
    Pip {
        venv: PathBuf,
        status: String,
        tail: String,
    },
    #[error("no harness script named {name:?} is built into keypose (known: {known})")]
    UnknownScript { name: String, known: String },
}

fn min_python() -> String {
    format!("{}.{}", MIN_PYTHON.0, MIN_PYTHON.1)
}

#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    #[error(transparent)]
    Env(#[from] PyEnvError),
    #[error("cannot start {python} {script}: {source}")]
    Spawn {
        python: String,
        script: String,
        source: io::Error,
    },
    #[error("{script} did not start: {reason}{hint}{stderr}")]
    NotReady {
        script: String,
        reason: String,
        /// Empty, or a sentence that starts with "; ".
        hint: String,
        /// Empty, or the child's last stderr lines on lines of their own.
        stderr: String,
    },
    #[error("{script} exited ({status}){stderr}")]
    Exited {
        script: String,
        status: String,
        stderr: String,
    },
    #[error("{script} did not answer {op} within {waited_ms} ms")]
    Timeout {
        script: String,
        op: String,
        waited_ms: u64,
    },
    #[error("{script}: {op} failed: {message}")]
    Failed {
        script: String,
        op: String,
        message: String,
        /// The whole reply, for callers that map its fields (error kinds, codes) further.
        reply: Box<Value>,
    },
    #[error("{script} sent a line that is not a reply ({detail}): {line}")]
    BadReply {
        script: String,
        detail: String,
        line: String,
    },
    #[error("writing a request to {script}: {source}")]
    Write { script: String, source: io::Error },
}

impl HarnessError {
    /// The reply of a request that the script answered with `"ok": false`.
    pub fn reply(&self) -> Option<&Value> {
        match self {
            HarnessError::Failed { reply, .. } => Some(reply),
            _ => None,
        }
    }
}

/// Where keypose's Python side lives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PyConfig {
    /// `KEYPOSE_PYTHON`: an interpreter that already has the packages; no environment is built.
    pub python_override: Option<PathBuf>,
    /// keypose's cache directory: the environment and the written-out scripts live here.
    pub cache_dir: PathBuf,
}

/// An interpreter ready to run the harness scripts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PythonEnv {
    pub python: PathBuf,
    /// keypose's own virtual environment; `None` when `KEYPOSE_PYTHON` is used.
    pub venv: Option<PathBuf>,
    /// Whether this call ran pip to build the environment.
    pub created: bool,
}

/// The stable key of a requirements text: FNV-1a 64, in hex.
///
/// `std`'s hashers may change between Rust releases, which would rebuild every user's
/// environment on a toolchain update; FNV-1a is fixed forever.
pub fn env_key(requirements: &str) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in requirements.as_bytes() {
        hash ^= u64::from(*byte);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{hash:016x}")
}

/// The `name==version` pins of [`REQUIREMENTS`], in file order.
pub fn pinned_versions() -> Vec<(&'static str, &'static str)> {
    parse_pins(REQUIREMENTS)
}

fn parse_pins(text: &str) -> Vec<(&str, &str)> {
    text.lines()
        .map(|line| line.split('#').next().unwrap_or("").trim())
        .filter_map(|line| {
            let (name, version) = line.split_once("==")?;
            let version = version.split(';').next().unwrap_or("").trim();
            Some((name.trim(), version))
        })
        .collect()
}

/// The file names of the embedded harness scripts.
pub fn script_names() -> Vec<&'static str> {
    SCRIPTS.iter().map(|(name, _)| *name).collect()
}

/// The interpreter for the harness scripts, building keypose's environment first if needed.
pub fn python_for_harness() -> Result<PathBuf, PyEnvError> {
    Ok(PyConfig::from_env()?.ensure_python()?.python)
}

/// The path of an embedded harness script, written to the cache directory if it is not there
/// with the embedded content.
pub fn script_path(name: &str) -> Result<PathBuf, PyEnvError> {
    PyConfig::from_env()?.script_path(name)
}

/// Serialises environment builds inside one process; other processes are handled by building
/// in a private directory and renaming it into place.
static BUILD_LOCK: Mutex<()> = Mutex::new(());

impl PyConfig {
    /// The configuration from `KEYPOSE_PYTHON`, `KEYPOSE_CACHE`, `XDG_CACHE_HOME` and `HOME`.
    pub fn from_env() -> Result<PyConfig, PyEnvError> {
        PyConfig::from_lookup(|name| std::env::var_os(name))
    }

    /// The configuration from variables looked up by `get` (the environment, or a test's map).
    pub fn from_lookup(get: impl Fn(&str) -> Option<OsString>) -> Result<PyConfig, PyEnvError> {
        let var = |name: &str| get(name).filter(|value| !value.is_empty());
        let cache_dir = if let Some(dir) = var("KEYPOSE_CACHE") {
            PathBuf::from(dir)
        } else if let Some(xdg) = var("XDG_CACHE_HOME")
            .map(PathBuf::from)
            // The XDG spec says a relative path there is invalid and must be ignored.
            .filter(|path| path.is_absolute())
        {
            xdg.join("keypose")
        } else if let Some(home) = var("HOME") {
            PathBuf::from(home).join(".cache").join("keypose")
        } else if let Some(local) = var("LOCALAPPDATA") {
            PathBuf::from(local).join("keypose")
        } else {
            return Err(PyEnvError::NoCacheDir);
        };
        Ok(PyConfig {
            python_override: var("KEYPOSE_PYTHON").map(PathBuf::from),
            cache_dir,
        })
    }

    /// keypose's own environment in `cache_dir`, ignoring `KEYPOSE_PYTHON`.
    pub fn with_cache_dir(cache_dir: impl Into<PathBuf>) -> PyConfig {
        PyConfig {
            python_override: None,
            cache_dir: cache_dir.into(),
        }
    }

    /// Where keypose's environment for the embedded requirements lives (built or not).
    pub fn venv_dir(&self) -> PathBuf {
        self.cache_dir
            .join(format!("venv-{}", env_key(REQUIREMENTS)))
    }

    /// Where the embedded scripts are written.
    pub fn sim_dir(&self) -> PathBuf {
        self.cache_dir.join("sim")
    }

    /// The path of an embedded script, written out when missing or different.
    pub fn script_path(&self, name: &str) -> Result<PathBuf, PyEnvError> {
        let content = SCRIPTS
            .iter()
            .find(|(script, _)| *script == name)
            .map(|(_, content)| *content)
            .ok_or_else(|| PyEnvError::UnknownScript {
                name: name.to_string(),
                known: script_names().join(", "),
            })?;
        // The modules first: a script never starts without what it imports.
        for (module, text) in SUPPORT {
            self.write_embedded(module, text)?;
        }
        self.write_embedded(name, content)
    }

    /// The embedded requirements written out, for a `pip install -r` by hand.
    pub fn requirements_path(&self) -> Result<PathBuf, PyEnvError> {
        self.write_embedded("requirements.txt", REQUIREMENTS)
    }

    fn write_embedded(&self, name: &str, content: &str) -> Result<PathBuf, PyEnvError> {
        let dir = self.sim_dir();
        let path = dir.join(name);
        if fs::read(&path).is_ok_and(|on_disk| on_disk == content.as_bytes()) {
            return Ok(path);
        }
        atomic_file::create_private_dir(&dir).map_err(io_error("creating", &dir))?;
        // Atomic, so that a process starting the script meanwhile never sees half a file.
        atomic_file::write(&path, content.as_bytes()).map_err(io_error("writing", &path))?;
        Ok(path)
    }

    /// The interpreter to use if it is there now, without building anything.
    pub fn find_python(&self) -> Result<Option<PythonEnv>, PyEnvError> {
        if let Some(python) = &self.python_override {
            return resolve_override(python).map(|python| {
                Some(PythonEnv {
                    python,
                    venv: None,
                    created: false,
                })
            });
        }
        let venv = self.venv_dir();
        Ok(env_is_ready(&venv).then(|| PythonEnv {
            python: venv_python(&venv),
            venv: Some(venv),
            created: false,
        }))
    }

    /// The interpreter to use, building keypose's environment first when it is not there.
    ///
    /// Progress (pip's own output, prefixed) goes to stderr; a build happens once per
    /// requirements text.
    pub fn ensure_python(&self) -> Result<PythonEnv, PyEnvError> {
        if let Some(found) = self.find_python()? {
            return Ok(found);
        }
        let _guard = BUILD_LOCK
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // Another thread may have finished the build while this one waited for the lock.
        if let Some(found) = self.find_python()? {
            return Ok(found);
        }
        self.build_env()
    }

    fn build_env(&self) -> Result<PythonEnv, PyEnvError> {
        let venv = self.venv_dir();
        let key = env_key(REQUIREMENTS);
        atomic_file::create_private_dir(&self.cache_dir)
            .map_err(io_error("creating", &self.cache_dir))?;
        remove_stale_builds(&self.cache_dir, &key);
        if venv.exists() {
            // There, but without its marker or with its interpreter gone (a Python upgrade
            // removes the one a venv links to): rebuild rather than fail later on an import.
            let trash = self
                .cache_dir
                .join(format!("venv-{key}.broken-{}", unique_suffix()));
            fs::rename(&venv, &trash).map_err(io_error("moving aside", &venv))?;
            if env_is_ready(&trash) {
                // Another keypose renamed its finished build into place after this one
                // looked: put it back and use it.
                fs::rename(&trash, &venv).map_err(io_error("restoring", &venv))?;
                return Ok(PythonEnv {
                    python: venv_python(&venv),
                    venv: Some(venv),
                    created: false,
                });
            }
            eprintln!(
                "keypose: the Python environment {} is incomplete; rebuilding it",
                venv.display()
            );
            let _ = fs::remove_dir_all(&trash);
        }

        let base = find_base_python()?;
        eprintln!(
            "keypose: building the Python environment for the harness scripts in {} \
             (once: later runs reuse it)",
            venv.display()
        );
        eprintln!(
            "keypose: with {} (Python {})",
            base.executable, base.version
        );
        // Built under a private name and renamed into place only when complete, so a process
        // that races this one, or one killed half-way, never leaves a half-built environment
        // under the real name. Only `bin/python` is ever run from it, and a venv's interpreter
        // finds its site-packages relative to itself, so the rename does not break it.
        let building = self
            .cache_dir
            .join(format!("venv-{key}.tmp-{}", unique_suffix()));
        let result = build_into(&base, &building, &key);
        if let Err(error) = result {
            let _ = fs::remove_dir_all(&building);
            return Err(error);
        }
        if let Err(rename_error) = fs::rename(&building, &venv) {
            let _ = fs::remove_dir_all(&building);
            if env_is_ready(&venv) {
                eprintln!("keypose: another keypose finished the environment first; using it");
            } else {
                return Err(PyEnvError::Io {
                    action: "moving the new environment to",
                    path: venv,
                    source: rename_error,
                });
            }
        } else {
            eprintln!("keypose: Python environment ready: {}", venv.display());
        }
        Ok(PythonEnv {
            python: venv_python(&venv),
            venv: Some(venv),
            created: true,
        })
    }
}

fn io_error<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(io::Error) -> PyEnvError + 'a {
    move |source| PyEnvError::Io {
        action,
        path: path.to_path_buf(),
        source,
    }
}

fn unique_suffix() -> String {
    let nanos = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    format!("{}-{nanos}", std::process::id())
}

fn venv_python(venv: &Path) -> PathBuf {
    if cfg!(windows) {
        venv.join("Scripts").join("python.exe")
    } else {
        venv.join("bin").join("python")
    }
}

fn env_is_ready(venv: &Path) -> bool {
    // `is_file` follows the interpreter's symlink, so a venv whose base Python was removed
    // counts as not ready.
    venv.join(MARKER).is_file() && venv_python(venv).is_file()
}

fn remove_stale_builds(cache_dir: &Path, key: &str) {
    let Ok(entries) = fs::read_dir(cache_dir) else {
        return;
    };
    let prefixes = [format!("venv-{key}.tmp-"), format!("venv-{key}.broken-")];
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !prefixes
            .iter()
            .any(|prefix| name.starts_with(prefix.as_str()))
        {
            continue;
        }
        let old = entry
            .metadata()
            .and_then(|meta| meta.modified())
            .ok()
            .and_then(|modified| modified.elapsed().ok())
            .is_some_and(|age| age > STALE_BUILD);
        if old {
            let _ = fs::remove_dir_all(entry.path());
        }
    }
}

fn resolve_override(python: &Path) -> Result<PathBuf, PyEnvError> {
    let shown = python.display().to_string();
    // A bare name ("python3.11") is looked up on PATH, as a shell would.
    let bare = python.components().count() == 1 && !python.is_absolute();
    if bare && !python.exists() {
        if let Some(found) = search_path(python.as_os_str()) {
            return Ok(found);
        }
    }
    if python.is_file() {
        Ok(python.to_path_buf())
    } else {
        Err(PyEnvError::OverrideMissing(shown))
    }
}

fn search_path(name: &std::ffi::OsStr) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| candidate.is_file())
}

struct BasePython {
    executable: String,
    version: String,
}

/// Prints the interpreter's real path (not a pyenv shim's) and version, and fails without the
/// venv module.
const PROBE: &str = "import sys, venv; print(sys.executable); \
                     print('%d.%d.%d' % sys.version_info[:3])";

fn find_base_python() -> Result<BasePython, PyEnvError> {
    // `python3` first, as users expect; the versioned names rescue systems whose default
    // python3 is older than MIN_PYTHON but that have a newer one installed beside it.
    let candidates = [
        "python3",
        "python",
        "python3.14",
        "python3.13",
        "python3.12",
        "python3.11",
        "python3.10",
    ];
    let mut first_problem: Option<PyEnvError> = None;
    for candidate in candidates {
        let output = match Command::new(candidate)
            .args(["-c", PROBE])
            .stdin(Stdio::null())
            .output()
        {
            Ok(output) => output,
            Err(error) if error.kind() == io::ErrorKind::NotFound => continue,
            Err(error) => {
                first_problem.get_or_insert(PyEnvError::PythonBroken {
                    python: candidate.to_string(),
                    detail: error.to_string(),
                });
                continue;
            }
        };
        if !output.status.success() {
            let detail = last_lines(&String::from_utf8_lossy(&output.stderr), 5);
            first_problem.get_or_insert(PyEnvError::PythonBroken {
                python: candidate.to_string(),
                detail: if detail.contains("venv") {
                    format!("{detail} (Debian/Ubuntu: apt install python3-venv)")
                } else {
                    detail
                },
            });
            continue;
        }
        let stdout = String::from_utf8_lossy(&output.stdout);
        let mut lines = stdout.lines();
        let executable = lines.next().unwrap_or(candidate).trim().to_string();
        let version = lines.next().unwrap_or("").trim().to_string();
        if version_at_least(&version, MIN_PYTHON) {
            return Ok(BasePython {
                executable: if executable.is_empty() {
                    candidate.to_string()
                } else {
                    executable
                },
                version,
            });
        }
        first_problem.get_or_insert(PyEnvError::PythonTooOld {
            python: candidate.to_string(),
            version,
        });
    }
    Err(first_problem.unwrap_or_else(|| PyEnvError::PythonNotFound {
        tried: candidates.join(", "),
    }))
}

fn version_at_least(version: &str, (major, minor): (u32, u32)) -> bool {
    let mut parts = version.split('.').map(|part| part.parse::<u32>().ok());
    match (parts.next().flatten(), parts.next().flatten()) {
        (Some(have_major), Some(have_minor)) => (have_major, have_minor) >= (major, minor),
        _ => false,
    }
}

fn build_into(base: &BasePython, building: &Path, key: &str) -> Result<(), PyEnvError> {
    let mut venv_cmd = Command::new(&base.executable);
    venv_cmd.arg("-m").arg("venv").arg(building);
    run_streamed(&mut venv_cmd, "  venv: ").map_err(|failure| match failure {
        StreamFailure::Spawn(source) => PyEnvError::PythonBroken {
            python: base.executable.clone(),
            detail: source.to_string(),
        },
        StreamFailure::Status { status, tail } => PyEnvError::Venv {
            python: base.executable.clone(),
            status,
            tail,
        },
    })?;

    // The requirements go inside the environment: pip reads them from there, and they record
    // what the environment was built from.
    let requirements = building.join("keypose-requirements.txt");
    atomic_file::write(&requirements, REQUIREMENTS.as_bytes())
        .map_err(io_error("writing", &requirements))?;
    let python = venv_python(building);
    let mut pip = Command::new(&python);
    // --no-compile: compiled files would name the temporary directory in their tracebacks;
    // Python compiles on first import instead, under the final name.
    let options = ["--no-input", "--progress-bar", "off", "--no-compile"];
    pip.args(["-m", "pip", "install"])
        .args(options)
        .arg("-r")
        .arg(&requirements)
        .env("PIP_DISABLE_PIP_VERSION_CHECK", "1")
        .env("PYTHONUNBUFFERED", "1");
    run_streamed(&mut pip, "  pip: ").map_err(|failure| match failure {
        StreamFailure::Spawn(source) => PyEnvError::PythonBroken {
            python: python.display().to_string(),
            detail: source.to_string(),
        },
        StreamFailure::Status { status, tail } => PyEnvError::Pip {
            venv: building.to_path_buf(),
            status,
            tail,
        },
    })?;

    let marker = building.join(MARKER);
    let record = serde_json::json!({
        "requirements_key": key,
        "base_python": base.executable,
        "python_version": base.version,
        "built_by": format!("keypose {}", env!("CARGO_PKG_VERSION")),
    });
    atomic_file::write(&marker, format!("{record:#}\n").as_bytes())
        .map_err(io_error("writing", &marker))
}

enum StreamFailure {
    Spawn(io::Error),
    Status { status: String, tail: String },
}

/// Runs a command, echoing its stdout and stderr lines to our stderr with a prefix, and keeps
/// the last lines to explain a failure.
fn run_streamed(command: &mut Command, prefix: &str) -> Result<(), StreamFailure> {
    let mut child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(StreamFailure::Spawn)?;
    let (sender, lines) = mpsc::channel::<String>();
    let mut readers = Vec::new();
    if let Some(stdout) = child.stdout.take() {
        readers.push(spawn_line_reader(stdout, sender.clone()));
    }
    if let Some(stderr) = child.stderr.take() {
        readers.push(spawn_line_reader(stderr, sender.clone()));
    }
    drop(sender);
    let mut tail: VecDeque<String> = VecDeque::new();
    // Printed from this thread, so that a test harness capturing this thread's output sees it.
    for line in lines {
        eprintln!("{prefix}{line}");
        if tail.len() == TAIL_LINES {
            tail.pop_front();
        }
        tail.push_back(line);
    }
    for reader in readers {
        let _ = reader.join();
    }
    let status = child.wait().map_err(StreamFailure::Spawn)?;
    if status.success() {
        Ok(())
    } else {
        Err(StreamFailure::Status {
            status: describe_status(status),
            tail: tail.into_iter().collect::<Vec<_>>().join("\n"),
        })
    }
}

fn spawn_line_reader(
    stream: impl Read + Send + 'static,
    sender: mpsc::Sender<String>,
) -> JoinHandle<()> {
    thread::spawn(move || {
        let mut reader = BufReader::new(stream);
        let mut buffer = Vec::new();
        loop {
            buffer.clear();
            match reader.read_until(b'\n', &mut buffer) {
                Ok(0) | Err(_) => break,
                Ok(_) => {
                    let line = String::from_utf8_lossy(&buffer).trim_end().to_string();
                    if sender.send(line).is_err() {
                        break;
                    }
                }
            }
        }
    })
}

fn describe_status(status: ExitStatus) -> String {
    match status.code() {
        Some(code) => format!("exit code {code}"),
        None => format!("{status}"),
    }
}

fn last_lines(text: &str, count: usize) -> String {
    let lines: Vec<&str> = text
        .lines()
        .filter(|line| !line.trim().is_empty())
        .collect();
    lines[lines.len().saturating_sub(count)..].join("\n")
}

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

enum Event {
    Line(String),
    ReadError(io::Error),
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
    stderr: Arc<Mutex<VecDeque<String>>>,
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
    pub fn start(name: &str) -> Result<Harness, HarnessError> {
        Harness::start_in(&PyConfig::from_env()?, name, HarnessOptions::default())
    }

    /// Starts an embedded script with the interpreter of `config`, building its environment
    /// first if needed.
    pub fn start_in(
        config: &PyConfig,
        name: &str,
        options: HarnessOptions,
    ) -> Result<Harness, HarnessError> {
        let env = config.ensure_python()?;
        let script = config.script_path(name)?;
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
        let mut child = command.spawn().map_err(|source| HarnessError::Spawn {
            python: python.display().to_string(),
            script: script.display().to_string(),
            source,
        })?;
        let stdin = child.stdin.take();
        let (sender, lines) = mpsc::channel();
        if let Some(stdout) = child.stdout.take() {
            thread::spawn(move || {
                let mut reader = BufReader::new(stdout);
                let mut buffer = Vec::new();
                loop {
                    buffer.clear();
                    let event = match reader.read_until(b'\n', &mut buffer) {
                        Ok(0) => break,
                        Ok(_) => {
                            Event::Line(String::from_utf8_lossy(&buffer).trim_end().to_string())
                        }
                        Err(error) => Event::ReadError(error),
                    };
                    let stop = matches!(event, Event::ReadError(_));
                    if sender.send(event).is_err() || stop {
                        break;
                    }
                }
            });
        }
        let stderr = Arc::new(Mutex::new(VecDeque::new()));
        let stderr_reader = child.stderr.take().map(|pipe| {
            let kept = Arc::clone(&stderr);
            thread::spawn(move || {
                let mut reader = BufReader::new(pipe);
                let mut buffer = Vec::new();
                while matches!(reader.read_until(b'\n', &mut buffer), Ok(n) if n > 0) {
                    let line = String::from_utf8_lossy(&buffer).trim_end().to_string();
                    buffer.clear();
                    let mut kept = kept.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                    if kept.len() == STDERR_LINES {
                        kept.pop_front();
                    }
                    kept.push_back(line);
                }
            })
        });
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
        let not_ready = |harness: &mut Harness, reason: String| HarnessError::NotReady {
            script: harness.script.clone(),
            reason,
            hint: String::new(),
            stderr: harness.stderr_block(),
        };
        let line = match self.lines.recv_timeout(timeout) {
            Ok(Event::Line(line)) => line,
            Ok(Event::ReadError(error)) => {
                return Err(not_ready(self, format!("reading its output: {error}")))
            }
            Err(RecvTimeoutError::Timeout) => {
                let reason = format!("no ready line within {} s", timeout.as_secs_f64());
                return Err(not_ready(self, reason));
            }
            Err(RecvTimeoutError::Disconnected) => {
                let status = self.exit_status();
                return Err(not_ready(
                    self,
                    format!("it exited ({status}) before saying it was ready"),
                ));
            }
        };
        let ready: Value = match serde_json::from_str(&line) {
            Ok(value) => value,
            Err(error) => {
                return Err(not_ready(
                    self,
                    format!("its first line is not JSON ({error}): {}", clip(&line)),
                ))
            }
        };
        match ready.get("ready") {
            Some(Value::Bool(true)) => Ok(ready),
            Some(Value::Bool(false)) => {
                let reason = ready
                    .get("error")
                    .and_then(Value::as_str)
                    .unwrap_or("it says it is not ready")
                    .to_string();
                Err(not_ready(self, reason))
            }
            _ => Err(not_ready(
                self,
                format!("its first line is not a ready line: {}", clip(&line)),
            )),
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
    pub fn script(&self) -> &str {
        &self.script
    }

    pub fn request_timeout(&self) -> Duration {
        self.request_timeout
    }

    pub fn set_request_timeout(&mut self, timeout: Duration) {
        self.request_timeout = timeout;
    }

    /// The last lines the script wrote to its stderr.
    pub fn stderr_tail(&self) -> Vec<String> {
        self.stderr
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .iter()
            .cloned()
            .collect()
    }

    /// Sends one request and waits for its reply, with the default timeout.
    ///
    /// A reply with `"ok": false` is [`HarnessError::Failed`], carrying the script's message
    /// and the whole reply.
    pub fn request(&mut self, request: &Value) -> Result<Value, HarnessError> {
        self.request_within(request, self.request_timeout)
    }

    /// Sends one request and waits at most `timeout` for its reply.
    pub fn request_within(
        &mut self,
        request: &Value,
        timeout: Duration,
    ) -> Result<Value, HarnessError> {
        let op = request
            .get("op")
            .and_then(Value::as_str)
            .unwrap_or("a request")
            .to_string();
        self.seq += 1;
        let seq = self.seq;
        let line = match request {
            Value::Object(fields) => {
                let mut fields: Map<String, Value> = fields.clone();
                fields.insert("seq".to_string(), Value::from(seq));
                Value::Object(fields).to_string()
            }
            other => other.to_string(),
        };
        let reply = self.exchange(&line, &op, Some(seq), timeout)?;
        match reply.get("ok") {
            Some(Value::Bool(true)) => Ok(reply),
            Some(Value::Bool(false)) => Err(HarnessError::Failed {
                script: self.script.clone(),
                op,
                message: reply
                    .get("error")
                    .and_then(Value::as_str)
                    .unwrap_or("no message")
                    .to_string(),
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
        self.exchange(line.trim_end(), "a raw line", None, timeout)
    }

    fn exchange(
        &mut self,
        line: &str,
        op: &str,
        seq: Option<u64>,
        timeout: Duration,
    ) -> Result<Value, HarnessError> {
        self.send(line)?;
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let line = match self.lines.recv_timeout(left) {
                Ok(Event::Line(line)) => line,
                Ok(Event::ReadError(error)) => {
                    return Err(HarnessError::BadReply {
                        script: self.script.clone(),
                        detail: format!("reading it failed: {error}"),
                        line: String::new(),
                    })
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(HarnessError::Timeout {
                        script: self.script.clone(),
                        op: op.to_string(),
                        waited_ms: timeout.as_millis().try_into().unwrap_or(u64::MAX),
                    })
                }
                Err(RecvTimeoutError::Disconnected) => return Err(self.exited()),
            };
            let reply: Value =
                serde_json::from_str(&line).map_err(|error| HarnessError::BadReply {
                    script: self.script.clone(),
                    detail: format!("not JSON: {error}"),
                    line: clip(&line),
                })?;
            if !reply.is_object() {
                return Err(HarnessError::BadReply {
                    script: self.script.clone(),
                    detail: "not a JSON object".to_string(),
                    line: clip(&line),
                });
            }
            match (seq, reply.get("seq").and_then(Value::as_u64)) {
                // The late answer to a request that timed out: already given up on.
                (Some(wanted), Some(got)) if got < wanted => continue,
                (Some(wanted), Some(got)) if got > wanted => {
                    return Err(HarnessError::BadReply {
                        script: self.script.clone(),
                        detail: format!("answers request {got}, but {wanted} is the latest"),
                        line: clip(&line),
                    })
                }
                _ => return Ok(reply),
            }
        }
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
            format!("; its stderr ends with:\n  {}", lines.join("\n  "))
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

fn clip(line: &str) -> String {
    const MAX: usize = 300;
    if line.len() <= MAX {
        return line.to_string();
    }
    let mut end = MAX;
    while !line.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}…", &line[..end])
}

/// What `keypose doctor` says about the Python side.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PythonReport {
    /// What was found, one fact a line.
    pub lines: Vec<String>,
    /// What is wrong, each with what to do.
    pub problems: Vec<String>,
}

impl PythonReport {
    pub fn ok(&self) -> bool {
        self.problems.is_empty()
    }
}

impl fmt::Display for PythonReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for line in &self.lines {
            writeln!(f, "{line}")?;
        }
        for problem in &self.problems {
            writeln!(f, "problem: {problem}")?;
        }
        Ok(())
    }
}

/// The Python side for `keypose doctor`: indented lines, problems marked, without building
/// anything (a missing environment is reported as such, with the interpreter it would use).
pub fn doctor_report() -> String {
    python_report(false)
        .to_string()
        .lines()
        .map(|line| format!("  {line}\n"))
        .collect()
}

/// The Python side as found from the process's variables. With `build`, keypose's environment
/// is built when missing; without, the report only says it is missing.
pub fn python_report(build: bool) -> PythonReport {
    match PyConfig::from_env() {
        Ok(config) => python_report_for(&config, build),
        Err(error) => PythonReport {
            lines: Vec::new(),
            problems: vec![error.to_string()],
        },
    }
}

/// The Python side of `config`, started for real (the SDK bridge's ready line) when possible.
pub fn python_report_for(config: &PyConfig, build: bool) -> PythonReport {
    let mut report = PythonReport::default();
    report
        .lines
        .push(format!("cache directory: {}", config.cache_dir.display()));
    match &config.python_override {
        Some(python) => report
            .lines
            .push(format!("KEYPOSE_PYTHON: {} (used as is)", python.display())),
        None => {
            let venv = config.venv_dir();
            let state = if env_is_ready(&venv) {
                "built"
            } else if build {
                "not built yet: building it now"
            } else {
                "not built yet: keypose builds it on first use"
            };
            report.lines.push("KEYPOSE_PYTHON: not set".to_string());
            report
                .lines
                .push(format!("environment: {} ({state})", venv.display()));
            if !env_is_ready(&venv) {
                match find_base_python() {
                    Ok(base) => report.lines.push(format!(
                        "base interpreter: {} (Python {})",
                        base.executable, base.version
                    )),
                    Err(error) => report.problems.push(error.to_string()),
                }
            }
        }
    }
    let env = if build {
        config.ensure_python().map(Some)
    } else {
        config.find_python()
    };
    match env {
        Ok(Some(env)) => {
            report
                .lines
                .push(format!("interpreter: {}", env.python.display()));
            match Harness::start_in(config, "sdk_bridge.py", HarnessOptions::default()) {
                Ok(harness) => describe_ready(&mut report, harness.script(), harness.ready()),
                Err(error) => report.problems.push(error.to_string()),
            }
        }
        Ok(None) => {}
        Err(error) => report.problems.push(error.to_string()),
    }
    report
}

fn describe_ready(report: &mut PythonReport, script: &str, ready: &Value) {
    let text = |key: &str| {
        ready
            .get(key)
            .and_then(Value::as_str)
            .unwrap_or("?")
            .to_string()
    };
    let packages = ready.get("packages").and_then(Value::as_object);
    let listed = packages
        .map(|packages| {
            packages
                .iter()
                .map(|(name, version)| format!("{name} {}", version.as_str().unwrap_or("missing")))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default();
    report.lines.push(format!(
        "{script}: ready on Python {} ({}): {listed}",
        text("python"),
        text("executable")
    ));
    let Some(packages) = packages else {
        return;
    };
    for (name, pinned) in pinned_versions() {
        let Some(found) = packages.get(name) else {
            continue;
        };
        let found = found.as_str().unwrap_or("missing");
        if found != pinned {
            report.problems.push(format!(
                "{name} is {found} where sim/requirements.txt pins {pinned}: keypose is tested \
                 with the pinned version"
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn lookup(vars: &[(&str, &str)]) -> impl Fn(&str) -> Option<OsString> {
        let map: HashMap<String, OsString> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), OsString::from(v)))
            .collect();
        move |name| map.get(name).cloned()
    }

    #[test]
    fn cache_dir_follows_keypose_cache_then_xdg_then_home() {
        let all = [
            ("KEYPOSE_CACHE", "/k"),
            ("XDG_CACHE_HOME", "/x"),
            ("HOME", "/h"),
        ];
        let config = PyConfig::from_lookup(lookup(&all)).expect("config");
        assert_eq!(config.cache_dir, PathBuf::from("/k"));
        let config = PyConfig::from_lookup(lookup(&all[1..])).expect("config");
        assert_eq!(config.cache_dir, PathBuf::from("/x/keypose"));
        let config = PyConfig::from_lookup(lookup(&all[2..])).expect("config");
        assert_eq!(config.cache_dir, PathBuf::from("/h/.cache/keypose"));
        assert!(config.python_override.is_none());
    }

    #[test]
    fn empty_or_relative_variables_are_ignored() {
        let config = PyConfig::from_lookup(lookup(&[
            ("KEYPOSE_CACHE", ""),
            ("XDG_CACHE_HOME", "relative/cache"),
            ("HOME", "/h"),
            ("KEYPOSE_PYTHON", ""),
        ]))
        .expect("config");
        assert_eq!(config.cache_dir, PathBuf::from("/h/.cache/keypose"));
        assert!(config.python_override.is_none());
    }

    #[test]
    fn no_cache_dir_is_an_error_that_says_what_to_set() {
        let error = PyConfig::from_lookup(lookup(&[])).expect_err("no directory");
        assert!(matches!(error, PyEnvError::NoCacheDir));
        assert!(error.to_string().contains("KEYPOSE_CACHE"));
    }

    #[test]
    fn keypose_python_is_taken_as_the_override() {
        let config = PyConfig::from_lookup(lookup(&[
            ("HOME", "/h"),
            ("KEYPOSE_PYTHON", "/opt/py/bin/python3"),
        ]))
        .expect("config");
        assert_eq!(
            config.python_override,
            Some(PathBuf::from("/opt/py/bin/python3"))
        );
    }

    #[test]
    fn a_missing_override_is_reported_with_the_fix() {
        let config = PyConfig {
            python_override: Some(PathBuf::from("/no/such/python")),
            cache_dir: PathBuf::from("/tmp/unused"),
        };
        let error = config.ensure_python().expect_err("missing interpreter");
        let text = error.to_string();
        assert!(text.contains("KEYPOSE_PYTHON=/no/such/python"), "{text}");
        assert!(text.contains("unset it"), "{text}");
    }

    #[test]
    fn env_key_is_fnv1a_and_changes_with_the_text() {
        // FNV-1a 64 reference values.
        assert_eq!(env_key(""), "cbf29ce484222325");
        assert_eq!(env_key("a"), "af63dc4c8601ec8c");
        assert_ne!(env_key("x==1.0\n"), env_key("x==1.1\n"));
    }

    #[test]
    fn pins_are_parsed_without_comments_or_markers() {
        let pins = parse_pins(
            "# comment\nfoo==1.2.3\n\nbar == 4.5 ; python_version < \"3.9\"  # why\nbaz>=1\n",
        );
        assert_eq!(pins, vec![("foo", "1.2.3"), ("bar", "4.5")]);
        let embedded = pinned_versions();
        assert!(
            embedded.contains(&("dynamixel-sdk", "4.1.0")),
            "{embedded:?}"
        );
        assert!(
            embedded.contains(&("feetech-servo-sdk", "1.0.0")),
            "{embedded:?}"
        );
    }

    #[test]
    fn unknown_scripts_are_named_with_the_known_ones() {
        let config = PyConfig::with_cache_dir("/tmp/unused");
        let error = config.script_path("nope.py").expect_err("unknown");
        assert!(error.to_string().contains("sdk_bridge.py"), "{error}");
    }

    #[test]
    fn versions_compare_by_major_and_minor() {
        assert!(version_at_least("3.11.7", (3, 10)));
        assert!(version_at_least("3.10.0", (3, 10)));
        assert!(!version_at_least("3.9.18", (3, 10)));
        assert!(version_at_least("4.0.0", (3, 10)));
        assert!(!version_at_least("", (3, 10)));
    }
}
