//! An episode's row of `meta/episodes` (docs/interop.md §1.1): which data file holds its
//! frames and which global indices they have, judged as pyarrow read them.

use super::error::{Place, Problem};
use super::reader::bad_reply;
use super::LeRobotError;
use serde_json::Value;

/// Most frames an episode may have: an hour at LeRobot's usual 30 fps. Fitting keys takes time
/// about linear in the frames (this many took 43–50 s on a busy 2-core machine, docs/interop.md
/// §1.6); longer episodes are refused before any row is read.
pub const MAX_FRAMES: u64 = 108_000;
/// Longest episode by its fps, seconds: the longest recording `keypose record` makes.
pub const MAX_SECONDS: f64 = crate::record::MAX_SECONDS;

/// Where an episode's frames are: made only by [`EpisodeSpan::from_reply`], so a span always
/// holds at least one frame and at most [`MAX_FRAMES`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EpisodeSpan {
    episode: u64,
    chunk_index: u64,
    file_index: u64,
    from: u64,
    to: u64,
}

impl EpisodeSpan {
    /// The episode's index.
    pub fn episode(&self) -> u64 {
        self.episode
    }

    /// Which data file: its chunk and file index.
    pub fn data_file(&self) -> (u64, u64) {
        (self.chunk_index, self.file_index)
    }

    /// The first global frame index.
    pub fn from(&self) -> u64 {
        self.from
    }

    /// The global frame index after the last.
    pub fn to(&self) -> u64 {
        self.to
    }

    /// Number of frames (at least one).
    pub fn frames(&self) -> u64 {
        self.to - self.from
    }

    /// The episode's span from the reader's answer to "episode" (its meta/episodes rows, and
    /// every episode index seen), refusing an episode listed twice or not at all, indices that
    /// are not whole numbers, an empty span, a `length` that contradicts it, and spans above
    /// [`MAX_FRAMES`].
    pub fn from_reply(place: &Place, fps: f64, reply: &Value) -> Result<EpisodeSpan, LeRobotError> {
        let rows = reply
            .get("rows")
            .and_then(Value::as_array)
            .ok_or_else(|| bad_reply("rows", reply))?;
        let row = match rows.as_slice() {
            [] => {
                let known = reply
                    .get("episodes")
                    .and_then(Value::as_array)
                    .map(|e| known_episodes(e))
                    .unwrap_or_default();
                return Err(place.error(Problem::NotListed { known }));
            }
            [row] => row,
            more => {
                return Err(place.error(Problem::ListedTwice {
                    count: more.len(),
                    rows: more.iter().map(row_name).collect::<Vec<_>>().join(", "),
                }))
            }
        };
        let number = |column: &str| -> Result<u64, LeRobotError> {
            let found = row.get(column).unwrap_or(&Value::Null);
            found.as_u64().ok_or_else(|| {
                place.error(Problem::MetaNumber {
                    row: row_name(row),
                    column: column.to_string(),
                    found: crate::json::describe(found),
                })
            })
        };
        let (from, to) = (number("dataset_from_index")?, number("dataset_to_index")?);
        let span = EpisodeSpan {
            episode: place.episode,
            chunk_index: number("data/chunk_index")?,
            file_index: number("data/file_index")?,
            from,
            to,
        };
        if to <= from {
            return Err(place.error(Problem::Empty { from, to }));
        }
        if row.get("length").is_some_and(|l| !l.is_null()) {
            let length = number("length")?;
            if length != to - from {
                return Err(place.error(Problem::Length {
                    length,
                    from,
                    to,
                    span: to - from,
                }));
            }
        }
        span.check_length(place, fps)?;
        Ok(span)
    }

    /// Refuses a span of more than [`MAX_FRAMES`] frames or [`MAX_SECONDS`] at `fps`.
    fn check_length(&self, place: &Place, fps: f64) -> Result<(), LeRobotError> {
        let seconds = (self.frames() - 1) as f64 / fps;
        // NaN seconds (an fps of 0 cannot pass info.rs, but this is no place to rely on it).
        if self.frames() > MAX_FRAMES || seconds.is_nan() || seconds > MAX_SECONDS {
            return Err(place.error(Problem::TooLong {
                frames: self.frames(),
                seconds,
                fps,
                from: self.from,
                to: self.to,
                max_frames: MAX_FRAMES,
                max_seconds: MAX_SECONDS,
            }));
        }
        Ok(())
    }
}

