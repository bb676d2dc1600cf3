//! Inverse kinematics against forward kinematics: round trips FK → IK → FK over random
//! reachable poses of every built-in arm, every solution inside the limits; the documented
//! errors for targets out of reach and below the floor. (The tool positions of solved joints
//! are measured in the official MuJoCo models by tests/simulation/models.rs.)

use keypose::kinematics::{lowest_below_floor, Dls, IkError, Solver, ToolTarget};
use keypose::robot::Robot;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// How near the pan axis the orientation is not checked, metres.
const NEAR_PAN_AXIS_M: f64 = 0.05;
const ARMS: [&str; 4] = ["so101", "so100", "koch", "omx"];

#[test]
fn builtins_get_the_closed_form() {
    for name in ARMS {
        let robot = Robot::builtin(name).unwrap();
        assert!(Solver::for_robot(&robot).is_closed_form(), "{name}");
    }
}

/// Random values inside the limits for the joints that move the tool, home for the rest.
fn random_pose(robot: &Robot) -> impl Strategy<Value = Vec<f64>> {
    let home = robot.home.clone();
    let tool = keypose::kinematics::tool_joints(robot);
    let ranges: Vec<_> = robot
        .joints
        .iter()
        .map(|j| j.limits.min..=j.limits.max)
        .collect();
    ranges.prop_map(move |values| {
        values
            .iter()
            .zip(&home)
            .zip(&tool)
            .map(|((&v, &h), &t)| if t { v } else { h })
            .collect()
    })
}

/// A runner with a fixed seed: the same poses on every run, so a CI failure reproduces (the
/// cases are many, and the seed can be changed to explore).
fn runner(config: Config) -> TestRunner {
    use proptest::test_runner::{RngAlgorithm, TestRng};
    TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha))
}

/// Most random poses of some arms (Koch) are under the floor and rejected.
fn config(cases: u32) -> Config {
    Config {
        cases,
        max_global_rejects: cases * 1000,
        ..Config::default()
    }
}

fn inside_limits(robot: &Robot, values: &[f64]) -> bool {
    robot
        .joints
        .iter()
        .zip(values)
        .all(|(j, &v)| j.limits.contains(v))
}

