//! An episode's frames out of the reader's answer to "rows" (what pyarrow read from the data
//! file), judged before anything is made of them: every frame of the span present once, each
//! row of the episode, as many rows of the episode in the file as the span says, each row as
//! wide as the feature's names, every value and timestamp a finite number.

use super::episode::EpisodeSpan;
use super::error::{Place, Problem};
use super::reader::bad_reply;
use super::LeRobotError;
use serde_json::Value;

/// The frames of one episode, in frame order.
#[derive(Debug, Clone, PartialEq)]
pub struct Frames {
    /// The column's Arrow type (`list<element: float>`, `fixed_size_list<…>[6]`).
    pub column_type: String,
    /// The `timestamp` column, seconds, if the file has one.
    pub timestamps: Option<Vec<f64>>,
    /// One row of the field per frame.
    pub values: Vec<Vec<f64>>,
}

/// The reader's answer to "rows", its arrays checked to be of one length (the reader's
/// promise: a broken one is the reader's fault, not the dataset's).
struct Reply<'a> {
    whole: &'a Value,
    index: &'a [Value],
    episode: &'a [Value],
    timestamps: Option<&'a [Value]>,
    lengths: &'a [Value],
    /// Every row's values, one row after the other.
    flat: &'a [Value],
    episode_rows: u64,
    column_type: &'a str,
}

impl<'a> Reply<'a> {
    fn parse(reply: &'a Value) -> Result<Reply<'a>, LeRobotError> {
        let array = |name: &str| {
            reply
                .get(name)
                .and_then(Value::as_array)
                .map(Vec::as_slice)
                .ok_or_else(|| bad_reply(name, reply))
        };
        let timestamps = match reply.get("timestamp") {
            None | Some(Value::Null) => None,
            Some(Value::Array(ts)) => Some(ts.as_slice()),
            Some(_) => return Err(bad_reply("timestamp", reply)),
        };
        let parsed = Reply {
            whole: reply,
            index: array("index")?,
            episode: array("episode_index")?,
            timestamps,
            lengths: array("lengths")?,
            flat: array("values")?,
            episode_rows: reply
                .get("episode_rows")
                .and_then(Value::as_u64)
                .ok_or_else(|| bad_reply("episode_rows", reply))?,
            column_type: reply
                .get("column_type")
                .and_then(Value::as_str)
                .ok_or_else(|| bad_reply("column_type", reply))?,
        };
        let rows = parsed.index.len();
        if parsed.episode.len() != rows
            || parsed.lengths.len() != rows
            || timestamps.is_some_and(|t| t.len() != rows)
        {
            return Err(bad_reply("arrays of one length", reply));
        }
        Ok(parsed)
    }

    fn rows(&self) -> usize {
        self.index.len()
    }
}

/// A row's values and timestamp, once judged.
type Judged = (Vec<f64>, Option<f64>);

/// What the rows are judged against: the episode and the feature read.
struct Judge<'a> {
    place: &'a Place,
    span: &'a EpisodeSpan,
    field: &'a str,
    names: &'a [String],
}

impl Frames {
    /// The frames of `span` from the reader's answer; `place` names the dataset, episode and
    /// data file; `field` and `names` the feature read.
    pub fn from_reply(
        place: &Place,
        span: &EpisodeSpan,
        field: &str,
        names: &[String],
        reply: &Value,
    ) -> Result<Frames, LeRobotError> {
        let reply = Reply::parse(reply)?;
        let judge = Judge {
            place,
            span,
            field,
            names,
        };
        // One slot per frame of the span (at most MAX_FRAMES: the span was judged).
        let mut slots: Vec<Option<Judged>> = Vec::new();
        slots.resize_with(span.frames() as usize, || None);
        let mut offset = 0usize;
        for k in 0..reply.rows() {
            let (slot, judged) = judge.row(&reply, k, &mut offset)?;
            if slots[slot].is_some() {
                let index = span.from() + slot as u64;
                return Err(place
                    .at_index(span.from(), index)
                    .error(Problem::DuplicateIndex { index }));
            }
            slots[slot] = Some(judged);
        }
        if offset != reply.flat.len() {
            return Err(bad_reply("values of the lengths given", reply.whole));
        }
        judge.complete(&slots, reply.episode_rows)?;
        let (values, stamps): (Vec<Vec<f64>>, Vec<Option<f64>>) =
            slots.into_iter().flatten().unzip();
        Ok(Frames {
            column_type: reply.column_type.to_string(),
            timestamps: reply
                .timestamps
                .map(|_| stamps.into_iter().flatten().collect()),
            values,
        })
    }
}

