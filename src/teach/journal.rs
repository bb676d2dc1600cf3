//! The session journal: after every edit the whole list and its undo history are written,
//! atomically, to a file in keypose's cache directory, so that a crash or a killed terminal
//! loses nothing, not even what undo could take back. The next session for the same target
//! file offers to recover it.
//!
//! The journal is a `keypose-journal/1` file: `"list"` is the list as a `keypose-sequence/1`
//! sequence (copy it out to open it with any keypose command), `"current"` its current key,
//! `"undo"` and `"redo"` the history ([`History`]), each step `{"what", "current", "after",
//! "list"}` ([`Edit`]), and `"layout"`, when the list came from a file, `{"file_hash",
//! "places"}`: a hash of that file's text and where each key of the list was in it, so that a
//! recovered list is written in its file's layout again (its formatting and numbers as
//! written, [`Sequence::to_text`]) as long as the file is still the one it was edited from.
//! A journal of an older keypose, a bare `keypose-sequence/1` file, is read as a list without
//! history. It is named after the target file's name plus a hash of its absolute path (two
//! `taught.json` in different directories do not share a journal), and removed after a
//! successful write or a clean quit.

use super::history::{Edit, History, Version};
use crate::atomic_file;
use crate::json::{InputError, Node};
use crate::sequence::{Sequence, SEQUENCE_FORMAT};
use serde_json::{json, Value};
use std::io;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// Subdirectory of the cache directory that holds the journals.
const JOURNAL_DIR: &str = "teach";
/// The journal's own format: the list with its history.
pub const JOURNAL_FORMAT: &str = "keypose-journal/1";
/// The most the history takes in a journal, bytes. The whole file is written after every edit:
/// a list of a few hundred keys is tens of kilobytes as JSON, and [`super::history::DEPTH`]
/// copies of it would be megabytes written per key press. Past this budget the steps farthest
/// from the present are left out of the journal (the session still has them): what a crash can
/// lose is the far end of the undo history, never the list.
pub const HISTORY_BYTES: usize = 1 << 20;

/// What a journal holds: the list being edited and its undo history.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The list as it is now, with its current key.
    pub list: Version,
    /// What undo and redo can go back and forward to.
    pub history: History,
}

/// The journal of one target file: where its unsaved list is kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Journal {
    path: PathBuf,
}

/// A journal found at start that is newer than its target file.
#[derive(Debug, Clone)]
pub struct Pending {
    /// The list the journal holds, and its history.
    pub entry: Entry,
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

    /// Writes the list and its history. An empty list is not a valid sequence and there is
    /// nothing in it to recover, so the journal is removed instead (its history goes with it).
    pub fn save(&self, entry: &Entry) -> io::Result<()> {
        if entry.list.sequence.keyframes.is_empty() {
            return self.remove();
        }
        // Unsaved work is the user's alone: the journal is 0600 in a 0700 directory.
        if let Some(dir) = self.path.parent() {
            atomic_file::make_private_dir(dir)?;
        }
        atomic_file::write_private(&self.path, entry_json(entry).as_bytes())
    }

    /// Reads the journal: its list and history.
    pub fn read(&self) -> Result<Entry, InputError> {
        self.read_with_layout().map(|(entry, _)| entry)
    }

    fn read_with_layout(&self) -> Result<(Entry, Option<FileLayout>), InputError> {
        let file = self.path.display().to_string();
        let text = crate::json::read_text(&self.path)?;
        let value = crate::json::parse(&file, &text)?;
        let root = Node::root(&file, &value);
        Ok((read_entry(&root)?, read_layout(&root)?))
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
        let (mut entry, layout) = self.read_with_layout()?;
        if let Some(layout) = layout {
            layout.restore(&mut entry.list.sequence, target);
        }
        Ok(Some(Pending { entry, modified }))
    }
}

/// Which file's layout a journaled list keeps, and where its keys were in that file.
#[derive(Debug, Clone, PartialEq)]
struct FileLayout {
    /// [`fnv1a`] of the file's text.
    file_hash: u64,
    /// Each key's place in the file, `None` for a key added since.
    places: Vec<Option<usize>>,
}