/// FK → IK → FK with `solver` from `seed_of(truth)`: the position within 1 µm, inside the
/// limits, the orientation (which the arm reached, so it can) within 0.1°: exact away from
/// the pan axis; near it the roll moves the tool point round the axis and the solver settles
/// for a branch within 0.05° of the best it finds. Oriented targets within [`NEAR_PAN_AXIS_M`] of the pan axis
/// (the pan singularity, docs/robots.md §9) are left out of the orientation check.
fn round_trip(
    name: &str,
    cases: u32,
    solver_of: fn(&Robot) -> Solver,
    seed_of: fn(&Robot, &[f64]) -> Vec<f64>,
    oriented: bool,
) {
    let robot = Robot::builtin(name).unwrap();
    let solver = solver_of(&robot);
    let held = vec![false; robot.joints.len()];
    let mut runner = runner(config(cases));
    runner
        .run(&random_pose(&robot), |truth| {
            prop_assume!(lowest_below_floor(&robot, &truth).is_none());
            let frame = robot.tcp_frame(&truth);
            if oriented {
                if let Solver::ClosedForm(g) = &solver {
                    prop_assume!(g.pan_axis_distance(frame.t) >= NEAR_PAN_AXIS_M);
                }
            }
            let target = if oriented {
                ToolTarget::pose(frame.t, frame.r)
            } else {
                ToolTarget::position(frame.t)
            };
            let seed = seed_of(&robot, &truth);
            let solution = solver
                .solve(&robot, &target, &seed, &held)
                .map_err(|e| TestCaseError::fail(format!("{name} {truth:?}: {e}")))?;
            let reached = robot.tcp_position(&solution.values);
            prop_assert!(
                reached.distance(frame.t) < 1e-6,
                "{name}: {truth:?} → {:?} misses by {} m",
                solution.values,
                reached.distance(frame.t)
            );
            prop_assert!(
                inside_limits(&robot, &solution.values),
                "{:?}",
                solution.values
            );
            // The general solver's orientation is the best near the seed, not necessarily the best.
            if solver.is_closed_form() {
                prop_assert!(
                    solution.orientation_error_deg() < 0.1,
                    "{truth:?}: {solution:?}"
                );
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
}

fn closed_form(robot: &Robot) -> Solver {
    Solver::for_robot(robot)
}

fn general(robot: &Robot) -> Solver {
    Solver::General(Dls::new(robot))
}

fn home_seed(robot: &Robot, _: &[f64]) -> Vec<f64> {
    robot.home.clone()
}

/// A previous key 5° from the truth on every tool joint (clamped into the limits).
fn nearby_seed(robot: &Robot, truth: &[f64]) -> Vec<f64> {
    robot
        .joints
        .iter()
        .zip(truth)
        .map(|(j, &v)| (v + 5.0).clamp(j.limits.min, j.limits.max))
        .collect()
}

#[test]
fn closed_form_round_trips_with_orientation() {
    for name in ARMS {
        round_trip(name, 2000, closed_form, home_seed, true);
    }
}

#[test]
fn closed_form_round_trips_position_only() {
    for name in ARMS {
        round_trip(name, 2000, closed_form, home_seed, false);
    }
}

#[test]
fn general_solver_round_trips_from_a_nearby_key() {
    for name in ARMS {
        round_trip(name, 300, general, nearby_seed, true);
        round_trip(name, 300, general, nearby_seed, false);
    }
}

/// From the home pose (a singular stretch), on pose targets over the whole joint ranges that
/// the arm reached (so an exact answer exists), the general solver meets position and
/// orientation (within 0.001°) on at least 90 %: a start stuck short of them gives way to
/// others. It met 288, 284, 275 and 286 of 300 on the SO-101, SO-100, Koch and OMX; before, with
/// five starts each run to 500 iterations and the first answer at the position kept however far
/// its orientation was, 254, 267, 261 and 234.
#[test]
fn general_solver_from_home_meets_poses_it_was_stuck_short_of() {
    for name in ARMS {
        let robot = Robot::builtin(name).unwrap();
        let solver = general(&robot);
        let held = vec![false; robot.joints.len()];
        let (cases, met) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
        runner(config(300))
            .run(&random_pose(&robot), |truth| {
                prop_assume!(lowest_below_floor(&robot, &truth).is_none());
                let frame = robot.tcp_frame(&truth);
                let target = ToolTarget::pose(frame.t, frame.r);
                cases.set(cases.get() + 1);
                if let Ok(solution) = solver.solve(&robot, &target, &robot.home, &held) {
                    let on_target = robot.tcp_position(&solution.values).distance(frame.t) < 1e-6;
                    if on_target && solution.orientation_error_deg() < 1e-3 {
                        met.set(met.get() + 1);
                    }
                }
                Ok(())
            })
            .unwrap();
        eprintln!("{name}: {} of {} poses met", met.get(), cases.get());
        assert!(
            f64::from(met.get()) >= 0.9 * f64::from(cases.get()),
            "{name}: {} of {} poses met",
            met.get(),
            cases.get()
        );
    }
}

/// With the orientation given, the closed form chooses the solution nearest the previous key:
/// never farther than the joints FK started from (which are one of the solutions).
#[test]
fn closed_form_picks_the_branch_of_a_nearby_key() {
    for name in ARMS {
        let robot = Robot::builtin(name).unwrap();
        let solver = Solver::for_robot(&robot);
        let held = vec![false; robot.joints.len()];
        let mut runner = runner(config(1000));
        runner
            .run(&random_pose(&robot), |truth| {
                prop_assume!(lowest_below_floor(&robot, &truth).is_none());
                let frame = robot.tcp_frame(&truth);
                if let Solver::ClosedForm(g) = &solver {
                    prop_assume!(g.pan_axis_distance(frame.t) >= NEAR_PAN_AXIS_M);
                }
                let tool = keypose::kinematics::tool_joints(&robot);
                let seed: Vec<f64> = truth
                    .iter()
                    .zip(&tool)
                    .map(|(v, &t)| if t { v + 2.0 } else { *v })
                    .collect();
                prop_assume!(inside_limits(&robot, &seed));
                let solution = solver
                    .solve(&robot, &ToolTarget::pose(frame.t, frame.r), &seed, &held)
                    .map_err(|e| TestCaseError::fail(e.to_string()))?;
                // The chosen one is the nearest of the solutions, and the truth is one of them.
                let distance = |v: &[f64]| keypose::kinematics::joint_distance(&robot, v, &seed);
                prop_assert!(
                    distance(&solution.values) <= distance(&truth) + 1e-9,
                    "{name}: {:?} is farther from {seed:?} than {truth:?}",
                    solution.values
                );
                Ok(())
            })
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// A point a metre away: out of reach, by the metre less the arm's reach, and the nearest
/// reachable point lies on the way to it (same direction from the shoulder, within a few mm).
#[test]
fn out_of_reach_names_the_miss_and_the_nearest_point() {
    let robot = Robot::builtin("so101").unwrap();
    let solver = Solver::for_robot(&robot);
    let target = glam::DVec3::new(1.0, 0.0, 0.1);
    let held = vec![false; robot.joints.len()];
    let error = solver
        .solve(&robot, &ToolTarget::position(target), &robot.home, &held)
        .unwrap_err();
    let IkError::OutOfReach { miss, nearest, .. } = error.clone() else {
        panic!("{error}");
    };
    // The SO-101 reaches about 0.45 m from its base (0.1126 + 0.1349 + ~0.16 of wrist and
    // tool past the shoulder at x ≈ 0.04): the miss is over half a metre and under 0.65 m.
    assert!((0.5..0.65).contains(&miss), "{error}");
    assert!((nearest.distance(target) - miss).abs() < 1e-9);
    assert!(nearest.y.abs() < 0.01 && nearest.x > 0.3, "{error}");
    let text = error.to_string();
    assert!(
        text.contains("misses by") && text.contains("nearest reachable point"),
        "{text}"
    );
}

#[test]
fn a_target_under_the_floor_is_refused_as_such() {
    let robot = Robot::builtin("so101").unwrap();
    let solver = Solver::for_robot(&robot);
    let held = vec![false; robot.joints.len()];
    let target = glam::DVec3::new(0.25, 0.0, -0.03);
    let error = solver
        .solve(&robot, &ToolTarget::position(target), &robot.home, &held)
        .unwrap_err();
    assert!(matches!(error, IkError::BelowFloor { .. }), "{error}");
}

mod sequences {
    use keypose::plan::Trajectory;
    use keypose::robot::Robot;
    use keypose::sequence::Sequence;

    fn sequence(keys: &str) -> Sequence {
        let text = format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "monotone",
                "keyframes": [{keys}]}}"#
        );
        Sequence::from_json("tool.json", &text).expect("parses")
    }

    const START: &str = r#"{"name": "start", "time": 0, "joints": {"shoulder_pan": 0, "shoulder_lift": 0, "elbow_flex": 0, "wrist_flex": 0, "wrist_roll": 0, "gripper": 0}}"#;

    /// The solved joints put the tool where the key says (by the forward kinematics), and the
    /// joint the key gives keeps its value.
    #[test]
    fn a_tool_key_is_solved_into_joints_and_keeps_its_own() {
        let robot = Robot::builtin("so101").unwrap();
        let keys = format!(
            r#"{START}, {{"name": "grasp", "time": 2, "tool": {{"xyz": [0.25, 0.05, 0.06]}}, "joints": {{"gripper": 30}}}}"#
        );
        let trajectory = Trajectory::build(&sequence(&keys), &robot).unwrap();
        let at_key = trajectory.sample(2.0);
        let tool = robot.tcp_position(&at_key);
        assert!(
            tool.distance(glam::DVec3::new(0.25, 0.05, 0.06)) < 1e-6,
            "{tool:?}"
        );
        assert_eq!(at_key[5], 30.0);
    }

    #[test]
    fn an_unreachable_tool_key_names_the_key_and_the_miss() {
        let robot = Robot::builtin("so101").unwrap();
        let keys =
            format!(r#"{START}, {{"name": "far", "time": 2, "tool": {{"xyz": [0.9, 0, 0.1]}}}}"#);
        let error = Trajectory::build(&sequence(&keys), &robot)
            .unwrap_err()
            .to_string();
        for part in [
            "tool.json",
            "$.keyframes[1].tool.xyz",
            "key far",
            "misses by",
            "nearest reachable point",
        ] {
            assert!(error.contains(part), "{part:?} in {error}");
        }
    }

    #[test]
    fn a_bad_tool_field_is_refused_with_its_path() {
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"time": 0, "tool": {"xyz": [0.2, 0], "rpy": [0, 0, 0]}}]}"#;
        let error = Sequence::from_json("bad.json", text)
            .unwrap_err()
            .to_string();
        assert!(error.contains("$.keyframes[0].tool.xyz"), "{error}");
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"time": 0, "tool": {"xyz": [0.2, 0, 0.1], "r": {"w": 1, "x": 0, "y": 0, "z": 0}, "rpy": [0, 0, 0]}}]}"#;
        let error = Sequence::from_json("bad.json", text)
            .unwrap_err()
            .to_string();
        assert!(error.contains("given twice"), "{error}");
    }

    /// Saving keeps the key as written (tool, rpy, line), and the saved text loads to the same.
    #[test]
    fn tool_keys_and_lines_save_as_written() {
        let keys = format!(
            r#"{START}, {{"time": 2, "interp": "line", "tool": {{"xyz": [0.25, 0.05, 0.12], "rpy": [0.1, 0.2, 0.3]}}}}, {{"time": 3, "tool": {{"xyz": [0.25, 0.05, 0.06]}}}}"#
        );
        let loaded = sequence(&keys);
        let text = loaded.to_json();
        assert!(
            text.contains(r#""interp":"line""#) && text.contains(r#""rpy":[0.1,0.2,0.3]"#),
            "{text}"
        );
        let again = Sequence::from_json("tool.json", &text).unwrap();
        assert_eq!(again.keyframes, loaded.keyframes);
    }

    /// Along a line the tool stays on the segment between the two targets: every control-rate
    /// sample of the solved joint curves, through the forward kinematics, within 0.1 mm of it
    /// (the samples are exact; between them the monotone joint curve bends it by less).
    #[test]
    fn a_line_keeps_the_tool_on_the_segment() {
        let robot = Robot::builtin("so101").unwrap();
        let keys = format!(
            r#"{START}, {{"time": 2, "interp": "line", "tool": {{"xyz": [0.25, 0.05, 0.12]}}}}, {{"time": 3.5, "tool": {{"xyz": [0.20, -0.05, 0.06]}}}}"#
        );
        let trajectory = Trajectory::build(&sequence(&keys), &robot).unwrap();
        assert!(
            trajectory.tools.lines[0].problem.is_none(),
            "{:?}",
            trajectory.tools.lines
        );
        let (a, b) = (
            glam::DVec3::new(0.25, 0.05, 0.12),
            glam::DVec3::new(0.20, -0.05, 0.06),
        );
        let mut previous: Option<Vec<f64>> = None;
        for k in 0..=150 {
            let values = trajectory.sample(2.0 + k as f64 / 100.0);
            let p = robot.tcp_position(&values);
            let s = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            let off = p.distance(a + (b - a) * s);
            assert!(
                off < 1e-4,
                "t = {}: {:.3} mm off the line",
                2.0 + k as f64 / 100.0,
                off * 1e3
            );
            // Branch continuity: no joint moves more than a few degrees per 10 ms.
            if let Some(prev) = &previous {
                for (x, y) in values.iter().zip(prev) {
                    assert!((x - y).abs() < 3.0, "{values:?} after {prev:?}");
                }
            }
            previous = Some(values);
        }
    }

    /// A line through the base (out of the workspace half-way) is reported with its feasible
    /// share, and the trajectory still builds (joint interpolation there).
    #[test]
    fn a_line_out_of_the_workspace_reports_its_feasible_fraction() {
        let robot = Robot::builtin("so101").unwrap();
        let keys = format!(
            r#"{START}, {{"time": 2, "interp": "line", "tool": {{"xyz": [0.30, 0.0, 0.10]}}}}, {{"time": 4, "tool": {{"xyz": [-0.25, 0.0, 0.10]}}}}"#
        );
        let trajectory = Trajectory::build(&sequence(&keys), &robot).unwrap();
        let line = &trajectory.tools.lines[0];
        let problem = line
            .problem
            .as_deref()
            .expect("the line cannot be followed");
        assert!(line.fraction > 0.0 && line.fraction < 1.0, "{line:?}");
        assert!(problem.contains('%'), "{problem}");
    }
}

