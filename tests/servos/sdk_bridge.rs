//! The Python side for real: keypose's environment built from scratch (pip downloads the pinned
//! packages from PyPI), the vendor-SDK bridge started in it, the bridge's answers to bad input,
//! and the harness plumbing (timeouts, exits, readiness) with small scripts of our own.
//!
//! The environment is built from scratch once per run of this test binary, in a cache of its
//! own under `target/tmp` (after removing the previous run's), by one test; the others use the
//! suites' shared environment. Without python3 (3.11+, with venv) or without PyPI these tests fail and
//! say so: they never skip.

use keypose::bus::sdk::{SdkBus, SdkError};
use keypose::bus::BusError;
use keypose::python::{
    Harness, HarnessError, HarnessOptions, PyConfig, PyEnvError, PythonEnv, REQUIREMENTS,
};
use keypose::robot::Protocol;
use serde_json::json;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The suites' shared Python environment (tests/README.md), built if it is not there yet.
/// The bridge and the plumbing tests run in it; only
/// [`the_environment_is_built_from_scratch_then_reused`] builds one of its own, so that no
/// test here waits for that build but that one.
struct Suite {
    config: PyConfig,
    env: PythonEnv,
}

fn suite() -> &'static Suite {
    static SUITE: OnceLock<Result<Suite, String>> = OnceLock::new();
    let built = SUITE.get_or_init(|| {
        let cache = crate::common::python_cache();
        let config = PyConfig::with_cache_dir(&cache);
        let env = config
            .ensure_python()
            .map_err(|e| build_failed(&cache, e))?;
        Ok(Suite { config, env })
    });
    match built {
        Ok(suite) => suite,
        Err(reason) => panic!("{reason}"),
    }
}

fn build_failed(cache: &Path, error: PyEnvError) -> String {
    format!(
        "building keypose's Python environment in {} failed; these tests need python3 {}.{}+ \
         with its venv module and access to PyPI: {error}",
        cache.display(),
        keypose::python::MIN_PYTHON.0,
        keypose::python::MIN_PYTHON.1
    )
}

fn marker(env: &PythonEnv) -> PathBuf {
    env.venv
        .as_ref()
        .expect("keypose's own environment, not KEYPOSE_PYTHON")
        .join("keypose-env.json")
}

fn bridge() -> Harness {
    Harness::start_in(&suite().config, "sdk_bridge.py", HarnessOptions::default())
        .unwrap_or_else(|e| panic!("the SDK bridge did not start: {e}"))
}

/// The pins of sim/requirements.txt, read from the file itself rather than through keypose.
fn pins_on_disk() -> Vec<(String, String)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/sim/requirements.txt");
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
    text.lines()
        .map(|line| line.split('#').next().unwrap_or("").trim())
        .filter(|line| !line.is_empty())
        .map(|line| {
            let (name, version) = line
                .split_once("==")
                .unwrap_or_else(|| panic!("{path}: {line:?} is not pinned with =="));
            (name.trim().to_string(), version.trim().to_string())
        })
        .collect()
}

fn pin(name: &str) -> String {
    pins_on_disk()
        .into_iter()
        .find(|(pinned, _)| pinned == name)
        .map(|(_, version)| version)
        .unwrap_or_else(|| panic!("sim/requirements.txt does not pin {name}"))
}

