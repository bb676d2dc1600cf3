//! `keypose export c` and the reference player in players/c/, compiled on the host with gcc and
//! run: the ticks it computes at the control rate against `keypose sample --units ticks`
//! (±1 tick: the player rounds its fixed-point cubic, keypose its f64 curve), and its approach
//! against the robot's limits. Without gcc these tests fail.

mod common;

use common::{repo, run, show, stdout};
use keypose::robot::Robot;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Compiles the player with the header exported from `sequence`; returns the program.
fn build_player(sequence: &str, dir: &Path) -> PathBuf {
    let header = dir.join("seq.h");
    let out = run(&["export", "c", sequence, "-o", header.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", show(&out));
    let program = dir.join("player");
    let players = repo("players/c");
    let gcc = Command::new("gcc")
        .args([
            "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-I", &players, "-include",
        ])
        .arg(&header)
        .arg(format!("{players}/host_dump.c"))
        .arg(format!("{players}/keypose_player.c"))
        .args(["-lm", "-o"])
        .arg(&program)
        .output()
        .expect("gcc is needed to build the C player");
    assert!(
        gcc.status.success(),
        "gcc: {}",
        String::from_utf8_lossy(&gcc.stderr)
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
    let dir = tempfile::tempdir().unwrap();
    let program = build_player(sequence, dir.path());
    let played = player_rows(&program, &["100"]);
    let sampled = run(&["sample", sequence, "--units", "ticks", "--rate", "100"]);
    assert_eq!(sampled.status.code(), Some(0), "{}", show(&sampled));
    let expected = rows(&stdout(&sampled));
    assert_eq!(played.len(), expected.len(), "{sequence}: rows");
    for (p, e) in played.iter().zip(&expected) {
        for j in 1..e.len() {
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
fn the_approach_eases_in_to_the_first_pose_within_the_limits() {
    let dir = tempfile::tempdir().unwrap();
    let sequence = repo("sequences/so101_nod.json");
    let program = build_player(&sequence, dir.path());
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