impl Judge<'_> {
    /// Row `k` judged: its slot in the episode, its values and its timestamp. `offset` walks
    /// the flat values.
    fn row(
        &self,
        reply: &Reply,
        k: usize,
        offset: &mut usize,
    ) -> Result<(usize, Judged), LeRobotError> {
        let (span, place) = (self.span, self.place);
        let index = reply.index[k].as_u64().ok_or_else(|| {
            place.error(Problem::RowNumber {
                column: "index",
                found: crate::json::describe(&reply.index[k]),
            })
        })?;
        if !(span.from()..span.to()).contains(&index) {
            return Err(place.error(Problem::IndexOutside {
                index,
                from: span.from(),
                to: span.to(),
            }));
        }
        let at = place.at_index(span.from(), index);
        if reply.episode[k].as_u64() != Some(span.episode()) {
            return Err(at.error(Problem::OtherEpisode {
                found: crate::json::describe(&reply.episode[k]),
                expected: span.episode(),
            }));
        }
        let values = self.values(reply, k, offset, &at)?;
        let timestamp = match reply.timestamps.map(|t| &t[k]) {
            None => None,
            Some(t) => Some(finite(t).ok_or_else(|| {
                at.error(Problem::TimestampNotFinite {
                    found: describe_number(t),
                })
            })?),
        };
        Ok(((index - span.from()) as usize, (values, timestamp)))
    }

    /// Row `k`'s values, as wide as the names and every one finite.
    fn values(
        &self,
        reply: &Reply,
        k: usize,
        offset: &mut usize,
        at: &Place,
    ) -> Result<Vec<f64>, LeRobotError> {
        // A missing row (null) has no values among the flat ones.
        let width = match &reply.lengths[k] {
            Value::Null => None,
            length => Some(
                length
                    .as_u64()
                    .and_then(|n| usize::try_from(n).ok())
                    .filter(|&n| n <= reply.flat.len() - *offset)
                    .ok_or_else(|| bad_reply("lengths", reply.whole))?,
            ),
        };
        if width != Some(self.names.len()) {
            return Err(at.error(Problem::Width {
                field: self.field.to_string(),
                found: width.map_or("no list (null)".to_string(), |n| n.to_string()),
                expected: self.names.len(),
            }));
        }
        let row = &reply.flat[*offset..*offset + self.names.len()];
        *offset += self.names.len();
        row.iter()
            .zip(self.names)
            .map(|(value, name)| {
                finite(value).ok_or_else(|| {
                    at.error(Problem::NotFinite {
                        field: self.field.to_string(),
                        name: name.clone(),
                        found: describe_number(value),
                    })
                })
            })
            .collect()
    }

    /// Refuses a span with a frame no row gave, or whose episode has another count of rows in
    /// the file than the span says.
    fn complete(&self, slots: &[Option<Judged>], episode_rows: u64) -> Result<(), LeRobotError> {
        let span = self.span;
        if let Some(missing) = slots.iter().position(Option::is_none) {
            let index = span.from() + missing as u64;
            return Err(self
                .place
                .at_index(span.from(), index)
                .error(Problem::MissingIndex {
                    index,
                    found: slots.iter().filter(|s| s.is_some()).count() as u64,
                    expected: span.frames(),
                    from: span.from(),
                    to: span.to(),
                }));
        }
        if episode_rows != span.frames() {
            return Err(self.place.error(Problem::EpisodeRows {
                episode: span.episode(),
                found: episode_rows,
                expected: span.frames(),
                from: span.from(),
                to: span.to(),
            }));
        }
        Ok(())
    }
}

