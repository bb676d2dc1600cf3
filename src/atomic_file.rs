//! Writing files atomically: readers, and a crash at any moment, see the old file or the new one,
//! never an empty or torn one. Every file keypose writes goes through here.
//!
//! The bytes go to a temporary file created exclusively (`O_EXCL`, an unpredictable name) in the
//! target's directory, which is flushed to disk, renamed over the target, and the directory is
//! flushed so that the rename itself survives a power cut. Around that:
//!
//! - a symbolic link is followed and its target replaced, so the link stays a link;
//! - an existing file keeps its permission bits (owner and group are not copied: keypose writes
//!   as the user it runs as);
//! - temporaries are named `.NAME.keypose-tmp-PID-RANDOM`, and those of the same target left by
//!   a process that is no longer running (killed mid-write) are removed on the next write;
//! - private files (the teach journal, the cache) are created `0600` in `0700` directories;
//! - a target that exists and is not a regular file (`/dev/stdout`, a FIFO) cannot be replaced
//!   by a rename, so it is written straight through.
//!
//! A file written over a long time (a playback log) can be put in place early and then grow
//! there (`AtomicFile::publish`): readers, and a kill at any moment, then see the old file or
//! the new one up to its last write, so a writer that writes whole lines leaves whole lines.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Who may read the file once written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Privacy {
    /// A new file gets the usual mode (0666 less the umask); an existing one keeps its own.
    Shared,
    /// Only the user: mode 0600, whatever the file had before (journals hold unsaved work).
    Private,
}

/// Marks keypose's temporaries: `.NAME` + this + `PID-RANDOM`.
const TEMP_MARK: &str = ".keypose-tmp-";
/// Symbolic links followed before giving up, as the kernel's own limit.
const MAX_LINKS: usize = 40;
/// Where `/proc` cannot tell whether a temporary's writer still runs, it is stale after this.
const STALE_WITHOUT_PROC: std::time::Duration = std::time::Duration::from_secs(24 * 3600);

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_with(path, Privacy::Shared, |out| out.write_all(bytes))
}

/// Writes `bytes` to `path` atomically, readable by the user only.
pub(crate) fn write_private(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_with(path, Privacy::Private, |out| out.write_all(bytes))
}

/// Writes what `fill` produces to `path` atomically. If `fill` fails, the target is untouched
/// and the temporary removed.
fn write_with(
    path: &Path,
    privacy: Privacy,
    fill: impl FnOnce(&mut AtomicFile) -> io::Result<()>,
) -> io::Result<()> {
    let mut file = AtomicFile::create(path, privacy)?;
    fill(&mut file)?;
    file.commit()
}

/// Creates `dir` and its missing parents as `0700`: they hold the user's private data. An
/// existing directory is left as it is (it may be one the user chose to share, such as
/// `$KEYPOSE_CACHE=/tmp/k`); use [`make_private_dir`] for a directory keypose alone owns.
pub(crate) fn create_private_dir(dir: &Path) -> io::Result<()> {
    let mut builder = fs::DirBuilder::new();
    builder.recursive(true);
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
    builder.create(dir)
}

/// Creates `dir` as [`create_private_dir`] does and, when it already existed with wider
/// permissions (made by an older keypose), narrows it to `0700`.
pub(crate) fn make_private_dir(dir: &Path) -> io::Result<()> {
    create_private_dir(dir)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = fs::metadata(dir)?.permissions().mode() & 0o777;
        if mode != 0o700 {
            fs::set_permissions(dir, fs::Permissions::from_mode(0o700))?;
        }
    }
    Ok(())
}

/// A file being written: bytes go to the temporary until [`AtomicFile::commit`] renames it over
/// the target. Dropped without a commit, the temporary is removed and the target untouched.
pub(crate) struct AtomicFile {
    file: File,
    /// `None` when the target is not a regular file and is written straight through.
    staged: Option<Staged>,
}

struct Staged {
    temp: PathBuf,
    target: PathBuf,
    /// Renamed over the target already ([`AtomicFile::publish`]): the writes go on there.
    published: bool,
}

