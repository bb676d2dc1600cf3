//! What `keypose doctor` says about the Python side: the cache, the interpreter, the
//! environment and the SDK bridge's ready line against the pins.
//!
//! Knows nothing about building or running beyond what [`PyConfig`] and [`Harness`] offer.

use super::base_python::find_base_python;
use super::requirements::pinned_versions;
use super::venv::env_is_ready;
use super::{Harness, HarnessOptions, PyConfig};
use crate::error::Report;
use serde_json::Value;
use std::fmt;

/// What `keypose doctor` says about the Python side.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct PythonReport {
    /// What was found, one fact a line.
    pub lines: Vec<String>,
    /// What is wrong, each with what to do.
    pub problems: Vec<String>,
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
pub(crate) fn python_report(build: bool) -> PythonReport {
    match PyConfig::from_env() {
        Ok(config) => python_report_for(&config, build),
        Err(error) => PythonReport {
            lines: Vec::new(),
            problems: vec![Report(&error).to_string()],
        },
    }
}

/// The Python side of `config`, started for real (the SDK bridge's and the dataset reader's
/// ready lines) when possible.
pub(crate) fn python_report_for(config: &PyConfig, build: bool) -> PythonReport {
    let mut report = PythonReport::default();
    report
        .lines
        .push(format!("cache directory: {}", config.cache_dir.display()));
    match &config.python_override {
        Some(python) => report
            .lines
            .push(format!("KEYPOSE_PYTHON: {} (used as is)", python.display())),
        None => describe_own_environment(&mut report, config, build),
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
            // The SDK bridge, and the dataset reader (pyarrow) of `import lerobot`.
            for script in ["sdk_bridge.py", "dataset_reader.py"] {
                match Harness::start_in(config, script, HarnessOptions::default()) {
                    Ok(harness) => describe_ready(&mut report, harness.script(), harness.ready()),
                    Err(error) => report.problems.push(Report(&error).to_string()),
                }
            }
        }
        Ok(None) => {}
        Err(error) => report.problems.push(Report(&error).to_string()),
    }
    report
}

/// keypose's own environment: built or not, and the base interpreter a build would use.
fn describe_own_environment(report: &mut PythonReport, config: &PyConfig, build: bool) {
    let venv = config.venv_dir();
    let ready = env_is_ready(&venv);
    let state = if ready {
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
    if ready {
        return;
    }
    match find_base_python() {
        Ok(base) => report.lines.push(format!(
            "base interpreter: {} (Python {})",
            base.executable, base.version
        )),
        Err(error) => report.problems.push(Report(&error).to_string()),
    }
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
