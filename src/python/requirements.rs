//! The pinned requirements embedded in the binary, their pins and the key that names the
//! environment built from them.
//!
//! Knows nothing about where the environment lives or how it is built.

/// The pinned requirements the environment is built from (`sim/requirements.txt`).
pub const REQUIREMENTS: &str = include_str!("../../sim/requirements.txt");

/// The stable key of a requirements text: FNV-1a 64, in hex.
///
/// `std`'s hashers may change between Rust releases, which would rebuild every user's
/// environment on a toolchain update; FNV-1a is fixed forever.
pub fn env_key(requirements: &str) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in requirements.as_bytes() {
        hash ^= u64::from(*byte);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{hash:016x}")
}

/// The `name==version` pins of [`REQUIREMENTS`], in file order.
pub fn pinned_versions() -> Vec<(&'static str, &'static str)> {
    parse_pins(REQUIREMENTS)
}

fn parse_pins(text: &str) -> Vec<(&str, &str)> {
    text.lines()
        .map(|line| line.split('#').next().unwrap_or("").trim())
        .filter_map(|line| {
            let (name, version) = line.split_once("==")?;
            let version = version.split(';').next().unwrap_or("").trim();
            Some((name.trim(), version))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_key_is_fnv1a_and_changes_with_the_text() {
        // FNV-1a 64 reference values.
        assert_eq!(env_key(""), "cbf29ce484222325");
        assert_eq!(env_key("a"), "af63dc4c8601ec8c");
        assert_ne!(env_key("x==1.0\n"), env_key("x==1.1\n"));
    }

    #[test]
    fn pins_are_parsed_without_comments_or_markers() {
        let pins = parse_pins(
            "# comment\nfoo==1.2.3\n\nbar == 4.5 ; python_version < \"3.9\"  # why\nbaz>=1\n",
        );
        assert_eq!(pins, vec![("foo", "1.2.3"), ("bar", "4.5")]);
        let embedded = pinned_versions();
        assert!(
            embedded.contains(&("dynamixel-sdk", "4.1.0")),
            "{embedded:?}"
        );
        assert!(
            embedded.contains(&("feetech-servo-sdk", "1.0.0")),
            "{embedded:?}"
        );
    }
}
