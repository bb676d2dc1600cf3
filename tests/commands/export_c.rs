//! `keypose export c` and the reference player in players/c/, compiled on the host with gcc and
//! run: the ticks it computes at the control rate against `keypose sample --units ticks`
//! (±1 tick: the player rounds its fixed-point cubic, keypose its f64 curve), and its approach
//! against the robot's limits. Without gcc these tests fail.

use crate::common::{repo, run, show, stderr, stdout};
use keypose::robot::Robot;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs gcc with the strict flags every C test here uses (`-std=c99 -Wall -Wextra -Werror`),
/// then `args`; fails the test with gcc's messages, and `context`, unless it compiles.
fn gcc(args: &[&str], context: &str) {
    let out = Command::new("gcc")
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror"])
        .args(args)
        .output()
        .expect("gcc is needed to build the C player");
    assert!(
        out.status.success(),
        "gcc: {}\n{context}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Compiles the player with the header exported from `sequence`; returns the program.
fn build_player(sequence: &str, dir: &Path, extra: &[&str]) -> PathBuf {
    let header = dir.join("seq.h");
    let mut args = vec!["export", "c", sequence, "-o", header.to_str().unwrap()];
    args.extend_from_slice(extra);
    let out = run(&args);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let program = dir.join("player");
    let players = repo("players/c");
    gcc(
        &[
            "-O2",
            "-I",
            &players,
            "-include",
            header.to_str().unwrap(),
            &format!("{players}/host_dump.c"),
            &format!("{players}/keypose_player.c"),
            "-lm",
            "-o",
            program.to_str().unwrap(),
        ],
        "",
    );
    program
}

fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .filter(|l| !l.starts_with("time"))
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn player_rows(program: &Path, args: &[&str]) -> Vec<Vec<f64>> {
    let out = Command::new(program).args(args).output().unwrap();
    assert!(out.status.success());
    rows(&String::from_utf8_lossy(&out.stdout))
}

fn assert_same_ticks(sequence: &str) {
    assert_same_ticks_of(sequence, &[], 0);
}

/// The player built with `extra` export options against the sampled columns from `first` on
/// (after the time column: 0 for a one-arm sequence, an arm's first joint in a cell).
fn assert_same_ticks_of(sequence: &str, extra: &[&str], first: usize) {
    let dir = tempfile::tempdir().unwrap();
    let program = build_player(sequence, dir.path(), extra);
    let played = player_rows(&program, &["100"]);
    let sampled = run(&["sample", sequence, "--units", "ticks", "--rate", "100"]);
    assert_eq!(sampled.status.code(), Some(0), "{}", show(&sampled));
    let expected = rows(&stdout(&sampled));
    assert_eq!(played.len(), expected.len(), "{sequence}: rows");
    for (p, e) in played.iter().zip(&expected) {
        let e = [&e[..1], &e[1 + first..]].concat();
        for j in 1..p.len() {
            assert!(
                (p[j] - e[j]).abs() <= 1.0,
                "{sequence}: t = {}, joint {}: player {}, keypose {}",
                e[0],
                j - 1,
                p[j],
                e[j]
            );
        }
    }
}

#[test]
fn the_players_ticks_are_keyposes_within_one_tick() {
    // Feetech with holds and partial keys; Dynamixel; a prismatic gripper in ticks.
    assert_same_ticks(&repo("sequences/so101_pick_place.json"));
    assert_same_ticks(&repo("sequences/koch_wave.json"));
    assert_same_ticks(&repo("sequences/omx_reach.json"));
}

#[test]
fn one_arm_of_a_cell_exports_alone_with_its_own_servo_ids() {
    let sequence = repo("sequences/bimanual_wave.json");
    // The right arm's joints are the cell's 7th to 12th columns.
    assert_same_ticks_of(&sequence, &["--arm", "right"], 6);
    let dir = tempfile::tempdir().unwrap();
    let header = dir.path().join("right.h");
    let header_path = header.to_str().unwrap();
    let out = run(&[
        "export",
        "c",
        &sequence,
        "-o",
        header_path,
        "--arm",
        "right",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    // The SO-101's servos are 1 … 6 on each arm's bus, not the cell's 7 … 12.
    let text = std::fs::read_to_string(&header).unwrap();
    assert!(
        text.contains("kp_seq_ids[KP_SEQ_JOINTS] = {1, 2, 3, 4, 5, 6};"),
        "{text}"
    );
    let out = run(&["export", "c", &sequence, "-o", header_path]);
    assert_eq!(out.status.code(), Some(2), "{}", show(&out));
    assert!(
        stderr(&out).contains("give --arm, one of left, right"),
        "{}",
        show(&out)
    );
}

#[test]
fn the_approach_eases_in_to_the_first_pose_within_the_limits() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = repo("sequences/so101_nod.json");
    let program = build_player(&sequence, dir.path(), &[]);
    // From 600 ticks away on shoulder_pan and 300 the other way on elbow_flex.
    let rate = 100.0;
    let approach = player_rows(&program, &["100", "1447,2047,2347,2047,2047,2047"]);
    let first = &player_rows(&program, &["100"])[0];
    let last = approach.last().unwrap();
    assert_eq!(
        &last[1..],
        &first[1..],
        "the approach ends at the first pose"
    );
    assert_eq!(approach[0][1], 1447.0, "it starts where the arm is");
    // The SO-101's limits in ticks per second (4096 ticks a turn): every step within the
    // speed limit, the pan rising without ever going back (a smoothstep is monotone).
    let robot = Robot::builtin("so101").unwrap();
    for (j, joint) in robot.joints.iter().enumerate() {
        let max_step = joint.limits.velocity * 4096.0 / 360.0 / rate;
        for w in approach.windows(2) {
            assert!(
                (w[1][j + 1] - w[0][j + 1]).abs() <= max_step + 1.0,
                "joint {j}: step beyond {max_step} ticks"
            );
        }
    }
    assert!(approach.windows(2).all(|w| w[1][1] >= w[0][1]));
}

/// An SO-101 sequence whose first segment (after a 0.5 s hold) is linear and eased as the
/// studio's easing handles ease it (`SegmentTiming::eased`: a quarter of the path speeding up
/// evenly from rest, a quarter slowing down evenly to rest), then a monotone segment back.
/// Elbow 0 → 60° over 1.5 s: the trapezoid's speeds are scaled by 1.5 to last that, peaking at
/// 60 °/s and 120 °/s², within the SO-101's 115 °/s and 344 °/s².
pub(crate) fn eased_sequence(dir: &Path) -> PathBuf {
    use keypose::sequence::{SegmentTiming, TimeProfile};
    let timing = SegmentTiming::eased(1.5, 0.25, 0.25).unwrap();
    let TimeProfile::Speeds(speeds) = &timing.profile else {
        panic!("an eased segment has speeds")
    };
    let text = format!(
        r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
            "keyframes": [
              {{"time": 0, "hold": 0.5, "interp": "linear",
               "timing": {{"path_time": 1.5, "speeds": {speeds:?}}},
               "joints": {{"elbow_flex": 0, "wrist_flex": 0, "shoulder_pan": 10}}}},
              {{"time": 2, "joints": {{"elbow_flex": 60, "wrist_flex": -30, "shoulder_pan": 40}}}},
              {{"time": 3.5, "joints": {{"elbow_flex": 10, "wrist_flex": 20, "shoulder_pan": 0}}}}]}}"#
    );
    let path = dir.join("eased.json");
    std::fs::write(&path, text).unwrap();
    path
}

/// An SO-101 sequence whose first segment is a cubic run by a hand-written profile of three
/// long pieces (path speeds 0, 1, 1.5, 0): a polynomial of degree six in time on each, which
/// the cubic through its ends strays from by 0.11°. The profile ends at rest and the next
/// cubic segment starts moving: a corner at 2 s (within the limits at 100 Hz).
pub(crate) fn curved_sequence(dir: &Path) -> PathBuf {
    let path = dir.join("curved.json");
    std::fs::write(
        &path,
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [
              {"time": 0, "timing": {"path_time": 2, "speeds": [0, 1, 1.5, 0]},
               "joints": {"elbow_flex": 0, "wrist_flex": 0}},
              {"time": 2, "joints": {"elbow_flex": 40, "wrist_flex": -20}},
              {"time": 3.5, "joints": {"elbow_flex": 0, "wrist_flex": 10}}]}"#,
    )
    .unwrap();
    path
}