/// The whole build, pip downloading the pinned packages, in a cache of its own (the previous
/// run's removed first), so that the suites' shared environment is neither removed nor rebuilt.
#[test]
fn the_environment_is_built_from_scratch_then_reused() {
    let cache = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python_cache_from_scratch");
    if cache.exists() {
        fs::remove_dir_all(&cache)
            .unwrap_or_else(|e| panic!("removing the previous run's {}: {e}", cache.display()));
    }
    let config = PyConfig::with_cache_dir(&cache);
    let first = config
        .ensure_python()
        .unwrap_or_else(|e| panic!("{}", build_failed(&cache, e)));
    assert!(first.created, "the first call must have built it");
    let marker_modified = marker(&first)
        .metadata()
        .and_then(|meta| meta.modified())
        .expect("the new environment's marker file");
    let venv = first.venv.clone().expect("a venv");
    assert!(venv.starts_with(&config.cache_dir));
    let key = keypose::python::env_key(REQUIREMENTS);
    assert_eq!(
        venv.file_name().and_then(|n| n.to_str()),
        Some(format!("venv-{key}").as_str())
    );
    assert_eq!(
        fs::read_to_string(venv.join("keypose-requirements.txt")).expect("recorded requirements"),
        REQUIREMENTS
    );

    let again = config.ensure_python().expect("the built environment");
    assert!(!again.created, "the second call must not run pip");
    assert_eq!(again.python, first.python);
    let modified = marker(&again)
        .metadata()
        .and_then(|m| m.modified())
        .expect("marker");
    assert_eq!(
        modified, marker_modified,
        "the marker was rewritten, so the environment was rebuilt"
    );
    let leftovers: Vec<String> = fs::read_dir(&config.cache_dir)
        .expect("cache dir")
        .flatten()
        .map(|entry| entry.file_name().to_string_lossy().into_owned())
        .filter(|name| name.contains(".tmp-") || name.contains(".broken-"))
        .collect();
    assert!(leftovers.is_empty(), "build leftovers: {leftovers:?}");

    // The new environment runs the bridge with the pinned SDKs.
    let bridge = Harness::start_in(&config, "sdk_bridge.py", HarnessOptions::default())
        .unwrap_or_else(|e| panic!("the SDK bridge did not start in the new environment: {e}"));
    for name in ["dynamixel-sdk", "feetech-servo-sdk", "pyserial"] {
        let ready = bridge.ready();
        assert_eq!(ready["packages"][name], json!(pin(name)), "{name}: {ready}");
    }
}

#[test]
fn the_bridge_reports_the_pinned_versions_when_ready() {
    let harness = bridge();
    let ready = harness.ready();
    assert_eq!(ready["ready"], json!(true), "{ready}");
    assert_eq!(
        ready["dynamixel_sdk"],
        json!(pin("dynamixel-sdk")),
        "{ready}"
    );
    assert_eq!(
        ready["scservo_sdk"],
        json!(pin("feetech-servo-sdk")),
        "{ready}"
    );
    assert_eq!(ready["pyserial"], json!(pin("pyserial")), "{ready}");
    // The bridge reports its own packages; the environment also holds the simulation's.
    for name in ["dynamixel-sdk", "feetech-servo-sdk", "pyserial"] {
        assert_eq!(ready["packages"][name], json!(pin(name)), "{name}: {ready}");
    }
    let python = ready["python"].as_str().expect("python version");
    let mut parts = python
        .split('.')
        .map(|p| p.parse::<u32>().expect("numeric"));
    let (major, minor) = (parts.next(), parts.next());
    assert!(
        (major, minor) >= (Some(3), Some(11)),
        "Python {python} is too old"
    );
}

#[test]
fn opening_a_missing_port_is_a_typed_error_that_names_it() {
    let port = "/nonexistent/keypose-ttyUSB9";
    for protocol in [
        Protocol::Dynamixel2,
        Protocol::FeetechSts,
        Protocol::FeetechScs,
    ] {
        match SdkBus::with_harness(bridge(), port, 1_000_000, protocol, &[]) {
            Err(SdkError::Bus(BusError::Port {
                port: named,
                source,
            })) => {
                assert_eq!(named, port);
                assert_eq!(source.kind(), io::ErrorKind::NotFound, "{source}");
                let error = BusError::Port {
                    port: named,
                    source,
                };
                assert!(error.to_string().contains(port), "{error}");
            }
            Err(other) => panic!("{}: expected a port error, got {other:?}", protocol.name()),
            Ok(bus) => panic!("{}: opened a missing port: {bus:?}", protocol.name()),
        }
    }

    // The bridge's own reply says the same, with the SDK's words.
    let mut harness = bridge();
    let request = json!({"op": "open", "port": port, "baud": 57600, "protocol": "dynamixel-2"});
    match harness.request(&request) {
        Err(HarnessError::Failed { message, reply, .. }) => {
            assert!(message.contains(port), "{message}");
            assert_eq!(reply["kind"], json!("port"), "{reply}");
            assert_eq!(reply["errno"], json!(2), "{reply}");
        }
        other => panic!("expected the bridge to refuse, got {other:?}"),
    }
}

