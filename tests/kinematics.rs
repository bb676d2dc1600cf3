//! Inverse kinematics against forward kinematics: round trips FK → IK → FK over random
//! reachable poses of every built-in arm, every solution inside the limits; the documented
//! errors for targets out of reach and below the floor. (The tool positions of solved joints
//! are measured in the official MuJoCo models by tests/sim_models.rs.)

use keypose::kinematics::{dls::Dls, lowest_below_floor, IkError, Solver, ToolTarget};
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
    let mut runner = TestRunner::new(config(cases));
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

/// With the orientation given, the closed form chooses the solution nearest the previous key:
/// never farther than the joints FK started from (which are one of the solutions).
#[test]
fn closed_form_picks_the_branch_of_a_nearby_key() {
    for name in ARMS {
        let robot = Robot::builtin(name).unwrap();
        let solver = Solver::for_robot(&robot);
        let held = vec![false; robot.joints.len()];
        let mut runner = TestRunner::new(config(1000));
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
