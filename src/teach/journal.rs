//! The session journal: after every edit the whole list is written, atomically, to a file in
//! keypose's cache directory, so that a crash or a killed terminal loses nothing. The next
//! session for the same target file offers to recover it.
//!
//! The journal is itself a `keypose-sequence/1` file, so it can also be opened by hand with any
//! keypose command. It is named after the target file's name plus a hash of its absolute path
//! (two `taught.json` in different directories do not share a journal), and removed after a
//! successful write or a clean quit.

use crate::atomic_file;
use crate::json::InputError;
use crate::sequence::Sequence;
use std::io;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// Subdirectory of the cache directory that holds the journals.
const JOURNAL_DIR: &str = "teach";

/// The journal of one target file: where its unsaved list is kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Journal {
    path: PathBuf,
}

/// A journal found at start that is newer than its target file.
#[derive(Debug, Clone)]
pub struct Pending {
    /// The list the journal holds.
    pub sequence: Sequence,
    /// When the journal was last written.
    pub modified: SystemTime,
}

impl Journal {
    /// The journal of `target` inside `cache_dir`.
    pub fn for_target(cache_dir: &Path, target: &Path) -> Journal {
        // Relative targets name a file in the working directory; the absolute path is what
        // identifies it across sessions started from the same place.
        let absolute = std::path::absolute(target).unwrap_or_else(|_| target.to_path_buf());
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "untitled".into());
        let safe: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || "._-".contains(c) {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let hash = fnv1a(absolute.to_string_lossy().as_bytes());
        Journal {
            path: cache_dir
                .join(JOURNAL_DIR)
                .join(format!("{safe}-{hash:016x}.journal.json")),
        }
    }

    /// The journal of another target in the same cache directory (after a save-as).
    pub fn for_other_target(&self, target: &Path) -> Journal {
        let cache_dir = self
            .path
            .parent()
            .and_then(Path::parent)
            .unwrap_or(Path::new("."));
        Journal::for_target(cache_dir, target)
    }

    /// The journal's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the list. An empty list is not a valid sequence file and there is nothing in it
    /// to recover, so the journal is removed instead.
    pub fn save(&self, sequence: &Sequence) -> io::Result<()> {
        if sequence.keyframes.is_empty() {
            return self.remove();
        }
        // Unsaved work is the user's alone: the journal is 0600 in a 0700 directory.
        if let Some(dir) = self.path.parent() {
            atomic_file::make_private_dir(dir)?;
        }
        atomic_file::write_private(&self.path, sequence.to_text().as_bytes())
    }

    /// Removes the journal; a journal that is not there is not an error.
    pub fn remove(&self) -> io::Result<()> {
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }

    /// The journal's list when it is at least as new as `target` (or `target` does not exist):
    /// then it holds edits the target lacks. An older journal is stale (the file was written
    /// since, perhaps by another program) and is not offered.
    pub fn pending(&self, target: &Path) -> Result<Option<Pending>, InputError> {
        let Ok(journal_meta) = std::fs::metadata(&self.path) else {
            return Ok(None);
        };
        let modified = journal_meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
        let target_time = std::fs::metadata(target).and_then(|m| m.modified()).ok();
        // Equal times count as newer: on a coarse-grained file system an edit made within the
        // same tick as the last write must still be offered.
        if target_time.is_some_and(|t| modified < t) {
            return Ok(None);
        }
        let sequence = Sequence::load(&self.path)?;
        Ok(Some(Pending { sequence, modified }))
    }
}

/// FNV-1a, 64 bits: a stable hash (the standard library's may change between releases, which
/// would orphan journals).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sequence::{KeyValue, Keyframe};

    /// A one-key list, also for the file executor's tests.
    pub(crate) fn one_key() -> Sequence {
        let mut s = Sequence::new("so101");
        s.keyframes.push(Keyframe::new(vec![(
            "gripper".into(),
            KeyValue::Joint(5.0),
        )]));
        s
    }

    #[test]
    fn named_after_the_target_and_distinct_per_directory() {
        let cache = Path::new("/cache");
        let a = Journal::for_target(cache, Path::new("/a/taught.json"));
        let b = Journal::for_target(cache, Path::new("/b/taught.json"));
        assert_ne!(a, b);
        assert_eq!(a.for_other_target(Path::new("/b/taught.json")), b);
        assert!(a.path().starts_with("/cache/teach"));
        let name = a.path().file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with("taught.json-"), "{name}");
    }

    #[test]
    fn save_pending_remove_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("seq.json");
        let journal = Journal::for_target(dir.path(), &target);
        assert!(journal.pending(&target).unwrap().is_none());
        journal.save(&one_key()).unwrap();
        let pending = journal.pending(&target).unwrap().expect("offered");
        assert_eq!(pending.sequence.to_json(), one_key().to_json());
        // An empty list removes the journal.
        journal.save(&Sequence::new("so101")).unwrap();
        assert!(!journal.path().exists());
        journal.remove().unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn the_journal_is_private_0600_in_a_0700_directory() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        journal.save(&one_key()).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(journal.path()), 0o600);
        assert_eq!(mode(journal.path().parent().unwrap()), 0o700);
    }

    #[test]
    fn a_journal_older_than_its_target_is_not_offered() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("seq.json");
        let journal = Journal::for_target(dir.path(), &target);
        journal.save(&one_key()).unwrap();
        one_key().save(&target).unwrap();
        let old = SystemTime::now() - std::time::Duration::from_secs(60);
        std::fs::File::options()
            .write(true)
            .open(journal.path())
            .unwrap()
            .set_modified(old)
            .unwrap();
        assert!(journal.pending(&target).unwrap().is_none());
    }
}