impl FileLayout {
    fn of(sequence: &Sequence) -> Option<FileLayout> {
        Some(FileLayout {
            file_hash: fnv1a(sequence.source_text()?.as_bytes()),
            places: sequence.source_places(),
        })
    }

    /// Gives `sequence` the layout of `target` when `target` is still the text the list was
    /// edited from; otherwise (changed, gone, unreadable) the list keeps the canonical layout,
    /// as any list that came from no file.
    fn restore(&self, sequence: &mut Sequence, target: &Path) {
        let Ok(text) = std::fs::read_to_string(target) else {
            return;
        };
        if fnv1a(text.as_bytes()) != self.file_hash {
            return;
        }
        if let Ok(file) = Sequence::from_json(&target.display().to_string(), &text) {
            sequence.adopt_layout(&file, &self.places);
        }
    }

    fn to_value(&self) -> Value {
        json!({"file_hash": format!("{:016x}", self.file_hash), "places": self.places})
    }
}

/// The journal's `"layout"`, if it has one.
fn read_layout(root: &Node) -> Result<Option<FileLayout>, InputError> {
    let Some(node) = root.get("layout") else {
        return Ok(None);
    };
    node.only_fields(&["file_hash", "places"])?;
    let hash_node = node.require("file_hash", "16 hex digits")?;
    let file_hash = u64::from_str_radix(hash_node.str("16 hex digits")?, 16)
        .map_err(|_| hash_node.expected("16 hex digits"))?;
    let places = (node
        .require("places", "each key's place in the file")?
        .items()?)
    .iter()
    .map(|item| match item.value.is_null() {
        true => Ok(None),
        false => item
            .integer("a key's place in the file, or null", 0, u32::MAX.into())
            .map(|i| Some(i as usize)),
    })
    .collect::<Result<_, _>>()?;
    Ok(Some(FileLayout { file_hash, places }))
}

/// The journal's text: one line per member and per step, so that a look at it shows the
/// history's shape.
fn entry_json(entry: &Entry) -> String {
    let step = |s: &Edit| {
        let line = json!({
            "what": s.what,
            "current": s.version.current,
            "after": s.after,
            "list": s.version.sequence.to_value(),
        });
        format!("    {line}")
    };
    let undo: Vec<String> = entry.history.undo.iter().map(step).collect();
    let redo: Vec<String> = entry.history.redo.iter().map(step).collect();
    let (undo, redo) = nearest_within(&undo, &redo, HISTORY_BYTES);
    let steps = |lines: &[String]| {
        if lines.is_empty() {
            "[]".to_string()
        } else {
            format!("[\n{}\n  ]", lines.join(",\n"))
        }
    };
    let layout = FileLayout::of(&entry.list.sequence)
        .map(|layout| format!(",\n  \"layout\": {}", layout.to_value()))
        .unwrap_or_default();
    format!(
        "{{\n  \"format\": {},\n  \"current\": {},\n  \"list\": {},\n  \"undo\": {},\n  \"redo\": {}{layout}\n}}\n",
        Value::from(JOURNAL_FORMAT),
        entry.list.current,
        entry.list.sequence.to_value(),
        steps(undo),
        steps(redo)
    )
}

/// The steps of `undo` and `redo` nearest the present (the end of each: the last edit, the next
/// redo) that fit in `budget` bytes, taken one from each side in turn.
fn nearest_within<'a>(
    undo: &'a [String],
    redo: &'a [String],
    budget: usize,
) -> (&'a [String], &'a [String]) {
    let (mut kept_undo, mut kept_redo, mut spent) = (0, 0, 0);
    loop {
        let mut took = false;
        for (lines, kept) in [(undo, &mut kept_undo), (redo, &mut kept_redo)] {
            let Some(line) = lines.len().checked_sub(*kept + 1).map(|i| &lines[i]) else {
                continue;
            };
            if spent + line.len() > budget {
                continue;
            }
            spent += line.len();
            *kept += 1;
            took = true;
        }
        if !took {
            break;
        }
    }
    (
        &undo[undo.len() - kept_undo..],
        &redo[redo.len() - kept_redo..],
    )
}

