//! Opening input files defensively: only regular files, and no more bytes than a sane input has.
//!
//! A FIFO or a character device (`/dev/zero`, a serial port given by mistake) would be read
//! forever, and a huge file read whole would take memory without bound; both are refused up
//! front as bad input (exit 2) naming the file.

use super::{InputError, Location};
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Largest sequence, robot or calibration file: a 100 000-key sequence with every joint named
/// takes about 10 MB.
pub const MAX_INPUT_BYTES: u64 = 16 * 1024 * 1024;

/// Largest playback log read back (`plot --log`): about two hours at 100 Hz for a 6-joint arm.
pub const MAX_LOG_BYTES: u64 = 256 * 1024 * 1024;

/// Opens `path` for reading if it is a regular file (symbolic links followed).
pub fn open_regular(path: &Path) -> Result<File, InputError> {
    let label = path.display().to_string();
    let cannot_read =
        |e: std::io::Error| InputError::new(&label, Location::File, format!("cannot read: {e}"));
    // Looked at before opening: opening a FIFO for reading blocks until a writer comes.
    let meta = std::fs::metadata(path).map_err(cannot_read)?;
    refuse_non_regular(&label, &meta)?;
    let file = File::open(path).map_err(cannot_read)?;
    // And again on what was opened, in case the name was swapped in between.
    refuse_non_regular(&label, &file.metadata().map_err(cannot_read)?)?;
    Ok(file)
}

/// Refuses `path` unless it is a regular file (symbolic links followed), without opening it:
/// for a file another program reads (a dataset's parquet file, which the reader process would
/// wait on forever were it a FIFO).
pub fn require_regular(path: &Path) -> Result<(), InputError> {
    let label = path.display().to_string();
    let meta = std::fs::metadata(path)
        .map_err(|e| InputError::new(&label, Location::File, format!("cannot read: {e}")))?;
    refuse_non_regular(&label, &meta)
}

/// Reads a regular file of at most `max_bytes` as UTF-8 text.
pub fn read_text(path: &Path, max_bytes: u64) -> Result<String, InputError> {
    let label = path.display().to_string();
    let file = open_regular(path)?;
    let too_big = |size: u64| {
        InputError::new(
            &label,
            Location::File,
            format!(
                "is {size} bytes; expected at most {} MiB ({max_bytes} bytes) for an input file",
                max_bytes / (1024 * 1024)
            ),
        )
    };
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    if size > max_bytes {
        return Err(too_big(size));
    }
    // Capped while reading too: the file may grow after its size was looked at.
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::new(&label, Location::File, format!("cannot read: {e}")))?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|e| {
        InputError::new(
            &label,
            Location::File,
            format!(
                "expected UTF-8 text, found invalid UTF-8 at byte {}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

fn refuse_non_regular(label: &str, meta: &std::fs::Metadata) -> Result<(), InputError> {
    if meta.is_file() {
        return Ok(());
    }
    Err(InputError::new(
        label,
        Location::File,
        format!("is {}; expected a regular file", kind_of(meta)),
    ))
}

/// "a directory", "a FIFO", … for the message.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    if meta.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn devices_fifos_and_directories_are_refused_without_reading() {
        let err = read_text(Path::new("/dev/zero"), MAX_INPUT_BYTES).unwrap_err();
        assert_eq!(
            err.to_string(),
            "/dev/zero: is a character device; expected a regular file"
        );
        let dir = tempfile::tempdir().unwrap();
        let err = read_text(dir.path(), MAX_INPUT_BYTES).unwrap_err();
        assert!(err.message.contains("is a directory"), "{err}");
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.unwrap().success());
        // No writer ever opens it: reading would block forever.
        let err = read_text(&fifo, MAX_INPUT_BYTES).unwrap_err();
        assert!(err.message.contains("is a FIFO"), "{err}");
    }

    #[test]
    fn a_file_over_the_cap_is_refused_with_its_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.json");
        std::fs::write(&path, vec![b' '; 1025]).unwrap();
        let err = read_text(&path, 1024).unwrap_err();
        assert!(
            err.message.starts_with("is 1025 bytes; expected at most"),
            "{err}"
        );
        std::fs::write(&path, vec![b' '; 1024]).unwrap();
        assert_eq!(read_text(&path, 1024).unwrap().len(), 1024);
    }
}