/// `sequences/so101_pick_place.json` through `keypose retime --fastest`: every moving segment
/// a time-optimal profile along its monotone cubic.
pub(crate) fn fastest_sequence(dir: &Path) -> PathBuf {
    let path = dir.join("fastest.json");
    let out = run(&[
        "retime",
        &repo("sequences/so101_pick_place.json"),
        "--fastest",
        "-o",
        path.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    path
}

/// The `#define KP_SEQ_DEGREE` of an exported header.
fn header_degree(header: &Path) -> usize {
    let text = std::fs::read_to_string(header).unwrap();
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("#define KP_SEQ_DEGREE "))
        .unwrap_or_else(|| panic!("no KP_SEQ_DEGREE in {text}"));
    line.trim().parse().unwrap()
}

#[test]
fn timing_profiles_play_as_keypose_samples_them() {
    // Before, both were refused ("cannot carry a timing profile"). keypose samples a profiled
    // segment by mapping time to path time and the path time to the curve
    // (`Trajectory::sample`); the player evaluates the check's composed polynomials. Ticks
    // within one, and the limiter changed no goal.
    let dir = tempfile::tempdir().unwrap();
    for (sequence, degree) in [
        // A straight path of a quadratic of time (degree 2), and a monotone cubic: degree 3.
        (eased_sequence(dir.path()), 3),
        // A quintic (smooth keys) of a quadratic of time: degree 10; a cubic of one: 6.
        (fastest_sequence(dir.path()), 10),
        (curved_sequence(dir.path()), 6),
    ] {
        let sequence = sequence.to_str().unwrap();
        assert_same_ticks(sequence);
        let build = tempfile::tempdir().unwrap();
        let program = build_player(sequence, build.path(), &[]);
        assert_eq!(
            header_degree(&build.path().join("seq.h")),
            degree,
            "{sequence}"
        );
        // At the control rate the sequence was checked for (at a higher one the dump's start,
        // the first goal rounded to a whole tick, is a fraction of a tick off the curve, more
        // than a·T² there: the limiter eases that in, with or without a profile).
        let out = Command::new(&program).arg("100").output().unwrap();
        assert_eq!(stderr(&out).trim(), "limited 0", "{sequence}");
    }
    // A sequence without profiles keeps its polynomials: a smooth one its quintics (six
    // coefficients per joint and piece), a monotone one its cubics (four).
    for (sequence, degree) in [
        (repo("sequences/so101_pick_place.json"), 5),
        (
            crate::export::example_in_mode(dir.path(), "so101_pick_place.json", "monotone"),
            3,
        ),
    ] {
        let build = tempfile::tempdir().unwrap();
        build_player(&sequence, build.path(), &[]);
        assert_eq!(
            header_degree(&build.path().join("seq.h")),
            degree,
            "{sequence}"
        );
    }
}

/// Prints the Sync Write packets keypose_bus.c builds for ids 1, 2 and the ticks given.
const PACKETS_MAIN: &str = r#"
#include <stdio.h>
#include <stdlib.h>
#include "keypose_bus.h"
static void show(const uint8_t *b, size_t n) { for (size_t i = 0; i < n; i++) printf("%02X", b[i]); printf("\n"); }
int main(int argc, char **argv) {
    uint8_t ids[2] = {1, 2}; int32_t ticks[2] = {atoi(argv[1]), atoi(argv[2])}; uint8_t out[64];
    (void)argc;
    show(out, kp_feetech_sync_write(ids, ticks, 2, out, sizeof out));
    show(out, kp_dynamixel_sync_write(ids, ticks, 2, out, sizeof out));
    return 0;
}
"#;

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

#[test]
fn the_example_firmwares_sync_writes_are_the_protocols_bytes() {
    use keypose::bus::protocol::codec;
    use keypose::robot::Protocol;
    let dir = tempfile::tempdir().unwrap();
    let players = repo("players/c");
    let main = dir.path().join("packets.c");
    std::fs::write(&main, PACKETS_MAIN).unwrap();
    let program = dir.path().join("packets");
    gcc(
        &[
            "-I",
            &players,
            main.to_str().unwrap(),
            &format!("{players}/keypose_bus.c"),
            "-o",
            program.to_str().unwrap(),
        ],
        "",
    );
    // 2047 and 1024; then −131073 = 0xFFFDFFFF, whose little-endian bytes FF FF FD FF make
    // Dynamixel's header pattern and must be stuffed.
    for (a, b) in [(2047i32, 1024i32), (-131073, 5)] {
        let out = Command::new(&program)
            .args([a.to_string(), b.to_string()])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        let lines: Vec<&str> = text.lines().collect();
        // The layouts of docs/protocols.md, framed by keypose's own codecs (checksum, CRC,
        // stuffing), which tests/servos/conformance.rs holds to the vendor SDKs' bytes.
        let sts = |t: i32| -> [u8; 2] {
            let raw = if t < 0 {
                0x8000 | (-t as u16 & 0x7FFF)
            } else {
                t as u16
            };
            raw.to_le_bytes()
        };
        let mut sts_params = vec![42, 2, 1];
        sts_params.extend(sts(a));
        sts_params.push(2);
        sts_params.extend(sts(b));
        let mut dxl_params = vec![116, 0, 4, 0, 1];
        dxl_params.extend(a.to_le_bytes());
        dxl_params.push(2);
        dxl_params.extend(b.to_le_bytes());
        let sts_bytes =
            codec(Protocol::FeetechSts)
                .framing()
                .encode_instruction(0xFE, 0x83, &sts_params);
        let dxl_bytes =
            codec(Protocol::Dynamixel2)
                .framing()
                .encode_instruction(0xFE, 0x83, &dxl_params);
        if a >= 0 {
            assert_eq!(lines[0], hex(&sts_bytes), "Feetech STS");
        }
        assert_eq!(lines[1], hex(&dxl_bytes), "Dynamixel 2.0");
    }
    // The example firmware compiles against an exported header (the board's functions are its
    // own: compiled, not linked).
    let header_dir = tempfile::tempdir().unwrap();
    let out = run(&[
        "export",
        "c",
        &repo("sequences/koch_wave.json"),
        "-o",
        header_dir.path().join("seq.h").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    gcc(
        &[
            "-DKP_DYNAMIXEL",
            "-c",
            "-I",
            &players,
            "-I",
            header_dir.path().to_str().unwrap(),
            &format!("{players}/example_main.c"),
            "-o",
            header_dir.path().join("example.o").to_str().unwrap(),
        ],
        "",
    );
}

/// A hand-edited table for one SO-101 joint (115 °/s and 344 °/s² at 4096 ticks a turn:
/// 1308.444 ticks/s, 3913.955 ticks/s²) that holds 2047 ticks for 1 s, then 2647: a 600-tick
/// jump no check would pass.
const JUMP_HEADER: &str = r#"
#ifndef KP_SEQUENCE_H
#define KP_SEQUENCE_H
#include "keypose_player.h"
static const uint8_t kp_seq_ids[1] = {1};
static const int32_t kp_seq_tick_min[1] = {0};
static const int32_t kp_seq_tick_max[1] = {4095};
static const float kp_seq_max_speed[1] = {1308.444f};
static const float kp_seq_max_accel[1] = {3913.955f};
static const uint32_t kp_seq_piece_start_us[2] = {0, 1000000};
static const uint32_t kp_seq_piece_duration_us[2] = {1000000, 5000000};
static const int32_t kp_seq_coefficients[8] = {2047 * 65536, 0, 0, 0, 2647 * 65536, 0, 0, 0};
static const kp_sequence kp_seq = {
    1, 2, 3, 6000000u, kp_seq_ids, kp_seq_tick_min, kp_seq_tick_max, kp_seq_max_speed,
    kp_seq_max_accel, kp_seq_piece_start_us, kp_seq_piece_duration_us, kp_seq_coefficients};
#endif
"#;

/// Plays `seq.h` every 1/rate s from 2047 ticks until the player says it is done; prints per
/// call `t_us,goal before the limiter (ticks),goal written (Q16.16 ticks)`, then the state.
const LIMITED_MAIN: &str = r#"
#include <stdio.h>
#include <stdlib.h>
#include "keypose_player.h"
static int sent(void *c, const uint8_t *ids, const int32_t *ticks, uint8_t n) {
    (void)c; (void)ids; (void)ticks; (void)n; return 0;
}
int main(int argc, char **argv) {
    uint32_t period = (uint32_t)(1e6 / atof(argv[1]) + 0.5);
    int32_t present[1] = {2047};
    kp_player player;
    (void)argc;
    if (kp_player_start(&player, &kp_seq, present, period, sent, NULL) != 0) return 2;
    int state = 1;
    for (uint32_t k = 0; state == 1 && k < 200000; k++) {
        int32_t wanted[1];
        kp_player_goals(&player, k * period, wanted);
        state = kp_player_step(&player, k * period);
        printf("%u,%d,%lld\n", k * period, wanted[0], (long long)player.last[0]);
    }
    printf("state %d, limited %u\n", state, player.limited);
    return 0;
}
"#;

#[test]
fn a_jump_in_the_table_is_played_within_the_speed_and_acceleration_limits() {
    let dir = tempfile::tempdir().unwrap();
    let players = repo("players/c");
    std::fs::write(dir.path().join("seq.h"), JUMP_HEADER).unwrap();
    let main = dir.path().join("limited.c");
    std::fs::write(&main, LIMITED_MAIN).unwrap();
    let program = dir.path().join("limited");
    gcc(
        &[
            "-I",
            &players,
            "-include",
            dir.path().join("seq.h").to_str().unwrap(),
            main.to_str().unwrap(),
            &format!("{players}/keypose_player.c"),
            "-lm",
            "-o",
            program.to_str().unwrap(),
        ],
        "",
    );
    // At the rate the limits were meant for, and at others (another rate or phase than a table
    // was checked for).
    for rate in [100.0, 30.0, 250.0] {
        let out = Command::new(&program)
            .arg(rate.to_string())
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        let last = text.lines().last().unwrap();
        // It arrives and says so: the limiter let the end through unchanged.
        assert!(last.starts_with("state 0, limited "), "{rate} Hz: {last}");
        let rows: Vec<[f64; 3]> = text
            .lines()
            .filter(|l| !l.starts_with("state"))
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2] / 65536.0]
            })
            .collect();
        // The table asks for the whole jump within one period.
        let asked = rows
            .windows(2)
            .map(|w| w[1][1] - w[0][1])
            .fold(0.0, f64::max);
        assert_eq!(asked, 600.0, "{rate} Hz");
        // What is written moves at most v·T per period and changes its step by at most a·T²
        // (1/1024 tick of slack for the fixed point).
        let period = 1.0 / rate;
        let (v_step, a_step) = (1308.444 * period, 3913.955 * period * period);
        let slack = 1.0 / 1024.0;
        let mut previous_step = 0.0;
        let mut top_speed: f64 = 0.0;
        for w in rows.windows(2) {
            let step = w[1][2] - w[0][2];
            assert!(
                step.abs() <= v_step + slack,
                "{rate} Hz, t = {} µs: step {step} ticks > {v_step}",
                w[1][0]
            );
            assert!(
                (step - previous_step).abs() <= a_step + slack,
                "{rate} Hz, t = {} µs: step change {} ticks > {a_step}",
                w[1][0],
                step - previous_step
            );
            previous_step = step;
            top_speed = top_speed.max(step.abs());
        }
        // It did move as fast as allowed, and ended at the table's value.
        assert!(top_speed > v_step - a_step, "{rate} Hz: {top_speed}");
        assert_eq!(rows.last().unwrap()[2], 2647.0, "{rate} Hz");
    }
}

