//! Parsers of numeric command-line values: each says which values it takes, so that `1e300`,
//! `-1`, `nan` or `0` is refused by clap (exit 2, the option named) rather than reaching a
//! `Duration` that panics or a loop that never ends.
//!
//! Options that take a number set `allow_negative_numbers`, so `-1` reaches these parsers and
//! gets a message about the value instead of clap's tip about `-- -1`.

use std::ops::RangeInclusive;

/// Longest time an option may give in seconds: a day, as for key times.
pub const MAX_OPTION_SECONDS: f64 = 86_400.0;
/// Fastest baud rate of the supported servos (Dynamixel X: 4.5 Mbps; P series: 10.5 Mbps).
pub const MAX_BAUD: u32 = 10_500_000;
/// Longest injected answer delay of a virtual servo: well past any read timeout.
pub const MAX_LATE_MS: u64 = 10_000;

/// A finite number in `range`; `what` says what is expected.
pub fn number_in(s: &str, range: RangeInclusive<f64>, what: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && range.contains(&x) => Ok(x),
        _ => Err(format!("expected {what}, found {s:?}")),
    }
}

/// A finite number above 0 and at most `max`.
pub fn positive_up_to(s: &str, max: f64, what: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= max => Ok(x),
        _ => Err(format!(
            "expected {what} above 0 and at most {max}, found {s:?}"
        )),
    }
}

/// A whole number in `range`.
pub fn integer_in(s: &str, range: RangeInclusive<u64>, what: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if range.contains(&n) => Ok(n),
        _ => Err(format!(
            "expected {what}, a whole number from {} to {}, found {s:?}",
            range.start(),
            range.end()
        )),
    }
}

/// `--speed`: the time scale of playback.
pub fn parse_speed(s: &str) -> Result<f64, String> {
    number_in(s, 0.05..=4.0, "a speed factor from 0.05 to 4")
}

/// `--every`: seconds between the frames of a contact sheet.
pub fn parse_every(s: &str) -> Result<f64, String> {
    positive_up_to(s, MAX_OPTION_SECONDS, "seconds")
}

/// `--fault-after`: seconds after start.
pub fn parse_fault_after(s: &str) -> Result<f64, String> {
    number_in(
        s,
        0.0..=MAX_OPTION_SECONDS,
        &format!("seconds from 0 to {MAX_OPTION_SECONDS}"),
    )
}

/// `--baud`.
/// `--usb-latency`: milliseconds of adapter latency, 0 to 255 (the FTDI latency timer's range).
pub fn parse_usb_latency(s: &str) -> Result<std::time::Duration, String> {
    number_in(s, 0.0..=255.0, "a latency from 0 to 255 ms")
        .map(|ms| std::time::Duration::from_secs_f64(ms / 1000.0))
}

pub fn parse_baud(s: &str) -> Result<u32, String> {
    integer_in(s, 1..=u64::from(MAX_BAUD), "a baud rate").map(|n| n as u32)
}

/// `--readback`: cycles between read-backs, 0 for never.
pub fn parse_readback(s: &str) -> Result<u32, String> {
    integer_in(
        s,
        0..=u64::from(u32::MAX),
        "cycles between read-backs (0: never)",
    )
    .map(|n| n as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_non_finite_and_negative_values_are_refused() {
        assert_eq!(parse_speed("0.5"), Ok(0.5));
        for bad in ["0", "-1", "4.5", "nan", "inf", "1e300", "fast", ""] {
            assert!(parse_speed(bad).is_err(), "{bad}");
        }
        assert_eq!(
            parse_fault_after("1e300"),
            Err("expected seconds from 0 to 86400, found \"1e300\"".into())
        );
        assert_eq!(parse_fault_after("0"), Ok(0.0));
        assert_eq!(
            parse_every("0"),
            Err("expected seconds above 0 and at most 86400, found \"0\"".into())
        );
        assert_eq!(parse_baud("57600"), Ok(57_600));
        assert!(parse_baud("0").is_err() && parse_baud("-9600").is_err());
        assert!(parse_baud("4294967296").is_err());
        assert_eq!(parse_readback("0"), Ok(0));
        assert!(parse_readback("-1").is_err());
    }
}