/// A JSON number as a finite f64; anything else (the reader's "nan", "inf", null for a
/// missing value, numbers beyond f64) is None.
fn finite(value: &Value) -> Option<f64> {
    value.as_f64().filter(|v| v.is_finite())
}

/// "NaN", "inf", "null (missing)", or the value: what a refused number was.
fn describe_number(value: &Value) -> String {
    match value {
        Value::Null => "missing (null)".into(),
        Value::String(s) if s == "nan" => "NaN".into(),
        Value::String(s) if matches!(s.as_str(), "inf" | "-inf") => s.clone(),
        other => crate::json::describe(other),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn span() -> EpisodeSpan {
        crate::interop::lerobot::episode::span_for_tests(1, 10, 13)
    }

    fn names() -> Vec<String> {
        vec!["a.pos".into(), "b.pos".into()]
    }

    fn place() -> Place {
        Place::episode("ds", 1).in_file("data/chunk-000/file-000.parquet")
    }

    fn reply(index: Value, episode: Value, values: Value) -> Value {
        json!({"column_type": "list<element: float>", "index": index, "episode_index": episode,
            "timestamp": [0.2, 0.0, 0.1], "lengths": [2, 2, 2], "values": values,
            "episode_rows": 3})
    }

    #[test]
    fn rows_in_any_order_become_frames_in_index_order() {
        let reply = reply(
            json!([12, 10, 11]),
            json!([1, 1, 1]),
            json!([5, 6, 1, 2, 3, 4]),
        );
        let frames = Frames::from_reply(&place(), &span(), "action", &names(), &reply).unwrap();
        assert_eq!(
            frames.values,
            vec![vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0, 6.0]]
        );
        assert_eq!(frames.timestamps, Some(vec![0.0, 0.1, 0.2]));
    }

    #[test]
    fn a_corrupt_row_is_named_by_episode_frame_and_field() {
        let cases = [
            (
                json!([10, 11, 11]),
                json!([1, 1, 1]),
                json!([1, 2, 3, 4, 5, 6]),
                "frame 1 (index 11): a second row of index 11",
            ),
            (
                json!([10, 11, 12]),
                json!([1, 2, 1]),
                json!([1, 2, 3, 4, 5, 6]),
                "frame 1 (index 11): episode_index is 2, expected 1",
            ),
            (
                json!([10, 11, 12]),
                json!([1, 1, 1]),
                json!([1, 2, 3, "nan", 5, 6]),
                "frame 1 (index 11): action b.pos is NaN",
            ),
            (
                json!([10, 11, 12]),
                json!([1, 1, 1]),
                json!([1, 2, null, 4, 5, 6]),
                "frame 1 (index 11): action a.pos is missing (null)",
            ),
        ];
        for (index, episode, values, says) in cases {
            let reply = reply(index, episode, values);
            let error =
                Frames::from_reply(&place(), &span(), "action", &names(), &reply).unwrap_err();
            let text = error.to_string();
            assert!(error.is_bad_input(), "{text}");
            assert!(
                text.starts_with("ds: episode 1, data/chunk-000/file-000.parquet, "),
                "{text}"
            );
            assert!(text.contains(says), "{says}: {text}");
        }
    }

    #[test]
    fn a_missing_frame_or_an_episode_row_outside_the_span_is_refused() {
        let mut two = reply(json!([10, 12]), json!([1, 1]), json!([1, 2, 3, 4]));
        two["lengths"] = json!([2, 2]);
        two["timestamp"] = json!([0.0, 0.2]);
        let text = Frames::from_reply(&place(), &span(), "action", &names(), &two)
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("frame 1 (index 11): no row of index 11"),
            "{text}"
        );
        let mut more = reply(
            json!([10, 11, 12]),
            json!([1, 1, 1]),
            json!([1, 2, 3, 4, 5, 6]),
        );
        more["episode_rows"] = json!(5);
        let text = Frames::from_reply(&place(), &span(), "action", &names(), &more)
            .unwrap_err()
            .to_string();
        assert!(text.contains("holds 5 rows of episode_index 1"), "{text}");
    }
}
