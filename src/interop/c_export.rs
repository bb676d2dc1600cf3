//! A checked trajectory as a C header for the stand-alone player (`players/c/`,
//! docs/interop.md §4): per piece of time, every joint's polynomial in servo ticks as
//! fixed-point coefficients, the servo ids, the tick limits every goal is clamped to and the
//! speed and acceleration limits the player's step limiter bounds every step by.
//!
//! The pieces are the limit check's own: each joint's played curve as exact polynomials in
//! sequence time (`plan::check::spans::JointCurve`: a cubic between keys and hold ends, a
//! constant in a hold or a step, and on a segment with a timing profile the cubic of path time
//! composed with the profile's path time of time, a higher degree), cut where any joint's
//! polynomial changes. Ticks are a linear function of the joint value (`zero_tick + direction ·
//! value / units_per_tick`), so each piece is, exactly, a polynomial in ticks of
//! u = (t − start)/duration in [0, 1]: ticks = c0 + c1·u + … + cd·u^d, d the highest degree of
//! any piece (`KP_SEQ_DEGREE`). The header stores each c·2¹⁶ rounded (Q16.16), which the
//! player evaluates by Horner's rule in 64-bit integers.
//!
//! Nothing from a file becomes C code: the header's identifiers and comments are keypose's
//! own, and the names it carries (the joints', the source file's) are in string literals only,
//! every byte outside a few safe characters written as an octal escape. So a
//! name holding `*/`, a quote, a backslash, `??/` or a line break reads back as itself.

use crate::plan::Trajectory;
use crate::robot::Robot;
use std::fmt::Write;

/// Fixed-point scale of the coefficients: Q16.16.
const ONE: f64 = 65536.0;
/// The player counts time in microseconds in 32 bits: 71 minutes.
const MAX_SECONDS: f64 = u32::MAX as f64 / 1e6;
/// The player counts pieces in 16 bits (`kp_sequence.pieces`).
const MAX_PIECES: usize = u16::MAX as usize;

/// Why a trajectory cannot become a header for the C player.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CExportError {
    /// The trajectory lasts longer than the player's 32-bit microsecond clock counts.
    #[error("{seconds:.1} s is longer than the player's {MAX_SECONDS:.0} s (32-bit microseconds)")]
    TooLong {
        /// The trajectory's duration, seconds.
        seconds: f64,
    },
    /// More pieces than the player's 16-bit piece count holds (a timing profile has a piece per
    /// stretch of its speeds).
    #[error(
        "{pieces} pieces of time are more than the player's {MAX_PIECES} (16-bit count); \
         timing profiles add one per stretch of their speeds: export a shorter part \
         (--start/--end) or fewer profiled segments"
    )]
    TooManyPieces {
        /// How many the trajectory needs.
        pieces: usize,
    },
    /// A coefficient does not fit the player's Q16.16 fixed point.
    #[error(
        "joint {joint}: a coefficient of {ticks:.0} ticks (t = {time:.3} s) does not fit the \
         player's Q16.16 (±32767 ticks)"
    )]
    Overflow {
        /// The joint.
        joint: String,
        /// The coefficient, ticks.
        ticks: f64,
        /// Start of the piece it belongs to, seconds from the played start.
        time: f64,
    },
}

/// One piece: when it starts (seconds from the played start), how long, and per joint the
/// tick polynomial's coefficients in u.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    /// Seconds from the played start.
    pub start: f64,
    /// Seconds.
    pub duration: f64,
    /// Per joint, `[c0, c1, …]` of ticks = c0 + c1·u + c2·u² + …, u from 0 to 1, up to the
    /// highest power with a coefficient other than 0.
    pub coefficients: Vec<Vec<f64>>,
}

/// The pieces of `trajectory` in ticks.
pub fn pieces(trajectory: &Trajectory, robot: &Robot) -> Vec<Piece> {
    let curves = super::played_spans(trajectory);
    let times = super::span_boundaries(&curves);
    times
        .windows(2)
        .map(|w| Piece {
            start: w[0] - trajectory.start,
            duration: w[1] - w[0],
            coefficients: curves
                .iter()
                .zip(&robot.joints)
                .map(|(spans, joint)| {
                    let poly = super::polynomial_from(spans, w[0], w[1]);
                    tick_polynomial(poly.coefficients(), joint, w[1] - w[0])
                })
                .collect(),
        })
        .collect()
}

