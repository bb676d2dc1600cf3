//! `keypose teach` as a user runs it, without hardware: the real binary on emulated servos
//! (`--port virtual`), driven by a key script. The virtual arm starts at home (every joint at
//! 0°) and each jog is exactly ±1° or ±10°, stopped at the limits, so every captured value is
//! known by hand. Each script step waits until the arm has arrived, so nothing here depends on
//! timing.

use crate::common::SO101_JOINTS;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn keypose(dir: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_keypose"));
    // The journal goes to this test's own cache directory.
    command
        .current_dir(dir)
        .env("KEYPOSE_CACHE", dir.join("cache"));
    command
}

fn teach(dir: &Path, script: &str, extra: &[&str]) -> Output {
    std::fs::write(dir.join("session.keys"), script).expect("write the key script");
    // A loaded machine's stall is not these tests' subject (the one that tests the stall
    // guard gives its own --max-stall).
    let tolerance: &[&str] = match extra.contains(&"--max-stall") {
        true => &[],
        false => &crate::common::TOLERATED_STALL,
    };
    keypose(dir)
        .args(["teach", "--port", "virtual", "--keys", "session.keys"])
        .args(extra)
        .args(tolerance)
        .output()
        .expect("run keypose teach")
}

/// A teach session on the virtual bus taking `keys` on standard input, killed once its status
/// line says `until` (each step prints its status once done, and journaled): the journal it
/// leaves is a crashed session's. The status lines seen.
fn teach_killed_after(dir: &Path, keys: &str, until: &str) -> Vec<String> {
    let mut child = keypose(dir)
        .args(["teach", "seq.json", "--port", "virtual", "--keys", "-"])
        .args(crate::common::TOLERATED_STALL)
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("start keypose teach");
    let mut stdin = child.stdin.take().unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    writeln!(stdin, "{keys}").unwrap();
    stdin.flush().unwrap();
    let mut seen = Vec::new();
    loop {
        let line = lines
            .next()
            .expect("teach ended early")
            .expect("read stderr");
        seen.push(line.clone());
        if line.contains(until) {
            break;
        }
        assert!(!line.contains("error"), "{seen:?}");
    }
    child.kill().expect("kill teach");
    let _ = child.wait();
    seen
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).expect("the written file");
    serde_json::from_str(&text).expect("valid JSON")
}

fn pose(values: [f64; 6]) -> Value {
    let joints: serde_json::Map<String, Value> = SO101_JOINTS
        .iter()
        .zip(values)
        .map(|(n, v)| (n.to_string(), json!(v)))
        .collect();
    json!({ "joints": joints })
}

fn journals(dir: &Path) -> Vec<std::path::PathBuf> {
    match std::fs::read_dir(dir.join("cache").join("teach")) {
        Ok(entries) => entries.filter_map(|e| e.ok()).map(|e| e.path()).collect(),
        Err(_) => Vec::new(),
    }
}