#[test]
fn a_checked_table_passes_the_limiter_untouched() {
    // The exported sequences play as keypose samples them (the test above); the limiter never
    // changed a goal of them.
    for sequence in [
        "sequences/so101_pick_place.json",
        "sequences/koch_wave.json",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let program = build_player(&repo(sequence), dir.path(), &[]);
        let out = Command::new(&program)
            .args(["100", "1447,2047,2347,2047,2047,2047"])
            .output()
            .unwrap();
        assert_eq!(stderr(&out).trim(), "limited 0", "{sequence} approach");
        let out = Command::new(&program).arg("100").output().unwrap();
        assert_eq!(stderr(&out).trim(), "limited 0", "{sequence}");
    }
}

/// Joint names that would be C if they were written raw: a comment closed and code after it
/// (a constructor runs before `main`), a quote and a trailing backslash that would end or
/// continue a string literal, `??/` (a backslash as a trigraph under -std=c99), `#include`,
/// non-ASCII letters.
const HOSTILE_NAMES: [&str; 6] = [
    "pan */ extern int puts(const char *); __attribute__((constructor)) static void kp_injected(void) { puts(\"INJECTED\"); } /*",
    "lift\" }; static int kp_x = 1; //",
    "elbow\\",
    "wrist ??/ #include <stdio.h>",
    "épaule roll 🦾",
    "gripper // /* '",
];