/// The highest power any joint's polynomial of any piece has.
pub fn degree(pieces: &[Piece]) -> usize {
    pieces
        .iter()
        .flat_map(|p| &p.coefficients)
        .map(|c| c.len().saturating_sub(1))
        .max()
        .unwrap_or(0)
}

/// A joint's polynomial in its own units of the seconds since a piece's start as a
/// polynomial in ticks of u = seconds / `duration`.
fn tick_polynomial(c: &[f64], joint: &crate::robot::Joint, duration: f64) -> Vec<f64> {
    let scale = joint.servo.direction / joint.servo.units_per_tick;
    let mut power = 1.0;
    c.iter()
        .enumerate()
        .map(|(k, &x)| {
            if k == 0 {
                return joint.servo.tick_exact(x);
            }
            power *= duration;
            x * power * scale
        })
        .collect()
}

/// The header text; `source` names the sequence file in it (`kp_seq_source`).
pub fn header(
    trajectory: &Trajectory,
    robot: &Robot,
    source: &str,
) -> Result<String, CExportError> {
    let duration = trajectory.duration();
    if duration > MAX_SECONDS {
        return Err(CExportError::TooLong { seconds: duration });
    }
    let pieces = pieces(trajectory, robot);
    if pieces.len() > MAX_PIECES {
        return Err(CExportError::TooManyPieces {
            pieces: pieces.len(),
        });
    }
    let degree = degree(&pieces);
    let mut out = String::new();
    out.push_str("/* Generated by keypose export c (from kp_seq_source): do not edit. */\n");
    out.push_str("#ifndef KP_SEQUENCE_H\n#define KP_SEQUENCE_H\n#include \"keypose_player.h\"\n\n");
    let _ = writeln!(
        out,
        "static const char kp_seq_source[] = {};\n",
        c_string(source)
    );
    let joints = robot.joints.len();
    let _ = writeln!(
        out,
        "#define KP_SEQ_JOINTS {joints}\n#define KP_SEQ_PIECES {}\n\
         /* The highest power of u in any piece: (KP_SEQ_DEGREE + 1) coefficients each. */\n\
         #define KP_SEQ_DEGREE {degree}\n",
        pieces.len()
    );
    write_joint_tables(&mut out, robot);
    write_piece_tables(&mut out, robot, &pieces, degree)?;
    let _ = writeln!(
        out,
        "static const kp_sequence kp_seq = {{\n    KP_SEQ_JOINTS, KP_SEQ_PIECES, KP_SEQ_DEGREE, {}u,\n    kp_seq_ids, kp_seq_tick_min, kp_seq_tick_max, kp_seq_max_speed, kp_seq_max_accel,\n    kp_seq_piece_start_us, kp_seq_piece_duration_us, kp_seq_coefficients\n}};\n\n#endif",
        (duration * 1e6).round() as u32
    );
    Ok(out)
}