/// "meta/episodes/chunk-000/file-000.parquet row 3", for messages.
fn row_name(row: &Value) -> String {
    let file = row.get("file").and_then(Value::as_str).unwrap_or("?");
    match row.get("row").and_then(Value::as_u64) {
        Some(r) => format!("{file} row {r}"),
        None => file.to_string(),
    }
}

/// "0, 1, 2" (the first few and a count beyond them).
fn known_episodes(episodes: &[Value]) -> String {
    const SHOWN: usize = 20;
    let mut text: Vec<String> = episodes
        .iter()
        .take(SHOWN)
        .map(crate::json::describe)
        .collect();
    if episodes.len() > SHOWN {
        text.push(format!("… {} in all", episodes.len()));
    }
    if text.is_empty() {
        return "none".into();
    }
    text.join(", ")
}

/// The span of episode `episode` over [from, to) in data file 0, for tests of what reads it.
#[cfg(test)]
pub(crate) fn span_for_tests(episode: u64, from: u64, to: u64) -> EpisodeSpan {
    let reply = serde_json::json!({"rows": [{"episode_index": episode, "data/chunk_index": 0,
        "data/file_index": 0, "dataset_from_index": from, "dataset_to_index": to}]});
    EpisodeSpan::from_reply(&Place::episode("test", episode), 30.0, &reply).expect("a sound span")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn place() -> Place {
        Place::episode("ds", 3)
    }

    fn row(from: Value, to: Value) -> Value {
        json!({"rows": [{"file": "meta/episodes/chunk-000/file-000.parquet", "row": 3,
            "episode_index": 3, "data/chunk_index": 0, "data/file_index": 1,
            "dataset_from_index": from, "dataset_to_index": to}], "episodes": [0, 1, 2, 3]})
    }

    #[test]
    fn a_sound_row_gives_the_span() {
        let span = EpisodeSpan::from_reply(&place(), 30.0, &row(json!(100), json!(190))).unwrap();
        assert_eq!(
            (span.data_file(), span.from(), span.to()),
            ((0, 1), 100, 190)
        );
        assert_eq!(span.frames(), 90);
    }

    #[test]
    fn bad_rows_are_refused_naming_the_episode_and_column() {
        for (from, to, says) in [
            (json!(5), json!(5), "no frames"),
            (json!(9), json!(5), "no frames"),
            (json!(-1), json!(5), "dataset_from_index = -1"),
            (json!(1.5), json!(5), "dataset_from_index = 1.5"),
            (json!(0), json!("nan"), "dataset_to_index = \"nan\""),
            (json!(0), json!(MAX_FRAMES + 1), "at most 108000 frames"),
        ] {
            let error = EpisodeSpan::from_reply(&place(), 30.0, &row(from, to)).unwrap_err();
            let text = error.to_string();
            assert!(error.is_bad_input(), "{text}");
            assert!(text.starts_with("ds: episode 3: "), "{text}");
            assert!(text.contains(says), "{text}");
        }
    }

    #[test]
    fn an_episode_longer_than_an_hour_at_its_fps_is_refused() {
        // 36 001 frames at 10 fps span exactly 3600 s; one more is 3600.1 s.
        assert!(EpisodeSpan::from_reply(&place(), 10.0, &row(json!(0), json!(36_001))).is_ok());
        let text = EpisodeSpan::from_reply(&place(), 10.0, &row(json!(0), json!(36_002)))
            .unwrap_err()
            .to_string();
        assert!(text.contains("36002 frames, 3600.1 s at fps 10"), "{text}");
    }

    #[test]
    fn an_episode_listed_twice_or_not_at_all_is_refused() {
        let mut twice = row(json!(0), json!(5));
        let first = twice["rows"][0].clone();
        twice["rows"].as_array_mut().unwrap().push(first);
        let text = EpisodeSpan::from_reply(&place(), 30.0, &twice)
            .unwrap_err()
            .to_string();
        assert!(text.contains("listed 2 times"), "{text}");
        let none = json!({"rows": [], "episodes": [0, 1]});
        let text = EpisodeSpan::from_reply(&place(), 30.0, &none)
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("not in meta/episodes (episodes there: 0, 1)"),
            "{text}"
        );
    }
}