impl AtomicFile {
    /// Opens a temporary beside `path` (beside its final target, when `path` is a link).
    pub fn create(path: &Path, privacy: Privacy) -> io::Result<AtomicFile> {
        if let Some(special) = existing_non_regular(path)? {
            return Ok(special);
        }
        let target = resolve_links(path)?;
        let dir = parent_dir(&target);
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?
            .to_string_lossy()
            .into_owned();
        let prefix = format!(".{name}{TEMP_MARK}");
        remove_orphans(&dir, &prefix);
        let (temp, file) = create_temp(&dir, &prefix, privacy)?;
        let staged = Staged {
            temp,
            target,
            published: false,
        };
        // From here on, a failure removes the temporary (Drop).
        let atomic = AtomicFile {
            file,
            staged: Some(staged),
        };
        if let Some(staged) = &atomic.staged {
            keep_permissions(&staged.target, &atomic.file, privacy)?;
        }
        Ok(atomic)
    }

    /// Flushes the bytes to disk and puts them in place of the target.
    pub fn commit(mut self) -> io::Result<()> {
        self.file.flush()?;
        let Some(staged) = self.staged.take() else {
            return Ok(());
        };
        if staged.published {
            return self.file.sync_all();
        }
        let result = self.file.sync_all().and_then(|_| {
            fs::rename(&staged.temp, &staged.target)?;
            sync_dir(&parent_dir(&staged.target))
        });
        if result.is_err() {
            let _ = fs::remove_file(&staged.temp);
        }
        result
    }

    /// Puts what is written so far in place of the target now, and goes on writing there: each
    /// later write lands in the target itself, and [`AtomicFile::commit`] only flushes it to
    /// disk. Dropped without a commit, a published file stays. Calling it again does nothing.
    pub fn publish(&mut self) -> io::Result<()> {
        self.file.flush()?;
        let Some(staged) = self.staged.as_mut().filter(|s| !s.published) else {
            return Ok(());
        };
        self.file.sync_all()?;
        fs::rename(&staged.temp, &staged.target)?;
        staged.published = true;
        sync_dir(&parent_dir(&staged.target))
    }

    /// Cuts what is written back to its first `len` bytes and goes on writing there: a write
    /// that failed part-way (a full disk) leaves no part of what it was writing.
    pub fn truncate(&mut self, len: u64) -> io::Result<()> {
        use std::io::{Seek, SeekFrom};
        self.file.set_len(len)?;
        self.file.seek(SeekFrom::Start(len)).map(|_| ())
    }

    /// Whether the temporary is in place of the target already ([`AtomicFile::publish`]).
    pub fn published(&self) -> bool {
        self.staged.as_ref().is_none_or(|s| s.published)
    }

    /// The temporary being written (`None` when written straight through or published).
    #[cfg(test)]
    fn temp_path(&self) -> Option<&Path> {
        self.staged
            .as_ref()
            .filter(|s| !s.published)
            .map(|s| s.temp.as_path())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(staged) = self.staged.as_ref().filter(|s| !s.published) {
            let _ = fs::remove_file(&staged.temp);
        }
    }
}

/// A target that exists and is not a regular file: a directory is refused; a device or FIFO
/// (`-o /dev/stdout`) is opened and written straight through, as a rename would replace the
/// device node rather than write to it.
fn existing_non_regular(path: &Path) -> io::Result<Option<AtomicFile>> {
    let meta = match fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    if meta.is_file() {
        return Ok(None);
    }
    if meta.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            "is a directory; expected a file name",
        ));
    }
    let file = OpenOptions::new().write(true).open(path)?;
    Ok(Some(AtomicFile { file, staged: None }))
}

/// The file a chain of symbolic links ends at (which may not exist yet).
fn resolve_links(path: &Path) -> io::Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = fs::read_link(&current)?;
                current = parent_dir(&current).join(link);
            }
            _ => return Ok(current),
        }
    }
    Err(io::Error::other(format!(
        "more than {MAX_LINKS} levels of symbolic links"
    )))
}

fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Creates `dir/PREFIX<pid>-<random>` exclusively: never an existing file, never one another
/// process placed there (a link planted under a predictable name would redirect the write).
fn create_temp(dir: &Path, prefix: &str, privacy: Privacy) -> io::Result<(PathBuf, File)> {
    let mut options = OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    if privacy == Privacy::Private {
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    }
    #[cfg(not(unix))]
    let _ = privacy;
    loop {
        let temp = dir.join(format!(
            "{prefix}{}-{:016x}",
            std::process::id(),
            random_u64()
        ));
        match options.open(&temp) {
            Ok(file) => return Ok((temp, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
}

/// An unpredictable number: std's `RandomState` is seeded from the operating system's random
/// source; the counter and the clock make successive values differ within a process.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    hasher.write_u128(nanos);
    hasher.finish()
}

/// Gives the temporary the permissions the target has (or 0600 for a private file).
fn keep_permissions(target: &Path, temp: &File, privacy: Privacy) -> io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = match (privacy, fs::metadata(target)) {
            (Privacy::Private, _) => 0o600,
            (Privacy::Shared, Ok(meta)) => meta.permissions().mode() & 0o7777,
            (Privacy::Shared, Err(_)) => return Ok(()),
        };
        temp.set_permissions(fs::Permissions::from_mode(mode))?;
    }
    #[cfg(not(unix))]
    {
        let _ = privacy;
        if let Ok(meta) = fs::metadata(target) {
            temp.set_permissions(meta.permissions())?;
        }
    }
    Ok(())
}

/// Removes temporaries of the same target whose writer is gone: left by a crash or a kill. A
/// temporary of a running process (another keypose writing the same file now) is kept.
fn remove_orphans(dir: &Path, prefix: &str) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(prefix)) else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if is_orphan(&entry, pid) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

fn is_orphan(entry: &fs::DirEntry, pid: Option<u32>) -> bool {
    if !entry.file_type().is_ok_and(|t| t.is_file()) {
        return false;
    }
    let proc_fs = Path::new("/proc/self");
    match pid {
        Some(pid) if proc_fs.exists() => !Path::new("/proc").join(pid.to_string()).exists(),
        _ => entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > STALE_WITHOUT_PROC),
    }
}