#[test]
fn malformed_requests_get_error_replies_and_the_bridge_goes_on() {
    let mut harness = bridge();
    for line in ["this is not json", "[1, 2]", "{\"op\": "] {
        let reply = harness
            .send_raw_line(line)
            .unwrap_or_else(|e| panic!("{line:?}: no reply: {e}"));
        assert_eq!(reply["ok"], json!(false), "{line:?}: {reply}");
        assert_eq!(reply["kind"], json!("request"), "{line:?}: {reply}");
    }
    let cases = [
        (json!({"op": "teleport"}), "request", "unknown op"),
        (json!({"no_op": 1}), "request", "unknown op"),
        (
            json!({"op": "open", "port": "/dev/x", "protocol": "dynamixel-2"}),
            "request",
            "'baud'",
        ),
        (
            json!({"op": "open", "port": "/dev/x", "baud": true, "protocol": "dynamixel-2"}),
            "request",
            "'baud'",
        ),
        (
            json!({"op": "open", "port": "/dev/x", "baud": 57600, "protocol": "dynamixel-1"}),
            "request",
            "unknown protocol",
        ),
        (
            json!({"op": "read", "id": 1, "addr": 132, "len": 4}),
            "state",
            "no port is open",
        ),
        (
            json!({"op": "sync_write", "addr": 116, "len": 4, "values": [[1, 0]]}),
            "state",
            "no port is open",
        ),
    ];
    for (request, kind, words) in cases {
        match harness.request(&request) {
            Err(HarnessError::Failed { message, reply, .. }) => {
                assert_eq!(reply["kind"], json!(kind), "{request}: {reply}");
                assert!(message.contains(words), "{request}: {message}");
                // Each reply answers its own request.
                assert!(reply["seq"].is_u64(), "{request}: {reply}");
            }
            other => panic!("{request}: expected an error reply, got {other:?}"),
        }
    }
    let reply = harness
        .request(&json!({"op": "close"}))
        .expect("the bridge still answers");
    assert_eq!(reply["ok"], json!(true));
}

#[test]
fn the_embedded_script_is_written_out_and_restored_when_changed() {
    let cache = tempfile::tempdir().expect("temp dir");
    let config = PyConfig::with_cache_dir(cache.path());
    let embedded = include_str!("../../sim/sdk_bridge.py");
    let path = config.script_path("sdk_bridge.py").expect("written");
    assert!(path.starts_with(cache.path()));
    assert_eq!(fs::read_to_string(&path).expect("script"), embedded);
    fs::write(&path, "print('not ours')\n").expect("overwrite");
    let again = config.script_path("sdk_bridge.py").expect("rewritten");
    assert_eq!(again, path);
    assert_eq!(fs::read_to_string(&path).expect("script"), embedded);
    match config.script_path("missing.py") {
        Err(PyEnvError::UnknownScript { name, known }) => {
            assert_eq!(name, "missing.py");
            assert!(known.contains("sdk_bridge.py"));
        }
        other => panic!("expected an unknown-script error, got {other:?}"),
    }
}

#[cfg(unix)]
#[test]
fn keypose_python_without_the_packages_is_not_ready_and_says_how_to_fix_it() {
    use std::os::unix::fs::PermissionsExt;
    // The environment's own interpreter with `-S`: it runs, but sees no site-packages, as an
    // interpreter would that never had the SDKs installed.
    let dir = tempfile::tempdir().expect("temp dir");
    let wrapper = dir.path().join("bare-python");
    let script = format!(
        "#!/bin/sh\nexec '{}' -S \"$@\"\n",
        suite().env.python.display()
    );
    fs::write(&wrapper, script).expect("wrapper");
    fs::set_permissions(&wrapper, fs::Permissions::from_mode(0o755)).expect("chmod");
    let config = PyConfig {
        python_override: Some(wrapper.clone()),
        cache_dir: dir.path().join("cache"),
    };
    match Harness::start_in(&config, "sdk_bridge.py", HarnessOptions::default()) {
        Err(error @ HarnessError::NotReady { .. }) => {
            let text = error.to_string();
            assert!(text.contains("dynamixel_sdk"), "{text}");
            assert!(text.contains("KEYPOSE_PYTHON"), "{text}");
            assert!(text.contains("pip install -r"), "{text}");
        }
        other => panic!("expected the bridge not to be ready, got {other:?}"),
    }
    assert!(
        !config
            .cache_dir
            .join(format!("venv-{}", keypose::python::env_key(REQUIREMENTS)))
            .exists(),
        "with KEYPOSE_PYTHON set, keypose must not build an environment"
    );
}

