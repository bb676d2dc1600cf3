//! No input may make keypose panic: random bytes and random mutations of valid files go through
//! the loaders and, when they load, through planning and the limit check. A panic fails the
//! property; an `Err` is the expected answer to garbage.

use keypose::plan::{check, Trajectory};
use keypose::robot::{import_lerobot_calibration, Robot};
use keypose::sequence::Sequence;
use proptest::prelude::*;

const SEQUENCES: [&str; 7] = [
    include_str!("../../sequences/bimanual_wave.json"),
    include_str!("../../sequences/so101_wave.json"),
    include_str!("../../sequences/so101_pick_place.json"),
    include_str!("../../sequences/so101_nod.json"),
    include_str!("../../sequences/so101_sweep_control.json"),
    include_str!("../../sequences/koch_wave.json"),
    include_str!("../../sequences/omx_reach.json"),
];
const ROBOTS: [&str; 3] = [
    include_str!("../../robots/so101.json"),
    include_str!("../../robots/koch.json"),
    include_str!("../../robots/omx.json"),
];

/// Everything a command does with a sequence before it touches a servo.
fn run_pipeline(text: &str) {
    let Ok(sequence) = Sequence::from_json("fuzz.json", text) else {
        return;
    };
    let Some(robot) = keypose::plan::builtin_robot_of(&sequence) else {
        return;
    };
    if let Ok(trajectory) = Trajectory::build(&sequence, &robot) {
        // Keep the check cheap for mutated times far apart.
        if trajectory.duration() < 600.0 {
            let report = check(&trajectory, &robot, 50.0);
            for j in &report.joints {
                assert!(!j.peak_velocity.is_nan());
            }
        }
        let mut out = vec![0.0; robot.joints.len()];
        trajectory.sample_into(trajectory.start, &mut out);
        assert!(out.iter().all(|v| v.is_finite()));
    }
    let _ = Sequence::from_json("again.json", &sequence.to_json());
}

/// Mutations a person or a broken tool could make to a JSON file.
#[derive(Debug, Clone)]
enum Mutation {
    DeleteRange(usize, usize),
    Insert(usize, String),
    ReplaceByte(usize, u8),
    ReplaceNumber(usize, String),
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop::sample::select(vec![
        "-",
        "1e999",
        "NaN",
        "null",
        "\"\"",
        "{}",
        "[]",
        "0",
        "-0",
        "1e-320",
        "\"time\"",
        ",",
        ":",
        "\"hold\":",
        "\"interp\":\"monotone\"",
        "99999999999999999999",
        "-1e308",
        "true",
        "\u{0}",
        "\"joints\":{}",
        "\"r\":{\"w\":0}",
        "\"ends\":\"control\"",
    ]);
    prop_oneof![
        (any::<usize>(), 0usize..40).prop_map(|(a, n)| Mutation::DeleteRange(a, n)),
        (any::<usize>(), token.clone()).prop_map(|(a, s)| Mutation::Insert(a, s.to_string())),
        (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Mutation::ReplaceByte(a, b)),
        (any::<usize>(), token).prop_map(|(a, s)| Mutation::ReplaceNumber(a, s.to_string())),
        (any::<usize>(), 0usize..200).prop_map(|(a, n)| Mutation::Duplicate(a, n)),
    ]
}

fn apply(text: &str, mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    for m in mutations {
        let len = bytes.len().max(1);
        match m {
            Mutation::DeleteRange(at, n) => {
                let at = at % len;
                let end = (at + n).min(bytes.len());
                if at < end {
                    bytes.drain(at..end);
                }
            }
            Mutation::Insert(at, s) => {
                let at = (at % len).min(bytes.len());
                bytes.splice(at..at, s.bytes());
            }
            Mutation::ReplaceByte(at, b) => {
                if !bytes.is_empty() {
                    let at = at % bytes.len();
                    bytes[at] = *b;
                }
            }
            Mutation::ReplaceNumber(at, s) => {
                // Replace the number that starts at or after `at`, so values change but the
                // structure mostly survives and the deeper checks get exercised.
                let start = (at % len..bytes.len())
                    .find(|&i| bytes[i].is_ascii_digit() || bytes[i] == b'-');
                if let Some(start) = start {
                    let end = (start + 1..bytes.len())
                        .find(|&i| !(bytes[i].is_ascii_digit() || b".eE+-".contains(&bytes[i])))
                        .unwrap_or(bytes.len());
                    bytes.splice(start..end, s.bytes());
                }
            }
            Mutation::Duplicate(at, n) => {
                let at = at % len;
                let end = (at + n).min(bytes.len());
                if at < end {
                    let copy: Vec<u8> = bytes[at..end].to_vec();
                    bytes.splice(end..end, copy);
                }
            }
        }
    }
    bytes
}

