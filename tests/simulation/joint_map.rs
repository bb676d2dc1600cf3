//! `keypose sim --mjcf MODEL --joint-map …` with a model whose joints are named otherwise. The
//! official models themselves (MuJoCo Menagerie's low_cost_robot_arm, ROBOTIS's
//! OpenMANIPULATOR-X) are not in the repository: the test renames the joints of keypose's own
//! sim/models/koch.xml as Menagerie names them (docs/robots.md §2.2), so the physics is the
//! same and the renamed run must measure exactly what the built-in one does.

use crate::common::{repo, run_sim, show, stderr};
use std::path::Path;

const MENAGERIE_NAMES: [(&str, &str); 4] = [
    ("shoulder_pan", "base_rotation"),
    ("shoulder_lift", "pitch"),
    ("elbow_flex", "elbow"),
    ("wrist_flex", "wrist_pitch"),
];

fn renamed_koch(path: &Path) {
    let mut text = std::fs::read_to_string(repo("sim/models/koch.xml")).unwrap();
    for (ours, theirs) in MENAGERIE_NAMES {
        text = text
            .replace(&format!("name=\"{ours}\""), &format!("name=\"{theirs}\""))
            .replace(&format!("joint=\"{ours}\""), &format!("joint=\"{theirs}\""));
    }
    std::fs::write(path, text).unwrap();
}

fn report(args: &[&str], path: &Path) -> serde_json::Value {
    let mut all = vec!["sim", "--report", path.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = run_sim(&all);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let mut value: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for volatile in ["model", "wall_seconds"] {
        value.as_object_mut().unwrap().remove(volatile);
    }
    value
}

#[test]
fn a_model_with_other_joint_names_runs_through_a_joint_map() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("low_cost_robot_arm.xml");
    renamed_koch(&model);
    let sequence = repo("sequences/koch_wave.json");
    let model_arg = model.to_str().unwrap();

    let unmapped = run_sim(&["sim", &sequence, "--mjcf", model_arg]);
    assert_eq!(unmapped.status.code(), Some(2), "{}", show(&unmapped));
    assert!(
        stderr(&unmapped).contains("has no joint(s) shoulder_pan"),
        "{}",
        show(&unmapped)
    );

    let builtin = report(&[&sequence], &dir.path().join("builtin.json"));
    let shipped = report(
        &[
            &sequence,
            "--mjcf",
            model_arg,
            "--joint-map",
            "menagerie-koch",
        ],
        &dir.path().join("shipped.json"),
    );
    assert_eq!(shipped, builtin, "the same physics under other names");
    let pairs =
        "shoulder_pan=base_rotation,shoulder_lift=pitch,elbow_flex=elbow,wrist_flex=wrist_pitch";
    let inline = report(
        &[&sequence, "--mjcf", model_arg, "--joint-map", pairs],
        &dir.path().join("pairs.json"),
    );
    assert_eq!(inline, builtin);

    let wrong = run_sim(&[
        "sim",
        &sequence,
        "--mjcf",
        model_arg,
        "--joint-map",
        "elbow=elbow",
    ]);
    assert_eq!(wrong.status.code(), Some(2), "{}", show(&wrong));
    assert!(
        stderr(&wrong).contains("\"elbow\" is not a joint of koch"),
        "{}",
        show(&wrong)
    );
}