/// Flushes a directory's entries, so that a rename in it is on disk. File systems that cannot
/// sync a directory (some network and FUSE ones answer EINVAL) are not an error: the rename has
/// happened, and reporting the write as failed would be false.
fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        match File::open(dir)?.sync_all() {
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::InvalidInput | io::ErrorKind::Unsupported
                ) =>
            {
                Ok(())
            }
            other => other,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(unix)]
    use std::os::unix::fs::PermissionsExt;

    /// Names in `dir` other than `keep`.
    fn others(dir: &Path, keep: &[&str]) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| !keep.contains(&n.as_str()))
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_write_that_fails_midway_leaves_the_old_content_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.json");
        fs::write(&path, "old content\n").unwrap();
        let result = write_with(&path, Privacy::Shared, |out| {
            out.write_all(b"half of the new")?;
            Err(io::Error::other("the data source failed"))
        });
        assert_eq!(result.unwrap_err().to_string(), "the data source failed");
        assert_eq!(fs::read_to_string(&path).unwrap(), "old content\n");
        assert_eq!(others(dir.path(), &["seq.json"]), Vec::<String>::new());
    }

    #[test]
    fn a_write_replaces_the_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        fs::write(&path, "a much longer old content than the new one\n").unwrap();
        write(&path, b"new\n").unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new\n");
        write(&dir.path().join("fresh.csv"), b"x").unwrap();
        assert_eq!(fs::read(dir.path().join("fresh.csv")).unwrap(), b"x");
        assert_eq!(
            others(dir.path(), &["out.csv", "fresh.csv"]),
            Vec::<String>::new()
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_stays_a_link_and_its_target_is_updated() {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("real")).unwrap();
        let target = dir.path().join("real").join("seq.json");
        fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.json");
        // A relative link, resolved against the link's own directory.
        std::os::unix::fs::symlink("real/seq.json", &link).unwrap();
        write(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(fs::read_link(&link).unwrap(), Path::new("real/seq.json"));
        assert_eq!(fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(
            others(&dir.path().join("real"), &["seq.json"]),
            Vec::<String>::new()
        );
    }

    #[cfg(unix)]
    #[test]
    fn an_existing_files_permissions_are_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.json");
        fs::write(&path, "old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
        write(&path, b"new").unwrap();
        let mode = fs::metadata(&path).unwrap().permissions().mode() & 0o7777;
        assert_eq!(mode, 0o640);
    }

    #[cfg(unix)]
    #[test]
    fn private_files_are_0600_even_when_they_were_wider() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("journal.json");
        fs::write(&path, "old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o644)).unwrap();
        write_private(&path, b"new").unwrap();
        assert_eq!(
            fs::metadata(&path).unwrap().permissions().mode() & 0o777,
            0o600
        );
        write_private(&dir.path().join("fresh.json"), b"x").unwrap();
        let fresh = fs::metadata(dir.path().join("fresh.json")).unwrap();
        assert_eq!(fresh.permissions().mode() & 0o777, 0o600);
    }

    #[cfg(unix)]
    #[test]
    fn private_directories_are_0700_and_narrowed_when_keypose_owns_them() {
        let dir = tempfile::tempdir().unwrap();
        let nested = dir.path().join("cache").join("teach");
        create_private_dir(&nested).unwrap();
        for d in [dir.path().join("cache"), nested.clone()] {
            assert_eq!(
                fs::metadata(&d).unwrap().permissions().mode() & 0o777,
                0o700
            );
        }
        fs::set_permissions(&nested, fs::Permissions::from_mode(0o755)).unwrap();
        make_private_dir(&nested).unwrap();
        assert_eq!(
            fs::metadata(&nested).unwrap().permissions().mode() & 0o777,
            0o700
        );
    }

    #[test]
    fn an_orphan_temporary_of_a_dead_process_is_removed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.json");
        // A process that has exited: its pid names no running process (until reused).
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let orphan = format!(".seq.json.keypose-tmp-{dead}-00000000deadbeef");
        fs::write(dir.path().join(&orphan), "half").unwrap();
        // A live process's temporary, and another file's, are left alone.
        let live = format!(
            ".seq.json.keypose-tmp-{}-0000000000000001",
            std::process::id()
        );
        fs::write(dir.path().join(&live), "in progress").unwrap();
        let other = format!(".other.json.keypose-tmp-{dead}-0000000000000002");
        fs::write(dir.path().join(&other), "not ours").unwrap();
        write(&path, b"new").unwrap();
        assert_eq!(others(dir.path(), &["seq.json"]), {
            let mut v = vec![live, other];
            v.sort();
            v
        });
    }

    #[test]
    fn temporaries_have_unpredictable_names() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("seq.json");
        let a = AtomicFile::create(&path, Privacy::Shared).unwrap();
        let b = AtomicFile::create(&path, Privacy::Shared).unwrap();
        let (ta, tb) = (a.temp_path().unwrap(), b.temp_path().unwrap());
        assert_ne!(ta, tb);
        let name = ta.file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with(".seq.json.keypose-tmp-"), "{name}");
        drop((a, b));
        assert_eq!(others(dir.path(), &[]), Vec::<String>::new());
    }

    #[test]
    fn a_published_file_is_in_place_while_it_grows_and_stays_when_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("play.csv");
        fs::write(&path, "an earlier log\n").unwrap();
        let mut file = AtomicFile::create(&path, Privacy::Shared).unwrap();
        file.write_all(b"time\n").unwrap();
        // Not published yet: the earlier file is what a reader sees.
        assert_eq!(fs::read_to_string(&path).unwrap(), "an earlier log\n");
        file.publish().unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "time\n");
        assert_eq!(file.temp_path(), None);
        file.write_all(b"0.01\n").unwrap();
        file.publish().unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "time\n0.01\n");
        // A writer that stops without committing (a kill) leaves what it wrote, no temporary.
        drop(file);
        assert_eq!(fs::read_to_string(&path).unwrap(), "time\n0.01\n");
        assert_eq!(others(dir.path(), &["play.csv"]), Vec::<String>::new());
        // Committed after publishing: the same file, complete.
        let mut file = AtomicFile::create(&path, Privacy::Shared).unwrap();
        file.write_all(b"a\n").unwrap();
        file.publish().unwrap();
        file.write_all(b"b\n").unwrap();
        file.commit().unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "a\nb\n");
        assert_eq!(others(dir.path(), &["play.csv"]), Vec::<String>::new());
    }

    #[test]
    fn a_directory_is_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let err = write(dir.path(), b"x").unwrap_err();
        assert!(err.to_string().contains("directory"), "{err}");
    }

    /// A FIFO in a temporary directory, not a device under /dev: a broken writer running as
    /// root would replace the machine's device node.
    #[cfg(unix)]
    #[test]
    fn a_fifo_is_written_through_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read_to_string(fifo).unwrap())
        };
        write(&fifo, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe");
        assert!(fs::metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(others(dir.path(), &["pipe"]), Vec::<String>::new());
    }
}
