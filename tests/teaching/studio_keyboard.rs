//! The studio page by keyboard and on a phone's screen, in headless Chromium (see studio.rs
//! for what the browser tests need): Space and Enter on a focused button press it, the key
//! list is a listbox reached by Tab and moved by the arrows, the status line is spoken by a
//! live region; at 390 px wide nothing scrolls sideways, Stop stays in reach and the timeline
//! is drawn at the screen's density; unsaved edits are marked and a reload asks first.

use crate::studio::{browser_run, require_browser_tools, start_studio};
use serde_json::{json, Value};
use std::path::Path;

fn wave() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("sequences/so101_wave.json")
}

/// The layout at 390×844 CSS pixels, 3 device pixels each.
fn fits_a_phone(layout: &Value) {
    let number = |name: &str| {
        layout[name]
            .as_f64()
            .unwrap_or_else(|| panic!("{name}: {layout}"))
    };
    assert_eq!(number("ratio"), 3.0, "{layout}");
    assert!(
        number("scrollWidth") <= number("clientWidth"),
        "the page scrolls sideways: {layout}"
    );
    assert!(
        number("keysRight") <= 390.0,
        "the key list overflows: {layout}"
    );
    assert!(
        number("buttonsRight") <= 390.0,
        "a button is off screen: {layout}"
    );
    assert_eq!(layout["stacked"], json!(true), "{layout}");
    // Scrolled down to the timeline, the Stop button is still on the screen.
    assert!(
        number("scrolled") > 0.0,
        "the page is taller than the screen: {layout}"
    );
    assert_eq!(layout["stopVisible"], json!(true), "{layout}");
    assert_eq!(layout["stopInView"], json!(true), "{layout}");
    // One backing pixel per device pixel: 3 per CSS pixel each way.
    assert!(number("canvasCssWidth") > 0.0, "{layout}");
    assert_eq!(
        number("canvasWidth"),
        number("canvasCssWidth") * 3.0,
        "{layout}"
    );
    assert_eq!(
        number("canvasHeight"),
        number("canvasCssHeight") * 3.0,
        "{layout}"
    );
}

/// The page driven by its keyboard in a phone-sized window; the wave file is edited by one
/// key (`]`) and written by `w`. Each step's oracle is the wave file as written (8 keys, key 1
/// "raise" away from home) and the virtual arm's start at 0°.
#[test]
fn the_page_works_by_keyboard_on_a_phone_and_asks_before_losing_edits() {
    require_browser_tools();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(wave(), dir.path().join("wave.json")).unwrap();
    let (studio, url) = start_studio(dir.path(), &["wave.json"]);
    let results = browser_run("keyboard.mjs", &[Path::new(&url)]);
    drop(studio);

    assert_eq!(results["errors"], json!([]), "the page ran without errors");
    fits_a_phone(&results["layout"]);

    // Space on the focused "next ▶" button pressed it (the next key), not the page's Space
    // (go to the key): the arm's goals and activity are as they were.
    // The page started on key 1, "raise" (pan 20°, lift −30°, ...), with the arm at home (every
    // goal 0°): a go-to-key would have changed the goals.
    let before = &results["before"];
    assert_eq!(before["goals"], json!([0, 0, 0, 0, 0, 0]));
    let current = before["current"].as_u64().unwrap();
    assert_eq!(current, 1);
    assert_eq!(results["spacePressed"], json!(true), "{results}");
    assert_eq!(results["afterSpace"]["current"], json!(current + 1));
    assert_eq!(
        results["afterSpace"]["goals"], before["goals"],
        "the arm stays"
    );
    assert_eq!(results["afterSpace"]["activity"], json!("idle"));
    assert_eq!(
        results["focusKept"],
        json!(">"),
        "the button keeps the focus"
    );
    // Enter on "◀ prev" pressed it.
    assert_eq!(results["enterPressed"], json!(true), "{results}");
    assert_eq!(results["afterEnter"]["goals"], before["goals"]);

    // Tab from the last joint button lands on the key list, a listbox of the wave's 8 keys.
    assert_eq!(
        results["tabbedInto"],
        json!({"role": "listbox", "options": 8})
    );
    // Its arrows move the current key (not the selected joint, the page's ↑ ↓), and
    // aria-selected follows.
    let start = results["start"].as_u64().unwrap() as usize;
    assert_eq!(results["arrowDown"], json!(true), "{results}");
    assert_eq!(results["arrowUp"], json!(true), "{results}");
    let only = |index: usize| -> Value { (0..8).map(|i| json!(i == index)).collect() };
    assert_eq!(results["ariaAfterDown"]["selected"], only(start + 1));
    assert_eq!(
        results["ariaAfterDown"]["active"],
        json!(format!("key-{}", start + 1))
    );
    assert_eq!(results["ariaAfterUp"]["selected"], only(start));
    assert_eq!(results["afterDown"]["selected"], before["selected"]);
    assert_eq!(results["afterUp"]["selected"], before["selected"]);
    assert_eq!(
        results["afterUp"]["goals"], before["goals"],
        "the arm stays"
    );

    // The live region speaks the status line, and changed with it.
    let live = &results["live"];
    assert!(live["after"].is_string(), "no live region: {live}");
    assert_eq!(live["after"], live["status"]);
    assert_ne!(live["after"], live["before"], "{live}");

    // The unsaved mark: off at first, on after `]`, off after `w`; a reload with edits not
    // written asks (the browser's beforeunload question), after `w` it does not.
    assert_eq!(results["markBefore"], json!(false));
    assert_eq!(results["edited"], json!(true), "{results}");
    assert_eq!(results["markAfterEdit"], json!(true));
    assert_eq!(results["askedOnReload"], json!("beforeunload"));
    assert_eq!(results["saved"], json!(true), "{results}");
    assert_eq!(results["markAfterSave"], json!(false));
    assert_eq!(results["dialogsAfterSave"], json!(0));
}
