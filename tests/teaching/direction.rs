//! The direction check (`D`) through the real binary: `keypose teach --keys` on emulated
//! servos served by this test, with a robot file whose elbow direction is wrong. The emulated
//! servos are the real arm (the built-in so101's mapping), so the check's +5° jog moves the
//! elbow the other way; answering `r` must correct the file, and a following +1° jog must then
//! move the servo the right way: to -4° of the real arm (-5° from the check, +1°), where the
//! uncorrected file would have sent it to -6°.

use keypose::robot::Robot;
use keypose::testing::PtyServer;
use serde_json::Value;
use std::process::Command;

const ELBOW: usize = 2;

#[test]
fn a_reversed_joint_is_written_corrected_and_the_next_jog_goes_the_right_way() {
    let dir = tempfile::tempdir().unwrap();
    let real = Robot::builtin("so101").expect("built-in so101");
    let mut wrong: Value =
        serde_json::from_str(include_str!("../../robots/so101.json")).expect("so101.json");
    assert_eq!(wrong["joints"][ELBOW]["name"], "elbow_flex");
    assert_eq!(wrong["joints"][ELBOW]["servo"]["direction"], 1);
    wrong["joints"][ELBOW]["servo"]["direction"] = Value::from(-1);
    let file = dir.path().join("my_arm.json");
    std::fs::write(&file, serde_json::to_string_pretty(&wrong).unwrap()).unwrap();

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

    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).expect("JSON");
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
