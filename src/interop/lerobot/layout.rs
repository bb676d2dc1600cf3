//! Which files of a dataset are read, all of them inside its folder (docs/interop.md §1.1):
//! `meta/episodes/chunk-*/file-*.parquet`, and the data file `data_path` names for an episode
//! once its `{chunk_index}` and `{file_index}` are filled in.
//!
//! A path is refused when it is absolute, when its `..` lead above the folder, or when a
//! symbolic link on the way resolves outside the folder: a dataset says what is in it, never
//! what else on the machine to read.

use super::error::PathProblem;
use super::{DatasetInfo, EpisodeSpan, LeRobotError};
use std::path::{Component, Path, PathBuf};

/// Why a `data_path` template is not one keypose fills in.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TemplateError {
    /// A `}` that closes nothing and is not doubled.
    #[error("a single \"}}\" (write \"}}}}\" for a brace)")]
    LoneClose,
    /// A `{` that is never closed.
    #[error("a \"{{\" without its \"}}\"")]
    Unclosed,
    /// A field other than `chunk_index` and `file_index`.
    #[error("{{{field}}} is no field keypose fills in (chunk_index, file_index)")]
    UnknownField {
        /// The field's name.
        field: String,
    },
    /// A format spec other than a width, zero-padded or not, with or without `d`.
    #[error("format {spec:?} is not one keypose reads (such as 03d)")]
    Format {
        /// The spec after the colon.
        spec: String,
    },
}

/// `template` (Python's `str.format` syntax, as LeRobot writes `data_path`) with its
/// `{chunk_index}` and `{file_index}` filled in. Takes the subset LeRobot uses: `{name}` and
/// `{name:0Nd}`-like zero padding, `{{` and `}}` for braces.
pub fn fill_template(
    template: &str,
    chunk_index: u64,
    file_index: u64,
) -> Result<String, TemplateError> {
    let mut out = String::with_capacity(template.len() + 8);
    let mut chars = template.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '{' if chars.peek() == Some(&'{') => {
                chars.next();
                out.push('{');
            }
            '}' if chars.peek() == Some(&'}') => {
                chars.next();
                out.push('}');
            }
            '}' => return Err(TemplateError::LoneClose),
            '{' => {
                let mut field = String::new();
                loop {
                    match chars.next() {
                        Some('}') => break,
                        Some(c) => field.push(c),
                        None => return Err(TemplateError::Unclosed),
                    }
                }
                let (name, spec) = field.split_once(':').unwrap_or((field.as_str(), ""));
                let value = match name {
                    "chunk_index" => chunk_index,
                    "file_index" => file_index,
                    other => {
                        return Err(TemplateError::UnknownField {
                            field: other.to_string(),
                        })
                    }
                };
                out.push_str(&format_index(value, spec)?);
            }
            c => out.push(c),
        }
    }
    Ok(out)
}

/// `value` as Python formats it with `spec`: empty, `d`, `N`, `0N`, `Nd` or `0Nd`.
fn format_index(value: u64, spec: &str) -> Result<String, TemplateError> {
    let digits = spec.strip_suffix('d').unwrap_or(spec);
    let (zero, width) = match digits.strip_prefix('0') {
        Some(rest) if !rest.is_empty() => (true, rest),
        _ => (false, digits),
    };
    let unread = || TemplateError::Format {
        spec: spec.to_string(),
    };
    if !width.chars().all(|c| c.is_ascii_digit()) || width.len() > 2 {
        return Err(unread());
    }
    let width: usize = if width.is_empty() {
        0
    } else {
        width.parse().map_err(|_| unread())?
    };
    Ok(if zero {
        format!("{value:0width$}")
    } else {
        format!("{value:>width$}")
    })
}

/// Refuses a relative path that is absolute or whose `..` climb above where it starts.
pub fn check_relative(path: &str) -> Result<(), PathProblem> {
    if path.is_empty() {
        return Err(PathProblem::Unreadable {
            path: path.to_string(),
            reason: "an empty path".into(),
        });
    }
    let mut depth = 0usize;
    for component in Path::new(path).components() {
        match component {
            Component::Prefix(_) | Component::RootDir => {
                return Err(PathProblem::Absolute {
                    path: path.to_string(),
                })
            }
            Component::CurDir => {}
            Component::ParentDir => {
                depth = depth.checked_sub(1).ok_or_else(|| PathProblem::Escapes {
                    path: path.to_string(),
                })?;
            }
            Component::Normal(_) => depth += 1,
        }
    }
    Ok(())
}

/// `relative` inside `dir`, checked as written ([`check_relative`]) and as it resolves on disk
/// (symbolic links). Returns the path to read.
pub fn inside(dir: &Path, relative: &str) -> Result<PathBuf, PathProblem> {
    check_relative(relative)?;
    let unreadable = |e: std::io::Error| PathProblem::Unreadable {
        path: relative.to_string(),
        reason: if e.kind() == std::io::ErrorKind::NotFound {
            "no such file".to_string()
        } else {
            e.to_string()
        },
    };
    let root = dir.canonicalize().map_err(unreadable)?;
    let path = dir.join(relative);
    let resolved = path.canonicalize().map_err(unreadable)?;
    if !resolved.starts_with(&root) {
        return Err(PathProblem::LinkedOut {
            path: relative.to_string(),
            resolved: resolved.display().to_string(),
            dir: root.display().to_string(),
        });
    }
    Ok(path)
}

