//! `keypose play` and the bus commands as a user runs them: the real binary, the real serial
//! code, emulated servos on a pseudo-terminal (`--port virtual`, or a `keypose virtual-bus`
//! process), real signals.

use crate::common::{
    keypose, play_patiently, repo, run, stderr, VirtualBusProcess, TOLERATED_STALL,
};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// A slow 6 s sweep of one joint, within every limit.
fn long_sequence(dir: &std::path::Path, robot: &str, joint: &str) -> String {
    let path = dir.join(format!("{robot}_long.json"));
    std::fs::write(
        &path,
        format!(
            r#"{{"format":"keypose-sequence/1","robot":"{robot}","keyframes":[
              {{"time":0,"joints":{{"{joint}":0}}}},{{"time":6,"joints":{{"{joint}":30}}}}]}}"#
        ),
    )
    .unwrap();
    path.display().to_string()
}

#[test]
fn every_example_plays_end_to_end_on_the_virtual_bus() {
    let examples = ["so101_nod", "koch_wave", "omx_reach"];
    // Each plays in real time on servos of its own: side by side, the test waits for the
    // longest one instead of all three in turn.
    let outs: Vec<_> = std::thread::scope(|scope| {
        let players: Vec<_> = examples
            .iter()
            .map(|example| {
                let file = repo(&format!("sequences/{example}.json"));
                scope.spawn(move || play_patiently(&[&file, "--port", "virtual"]))
            })
            .collect();
        players
            .into_iter()
            .map(|p| p.join().expect("a player thread"))
            .collect()
    });
    for (example, out) in examples.iter().zip(outs) {
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(0), "{example}: {err}");
        // The progress line and the closing report.
        assert!(
            err.contains("approach") && err.contains("loop 1/1"),
            "{example}: {err}"
        );
        assert!(err.contains("done:"), "{example}: {err}");
    }
}