fn write_joint_tables(out: &mut String, robot: &Robot) {
    let ids: Vec<String> = robot
        .joints
        .iter()
        .map(|j| j.servo.id.to_string())
        .collect();
    let names: Vec<String> = robot.joint_names().iter().map(|n| c_string(n)).collect();
    let _ = writeln!(
        out,
        "/* Every table below is in the order of these joints. */\n\
         static const char *const kp_seq_joint_names[KP_SEQ_JOINTS] = {{{}}};",
        names.join(", ")
    );
    let _ = writeln!(
        out,
        "static const uint8_t kp_seq_ids[KP_SEQ_JOINTS] = {{{}}};",
        ids.join(", ")
    );
    let (mut low, mut high, mut speed, mut accel) = (vec![], vec![], vec![], vec![]);
    for joint in &robot.joints {
        // Rounded inwards: a clamped goal stays inside the joint's limits.
        let a = joint.servo.tick_exact(joint.limits.min);
        let b = joint.servo.tick_exact(joint.limits.max);
        low.push((a.min(b)).ceil() as i64);
        high.push((a.max(b)).floor() as i64);
        // Rounded down, to a float's precision: the player's step limiter bounds goals by them.
        let per_tick = 1.0 / joint.servo.units_per_tick;
        let down = |x: f64| format!("{:.3}f", (x * 1000.0).floor() / 1000.0);
        speed.push(down(joint.limits.velocity * per_tick));
        accel.push(down(joint.limits.acceleration * per_tick));
    }
    let join = |v: &[i64]| {
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        out,
        "static const int32_t kp_seq_tick_min[KP_SEQ_JOINTS] = {{{}}};",
        join(&low)
    );
    let _ = writeln!(
        out,
        "static const int32_t kp_seq_tick_max[KP_SEQ_JOINTS] = {{{}}};",
        join(&high)
    );
    let _ = writeln!(
        out,
        "/* Ticks per second and per second squared: the approach's and the step limiter's bounds. */"
    );
    let _ = writeln!(
        out,
        "static const float kp_seq_max_speed[KP_SEQ_JOINTS] = {{{}}};",
        speed.join(", ")
    );
    let _ = writeln!(
        out,
        "static const float kp_seq_max_accel[KP_SEQ_JOINTS] = {{{}}};\n",
        accel.join(", ")
    );
}

fn write_piece_tables(
    out: &mut String,
    robot: &Robot,
    pieces: &[Piece],
    degree: usize,
) -> Result<(), CExportError> {
    // Each piece's duration is the difference of the rounded times of its ends, so the pieces
    // tile the microseconds without a gap or an overlap.
    let us = |t: f64| (t * 1e6).round() as u32;
    let starts: Vec<String> = pieces.iter().map(|p| us(p.start).to_string()).collect();
    let durations: Vec<String> = pieces
        .iter()
        .map(|p| (us(p.start + p.duration) - us(p.start)).to_string())
        .collect();
    let _ = writeln!(
        out,
        "static const uint32_t kp_seq_piece_start_us[KP_SEQ_PIECES] = {{{}}};",
        starts.join(", ")
    );
    let _ = writeln!(
        out,
        "static const uint32_t kp_seq_piece_duration_us[KP_SEQ_PIECES] = {{{}}};",
        durations.join(", ")
    );
    out.push_str(
        "/* [piece][joint][c0..cKP_SEQ_DEGREE], ticks in Q16.16, of u = (t - start) / duration. */\n",
    );
    out.push_str(
        "static const int32_t kp_seq_coefficients[KP_SEQ_PIECES * KP_SEQ_JOINTS * (KP_SEQ_DEGREE + 1)] = {\n",
    );
    for piece in pieces {
        let mut row = Vec::new();
        for (joint, c) in robot.joints.iter().zip(&piece.coefficients) {
            let padded = c.iter().copied().chain(std::iter::repeat(0.0));
            for x in padded.take(degree + 1) {
                let q = (x * ONE).round();
                if q.abs() > i32::MAX as f64 {
                    return Err(CExportError::Overflow {
                        joint: joint.name.clone(),
                        ticks: x,
                        time: piece.start,
                    });
                }
                row.push((q as i32).to_string());
            }
        }
        let _ = writeln!(out, "    {},", row.join(", "));
    }
    out.push_str("};\n\n");
    Ok(())
}

/// `text` as a C string literal: its UTF-8 bytes, letters, digits, space and `_-./:,+=()[]`
/// as they are and every other byte as a three-digit octal escape (`\"` is `\042`). An octal
/// escape ends after three digits, so no following character extends it; `?` is escaped, so
/// no trigraph (`??/` is a backslash in C89 and C99) forms.
pub(crate) fn c_string(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for &byte in text.as_bytes() {
        if byte.is_ascii_alphanumeric() || b" _-./:,+=()[]".contains(&byte) {
            out.push(char::from(byte));
        } else {
            let _ = write!(out, "\\{byte:03o}");
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_string_literals_of_their_bytes() {
        assert_eq!(c_string("shoulder_pan"), r#""shoulder_pan""#);
        // ", \, *, /, ?, line break, é (C3 A9) in octal (C11 §6.4.4.4).
        assert_eq!(
            c_string("a\"b\\c*/??/\né"),
            r#""a\042b\134c\052/\077\077/\012\303\251""#
        );
    }
}
