//! The binary trace that follows a `run` reply (sim/PROTOCOL.md, run, `"trace": "binary"`),
//! decoded into the trace's columns.
//!
//! The layout: a 16-byte header — the magic `KPTR`, then the format version, the number of rows
//! and the number of joints, each a little-endian u32 — followed by the columns as
//! little-endian f64: time (one value per row), then qpos, qvel, force and limit (one value per
//! row and joint, row after row). A JSON trace of a minute at 100 Hz is about 1.6 MB of text
//! that both sides format and parse number by number; this one is 1.2 MB copied as it is.
//!
//! A payload that is not exactly that — cut short, too long, another format or version — is a
//! [`TraceBytesError`] that says what was expected: the trace's rows line up with the
//! commanded rows, so a misread value would misplace every finding after it.

use super::wire::TraceReply;

/// The first four bytes of a binary trace.
pub const MAGIC: [u8; 4] = *b"KPTR";
/// The layout described above.
pub const VERSION: u32 = 1;
/// Bytes before the first value: magic, version, rows, joints.
const HEADER: usize = 16;
/// Values per row and joint after the time column: qpos, qvel, force, limit.
const MATRICES: u128 = 4;

/// Why a binary trace cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TraceBytesError {
    /// Fewer bytes than the header takes.
    #[error("{actual} bytes, fewer than the {expected}-byte header")]
    NoHeader {
        /// The header's size.
        expected: usize,
        /// The payload's size.
        actual: usize,
    },
    /// Not a trace: it does not start with `MAGIC`.
    #[error("it starts with {found:?}; expected the magic {expected:?}")]
    Magic {
        /// `MAGIC`.
        expected: [u8; 4],
        /// Its first four bytes.
        found: [u8; 4],
    },
    /// A layout this keypose does not know.
    #[error("format version {found}; expected {expected}")]
    Version {
        /// `VERSION`.
        expected: u32,
        /// The header's.
        found: u32,
    },
    /// More or fewer bytes than the header's rows and joints take.
    #[error("{actual} bytes; a header of {rows} rows of {joints} joints takes {expected}")]
    Length {
        /// Rows, from the header.
        rows: u32,
        /// Joints, from the header.
        joints: u32,
        /// The bytes those take, header included.
        expected: u128,
        /// The payload's size.
        actual: usize,
    },
}