/// Prints every joint name and the source of the header as hex, one per line.
const NAMES_MAIN: &str = r#"
#include <stdio.h>
static void hex(const char *s) { for (; *s; s++) printf("%02x", (unsigned char)*s); printf("\n"); }
int main(void) {
    for (int j = 0; j < KP_SEQ_JOINTS; j++) hex(kp_seq_joint_names[j]);
    hex(kp_seq_source);
    return kp_seq.joints == KP_SEQ_JOINTS ? 0 : 1;
}
"#;

/// A sequence moving joints 1 and 2 of the SO-101 with its joints renamed to `names`, in
/// `dir` under a file name holding a quote, a backslash and a trigraph (`??=` is `#`).
fn sequence_with_joints_named(dir: &Path, names: [&str; 6]) -> PathBuf {
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(repo("robots/so101.json")).unwrap()).unwrap();
    robot.as_object_mut().unwrap().remove("home");
    robot["tcp"]["parent"] = names[4].into();
    for (joint, name) in robot["joints"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .zip(names)
    {
        joint["name"] = name.into();
    }
    let robot_path = dir.join("hostile robot.json");
    std::fs::write(&robot_path, robot.to_string()).unwrap();
    let sequence = serde_json::json!({"format": "keypose-sequence/1",
        "robot": robot_path.to_str().unwrap(),
        "keyframes": [{"time": 0, "joints": {names[1]: 0, names[2]: 0}},
                      {"time": 2, "joints": {names[1]: 20, names[2]: -20}}]});
    let sequence_path = dir.join("seq \"*\\ ??=.json");
    std::fs::write(&sequence_path, sequence.to_string()).unwrap();
    sequence_path
}