/// A journal's entry; a bare sequence (an older keypose's journal) is a list without history.
fn read_entry(root: &Node) -> Result<Entry, InputError> {
    let format = root.require("format", &format!("{JOURNAL_FORMAT:?}"))?;
    if format.str("a format name")? == SEQUENCE_FORMAT {
        let sequence = Sequence::from_node(root)?;
        return Ok(Entry {
            list: Version {
                sequence,
                current: 0,
            },
            history: History::default(),
        });
    }
    root.check_format(JOURNAL_FORMAT)?;
    root.only_fields(&["format", "current", "list", "undo", "redo", "layout"])?;
    let list = read_version(root)?;
    let steps = |name: &'static str| -> Result<Vec<Edit>, InputError> {
        let Some(node) = root.get(name) else {
            return Ok(Vec::new());
        };
        let items = node.items()?;
        if items.len() > super::history::DEPTH {
            return Err(node.error(format!(
                "{} steps; expected at most {}",
                items.len(),
                super::history::DEPTH
            )));
        }
        items.iter().map(read_step).collect()
    };
    let history = History {
        undo: steps("undo")?,
        redo: steps("redo")?,
    };
    Ok(Entry { list, history })
}

fn read_step(node: &Node) -> Result<Edit, InputError> {
    node.only_fields(&["what", "current", "after", "list"])?;
    let what = node
        .require("what", "what the edit did")?
        .text("what the edit did")?
        .to_string();
    let after = node
        .require("after", "the key the edit left current")?
        .integer("the key the edit left current", 0, u32::MAX.into())?;
    Ok(Edit {
        what,
        version: read_version(node)?,
        after: after as usize,
    })
}

