//! Counting the MuJoCo harness processes keypose starts, by the operating system's count rather
//! than keypose's: `KEYPOSE_PYTHON` points at a wrapper script that appends its process id to a
//! log when it is asked to run `sim_harness.py`, then `exec`s the simulation suites' real Python
//! (so the id written is the harness's own). The wrapper can also be told to start, from then
//! on, a harness that says it is ready and dies at its first request.

#![allow(dead_code)] // Each test crate uses its own part of this.

use std::path::{Path, PathBuf};

/// A wrapper Python in a temporary directory, and the log of the harnesses it started.
pub struct LoggedPython {
    dir: tempfile::TempDir,
}

impl LoggedPython {
    /// The wrapper around the suites' environment (built first if it is not yet).
    pub fn new() -> LoggedPython {
        let cache = crate::common::python_cache();
        let env = keypose::python::PyConfig::with_cache_dir(&cache)
            .ensure_python()
            .unwrap_or_else(|e| {
                panic!(
                    "building keypose's Python environment in {} failed; this test needs \
                     python3 with venv and PyPI: {e}",
                    cache.display()
                )
            });
        let dir = tempfile::tempdir().unwrap();
        let quote = |path: &Path| format!("'{}'", path.display());
        let real = quote(&env.python);
        let script = format!(
            "#!/bin/sh\n\
             case \"$*\" in\n\
             *sim_harness.py*)\n\
             \techo $$ >> {log}\n\
             \tif [ -e {die} ]; then exec {real} -c 'import sys; print(\"{{\\\"ready\\\": true}}\", flush=True); sys.stdin.readline()'; fi ;;\n\
             esac\n\
             exec {real} \"$@\"\n",
            log = quote(&dir.path().join("starts.log")),
            die = quote(&dir.path().join("die")),
        );
        let wrapper = dir.path().join("python");
        std::fs::write(&wrapper, script).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
        LoggedPython { dir }
    }

    /// The variables that make keypose run its harnesses through the wrapper, with the suites'
    /// cache for its scripts and models.
    pub fn env(&self) -> [(&'static str, PathBuf); 2] {
        [
            ("KEYPOSE_PYTHON", self.dir.path().join("python")),
            ("KEYPOSE_CACHE", crate::common::python_cache()),
        ]
    }

    /// The process ids of the harnesses started so far, in order.
    pub fn starts(&self) -> Vec<u32> {
        std::fs::read_to_string(self.dir.path().join("starts.log"))
            .unwrap_or_default()
            .lines()
            .map(|line| line.trim().parse().expect("a process id"))
            .collect()
    }

    /// From now on every harness started says it is ready and exits at its first request.
    pub fn die_at_first_request(&self) {
        std::fs::write(self.dir.path().join("die"), "").unwrap();
    }
}
