//! The studio as an editor, in headless Chromium (see studio.rs for what the browser tests
//! need): undo and redo from the page, and a studio without an arm (no `--port`: the arm
//! drawn only), which says so when its server goes away.

use crate::studio::{browser_run, require_browser_tools, start_studio};
use serde_json::{json, Value};

/// Numbers as the page sent them (JSON has one number type; 0 and 0.0 are the same time).
fn numbers(value: &Value) -> Vec<f64> {
    serde_json::from_value(value.clone()).unwrap_or_else(|e| panic!("{value}: {e}"))
}
use std::path::Path;

fn wave() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("sequences/so101_wave.json")
}

/// The wave's key times, from the file (an oracle the page does not compute).
fn wave_times() -> Vec<f64> {
    let sequence = keypose::sequence::Sequence::load(&wave()).unwrap();
    sequence.key_times()
}

/// A plain click on a key's mark selects it and leaves its time alone; `d` is undone by
/// Ctrl+Z and the undo button and redone by Ctrl+Shift+Z and Ctrl+Y; a drag in time is undone;
/// undo never moves the arm; a refusal on the status line goes with the next answer. The file
/// written at the end is the wave as it was.
#[test]
fn the_page_undoes_and_redoes_edits_and_a_click_on_a_key_does_not_move_it() {
    require_browser_tools();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(wave(), dir.path().join("wave.json")).unwrap();
    let (studio, url) = start_studio(dir.path(), &["wave.json"]);
    let results = browser_run("undo.mjs", &[Path::new(&url)]);
    drop(studio);

    assert_eq!(results["errors"], json!([]), "the page ran without errors");
    let times = wave_times();
    assert_eq!(numbers(&results["start"]), times);
    assert_eq!(numbers(&results["afterClick"]), times, "a click is no drag");
    assert_eq!(
        numbers(&results["afterUndo"]),
        times,
        "the deleted key is back"
    );
    assert_eq!(results["currentAfterUndo"], json!(2));
    let said = results["statusAfterUndo"].as_str().unwrap();
    assert!(said.starts_with("undid: deleted key 2"), "{said}");
    let title = results["undoTitle"].as_str().unwrap();
    assert!(title.starts_with("undo: deleted key 2"), "{title}");
    assert_eq!(results["redoOffAtEnd"], json!(true));
    assert_ne!(
        numbers(&results["afterDrag"]),
        times,
        "the drag moved key 2"
    );
    assert_eq!(numbers(&results["afterDragUndo"]), times);
    assert_eq!(
        results["goalsAfter"], results["goalsBefore"],
        "the arm stays"
    );
    assert_eq!(results["refusal"], json!("error"));
    assert_eq!(
        results["afterRefusal"],
        json!({"text": results["saidBefore"], "error": false})
    );
    let written = keypose::sequence::Sequence::load(&dir.path().join("wave.json")).unwrap();
    let original = keypose::sequence::Sequence::load(&wave()).unwrap();
    assert_eq!(
        written.keyframes, original.keyframes,
        "every edit was undone"
    );
}

/// `keypose studio SEQ` without `--port`: the arm drawn only. The page jogs it (the pan by
/// 10°, which the drawn servo reaches as 114 ticks of 4096 a turn: 10.01953125°), captures a
/// key, drags the tool handle (10 mm along −x, taken), moves to key 0 (home: every joint at
/// 0°, as the file says) and simulates. The studio is stopped for 3 s: the page watches
/// meanwhile and takes control back when it runs again. It saves; the file has the captured
/// key. Then the studio is killed: the page stops claiming control and says the studio does
/// not answer, and a key pressed then is answered as not sent. How long the page took to notice is measured, not
/// judged.
#[test]
fn without_a_port_the_studio_edits_a_drawn_arm_and_a_lost_server_is_said() {
    require_browser_tools();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(wave(), dir.path().join("wave.json")).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_keypose"))
        .args(["studio", "wave.json"])
        .current_dir(dir.path())
        .env("KEYPOSE_CACHE", crate::common::python_cache())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("start keypose studio");
    let stdout = child.stdout.take().unwrap();
    let pid = child.id().to_string();
    let _studio = crate::studio::Studio(child);
    let mut url = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut url).unwrap();
    let results = browser_run("drawn.mjs", &[Path::new(url.trim()), Path::new(&pid)]);

    assert_eq!(results["errors"], json!([]), "the page ran without errors");
    assert!(
        results["bus"].as_str().unwrap().starts_with("a drawn arm"),
        "{results}"
    );
    assert_eq!(numbers(&results["start"]), [0.0; 6], "home");
    let jogged = numbers(&results["jogged"]);
    assert!((jogged[0] - 10.01953125).abs() < 1e-9, "{jogged:?}");
    assert_eq!(results["keys"], json!(9));
    assert_eq!(results["target"]["refused"], json!(false), "{results}");
    let (before, after) = (
        numbers(&results["tcpBefore"]),
        numbers(&results["tcpAfter"]),
    );
    assert!(
        (after[0] - (before[0] - 0.01)).abs() < 0.0002,
        "{before:?} → {after:?}"
    );
    assert_eq!(numbers(&results["atKey0"]), [0.0; 6], "key 0 is home");
    assert_eq!(results["timelineJoints"], json!(6));
    assert_eq!(results["simulated"], json!(true));
    let written = keypose::sequence::Sequence::load(&dir.path().join("wave.json")).unwrap();
    assert_eq!(written.keyframes.len(), 9);
    let captured = written.keyframes[1].value("shoulder_pan");
    assert_eq!(
        captured,
        Some(&keypose::sequence::KeyValue::Joint(10.0)),
        "the capture, rounded to 0.1°"
    );

    // Stopped for 3 s, the studio lost the page's heartbeat; running again, the page's
    // first key took control back, and the badge says so.
    assert_eq!(results["badgeWhenStalled"], json!("watching"));
    assert_eq!(results["keyAfterStall"], json!(true), "{results}");
    assert_eq!(results["badgeAfterStall"], json!("in control"));

    assert_eq!(results["badge"], json!("watching"));
    for said in ["statusWhenLost", "statusAfterKey"] {
        let text = results[said].as_str().unwrap();
        assert!(text.contains("does not answer"), "{said}: {text}");
    }
    assert_eq!(results["keyAfterLoss"], json!(false));
    eprintln!(
        "the page noticed the killed studio after {:.0} ms",
        results["lostMs"].as_f64().unwrap()
    );
}

