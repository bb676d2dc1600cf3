//! Running an oracle script (`benches/*_oracle.py`) in keypose's Python environment: the
//! request as JSON on its stdin, the reply as JSON from its stdout. Shared by `topp.rs` and
//! `ruckig.rs` (and so by the benches and tests that include them).
#![allow(dead_code)]

use serde_json::Value;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// `benches/SCRIPT` run by `python` on `request`: its reply, or what went wrong.
pub fn run_oracle(python: &Path, script: &str, request: &Value) -> Result<Value, String> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("benches")
        .join(script);
    // keypose's environment keeps the bytecode of scipy and toppra once compiled, as the
    // harness does.
    let (name, value) = keypose::python::KEEP_BYTECODE;
    let mut child = Command::new(python)
        .arg(&script)
        .env(name, value)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(request.to_string().as_bytes())
        .map_err(|e| e.to_string())?;
    let output = child.wait_with_output().map_err(|e| e.to_string())?;
    if !output.status.success() {
        return Err(format!(
            "{} failed ({}): {}",
            script.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    serde_json::from_slice(&output.stdout).map_err(|e| e.to_string())
}

/// The reply's `"durations"`, seconds, and the version it names under `package`.
pub fn durations(reply: &Value, package: &str) -> Result<(Vec<f64>, String), String> {
    let durations = reply["durations"]
        .as_array()
        .ok_or("no durations in the reply")?
        .iter()
        .map(|d| d.as_f64().ok_or("a duration that is not a number"))
        .collect::<Result<Vec<f64>, _>>()?;
    Ok((
        durations,
        reply[package].as_str().unwrap_or("?").to_string(),
    ))
}