#[test]
fn a_joint_name_closing_the_comment_it_was_in_runs_nothing() {
    // The issue's injection without its line breaks (a name with one is refused at load,
    // tests/commands/hostile_input.rs): written raw into the header's comment of joint names, it
    // compiled with -Wall -Werror and ran before main.
    let dir = tempfile::tempdir().unwrap();
    let mut names = [
        "shoulder_pan",
        "shoulder_lift",
        "elbow_flex",
        "wrist_flex",
        "wrist_roll",
        "gripper",
    ];
    names[0] = HOSTILE_NAMES[0];
    let sequence = sequence_with_joints_named(dir.path(), names);
    let program = build_player(sequence.to_str().unwrap(), dir.path(), &[]);
    let played = Command::new(&program).arg("100").output().unwrap();
    assert!(played.status.success(), "{}", show(&played));
    assert!(!stdout(&played).contains("INJECTED"), "{}", show(&played));
    assert_eq!(rows(&stdout(&played)).len(), 201, "2 s at 100 Hz");
}

#[test]
fn joint_names_reach_the_header_as_string_literals_and_never_as_code() {
    let dir = tempfile::tempdir().unwrap();
    let sequence_path = sequence_with_joints_named(dir.path(), HOSTILE_NAMES);

    // The names program, built with -std=c99 (trigraphs on) and -Werror.
    let header = dir.path().join("seq.h");
    let out = run(&[
        "export",
        "c",
        sequence_path.to_str().unwrap(),
        "-o",
        header.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let main = dir.path().join("names.c");
    std::fs::write(&main, NAMES_MAIN).unwrap();
    let players = repo("players/c");
    let program = dir.path().join("names");
    let text = std::fs::read_to_string(&header).unwrap();
    gcc(
        &[
            "-I",
            &players,
            "-include",
            header.to_str().unwrap(),
            main.to_str().unwrap(),
            &format!("{players}/keypose_player.c"),
            "-lm",
            "-o",
            program.to_str().unwrap(),
        ],
        &text,
    );
    let ran = Command::new(&program).output().unwrap();
    assert!(ran.status.success(), "{}", show(&ran));
    let printed = stdout(&ran);
    // Nothing from a name ran; each name reads back, byte for byte, as the robot file has it.
    assert!(!printed.contains("INJECTED"), "{printed}");
    let hex = |s: &str| s.bytes().map(|b| format!("{b:02x}")).collect::<String>();
    let mut expected: Vec<String> = HOSTILE_NAMES.iter().map(|n| hex(n)).collect();
    expected.push(hex(sequence_path.to_str().unwrap()));
    assert_eq!(printed.lines().collect::<Vec<_>>(), expected, "{text}");
    // The header's code is keypose's own: with the string literals taken out, it is the
    // header of the same sequence with the SO-101's own names.
    let plain = tempfile::tempdir().unwrap();
    let plain_sequence = sequence_with_joints_named(
        plain.path(),
        [
            "shoulder_pan",
            "shoulder_lift",
            "elbow_flex",
            "wrist_flex",
            "wrist_roll",
            "gripper",
        ],
    );
    let plain_header = plain.path().join("seq.h");
    let out = run(&[
        "export",
        "c",
        plain_sequence.to_str().unwrap(),
        "-o",
        plain_header.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let plain_text = std::fs::read_to_string(&plain_header).unwrap();
    assert_eq!(without_strings(&text), without_strings(&plain_text));
}

/// C text with the content of every string literal dropped (`"…"` becomes `""`). Escapes
/// are skipped whole (a backslash and the character after it), so an escaped quote does not
/// end a literal.
fn without_strings(c: &str) -> String {
    let mut out = String::new();
    let mut chars = c.chars();
    while let Some(ch) = chars.next() {
        out.push(ch);
        if ch != '"' {
            continue;
        }
        loop {
            match chars.next() {
                Some('\\') => {
                    chars.next();
                }
                Some('"') | None => break,
                Some(_) => {}
            }
        }
        out.push('"');
    }
    out
}