#[test]
fn a_virtual_bus_process_serves_play_read_torque_and_scan() {
    let server = VirtualBusProcess::start(&["--robot", "koch"]);
    let port = server.path.as_str();
    let out = run(&["read", "--robot", "koch", "--port", port]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let pose: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Koch rests at home (all 0°): tick 2048 on every servo.
    assert_eq!(
        pose["ticks"],
        serde_json::json!([2048, 2048, 2048, 2048, 2048, 2048])
    );
    assert_eq!(pose["joints"]["elbow_flex"], 0.0);

    // What is played is not the subject (every_example_plays_end_to_end_on_the_virtual_bus
    // plays koch_wave): a second of it is enough to show the process serves a playback.
    let dir = tempfile::tempdir().unwrap();
    let short = dir.path().join("koch_short.json");
    std::fs::write(
        &short,
        r#"{"format":"keypose-sequence/1","robot":"koch","keyframes":[
          {"time":0,"joints":{"elbow_flex":0}},{"time":1,"joints":{"elbow_flex":10}}]}"#,
    )
    .unwrap();
    let short = short.display().to_string();
    let out = play_patiently(&[&short, "--port", port, "--quiet"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let out = run(&[
        "torque", "off", "--robot", "koch", "--port", port, "--joints", "gripper",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));

    let out = run(&["scan", "--port", port, "--protocol", "dynamixel-2"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let scan: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let models: Vec<(u64, String)> = scan["servos"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["id"].as_u64().unwrap(),
                s["model"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    // Koch v1.1: XL430-W250 on ids 1–2, XL330-M288 on 3–6 (docs/robots.md §2.4).
    let expected: Vec<(u64, String)> = (1..=6)
        .map(|id| {
            (
                id,
                if id <= 2 { "xl430-w250" } else { "xl330-m288" }.to_string(),
            )
        })
        .collect();
    assert_eq!(models, expected);
}

#[test]
fn every_injected_fault_ends_playback_with_a_report_and_exit_code_3() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("so101", "3:no-answer", "servo 3: no answer"),
        ("so101", "3:corrupt", "servo 3: corrupt answer"),
        ("so101", "3:late=150", "servo 3: no answer"),
        ("so101", "3:overload", "servo 3: alarm: overload"),
        ("koch", "3:overheating", "servo 3: alarm: overheating"),
        ("koch", "3:voltage", "servo 3: alarm: input voltage"),
        ("so101", "gone", "serial port"),
    ];
    let runs: Vec<_> = cases
        .iter()
        .map(|&(robot, fault, _)| {
            // Both arms name their third joint (servo 3) elbow_flex. Written once per robot:
            // writing it again for the next case would race with a run still reading it.
            let sequence = dir.path().join(format!("{robot}_long.json"));
            let sequence = if sequence.exists() {
                sequence.display().to_string()
            } else {
                long_sequence(dir.path(), robot, "elbow_flex")
            };
            std::thread::spawn(move || {
                let server = VirtualBusProcess::start(&[
                    "--robot",
                    robot,
                    "--fault",
                    fault,
                    "--fault-after",
                    "1.5",
                ]);
                let out = play_patiently(&[&sequence, "--port", &server.path, "--quiet"]);
                (out, server.path.clone())
            })
        })
        .collect();
    for ((_, fault, expected), run) in cases.iter().zip(runs) {
        let (out, path) = run.join().unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(3), "{fault}: {err}");
        assert!(
            err.contains(expected),
            "{fault}: expected {expected:?} in {err}"
        );
        assert!(err.contains("playback stopped"), "{fault}: {err}");
        if *fault == "gone" {
            assert!(
                err.contains(&path),
                "the report does not name the port: {err}"
            );
        } else {
            assert!(err.contains("joint elbow_flex"), "{fault}: {err}");
        }
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// Starts `play` on a 6 s sequence, sends SIGINT `signals` times after 1.5 s, returns output.
fn interrupted(signals: usize) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let sequence = long_sequence(dir.path(), "so101", "shoulder_pan");
    let child = keypose()
        // The test is about Ctrl-C: a loaded test machine can stall the process past the
        // default bound, which is a different fault (tests/servos/player_stalls.rs), so it is raised.
        .args(["play", &sequence, "--port", "virtual", "--quiet"])
        .args(TOLERATED_STALL)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    for _ in 0..signals {
        let status = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn ctrl_c_decelerates_and_holds_a_second_ctrl_c_holds_at_once() {
    let out = interrupted(1);
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    // A stop the user asked for is said plainly, not as an error.
    let err = stderr(&out);
    assert!(
        err.lines().any(|l| l.starts_with(
            "stopped on request: the arm decelerated along its path and holds there, torque on"
        )),
        "{err}"
    );
    assert!(!err.contains("error"), "{err}");
    let out = interrupted(2);
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.lines().any(|l| l.starts_with("held at once")), "{err}");
    assert!(!err.contains("error"), "{err}");
}

#[test]
fn a_missing_port_is_a_bus_error_and_nothing_plays() {
    let out = play_without_port(&repo("sequences/so101_nod.json"), &[]);
    assert_eq!(out.status.code(), Some(3));
    assert!(
        stderr(&out).contains("/dev/keypose-no-such-port"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_sequence_beyond_the_limits_at_the_chosen_speed_is_refused_before_any_port_is_opened() {
    let out = play_without_port(&repo("sequences/so101_nod.json"), &["--speed", "2"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("refusing to play"),
        "{}",
        stderr(&out)
    );
}

/// `keypose play SEQUENCE --port <a missing port> ARGS`: anything refused before the port is
/// opened exits with its own code, anything else meets the missing port (exit 3).
fn play_without_port(sequence: &str, args: &[&str]) -> Output {
    let mut all = vec!["play", sequence, "--port", "/dev/keypose-no-such-port"];
    all.extend_from_slice(args);
    run(&all)
}

#[test]
fn from_a_name_two_keys_share_is_refused_listing_both_indices() {
    // so101_pick_place.json starts and ends at a key named "home": keys 0 and 9.
    let pick_place = repo("sequences/so101_pick_place.json");
    let out = play_without_port(&pick_place, &["--from", "home"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("--from \"home\""), "{err}");
    assert!(
        err.contains("2 keys have this name, at indices 0, 9"),
        "{err}"
    );
    // A name one key has still starts there: at 4 s, where the arm's joints (keyed at "down"
    // and "lift" only) are on their way, so starting there from rest is a corner the check
    // refuses, at 4 s.
    let out = play_without_port(&pick_place, &["--from", "grasp"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("from key \"grasp\""), "{err}");
    assert!(
        err.contains("segment 4 (grasp → lift), t = 4.000 s"),
        "{err}"
    );
}

/// The first number after `prefix` in `text`.
fn number_after(text: &str, prefix: &str) -> f64 {
    let rest = &text[text
        .find(prefix)
        .unwrap_or_else(|| panic!("{prefix:?} in {text}"))
        + prefix.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end].parse().unwrap()
}

#[test]
fn a_refusal_at_speed_reports_the_robots_limits_and_the_servos_velocities() {
    // elbow_flex 0 → 90° in 2 s, cubic: at speed 1 it peaks at 1.5·Δ/T = 67.5 °/s and
    // 6·Δ/T² = 135 °/s², inside SO-101's 115 °/s and 344 °/s²; at speed 2 the servos would see
    // twice the velocity (135 °/s) and four times the acceleration (540 °/s²).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("slow.json");
    std::fs::write(
        &path,
        r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic","keyframes":[
          {"time":0,"joints":{"elbow_flex":0}},{"time":2,"joints":{"elbow_flex":90}}]}"#,
    )
    .unwrap();
    let out = play_without_port(path.to_str().unwrap(), &["--speed", "2"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    let velocity = err.lines().find(|l| l.contains(" velocity ")).expect(&err);
    assert!(velocity.contains("> limit 115.000 deg/s,"), "{velocity}");
    let peak = number_after(velocity, "): ");
    assert!((peak - 135.0).abs() < 1e-3, "{velocity}");
    let acceleration = err
        .lines()
        .find(|l| l.contains(" acceleration "))
        .expect(&err);
    assert!(
        acceleration.contains("limit 344.000 deg/s²"),
        "{acceleration}"
    );
    // The exact peak, at the ends of the cubic.
    let peak = number_after(acceleration, "): ").abs();
    assert!((peak - 540.0).abs() < 1e-3, "{acceleration}");
    // Steps and corners would be judged at the control rate, as the servos get it.
    assert!(err.contains("at the 100 Hz control rate"), "{err}");
}

#[test]
fn the_progress_line_reaches_the_last_key_and_the_summary_names_the_joint_and_unit() {
    let out = play_patiently(&[&repo("sequences/so101_nod.json"), "--port", "virtual"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    // The last redraw of the progress line, at the end: all six keys passed, the last is "rest".
    let last = err.rsplit('\r').find(|l| l.contains(" key ")).expect(&err);
    assert!(last.contains("key 6/6 rest"), "{last:?}");
    // wrist_flex swings 60° per key, three times as fast as any other joint: it lags most.
    let done = err.lines().find(|l| l.starts_with("done:")).expect(&err);
    let error = number_after(done, "largest tracking error ");
    assert!(error > 0.0, "{done}");
    assert!(
        done.ends_with(&format!(
            "largest tracking error {error:.2} deg (wrist_flex)"
        )),
        "{done}"
    );
}

#[test]
fn no_approach_needs_its_confirmation() {
    let out = run(&[
        "play",
        &repo("sequences/so101_nod.json"),
        "--port",
        "virtual",
        "--no-approach",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--i-accept-the-jump"));
}

#[test]
fn ports_and_doctor_run_on_a_machine_without_adapters() {
    for command in ["ports", "doctor"] {
        let out = keypose().arg(command).output().unwrap();
        assert_eq!(out.status.code(), Some(0), "{command}: {}", stderr(&out));
    }
}

#[test]
fn a_usb_latency_beyond_the_ftdi_timer_range_is_refused_before_anything_opens() {
    // The FTDI latency timer takes 0…255 ms; 300 is bad input: exit 2, naming the option.
    let out = keypose()
        .args([
            "play",
            &repo("sequences/so101_nod.json"),
            "--port",
            "virtual",
        ])
        .args(["--usb-latency", "300"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("--usb-latency"), "{}", stderr(&out));
    assert!(stderr(&out).contains("0 to 255 ms"), "{}", stderr(&out));
}

#[test]
fn doctor_reports_the_governors_the_sysfs_files_hold_and_how_to_tune_the_adapter() {
    let out = keypose().arg("doctor").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    // The governor files, read here independently of keypose.
    let mut governors = Vec::new();
    for entry in std::fs::read_dir("/sys/devices/system/cpu")
        .unwrap()
        .flatten()
    {
        let file = entry.path().join("cpufreq/scaling_governor");
        if let Ok(governor) = std::fs::read_to_string(&file) {
            let cpu = entry.file_name().to_string_lossy().into_owned();
            governors.push(format!("{cpu}: scaling_governor {}", governor.trim()));
        }
    }
    if governors.is_empty() {
        assert!(
            text.contains("CPU frequency scaling:\n  not exposed"),
            "{text}"
        );
    }
    for line in &governors {
        assert!(text.contains(line.as_str()), "{line} missing from:\n{text}");
    }
    // The udev rule that sets an FTDI adapter's latency timer to 1 ms (ftdi_sio's sysfs
    // attribute), and whether SCHED_FIFO is available.
    assert!(
        text.contains(r#"DRIVER=="ftdi_sio", ATTR{latency_timer}="1""#),
        "{text}"
    );
    assert!(
        text.contains("SCHED_FIFO: permitted") || text.contains("SCHED_FIFO: refused"),
        "{text}"
    );
}

#[test]
fn a_playback_log_overlays_on_its_sequence_and_a_broken_log_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("nod.csv");
    let out = keypose()
        .args([
            "play",
            &repo("sequences/so101_nod.json"),
            "--port",
            "virtual",
            "--quiet",
        ])
        .args(TOLERATED_STALL)
        .args(["--log", log.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = std::fs::read_to_string(&log).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.starts_with("time,phase,sequence_time,shoulder_pan_cmd"));
    assert!(header.contains("gripper_meas,lateness_ms,stall_ms,shoulder_pan_load_pct,"));
    assert!(
        header.ends_with(",wrist_roll_alarms,gripper_alarms"),
        "{header}"
    );
    // 0.5 s ramp + 6 s at 100 Hz, plus the final pose: at least 650 cycles.
    assert!(text.lines().count() > 650);

    let svg = dir.path().join("nod.svg");
    let out = keypose()
        .args([
            "plot",
            &repo("sequences/so101_nod.json"),
            "--log",
            log.to_str().unwrap(),
        ])
        .args(["-o", svg.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    // Position, velocity and the measured trace for each of the 6 joints; then each joint's
    // telemetry row: load, need and temperature.
    assert_eq!(
        std::fs::read_to_string(&svg)
            .unwrap()
            .matches("<polyline")
            .count(),
        18 + 18
    );

    let broken = dir.path().join("broken.csv");
    std::fs::write(&broken, text.replacen(",play,", ",play,x", 1)).unwrap();
    let out = keypose()
        .args([
            "plot",
            &repo("sequences/so101_nod.json"),
            "--log",
            broken.to_str().unwrap(),
        ])
        .args(["-o", svg.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("broken.csv:"), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("expected a number in column \"sequence_time\""),
        "{}",
        stderr(&out)
    );
}

/// The rows of a playback log (the header first), split into fields.
fn csv_rows(path: &std::path::Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

#[test]
fn a_killed_playback_keeps_its_log_under_its_own_name_up_to_the_last_second() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("wave.csv");
    // An earlier log of the same name: replaced whole by the new one.
    std::fs::write(&log, "an earlier log\n").unwrap();
    let mut child = keypose()
        .args([
            "play",
            &repo("sequences/so101_wave.json"),
            "--port",
            "virtual",
        ])
        .args(TOLERATED_STALL)
        .args(["--quiet", "--log", log.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Watch the log under its own name while it plays; once it holds two seconds of
    // playback, kill the process outright (SIGKILL: nothing of keypose's runs after it).
    let time_of = |row: &Vec<String>| row[0].parse::<f64>().ok();
    let mut seen = None;
    while child.try_wait().unwrap().is_none() {
        let rows = csv_rows(&log);
        if let Some(t) = rows.last().and_then(time_of).filter(|&t| t >= 2.0) {
            child.kill().unwrap();
            seen = Some(t);
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    // Killed, not ended on its own (after which its log is in place anyway).
    let seen = seen
        .filter(|_| out.status.code().is_none())
        .unwrap_or_else(|| {
            panic!(
                "the log never showed 2 s of playback under its own name while playing: {}",
                stderr(&out)
            )
        });
    let rows = csv_rows(&log);
    assert!(rows[0].starts_with(&["time".to_string(), "phase".to_string()]));
    let columns = rows[0].len();
    // Whole rows only, up to at least the row seen before the kill.
    for row in &rows[1..] {
        assert_eq!(row.len(), columns, "a torn row: {row:?}");
    }
    let last = rows.last().and_then(time_of).unwrap();
    assert!(last >= seen, "the log shrank from {seen} s to {last} s");
    // No hidden temporary is left beside it.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["wave.csv".to_string()]);
}

/// Plays `so101_wave.json` with a log, stops the process (SIGSTOP) for `stall_ms` 1.5 s in,
/// then lets it go on; returns the output and the log's rows.
fn stopped_for(stall_ms: u64, extra: &[&str]) -> (Output, Vec<Vec<String>>, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stall.csv");
    let log_arg = log.display().to_string();
    let wave = repo("sequences/so101_wave.json");
    let mut args = vec![
        "play",
        wave.as_str(),
        "--port",
        "virtual",
        "--quiet",
        "--log",
        log_arg.as_str(),
    ];
    args.extend_from_slice(extra);
    let child = keypose()
        .args(&args)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id().to_string();
    let signal = |name: &str| {
        let status = Command::new("kill")
            .args([name, pid.as_str()])
            .status()
            .unwrap();
        assert!(status.success());
    };
    std::thread::sleep(Duration::from_millis(1500));
    signal("-STOP");
    std::thread::sleep(Duration::from_millis(stall_ms));
    signal("-CONT");
    let out = child.wait_with_output().unwrap();
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (out, rows, header)
}

/// Checks every commanded step in a playback log against v·T of the SO-101 (115 °/s at
/// 100 Hz: 1.15° per cycle; the log keeps six decimals). Returns the rows marked as stalls.
fn commanded_steps_within_velocity(rows: &[Vec<String>], header: &[String]) -> usize {
    let columns: Vec<usize> = (0..header.len())
        .filter(|&i| header[i].ends_with("_cmd"))
        .collect();
    let stall = header.iter().position(|h| h == "stall_ms").unwrap();
    for pair in rows.windows(2) {
        for &c in &columns {
            let step: f64 = pair[1][c].parse::<f64>().unwrap() - pair[0][c].parse::<f64>().unwrap();
            assert!(
                step.abs() <= 1.15 + 2e-6,
                "{}: step {step}° at t = {}",
                header[c],
                pair[1][0]
            );
        }
    }
    rows.iter().filter(|r| !r[stall].is_empty()).count()
}

#[test]
fn a_process_stopped_for_600_ms_brakes_and_exits_3_naming_the_stall() {
    let (out, rows, header) = stopped_for(600, &[]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("stalled: the goal was held"), "{err}");
    assert!(err.contains("the bound is 250 ms"), "{err}");
    // What to do about it, with how busy the machine was (/proc/loadavg).
    assert!(
        err.contains("load average") && err.contains("--max-stall MS"),
        "{err}"
    );
    assert!(commanded_steps_within_velocity(&rows, &header) >= 1);
    // It braked along the path after the stall instead of playing on.
    let phase = header.iter().position(|h| h == "phase").unwrap();
    assert_eq!(rows.last().unwrap()[phase], "stopping", "{err}");
}

#[test]
fn with_a_looser_bound_playback_resumes_along_the_path_after_a_stall() {
    let (out, rows, header) = stopped_for(600, &["--max-stall", "5000"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("stall(s): the longest held a goal"), "{err}");
    assert!(commanded_steps_within_velocity(&rows, &header) >= 1);
    let phase = header.iter().position(|h| h == "phase").unwrap();
    assert!(rows.iter().any(|r| r[phase] == "resuming"), "{err}");
    // The whole sequence was played: the last commanded pose is the last key's.
    let time = header.iter().position(|h| h == "sequence_time").unwrap();
    let last: f64 = rows.last().unwrap()[time].parse().unwrap();
    assert!((last - 8.8).abs() < 1e-6, "ended at sequence time {last}");
}

#[test]
fn control_rates_outside_10_hz_to_1_khz_are_refused_before_anything_opens() {
    for rate in ["1e-300", "1e-10", "5", "2000", "inf", "NaN", "-100"] {
        for command in [
            vec!["play", "sequences/so101_wave.json"],
            vec!["record", "-o", "never.json"],
        ] {
            let mut args: Vec<&str> = command.clone();
            args.extend(["--port", "/dev/keypose-no-such-port", "--rate", rate]);
            let out = keypose()
                .args(&args)
                .current_dir(env!("CARGO_MANIFEST_DIR"))
                .output()
                .unwrap();
            let err = stderr(&out);
            // Exit 2 before the port is opened (opening it would be exit 3).
            assert_eq!(
                out.status.code(),
                Some(2),
                "{command:?} --rate {rate}: {err}"
            );
            assert!(
                err.contains("expected a control rate from 10 to 1000 Hz"),
                "{command:?} --rate {rate}: {err}"
            );
        }
    }
}

/// `--compensate-droop` on the virtual bus (its servos carry no weight, so they stand where
/// they are sent): the goals at rest lead the path by the weight each servo holds over its
/// stiffness, by hand from the check's torque at the key and the 5 V STS3215's 6 N·m/rad at
/// P = 16; the playback starts from the measured pose with no lead (it fades in along the
/// approach) and the step limiter never has to cut a goal.
#[test]
fn droop_compensation_leads_the_goals_by_the_weight_over_the_stiffness() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("wave.csv");
    let wave = repo("sequences/so101_wave.json");
    let out = keypose()
        .args(["play", &wave, "--port", "virtual", "--quiet"])
        .args(["--compensate-droop", "--log", log.to_str().unwrap()])
        .args(TOLERATED_STALL)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    // The limiter stays idle unless the machine stalled the player (bounding the catch-up
    // after a stall is its job).
    let err = stderr(&out);
    assert!(
        !err.contains("step limiter") || err.contains("stall(s)"),
        "{err}"
    );
    let check = keypose()
        .args(["check", &wave, "--format", "json"])
        .output()
        .unwrap();
    let report: serde_json::Value = serde_json::from_slice(&check.stdout).unwrap();
    let text = std::fs::read_to_string(&log).unwrap();
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = rows.map(|r| r.split(',').collect()).collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (first, last) = (&rows[0], rows.last().unwrap());
    for joint in ["shoulder_lift", "elbow_flex"] {
        let home = report["torque"]["droops"]
            .as_array()
            .unwrap()
            .iter()
            .rfind(|d| d["joint"] == joint && d["key_label"] == "home")
            .unwrap();
        let lead = (home["torque"].as_f64().unwrap() / 6.0).to_degrees();
        let goal: f64 = last[column(&format!("{joint}_cmd"))].parse().unwrap();
        // The wave ends at home, 0° on every joint.
        assert!(
            (goal - lead).abs() < 1e-3,
            "{joint}: goal {goal}, lead by hand {lead}"
        );
        assert!(lead.abs() > 3.0, "{joint}: {lead}");
        let start: f64 = first[column(&format!("{joint}_cmd"))].parse().unwrap();
        let measured: f64 = first[column(&format!("{joint}_meas"))].parse().unwrap();
        assert!(
            (start - measured).abs() < 0.1,
            "{joint}: {start} vs {measured}"
        );
    }
}

/// A port that is not there is named with the ports that are (`keypose ports` lists them), a
/// hardware error (exit 3) before anything is sent.
#[test]
fn a_missing_port_names_the_ports_there_are() {
    let out = keypose()
        .args([
            "read",
            "--robot",
            "so101",
            "--port",
            "/dev/ttyUSB-keypose-none",
        ])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("/dev/ttyUSB-keypose-none: No such file or directory"),
        "{err}"
    );
    assert!(err.contains("`keypose ports`"), "{err}");
}

/// A port another program holds (here the test itself, with the exclusive lock `serialport`
/// takes, as a LeRobot script or a serial monitor would) says so instead of the OS's "Unable
/// to acquire exclusive lock".
#[test]
fn a_port_another_program_holds_says_so() {
    let bus = VirtualBusProcess::start(&["--robot", "so101"]);
    let _held = serialport::new(&bus.path, 1_000_000).open().unwrap();
    let out = keypose()
        .args(["read", "--robot", "so101", "--port", &bus.path])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("another program holds the port"), "{err}");
}

/// `play --log` where the disk has no room (the file-size limit, `ulimit -f`, stands in for a
/// full disk: the writes fail with EFBIG as they would with ENOSPC): exit 2, an earlier log of
/// that name kept whole when the new one could not even hold its first rows, and a log that
/// ran out of room later ends with a whole row.
#[test]
fn a_log_the_disk_cannot_hold_keeps_the_earlier_log_and_ends_with_a_whole_row() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("nod.csv");
    let nod = repo("sequences/so101_nod.json");
    let limited = |kib: u32, log: &std::path::Path| {
        // SIGXFSZ ignored (inherited across exec), so that the write fails instead.
        let script = format!(
            "trap '' XFSZ; ulimit -f {kib}; exec \"$0\" play \"$1\" --port virtual --quiet \
             --max-stall 10000 --log \"$2\""
        );
        Command::new("bash")
            .args(["-c", &script, env!("CARGO_BIN_EXE_keypose"), &nod])
            .arg(log)
            .output()
            .unwrap()
    };
    let out = keypose()
        .args(["play", &nod, "--port", "virtual", "--quiet", "--log"])
        .arg(&log)
        .args(TOLERATED_STALL)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let before = std::fs::read(&log).unwrap();
    assert!(before.len() > 16 * 1024, "{} bytes", before.len());
    // 8 KiB: not even the first second of rows.
    let out = limited(8, &log);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("cannot write log"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        std::fs::read(&log).unwrap(),
        before,
        "the earlier log was touched"
    );
    // 40 KiB: the log is in place and runs out of room part-way.
    let cut = dir.path().join("cut.csv");
    let out = limited(40, &cut);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let text = std::fs::read_to_string(&cut).unwrap();
    let columns = text.lines().next().unwrap().split(',').count();
    assert!(text.lines().count() > 10 && text.ends_with('\n'), "{text}");
    for line in text.lines() {
        assert_eq!(line.split(',').count(), columns, "a cut row: {line:?}");
    }
}
