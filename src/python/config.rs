//! Where keypose's Python side lives, from the process's variables.
//!
//! Knows nothing about building environments, scripts or child processes: it only names
//! directories and the interpreter override.

use super::requirements::{env_key, REQUIREMENTS};
use super::PyEnvError;
use std::ffi::OsString;
use std::path::PathBuf;

/// Where keypose's Python side lives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PyConfig {
    /// `KEYPOSE_PYTHON`: an interpreter that already has the packages; no environment is built.
    pub python_override: Option<PathBuf>,
    /// keypose's cache directory: the environment and the written-out scripts live here.
    pub cache_dir: PathBuf,
}

impl PyConfig {
    /// The configuration from `KEYPOSE_PYTHON`, `KEYPOSE_CACHE`, `XDG_CACHE_HOME` and `HOME`.
    pub fn from_env() -> Result<PyConfig, PyEnvError> {
        PyConfig::from_lookup(|name| std::env::var_os(name))
    }

    /// The configuration from variables looked up by `get` (the environment, or a test's map).
    pub(crate) fn from_lookup(
        get: impl Fn(&str) -> Option<OsString>,
    ) -> Result<PyConfig, PyEnvError> {
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
    pub(crate) fn venv_dir(&self) -> PathBuf {
        self.cache_dir
            .join(format!("venv-{}", env_key(REQUIREMENTS)))
    }

    /// Where the embedded scripts are written.
    pub(crate) fn sim_dir(&self) -> PathBuf {
        self.cache_dir.join("sim")
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
}
