//! The direction check (`D`) through the real binary: `keypose teach --keys` on emulated
//! servos served by this test, with a robot file whose elbow direction is wrong. The emulated
//! servos are the real arm (the built-in so101's mapping), so the check's +5° jog moves the
//! elbow the other way; answering `r` must correct the file, and a following +1° jog must then
//! move the servo the right way: to -4° of the real arm (-5° from the check, +1°), where the
//! uncorrected file would have sent it to -6°. The same through the studio's page.

use keypose::robot::Robot;
use keypose::testing::PtyServer;
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};

const ELBOW: usize = 2;

/// The built-in so101's robot file with the elbow's direction reversed, written into `dir` as
/// my_arm.json; the file's JSON.
fn wrong_robot_file(dir: &Path) -> Value {
    let mut wrong: Value =
        serde_json::from_str(include_str!("../../robots/so101.json")).expect("so101.json");
    assert_eq!(wrong["joints"][ELBOW]["name"], "elbow_flex");
    assert_eq!(wrong["joints"][ELBOW]["servo"]["direction"], 1);
    wrong["joints"][ELBOW]["servo"]["direction"] = Value::from(-1);
    let text = serde_json::to_string_pretty(&wrong).unwrap();
    std::fs::write(dir.join("my_arm.json"), text).unwrap();
    wrong
}

/// The file corrected (only the elbow's direction) and the real elbow at −4°.
fn assert_corrected(dir: &Path, wrong: &Value, real: &Robot, server: &PtyServer, said: &str) {
    let file = dir.join("my_arm.json");
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(file).unwrap()).expect("JSON");
    let mut expected = wrong.clone();
    expected["joints"][ELBOW]["servo"]["direction"] = Value::from(1);
    assert_eq!(written, expected, "only the elbow's direction changes");

    let servo = &real.joints[ELBOW].servo;
    let tick = server.bus().lock().positions()[&servo.id];
    let degrees = servo.value_exact(tick);
    assert!(
        (degrees - -4.0).abs() < 0.1,
        "the real elbow is at {degrees:.2}° ({tick} ticks), expected -4°\n{said}"
    );
}

#[test]
fn a_reversed_joint_is_written_corrected_and_the_next_jog_goes_the_right_way() {
    let dir = tempfile::tempdir().unwrap();
    let real = Robot::builtin("so101").expect("built-in so101");
    let wrong = wrong_robot_file(dir.path());

    let server = PtyServer::start(&real).expect("virtual bus on a pseudo-terminal");
    // Every joint is asked in turn; the elbow (the third) is answered "reversed". Then the
    // elbow is selected and jogged +1°.
    let script = "D m m r m m m\ndown down right\nq\n";
    std::fs::write(dir.path().join("check.keys"), script).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_keypose"))
        .current_dir(dir.path())
        .env("KEYPOSE_CACHE", dir.path().join("cache"))
        .args(["teach", "--robot", "my_arm.json", "--port", server.path()])
        .args(["--keys", "check.keys"])
        .output()
        .expect("run keypose teach");
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    assert!(
        said.contains("direction check done: reversed elbow_flex, written to my_arm.json"),
        "{said}"
    );

    assert_corrected(dir.path(), &wrong, &real, &server, &said);
}

/// The page's "direction check" button, its question per joint and its two answer buttons,
/// on the same wrong file and emulated arm: the same correction and the same −4°.
#[test]
fn the_studio_page_checks_directions_with_its_buttons() {
    crate::studio::require_browser_tools();
    let dir = tempfile::tempdir().unwrap();
    let real = Robot::builtin("so101").expect("built-in so101");
    let wrong = wrong_robot_file(dir.path());
    let server = PtyServer::start(&real).expect("virtual bus on a pseudo-terminal");
    let mut child = Command::new(env!("CARGO_BIN_EXE_keypose"))
        .current_dir(dir.path())
        .env("KEYPOSE_CACHE", crate::common::python_cache())
        .args(["studio", "--robot", "my_arm.json", "--port", server.path()])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start keypose studio");
    let stdout = child.stdout.take().unwrap();
    let _studio = crate::studio::Studio(child);
    let mut url = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut url).unwrap();
    let results = crate::studio::browser_run("direction.mjs", &[Path::new(url.trim())]);

    assert_eq!(results["errors"], serde_json::json!([]), "{results}");
    let questions = results["questions"].as_array().unwrap();
    assert_eq!(questions.len(), 6);
    for (question, joint) in questions.iter().zip(&real.joints) {
        let text = question["text"].as_str().unwrap();
        assert!(text.contains(&joint.name), "{text}");
        assert_eq!(question["buttonsShown"], true, "{question}");
        assert_eq!(question["yesNoShown"], false, "{question}");
    }
    let status = results["status"].as_str().unwrap();
    assert!(
        status.contains("direction check done: reversed elbow_flex, written to my_arm.json"),
        "{status}"
    );
    assert_corrected(dir.path(), &wrong, &real, &server, status);
    // What the page drew for the elbow is the real one: −4°.
    let elbow = results["elbow"].as_f64().unwrap();
    assert!((elbow - -4.0).abs() < 0.1, "{elbow}");
}