/// The trace in `bytes`, its columns as the JSON trace has them.
pub(super) fn decode(bytes: &[u8]) -> Result<TraceReply, TraceBytesError> {
    let Some((header, values)) = bytes.split_first_chunk::<HEADER>() else {
        return Err(TraceBytesError::NoHeader {
            expected: HEADER,
            actual: bytes.len(),
        });
    };
    let word = |at: usize| {
        u32::from_le_bytes([header[at], header[at + 1], header[at + 2], header[at + 3]])
    };
    let found = [header[0], header[1], header[2], header[3]];
    if found != MAGIC {
        return Err(TraceBytesError::Magic {
            expected: MAGIC,
            found,
        });
    }
    if word(4) != VERSION {
        return Err(TraceBytesError::Version {
            expected: VERSION,
            found: word(4),
        });
    }
    let (rows, joints) = (word(8), word(12));
    // In u128: no header's counts overflow it, so a huge count is a length error, not a panic.
    let expected = HEADER as u128 + 8 * rows as u128 * (1 + MATRICES * joints as u128);
    if expected != bytes.len() as u128 {
        return Err(TraceBytesError::Length {
            rows,
            joints,
            expected,
            actual: bytes.len(),
        });
    }
    let mut numbers = values
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]));
    let (rows, joints) = (rows as usize, joints as usize);
    let time: Vec<f64> = numbers.by_ref().take(rows).collect();
    let mut matrix = || -> Vec<Vec<f64>> {
        (0..rows)
            .map(|_| numbers.by_ref().take(joints).collect())
            .collect()
    };
    Ok(TraceReply {
        time,
        qpos: matrix(),
        qvel: matrix(),
        force: matrix(),
        limit: matrix(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 0.5, 1.0, -2.0 and 0.25 as IEEE 754 doubles, little-endian, written out by hand.
    const HALF: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xE0, 0x3F];
    const ONE: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xF0, 0x3F];
    const MINUS_TWO: [u8; 8] = [0, 0, 0, 0, 0, 0, 0x00, 0xC0];
    const QUARTER: [u8; 8] = [0, 0, 0, 0, 0, 0, 0xD0, 0x3F];
    const ZERO: [u8; 8] = [0; 8];

    /// A header by hand: "KPTR", version 1, `rows` and `joints` as little-endian u32.
    fn header(version: u8, rows: u8, joints: u8) -> Vec<u8> {
        vec![
            b'K', b'P', b'T', b'R', version, 0, 0, 0, rows, 0, 0, 0, joints, 0, 0, 0,
        ]
    }

    /// Two rows of one joint: time 0.5 and 1.0; qpos -2.0, 0.25; qvel 0.25, 0.5; force 1.0,
    /// -2.0; the limit active in the second row only.
    fn two_rows() -> Vec<u8> {
        let mut bytes = header(1, 2, 1);
        for value in [
            HALF, ONE, MINUS_TWO, QUARTER, QUARTER, HALF, ONE, MINUS_TWO, ZERO, ONE,
        ] {
            bytes.extend(value);
        }
        bytes
    }

    #[test]
    fn a_trace_by_hand_reads_column_by_column() {
        let trace = decode(&two_rows()).unwrap();
        assert_eq!(trace.time, [0.5, 1.0]);
        assert_eq!(trace.qpos, [[-2.0], [0.25]]);
        assert_eq!(trace.qvel, [[0.25], [0.5]]);
        assert_eq!(trace.force, [[1.0], [-2.0]]);
        assert_eq!(trace.limit, [[0.0], [1.0]]);
    }

    #[test]
    fn rows_of_several_joints_are_read_row_after_row() {
        // One row of two joints: qpos (0.5, 1.0), qvel (-2.0, 0.25), force (0, 0), limit (1, 0).
        let mut bytes = header(1, 1, 2);
        for value in [
            QUARTER, HALF, ONE, MINUS_TWO, QUARTER, ZERO, ZERO, ONE, ZERO,
        ] {
            bytes.extend(value);
        }
        let trace = decode(&bytes).unwrap();
        assert_eq!(trace.time, [0.25]);
        assert_eq!(trace.qpos, [[0.5, 1.0]]);
        assert_eq!(trace.qvel, [[-2.0, 0.25]]);
        assert_eq!(trace.limit, [[1.0, 0.0]]);
    }

    #[test]
    fn an_empty_trace_is_a_header_alone() {
        let trace = decode(&header(1, 0, 6)).unwrap();
        assert!(trace.time.is_empty() && trace.qpos.is_empty() && trace.limit.is_empty());
    }

    #[test]
    fn a_payload_cut_short_says_how_long_it_should_be() {
        let mut bytes = two_rows();
        bytes.truncate(bytes.len() - 8);
        // 16 + 8 · 2 rows · (1 + 4 · 1 joint) = 96 bytes.
        assert_eq!(
            decode(&bytes),
            Err(TraceBytesError::Length {
                rows: 2,
                joints: 1,
                expected: 96,
                actual: 88
            })
        );
        let error = decode(&bytes).unwrap_err().to_string();
        assert_eq!(error, "88 bytes; a header of 2 rows of 1 joints takes 96");
    }

    #[test]
    fn a_payload_with_bytes_left_over_is_refused() {
        let mut bytes = two_rows();
        bytes.push(0);
        assert!(matches!(
            decode(&bytes),
            Err(TraceBytesError::Length {
                expected: 96,
                actual: 97,
                ..
            })
        ));
    }

    #[test]
    fn fewer_bytes_than_a_header_are_refused() {
        assert_eq!(
            decode(b"KPTR\x01\x00"),
            Err(TraceBytesError::NoHeader {
                expected: 16,
                actual: 6
            })
        );
        assert!(matches!(
            decode(&[]),
            Err(TraceBytesError::NoHeader { actual: 0, .. })
        ));
    }

    #[test]
    fn another_format_or_version_is_refused() {
        let mut json = br#"{"time": [0.5], "qpos": [[1]]}"#.to_vec();
        json.resize(16, b' ');
        assert_eq!(
            decode(&json),
            Err(TraceBytesError::Magic {
                expected: *b"KPTR",
                found: *b"{\"ti"
            })
        );
        assert_eq!(
            decode(&header(2, 0, 1)),
            Err(TraceBytesError::Version {
                expected: 1,
                found: 2
            })
        );
    }

    #[test]
    fn a_header_that_counts_more_than_memory_holds_is_a_length_error() {
        // u32::MAX rows of u32::MAX joints: the size is computed without overflow and refused.
        let mut bytes = b"KPTR\x01\x00\x00\x00".to_vec();
        bytes.extend([0xFF; 8]);
        let error = decode(&bytes).unwrap_err();
        let TraceBytesError::Length {
            expected, actual, ..
        } = error
        else {
            panic!("{error:?}");
        };
        assert_eq!(actual, 16);
        assert!(expected > u64::MAX as u128, "{expected}");
    }
}