/// A harness script of the test's own, run with the environment's interpreter.
fn own_script(dir: &Path, name: &str, body: &str) -> Harness {
    let path = dir.join(name);
    fs::write(&path, body).expect("script");
    let options = HarnessOptions {
        ready_timeout: Duration::from_secs(20),
        request_timeout: Duration::from_secs(5),
        ..HarnessOptions::default()
    };
    Harness::spawn(&suite().env.python, &path, options)
        .unwrap_or_else(|e| panic!("{name} did not start: {e}"))
}

const ECHO: &str = r#"
import json, sys, time
print(json.dumps({"ready": True, "python": "test"}), flush=True)
for line in sys.stdin:
    req = json.loads(line)
    if req.get("op") == "slow":
        time.sleep(0.6)
    if req.get("op") == "die":
        sys.stderr.write("boom: asked to die\n")
        sys.stderr.flush()
        sys.exit(3)
    print(json.dumps({"ok": True, "op": req.get("op"), "seq": req.get("seq")}), flush=True)
"#;

#[test]
fn a_late_reply_after_a_timeout_is_dropped_not_taken_for_the_next() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut harness = own_script(dir.path(), "echo.py", ECHO);
    match harness.request_within(&json!({"op": "slow"}), Duration::from_millis(100)) {
        Err(HarnessError::Timeout { op, waited_ms, .. }) => {
            assert_eq!(op, "slow");
            assert_eq!(waited_ms, 100);
        }
        other => panic!("expected a timeout, got {other:?}"),
    }
    let reply = harness
        .request(&json!({"op": "fast"}))
        .expect("the next request");
    assert_eq!(reply["op"], json!("fast"), "{reply}");
}

#[test]
fn a_script_that_exits_is_reported_with_its_status_and_stderr() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut harness = own_script(dir.path(), "echo.py", ECHO);
    match harness.request(&json!({"op": "die"})) {
        Err(error @ HarnessError::Exited { .. }) => {
            let text = error.to_string();
            assert!(text.contains("exit code 3"), "{text}");
            assert!(text.contains("boom: asked to die"), "{text}");
        }
        other => panic!("expected the script's exit, got {other:?}"),
    }
    // Later requests say the same instead of hanging.
    assert!(matches!(
        harness.request(&json!({"op": "fast"})),
        Err(HarnessError::Exited { .. })
    ));
}

#[test]
fn a_script_that_is_not_ready_says_why() {
    let dir = tempfile::tempdir().expect("temp dir");
    let python = &suite().env.python;
    let cases = [
        (
            "chatty.py",
            "print('hello there', flush=True)\n",
            "hello there",
        ),
        (
            "crash.py",
            "raise RuntimeError('cannot load the model')\n",
            "cannot load the model",
        ),
        (
            "refuses.py",
            "import json\nprint(json.dumps({'ready': False, 'error': 'no display'}), flush=True)\n",
            "no display",
        ),
    ];
    for (name, body, words) in cases {
        let path = dir.path().join(name);
        fs::write(&path, body).expect("script");
        match Harness::spawn(python, &path, HarnessOptions::default()) {
            Err(error @ HarnessError::NotReady { .. }) => {
                let text = error.to_string();
                assert!(text.contains(words), "{name}: {text}");
            }
            other => panic!("{name}: expected not ready, got {other:?}"),
        }
    }
}

#[cfg(target_os = "linux")]
#[test]
fn dropping_a_harness_stops_a_script_that_ignores_the_end_of_its_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let body = "import json, time\nprint(json.dumps({'ready': True}), flush=True)\n\
                while True:\n    time.sleep(1)\n";
    let harness = own_script(dir.path(), "stubborn.py", body);
    let pid = harness.pid().to_string();
    let proc_entry = PathBuf::from("/proc").join(&pid);
    assert!(proc_entry.exists());
    let started = Instant::now();
    drop(harness);
    assert!(started.elapsed() < Duration::from_secs(3));
    assert!(!proc_entry.exists(), "process {pid} still exists");
}

#[test]
fn requests_carry_a_sequence_number_that_the_bridge_echoes() {
    let mut harness = bridge();
    let first = harness.request(&json!({"op": "close"})).expect("close");
    let second = harness.request(&json!({"op": "close"})).expect("close");
    let (a, b) = (first["seq"].as_u64(), second["seq"].as_u64());
    assert!(
        matches!((a, b), (Some(a), Some(b)) if b == a + 1),
        "{first} {second}"
    );
}