/// `"list"` and its `"current"` key, which must be one of its keys (0 for none).
fn read_version(node: &Node) -> Result<Version, InputError> {
    let sequence = Sequence::from_node(&node.require("list", "the list of keys")?)?;
    let last = sequence.keyframes.len().saturating_sub(1);
    let current = match node.get("current") {
        Some(n) => n.integer("the current key's index", 0, last as i64)? as usize,
        None => 0,
    };
    Ok(Version { sequence, current })
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

    /// `sequence` as the only version of a list, key 0 current.
    pub(crate) fn entry(sequence: Sequence) -> Entry {
        Entry {
            list: Version {
                sequence,
                current: 0,
            },
            history: History::default(),
        }
    }

    #[test]
    fn save_pending_remove_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("seq.json");
        let journal = Journal::for_target(dir.path(), &target);
        assert!(journal.pending(&target).unwrap().is_none());
        journal.save(&entry(one_key())).unwrap();
        let pending = journal.pending(&target).unwrap().expect("offered");
        assert_eq!(pending.entry.list.sequence.to_json(), one_key().to_json());
        // An empty list removes the journal.
        journal.save(&entry(Sequence::new("so101"))).unwrap();
        assert!(!journal.path().exists());
        journal.remove().unwrap();
    }

    #[test]
    fn a_long_history_of_a_long_list_is_journaled_within_its_budget_nearest_first() {
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        // 500 keys of six joints with long decimals: about 100 KB a copy, so 100 steps would
        // be about 10 MB.
        let mut list = Sequence::new("so101");
        for k in 0..500 {
            list.keyframes.push(Keyframe::new(
                [
                    "shoulder_pan",
                    "shoulder_lift",
                    "elbow_flex",
                    "wrist_flex",
                    "wrist_roll",
                    "gripper",
                ]
                .iter()
                .map(|j| (j.to_string(), KeyValue::Joint(f64::from(k) / 7.0)))
                .collect(),
            ));
        }
        let mut saved = entry(list.clone());
        for step in 0..100 {
            saved
                .history
                .record(format!("edit {step}"), entry(list.clone()).list, 0);
        }
        // Two undone: the redo side keeps its nearest steps too.
        for _ in 0..2 {
            let back = saved.history.undo(saved.list.clone()).unwrap();
            saved.list = back.version;
        }
        journal.save(&saved).unwrap();
        let size = std::fs::metadata(journal.path()).unwrap().len() as usize;
        let one_copy = list.to_value().to_string().len();
        assert!(size <= HISTORY_BYTES + 2 * one_copy, "{size} bytes");
        let read = journal.read().unwrap();
        assert!(
            read.list.sequence.to_json() == saved.list.sequence.to_json(),
            "the list itself is always whole"
        );
        let names = |steps: &[Edit]| steps.iter().map(|s| s.what.clone()).collect::<Vec<_>>();
        let (undo, redo) = (names(&read.history.undo), names(&read.history.redo));
        // About ten copies fit in 1 MiB: the most recent edits (97, the last not undone,
        // backwards) and both undone ones (98 next, then 99).
        assert!((5..98).contains(&undo.len()), "{} undo steps", undo.len());
        assert_eq!(undo.last().map(String::as_str), Some("edit 97"));
        assert_eq!(undo, names(&saved.history.undo[98 - undo.len()..]));
        assert_eq!(redo, ["edit 99", "edit 98"]);
    }

    #[test]
    fn the_history_is_kept_with_the_list() {
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        let mut two = one_key();
        two.keyframes.push(Keyframe::new(vec![(
            "gripper".into(),
            KeyValue::Joint(-7.5),
        )]));
        let mut saved = entry(two.clone());
        saved.list.current = 1;
        saved
            .history
            .record("new key 1".into(), entry(one_key()).list, 1);
        saved
            .history
            .record("named key 1".into(), entry(two).list, 1);
        let redone = saved.history.undo(saved.list.clone()).unwrap();
        saved.list = redone.version;
        journal.save(&saved).unwrap();
        let text = std::fs::read_to_string(journal.path()).unwrap();
        assert!(
            text.starts_with("{\n  \"format\": \"keypose-journal/1\""),
            "{text}"
        );
        let mut read = journal.read().unwrap();
        // What a file read names: the journal.
        let file = journal.path().display().to_string();
        for version in std::iter::once(&mut read.list)
            .chain(read.history.undo.iter_mut().map(|s| &mut s.version))
            .chain(read.history.redo.iter_mut().map(|s| &mut s.version))
        {
            assert_eq!(version.sequence.file, file);
            version.sequence.file = "<new>".into();
            for key in &mut version.sequence.keyframes {
                key.source_index = None;
            }
        }
        assert_eq!(read, saved);
        assert_eq!(read.history.next_undo(), Some("new key 1"));
        assert_eq!(read.history.next_redo(), Some("named key 1"));
    }

    #[test]
    fn an_older_journal_is_a_list_without_history_and_a_bad_one_names_its_field() {
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        std::fs::create_dir_all(journal.path().parent().unwrap()).unwrap();
        std::fs::write(journal.path(), one_key().to_json()).unwrap();
        let read = journal.read().unwrap();
        assert_eq!(read.list.sequence.keyframes.len(), 1);
        assert_eq!(read.history, History::default());
        let bad = one_key().to_value().to_string();
        std::fs::write(
            journal.path(),
            format!(r#"{{"format": "keypose-journal/1", "current": 3, "list": {bad}}}"#),
        )
        .unwrap();
        let e = journal.read().unwrap_err().to_string();
        assert!(e.contains("$.current"), "{e}");
        assert!(e.contains("from 0 to 0"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn the_journal_is_private_0600_in_a_0700_directory() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let journal = Journal::for_target(dir.path(), &dir.path().join("seq.json"));
        journal.save(&entry(one_key())).unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(journal.path()), 0o600);
        assert_eq!(mode(journal.path().parent().unwrap()), 0o700);
    }

    #[test]
    fn a_journal_older_than_its_target_is_not_offered() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("seq.json");
        let journal = Journal::for_target(dir.path(), &target);
        journal.save(&entry(one_key())).unwrap();
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