/// `sample --tool` adds the tool path; at the key "above-cup" (t = 2 s) it is the key's target.
#[test]
fn sample_outputs_the_tool_path() {
    let sequence = format!(
        "{}/sequences/so101-tool-line.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_keypose"))
        .args(["sample", &sequence, "--tool", "--rate", "10"])
        .output()
        .expect("keypose runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).unwrap();
    let mut lines = text.lines();
    assert!(
        lines.next().unwrap().ends_with(",tool_x,tool_y,tool_z"),
        "{text}"
    );
    let at_two = lines.find(|l| l.starts_with("2,")).expect("a row at 2 s");
    let tool: Vec<f64> = at_two
        .rsplit(',')
        .take(3)
        .map(|v| v.parse().unwrap())
        .collect();
    for (got, want) in tool.iter().zip([0.12, 0.05, 0.25]) {
        assert!((got - want).abs() < 1e-6, "{at_two}");
    }
}

/// `plot --tool` draws the tool path as three more rows, every number finite.
#[test]
fn plot_draws_the_tool_path() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("tool.svg");
    let sequence = format!(
        "{}/sequences/so101-tool-line.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_keypose"))
        .args(["plot", &sequence, "--tool", "-o", svg.to_str().unwrap()])
        .output()
        .expect("keypose runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    for row in ["tool_x", "tool_y", "tool_z"] {
        assert!(text.contains(row), "{row} missing");
    }
    assert!(
        !text.contains("NaN") && !text.contains("inf"),
        "a non-finite number in the SVG"
    );
}
