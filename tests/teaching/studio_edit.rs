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
