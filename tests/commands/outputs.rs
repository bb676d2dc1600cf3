//! Every file the binary writes is replaced atomically: `-o` equal to the input, a symbolic
//! link, a file's permissions, a temporary left by a killed process.

use crate::common::{repo, run as keypose, show};
use std::fs;
use std::path::Path;

/// 90° in 0.5 s on so101's elbow: too fast, so `retime` changes it.
const FAST: &str = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
  {"time":0,"joints":{"shoulder_lift":-90,"elbow_flex":0}},{"time":0.5,"joints":{"elbow_flex":90}}]}"#;

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn retime_with_output_equal_to_input_rewrites_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fast.json");
    fs::write(&path, FAST).unwrap();
    let p = path.to_str().unwrap();
    let out = keypose(&["retime", p, "-o", p]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // The cubic needs T ≥ √(6·90/344) = 1.2529 s (docs/commands.md): the file now holds the longer time.
    let seq: serde_json::Value = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    let end = seq["keyframes"][1]["time"].as_f64().unwrap();
    assert!(end >= 1.2529, "end time {end}");
    assert_eq!(keypose(&["check", p]).status.code(), Some(0));
    assert_eq!(names_in(dir.path()), ["fast.json"]);
}

#[cfg(unix)]
#[test]
fn an_output_through_a_symlink_updates_the_target_and_keeps_its_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("data")).unwrap();
    let target = dir.path().join("data").join("fixed.json");
    fs::write(&target, "old").unwrap();
    fs::set_permissions(&target, fs::Permissions::from_mode(0o640)).unwrap();
    let link = dir.path().join("fixed.json");
    std::os::unix::fs::symlink("data/fixed.json", &link).unwrap();
    let input = dir.path().join("fast.json");
    fs::write(&input, FAST).unwrap();
    let out = keypose(&[
        "retime",
        input.to_str().unwrap(),
        "-o",
        link.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(fs::read_to_string(&target)
        .unwrap()
        .contains("keypose-sequence/1"));
    let mode = fs::metadata(&target).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o640);
    assert_eq!(names_in(&dir.path().join("data")), ["fixed.json"]);
}

#[test]
fn an_orphan_temporary_of_the_output_is_cleaned_up() {
    let dir = tempfile::tempdir().unwrap();
    // What a `keypose sample` killed mid-write leaves: a temporary of a process now gone.
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let orphan = dir
        .path()
        .join(format!(".samples.csv.keypose-tmp-{dead}-0123456789abcdef"));
    fs::write(&orphan, "time,shoulder_pan\n0,").unwrap();
    let output = dir.path().join("samples.csv");
    let out = keypose(&[
        "sample",
        &repo("sequences/so101_nod.json"),
        "-o",
        output.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    assert!(fs::read_to_string(&output).unwrap().starts_with("time,"));
    assert_eq!(names_in(dir.path()), ["samples.csv"]);
}

/// A playback log is streamed to a temporary and put in place when playback ends, also when it
/// ends in a fault (the case the log is most needed for).
#[test]
fn a_playback_log_is_kept_when_playback_ends_in_a_fault() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("faulted.csv");
    fs::write(&log, "an older log\n").unwrap();
    // Servo 3 stops answering 1.5 s in (as play_cli's fault cases), during the 6.5 s nod.
    let server = crate::common::VirtualBusProcess::start(&[
        "--robot",
        "so101",
        "--fault",
        "3:no-answer",
        "--fault-after",
        "1.5",
    ]);
    let out = keypose(&[
        "play",
        &repo("sequences/so101_nod.json"),
        "--port",
        &server.path,
        "--quiet",
        "--log",
        log.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(3), "{}", show(&out));
    let text = fs::read_to_string(&log).unwrap();
    assert!(text.starts_with("time,phase,sequence_time,"), "{text}");
    assert_eq!(names_in(dir.path()), ["faulted.csv"]);
}
