//! `keypose scan` through the real binary against a `keypose virtual-bus` process on a
//! pseudo-terminal: every servo found is listed with its model and alarms.

use crate::common::{repo, run, show, stderr, VirtualBusProcess};
use serde_json::{json, Value};

/// (id, model, alarms) of every servo in a scan's JSON.
fn listed(out: &std::process::Output) -> Vec<(u64, String, Value)> {
    let scan: Value = serde_json::from_slice(&out.stdout).expect("scan prints JSON");
    scan["servos"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["id"].as_u64().unwrap(),
                s["model"].as_str().unwrap_or("?").to_string(),
                s["alarms"].clone(),
            )
        })
        .collect()
}

#[test]
fn a_feetech_servo_in_alarm_is_listed_with_the_others_and_exit_1() {
    let server = VirtualBusProcess::start(&["--robot", "so101", "--fault", "3:overload"]);
    let out = run(&["scan", "--port", &server.path, "--protocol", "feetech-sts"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    // SO-101: six STS3215 on ids 1–6 (docs/robots.md); only servo 3 in alarm.
    let expected: Vec<(u64, String, Value)> = (1..=6)
        .map(|id| {
            let alarms = if id == 3 {
                json!(["overload"])
            } else {
                json!([])
            };
            (id, "sts3215".to_string(), alarms)
        })
        .collect();
    assert_eq!(listed(&out), expected, "{}", show(&out));
    assert!(
        stderr(&out).contains("servo 3: alarm: overload"),
        "{}",
        show(&out)
    );
}

#[test]
fn a_dynamixel_servo_in_alarm_is_listed_with_the_others_and_exit_1() {
    let server = VirtualBusProcess::start(&["--robot", "koch", "--fault", "3:overheating"]);
    let out = run(&["scan", "--port", &server.path, "--protocol", "dynamixel-2"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let servos = listed(&out);
    assert_eq!(servos.len(), 6, "{}", show(&out));
    for (id, model, alarms) in servos {
        // Koch v1.1: XL430-W250 on ids 1–2, XL330-M288 on 3–6.
        assert_eq!(model, if id <= 2 { "xl430-w250" } else { "xl330-m288" });
        let expected = if id == 3 {
            json!(["overheating"])
        } else {
            json!([])
        };
        assert_eq!(alarms, expected, "servo {id}");
    }
}

#[test]
fn a_scan_that_finds_nothing_says_what_to_check_and_exits_1() {
    // Feetech servos do not answer Dynamixel pings.
    let server = VirtualBusProcess::start(&["--robot", "so101"]);
    let out = run(&["scan", "--port", &server.path, "--protocol", "dynamixel-2"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    assert_eq!(listed(&out), vec![]);
    let err = stderr(&out);
    for expected in [
        "no servo answered",
        "powered",
        "--baud",
        "--protocol",
        "id",
        "adapter",
    ] {
        assert!(err.contains(expected), "{expected:?} in {err}");
    }
}

#[test]
fn a_port_that_cannot_be_opened_is_a_hardware_error() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("ttyUSB9").display().to_string();
    let out = run(&["scan", "--port", &missing, "--protocol", "feetech-sts"]);
    assert_eq!(out.status.code(), Some(3), "{}", show(&out));
    assert!(stderr(&out).contains(&missing), "{}", show(&out));
}

#[test]
fn a_plain_file_or_dev_null_is_not_a_serial_port() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("notes.txt");
    std::fs::write(&file, "not a port").unwrap();
    let file = file.display().to_string();
    let sequence = repo("sequences/so101_nod.json");
    for port in [file.as_str(), "/dev/null"] {
        for args in [
            vec!["read", "--robot", "so101", "--port", port],
            vec!["play", sequence.as_str(), "--port", port],
            vec!["scan", "--port", port, "--protocol", "feetech-sts"],
        ] {
            let out = run(&args);
            assert_eq!(out.status.code(), Some(3), "{args:?}: {}", show(&out));
            let err = stderr(&out);
            assert!(
                err.contains(&format!("serial port {port}: not a serial port")),
                "{args:?}: {err}"
            );
            assert!(!err.to_lowercase().contains("typewriter"), "{err}");
        }
    }
}

#[test]
fn a_bus_where_nothing_answers_says_what_to_check() {
    // Dynamixel servos do not answer the Feetech packets an SO-101 (1 Mbps) is spoken to with.
    let server = VirtualBusProcess::start(&["--robot", "koch"]);
    let sequence = repo("sequences/so101_nod.json");
    for args in [
        vec!["read", "--robot", "so101", "--port", &server.path],
        vec!["torque", "off", "--robot", "so101", "--port", &server.path],
        vec!["play", &sequence, "--port", &server.path],
    ] {
        let out = run(&args);
        assert_eq!(out.status.code(), Some(3), "{args:?}: {}", show(&out));
        assert!(
            stderr(&out).contains(
                "no answer from servo 1 at 1000000 baud: is the arm powered, is the id right? try `keypose scan`"
            ),
            "{args:?}: {}",
            show(&out)
        );
    }
}