proptest! {
    // 1,500 cases per property in every test run; PROPTEST_CASES raises it for a longer hunt.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(1500),
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        run_pipeline(&text);
        let _ = Robot::from_json("fuzz.json", &text);
    }

    #[test]
    fn mutated_sequences_never_panic(
        which in 0..SEQUENCES.len(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let bytes = apply(SEQUENCES[which], &mutations);
        run_pipeline(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn mutated_robots_never_panic(
        which in 0..ROBOTS.len(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let bytes = apply(ROBOTS[which], &mutations);
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(robot) = Robot::from_json("fuzz.json", &text) {
            let zero = vec![0.0; robot.joints.len()];
            let _ = robot.tcp_position(&zero);
            if let Ok(sequence) = Sequence::from_json("seq.json", SEQUENCES[0]) {
                let _ = Trajectory::build(&sequence, &robot);
            }
        }
    }

    #[test]
    fn mutated_calibrations_never_panic(mutations in prop::collection::vec(mutation(), 1..6)) {
        let valid = r#"{"shoulder_pan": {"id": 1, "drive_mode": 0, "homing_offset": -1470, "range_min": 758, "range_max": 3292},
                        "gripper": {"id": 6, "drive_mode": 1, "homing_offset": 12, "range_min": 2000, "range_max": 3300}}"#;
        let bytes = apply(valid, &mutations);
        if let Some(mut robot) = Robot::builtin("so101") {
            let _ = import_lerobot_calibration(&mut robot, "cal.json", &String::from_utf8_lossy(&bytes));
        }
    }
}

/// Values that sit on the edges of what the loaders and the curve math accept.
fn edge_value() -> impl Strategy<Value = serde_json::Value> {
    use serde_json::json;
    prop_oneof![
        prop::sample::select(vec![
            json!(0),
            json!(-0.0),
            json!(1e-320),
            json!(1e-9),
            json!(0.001),
            json!(0.0011),
            json!(1e308),
            json!(-1e308),
            json!(86400),
            json!(180),
            json!(-180),
            json!(175),
            json!(360),
            json!(1e5),
            json!(-1),
            json!(0.7072), // a hand-typed √½, just off
            json!(""),
            json!("step"),
            json!("linear"),
            json!("monotone"),
            json!("control"),
            json!("koch"),
            json!("omx"),
            json!(null),
            json!([]),
            json!({}),
        ]),
        (-1e4f64..1e4).prop_map(|x| json!(x)),
        (-1.0f64..1.0).prop_map(|x| json!(x)),
    ]
}

#[derive(Debug, Clone)]
enum Edit {
    /// Replace the n-th leaf (in document order) with a value.
    Replace(usize, serde_json::Value),
    /// Remove the n-th object member.
    Remove(usize),
    /// Duplicate the n-th array element.
    DuplicateItem(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        3 => (any::<usize>(), edge_value()).prop_map(|(n, v)| Edit::Replace(n, v)),
        1 => any::<usize>().prop_map(Edit::Remove),
        1 => any::<usize>().prop_map(Edit::DuplicateItem),
    ]
}

/// Applies `edit` to the `target`-th place of its kind; returns how many places there were.
fn apply_edit(value: &mut serde_json::Value, edit: &Edit, seen: &mut usize, target: usize) {
    use serde_json::Value;
    match value {
        Value::Object(map) => {
            if let Edit::Remove(_) = edit {
                if *seen == target {
                    if let Some(key) = map.keys().next().cloned() {
                        map.shift_remove(&key);
                    }
                }
                *seen += 1;
            }
            for (_, child) in map.iter_mut() {
                apply_edit(child, edit, seen, target);
            }
        }
        Value::Array(items) => {
            if let Edit::DuplicateItem(_) = edit {
                if *seen == target && !items.is_empty() {
                    items.push(items[0].clone());
                }
                *seen += 1;
            }
            for child in items.iter_mut() {
                apply_edit(child, edit, seen, target);
            }
        }
        leaf => {
            if let Edit::Replace(_, replacement) = edit {
                if *seen == target {
                    *leaf = replacement.clone();
                }
                *seen += 1;
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(1500),
        ..ProptestConfig::default()
    })]

    #[test]
    fn edited_sequence_values_never_panic(
        which in 0..SEQUENCES.len(),
        edits in prop::collection::vec(edit(), 1..4),
    ) {
        let mut value: serde_json::Value = serde_json::from_str(SEQUENCES[which]).unwrap();
        for e in &edits {
            let n = match e { Edit::Replace(n, _) | Edit::Remove(n) | Edit::DuplicateItem(n) => *n };
            let mut count = 0;
            apply_edit(&mut value.clone(), e, &mut count, usize::MAX);
            if count > 0 {
                let mut seen = 0;
                apply_edit(&mut value, e, &mut seen, n % count);
            }
        }
        run_pipeline(&value.to_string());
    }
}