/// Several keys at once through the page: Shift-click selects a range, Ctrl-click takes a key
/// out, Ctrl+C and Ctrl+V paste copies after the last key with their own spacing, a drag of
/// one pasted mark moves both by the same time, `d` deletes both and Ctrl+Z brings them back,
/// Ctrl+A selects every key. The pasted times are worked out here from the file's times and
/// the paste rule (docs/studio.md), not read from the page.
#[test]
fn the_page_selects_copies_pastes_drags_and_deletes_several_keys() {
    require_browser_tools();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(wave(), dir.path().join("wave.json")).unwrap();
    let (studio, url) = start_studio(dir.path(), &["wave.json"]);
    let shots = tempfile::tempdir().unwrap();
    let results = browser_run("selection.mjs", &[Path::new(&url), shots.path()]);
    drop(studio);
    let shot = "studio-selection-easing.png";
    assert!(shots.path().join(shot).exists(), "the screenshot was taken");
    if let Ok(keep) = std::env::var("KEYPOSE_STUDIO_SHOTS") {
        std::fs::copy(shots.path().join(shot), Path::new(&keep).join(shot)).unwrap();
    }

    assert_eq!(results["errors"], json!([]), "the page ran without errors");
    assert_eq!(results["range"], json!([1, 2, 3]));
    assert_eq!(
        results["ariaRange"],
        json!([1, 2, 3]),
        "the list says so too"
    );
    assert_eq!(results["toggled"], json!([1, 3]));
    let said = results["statusToggled"].as_str().unwrap();
    assert!(said.starts_with("keys 1 and 3 selected"), "{said}");

    // Pasted after key 7 (the last): one gap after it, the gap key 7 had after key 6's hold;
    // the copies keep their own spacing (key 3's time − key 1's).
    let wave = keypose::sequence::Sequence::load(&wave()).unwrap();
    let t = wave.key_times();
    let hold = |i: usize| wave.keyframes[i].hold;
    let gap = t[7] - (t[6] + hold(6));
    let first = t[7] + hold(7) + gap;
    let mut expected = t.clone();
    expected.extend([first, first + t[3] - t[1]]);
    let pasted = numbers(&results["pasted"]["times"]);
    for (got, want) in pasted.iter().zip(&expected) {
        assert!((got - want).abs() < 1e-9, "{pasted:?} vs {expected:?}");
    }
    assert_eq!(pasted.len(), 10);
    let values = &results["pasted"]["values"];
    assert_eq!(values[8], values[1], "key 1's pose");
    assert_eq!(values[9], values[3], "key 3's pose");
    assert_eq!(results["pasted"]["current"], json!(8));
    assert_eq!(results["pastedSelection"], json!([8, 9]));

    let dragged = numbers(&results["dragged"]);
    let (d8, d9) = (dragged[8] - pasted[8], dragged[9] - pasted[9]);
    assert!(d8 > 0.0, "moved later: {dragged:?}");
    assert!((d8 - d9).abs() < 1e-9, "both by the same time: {d8} {d9}");
    assert_eq!(dragged[..8], pasted[..8], "the other keys stay");
    let deleted = results["statusDeleted"].as_str().unwrap();
    assert!(deleted.starts_with("deleted keys 8 and 9"), "{deleted}");
    assert_eq!(results["all"], json!((0..10).collect::<Vec<_>>()));

    // Easing: refused on the wave's smooth segment, said on the page; on the segment made
    // linear both handles moved, and the file written has the segment eased from rest to rest.
    assert_eq!(results["easingCubic"]["allowed"], json!(false));
    let label = results["easingLabel"].as_str().unwrap();
    assert!(label.contains("linear segments"), "{label}");
    let eased = &results["eased"];
    let (out, into) = (
        eased["out"].as_f64().unwrap(),
        eased["in"].as_f64().unwrap(),
    );
    assert!(out > 0.0 && into > 0.0 && out + into <= 1.0, "{eased}");
    let said = results["easedStatus"].as_str().unwrap();
    assert!(said.contains("slows down over"), "{said}");
    let written = keypose::sequence::Sequence::load(&dir.path().join("wave.json")).unwrap();
    let timing = written.keyframes[0]
        .timing
        .as_ref()
        .expect("key 0's segment is eased");
    let keypose::sequence::TimeProfile::Speeds(speeds) = &timing.profile else {
        panic!("an eased segment has speeds")
    };
    assert_eq!(
        (speeds[0], speeds[speeds.len() - 1]),
        (0.0, 0.0),
        "from rest to rest"
    );
    let (o, i) = timing.ease_shares();
    assert!((o - out).abs() < 1e-9 && (i - into).abs() < 1e-9);
    assert_eq!(
        written.keyframes[0].interp,
        Some(keypose::curve::Interp::Linear)
    );
}