/// The data file of `span`'s episode: `info`'s `data_path` filled in with its chunk and file
/// index, inside the dataset at `dir`. Returns the path relative to the dataset, as written.
pub fn data_file(
    dir: &Path,
    info: &DatasetInfo,
    span: &EpisodeSpan,
) -> Result<String, LeRobotError> {
    let relative = data_path(info, span)?;
    inside(dir, &relative).map_err(|problem| data_path_error(info, span, problem))?;
    // Bad input at once, not a reader waiting on a FIFO until its timeout.
    crate::json::input_file::require_regular(&dir.join(&relative))?;
    Ok(relative)
}

/// [`data_file`] as written, without looking at the disk: filled in and [`check_relative`].
pub fn data_path(info: &DatasetInfo, span: &EpisodeSpan) -> Result<String, LeRobotError> {
    let (chunk_index, file_index) = span.data_file();
    let relative = fill_template(&info.data_path, chunk_index, file_index)
        .map_err(|reason| data_path_error(info, span, PathProblem::Template { reason }))?;
    check_relative(&relative).map_err(|problem| data_path_error(info, span, problem))?;
    Ok(relative)
}

fn data_path_error(info: &DatasetInfo, span: &EpisodeSpan, problem: PathProblem) -> LeRobotError {
    LeRobotError::DataPath {
        file: info.file.clone(),
        template: info.data_path.clone(),
        episode: span.episode(),
        problem: Box::new(problem),
    }
}

/// `meta/episodes/chunk-*/file-*.parquet` relative to `dir`, sorted, each inside the dataset.
pub fn episode_files(dir: &Path) -> Result<Vec<String>, LeRobotError> {
    let dataset = dir.display().to_string();
    let episodes = Path::new("meta").join("episodes");
    let mut files = Vec::new();
    for chunk in entries(&dir.join(&episodes), "chunk-", "")? {
        let chunk_dir = episodes.join(&chunk);
        if !dir.join(&chunk_dir).is_dir() {
            continue;
        }
        for file in entries(&dir.join(&chunk_dir), "file-", ".parquet")? {
            files.push(chunk_dir.join(file).display().to_string());
        }
    }
    files.sort();
    for file in &files {
        inside(dir, file).map_err(|problem| LeRobotError::Layout {
            dataset: dataset.clone(),
            problem: Box::new(problem),
        })?;
        crate::json::input_file::require_regular(&dir.join(file))?;
    }
    Ok(files)
}

/// The names in `dir` that start with `prefix` and end with `suffix` (none if `dir` is
/// missing).
fn entries(dir: &Path, prefix: &str, suffix: &str) -> Result<Vec<String>, LeRobotError> {
    let Ok(listing) = std::fs::read_dir(dir) else {
        return Ok(Vec::new());
    };
    let mut names = Vec::new();
    for entry in listing {
        let entry = entry.map_err(|e| LeRobotError::Dataset {
            dir: dir.display().to_string(),
            message: format!("listing the folder: {e}"),
        })?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(prefix) && name.ends_with(suffix) {
            names.push(name);
        }
    }
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lerobot_templates_fill_as_python_formats_them() {
        // "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet".format(chunk_index=1,
        // file_index=12) in Python is "data/chunk-001/file-012.parquet".
        assert_eq!(
            fill_template(super::super::info::DEFAULT_DATA_PATH, 1, 12).unwrap(),
            "data/chunk-001/file-012.parquet"
        );
        assert_eq!(fill_template("{file_index}/{{x}}", 0, 7).unwrap(), "7/{x}");
        assert_eq!(fill_template("{file_index:4}", 0, 7).unwrap(), "   7");
        assert_eq!(
            fill_template("{file_index:03d}", 0, 12345).unwrap(),
            "12345"
        );
        for bad in [
            "{episode}",
            "{chunk_index",
            "a}b",
            "{file_index:x}",
            "{file_index:>3}",
        ] {
            assert!(fill_template(bad, 0, 0).is_err(), "{bad}");
        }
    }

    #[test]
    fn absolute_and_escaping_paths_are_refused_as_written() {
        assert!(check_relative("data/chunk-000/file-000.parquet").is_ok());
        assert!(check_relative("data/../data/file.parquet").is_ok());
        assert!(matches!(
            check_relative("/etc/passwd"),
            Err(PathProblem::Absolute { .. })
        ));
        for escaping in ["../x.parquet", "data/../../x.parquet", "./../x"] {
            assert!(
                matches!(check_relative(escaping), Err(PathProblem::Escapes { .. })),
                "{escaping}"
            );
        }
    }
}