/// The whole path a new user takes: jog, capture, delete, reorder, move to a key and update it,
/// change the timing, play, write — then `keypose check` and `keypose play` accept the file.
#[test]
fn a_scripted_session_builds_checks_and_plays_a_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let script = "\
        # A: home
        n
        # B: pan 25 (two big steps, five small)
        shift-right shift-right right right right right right n
        # C: lift 30; elbow to its limit -96.83 (the 11th step is refused there), then back
        # 40° to -56.8 (a jog lands on tenths). A key at the limit would make a cubic
        # overshoot it on the way to the next key, which check and y refuse (the monotone
        # default cannot, but the path stays the one a cubic needs). Not towards +96.83: the
        # elbow folding down puts the gripper into the desk, which the collision rule refuses.
        down shift-right shift-right shift-right
        down shift-left shift-left shift-left shift-left shift-left
             shift-left shift-left shift-left shift-left shift-left shift-left
             shift-right shift-right shift-right shift-right
        n
        # D: gripper 40 then back 2
        down down down shift-right shift-right shift-right shift-right left left n
        # E: wrist flex -15
        up up shift-left left left left left left n
        # F: pan back to 15 - then deleted
        up up up shift-left n d
        # reorder: E before D
        [
        # the pan carries no weight: released at once, not jogged while limp, held again
        t right t
        # the lift carries weight: asks, and no keeps it held
        down t no
        # to C, open the gripper to 10, update C
        < space down down down down shift-right u
        # 2.1 s between keys
        + + -
        # play the last two keys, then write
        > y w q
    ";
    // Its subject is the session, not stalls: a loaded machine may stall the playback's
    // process longer than the default bound, which would rightly stop it.
    let out = teach(dir.path(), script, &[]);
    let log = stderr(&out);
    assert!(out.status.success(), "teach failed:\n{log}");
    assert!(log.contains("elbow_flex is at its limit"), "{log}");
    assert!(log.contains("shoulder_pan is limp"), "{log}");
    assert!(
        log.contains("shoulder_lift carries the arm's weight"),
        "{log}"
    );
    assert!(log.contains("played to the end"), "{log}");
    assert!(log.contains("check passes"), "{log}");

    let file = dir.path().join("taught.json");
    let expected = json!({
        "format": "keypose-sequence/1",
        "robot": "so101",
        "interpolation": "monotone",
        "key_interval": 2.1,
        "keyframes": [
            pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            pose([25.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            pose([25.0, 30.0, -56.8, 0.0, 0.0, 10.0]),
            pose([25.0, 30.0, -56.8, -15.0, 0.0, 38.0]),
            pose([25.0, 30.0, -56.8, 0.0, 0.0, 38.0]),
        ]
    });
    assert_eq!(read_json(&file), expected);
    assert!(
        journals(dir.path()).is_empty(),
        "the journal goes after a write"
    );

    let check = keypose(dir.path())
        .args(["check", "taught.json"])
        .output()
        .unwrap();
    assert!(check.status.success(), "check failed:\n{}", stderr(&check));
    // What is checked is that `play` accepts the file and plays it to the end; a stall of
    // the loaded machine is not this test's subject (tests/servos has those).
    let play = keypose(dir.path())
        .args(["play", "taught.json", "--port", "virtual", "--quiet"])
        .args(crate::common::TOLERATED_STALL)
        .output()
        .unwrap();
    assert!(play.status.success(), "play failed:\n{}", stderr(&play));
}

/// The edits typed into prompts: a name (and the warning a shared one gets), a hold, the mode
/// of a segment, a joint value typed in degrees and reached by the safe ramp — written, then
/// accepted by `keypose check`.
#[test]
fn a_scripted_session_names_holds_interpolates_and_types_values() {
    let dir = tempfile::tempdir().unwrap();
    let script = "\
        # key 0 at home, key 1 with the pan at 20; back to key 0
        n shift-right shift-right n <
        # name key 0, hold it half a second, make its segment cubic (monotone → step → linear
        # → cubic; linear's corners would break the acceleration limits)
        N w a v e enter
        h 0 . 5 enter
        p p p
        # elbow to -45 typed (97 is refused: beyond 96.83), and the arm moves there (+45
        # would put the gripper within the clearance of the desk)
        down down v 9 7 enter
        v - 4 5 enter yes
        # key 1: the same name is warned of, then it becomes reach
        > N w a v e enter
        N backspace backspace backspace backspace r e a c h enter
        w q
    ";
    let out = teach(dir.path(), script, &[]);
    let log = stderr(&out);
    assert!(out.status.success(), "teach failed:\n{log}");
    for expected in [
        "named key 0 (wave)",
        "key 0 (wave) holds 0.5 s",
        "key 0 (wave) → key 1: cubic",
        "97° is outside elbow_flex's limits -96.83° … 96.83°",
        "at key 0 (wave)",
        "key 0 has this name too",
        "named key 1 (reach)",
        "check passes",
    ] {
        assert!(log.contains(expected), "{expected:?} missing:\n{log}");
    }

    let expected = json!({
        "format": "keypose-sequence/1",
        "robot": "so101",
        "interpolation": "monotone",
        "key_interval": 2.0,
        "keyframes": [
            {
                "name": "wave",
                "hold": 0.5,
                "interp": "cubic",
                "joints": {
                    "shoulder_pan": 0.0, "shoulder_lift": 0.0, "elbow_flex": -45.0,
                    "wrist_flex": 0.0, "wrist_roll": 0.0, "gripper": 0.0
                }
            },
            {
                "name": "reach",
                "joints": {
                    "shoulder_pan": 20.0, "shoulder_lift": 0.0, "elbow_flex": 0.0,
                    "wrist_flex": 0.0, "wrist_roll": 0.0, "gripper": 0.0
                }
            }
        ]
    });
    assert_eq!(read_json(&dir.path().join("taught.json")), expected);
    let check = keypose(dir.path())
        .args(["check", "taught.json"])
        .output()
        .unwrap();
    assert!(check.status.success(), "check failed:\n{}", stderr(&check));
}

/// A session killed after some edits loses nothing: the next one offers the journal, and a
/// scripted "yes" recovers it.
#[test]
fn a_killed_session_is_recovered_by_the_next() {
    let dir = tempfile::tempdir().unwrap();
    let seen = teach_killed_after(dir.path(), "n shift-right right n", "new key 1");
    assert!(!dir.path().join("seq.json").exists(), "never written");
    assert_eq!(journals(dir.path()).len(), 1, "{seen:?}");

    let out = teach(dir.path(), "yes w q", &["seq.json"]);
    let log = stderr(&out);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains("recover it?") && log.contains("recovered 2 keys"),
        "{log}"
    );
    let written = read_json(&dir.path().join("seq.json"));
    assert_eq!(
        written["keyframes"],
        json!([
            pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            pose([11.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        ])
    );
    assert!(journals(dir.path()).is_empty());
}

/// A script that ends with unsaved work fails and keeps the journal; a script that does not
/// answer the recovery question is stopped; `--recover` recovers without asking.
#[test]
fn unsaved_scripts_keep_the_journal_for_recover() {
    let dir = tempfile::tempdir().unwrap();
    let out = teach(dir.path(), "n down shift-left n", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("unsaved changes"), "{}", stderr(&out));
    assert_eq!(journals(dir.path()).len(), 1);

    let out = teach(dir.path(), "down n w q", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("expected an answer"),
        "{}",
        stderr(&out)
    );
    assert!(!dir.path().join("taught.json").exists());

    let out = teach(dir.path(), "w q", &["--recover"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let written = read_json(&dir.path().join("taught.json"));
    assert_eq!(
        written["keyframes"],
        json!([
            pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            pose([0.0, -10.0, 0.0, 0.0, 0.0, 0.0])
        ])
    );
    assert!(journals(dir.path()).is_empty());

    // The next session opens the written file, with nothing to recover.
    let out = teach(dir.path(), "> d w q", &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        read_json(&dir.path().join("taught.json"))["keyframes"],
        json!([pose([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])])
    );
}

#[test]
fn bad_invocations_are_refused_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = keypose(dir.path())
        .args(["teach", "--keys", "x.keys"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--port is required"),
        "{}",
        stderr(&out)
    );

    let out = teach(dir.path(), "n", &["--max-stall", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("expected a stall bound from 1 to 10000 ms"),
        "{}",
        stderr(&out)
    );

    let out = teach(dir.path(), "n jump", &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("unknown key \"jump\""),
        "{}",
        stderr(&out)
    );

    // Without a terminal and without --keys there is nothing to read keys from.
    let out = keypose(dir.path())
        .args(["teach", "--port", "virtual"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("needs a terminal"),
        "{}",
        stderr(&out)
    );

    let help = keypose(dir.path())
        .args(["teach", "--help"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&help.stdout);
    for binding in ["space", "shift", "import:PATH", "quit (asks"] {
        assert!(text.contains(binding), "--help lacks {binding:?}:\n{text}");
    }
}

/// A key giving the gripper in percent of the calibrated range is saved back as written when
/// another field of it is edited: teach does not turn "40%" into degrees behind the user's back.
#[test]
fn a_percent_key_is_saved_as_written() {
    let dir = tempfile::tempdir().unwrap();
    // The gripper recorded over ticks 2000 … 3000, the other joints over the whole turn.
    let entries: Vec<String> = (1..)
        .zip(SO101_JOINTS)
        .map(|(id, name)| {
            let (min, max) = if name == "gripper" { (2000, 3000) } else { (0, 4095) };
            format!(
                r#""{name}": {{"id": {id}, "drive_mode": 0, "homing_offset": 0, "range_min": {min}, "range_max": {max}}}"#
            )
        })
        .collect();
    std::fs::write(
        dir.path().join("cal.json"),
        format!("{{{}}}", entries.join(",")),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("grip.json"),
        r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
          {"time":0,"joints":{"gripper":"40%","elbow_flex":10}}]}"#,
    )
    .unwrap();
    let out = teach(
        dir.path(),
        "N g r i p enter\nw q\n",
        &["grip.json", "-o", "out.json", "--calibration", "cal.json"],
    );
    assert!(out.status.success(), "teach failed:\n{}", stderr(&out));
    let saved = read_json(&dir.path().join("out.json"));
    let key = &saved["keyframes"][0];
    assert_eq!(key["name"], "grip", "{saved}");
    assert_eq!(key["joints"]["gripper"], "40%", "{saved}");
    assert_eq!(key["joints"]["elbow_flex"], 10.0, "{saved}");
}

/// The terminal itself (a pseudo-terminal through `script`, keys as a terminal sends them):
/// sixty shift-right presses arrive at once, then Ctrl-C, then `n` and `w`. The stop wins over
/// the queued jogs — the pan stops within the jog it was on, where before the sixty ran one
/// after another to the pan's limit, 110° — and the capture typed after it waits until the
/// arm is at rest, so the key holds where it stopped.
#[test]
fn ctrl_c_in_the_terminal_drops_sixty_queued_jogs() {
    let dir = tempfile::tempdir().unwrap();
    // A pseudo-terminal of a real terminal's size (script's own has none without one).
    let command = format!(
        "stty cols 140 rows 45 && exec {} teach --port virtual stopped.json",
        env!("CARGO_BIN_EXE_keypose")
    );
    let mut child = Command::new("script")
        .args(["-qfec", &command, "/dev/null"])
        .current_dir(dir.path())
        .env("KEYPOSE_CACHE", dir.path().join("cache"))
        .env("TERM", "xterm-256color")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("run keypose teach in a pseudo-terminal (script, from util-linux)");
    // The screen is up (and the terminal raw) once the joint table is drawn.
    let mut screen = BufReader::new(child.stdout.take().unwrap());
    let mut seen = Vec::new();
    while !String::from_utf8_lossy(&seen).contains("shoulder_pan") {
        let mut chunk = Vec::new();
        let read = screen.read_until(b'm', &mut chunk).unwrap();
        assert!(read > 0, "teach ended before drawing its screen");
        seen.extend(chunk);
    }
    // Whatever it draws from here on is read and dropped, so that it never blocks on a full
    // pipe.
    std::thread::spawn(move || std::io::copy(&mut screen, &mut std::io::sink()));
    let mut keys = child.stdin.take().unwrap();
    // One press, which usually has its jog running before the rest arrive (the pause only
    // makes that likely; either way the assertion below holds), then 59 more, Ctrl-C, n, w.
    keys.write_all(b"\x1b[1;2C").unwrap();
    keys.flush().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(200));
    keys.write_all(&b"\x1b[1;2C".repeat(59)).unwrap();
    keys.write_all(b"\x03nw").unwrap();
    keys.flush().unwrap();
    // The file appears once `w` has run, which it does only after the arm came to rest.
    let written = dir.path().join("stopped.json");
    let give_up = std::time::Instant::now() + std::time::Duration::from_secs(120);
    while !written.exists() {
        assert!(
            std::time::Instant::now() < give_up,
            "no file after two minutes"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    keys.write_all(b"q").unwrap();
    keys.flush().unwrap();
    drop(keys);
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let pan = read_json(&written)["keyframes"][0]["joints"]["shoulder_pan"]
        .as_f64()
        .unwrap();
    // At most the jog running when Ctrl-C came and the one waiting behind it.
    assert!((0.0..20.0).contains(&pan), "the pan went on to {pan}°");
}

/// `w` on a loaded file with nothing changed writes it back byte for byte: the hand-typed
/// quaternion 0.7071 stays 0.7071 (it was rewritten 0.7071067811865476), and the layout stays.
#[test]
fn w_on_an_unchanged_file_writes_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("sequences/so101_wave.json");
    let original = std::fs::read(&example).unwrap();
    std::fs::write(dir.path().join("wave.json"), &original).unwrap();
    let out = teach(dir.path(), "w q", &["wave.json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("wrote wave.json"), "{}", stderr(&out));
    let written = std::fs::read(dir.path().join("wave.json")).unwrap();
    assert_eq!(
        String::from_utf8_lossy(&written),
        String::from_utf8_lossy(&original)
    );
}

/// `U` and `R` (and the tokens `undo`, `redo`) take edits back and make them again, and only
/// the list changes: the capture after them finds the arm where the jogs left it (20°), not
/// where the undone keys were.
#[test]
fn a_script_undoes_and_redoes_edits_and_the_arm_stays() {
    let dir = tempfile::tempdir().unwrap();
    let out = teach(
        dir.path(),
        "n shift-right n shift-right n d U U R undo redo n w q",
        &[],
    );
    let log = stderr(&out);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("undid: deleted key 2"), "{log}");
    assert!(log.contains("redid: new key 2"), "{log}");
    let pan = |deg: f64| pose([deg, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(
        read_json(&dir.path().join("taught.json"))["keyframes"],
        json!([pan(0.0), pan(10.0), pan(20.0), pan(20.0)])
    );
}

/// The undo history is in the journal: a session killed right after an undo is recovered by
/// the next one, which undoes further and redoes what the killed one undid.
#[test]
fn the_undo_history_survives_a_killed_session() {
    let dir = tempfile::tempdir().unwrap();
    let seen = teach_killed_after(dir.path(), "n shift-right n shift-right n U", "undid:");
    assert_eq!(journals(dir.path()).len(), 1, "{seen:?}");

    // Recovered: keys at 0° and 10°; U takes the 10° key back, R makes it again, and R once
    // more the 20° key the killed session undid.
    let out = teach(dir.path(), "yes U R R w q", &["seq.json"]);
    let log = stderr(&out);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("recovered 2 keys"), "{log}");
    let pan = |deg: f64| pose([deg, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(
        read_json(&dir.path().join("seq.json"))["keyframes"],
        json!([pan(0.0), pan(10.0), pan(20.0)])
    );
}
