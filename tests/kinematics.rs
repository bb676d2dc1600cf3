//! Inverse kinematics against forward kinematics: round trips over random reachable poses.

use keypose::kinematics::{Solver, ToolTarget};
use keypose::robot::Robot;
use proptest::prelude::*;

#[test]
fn builtins_get_the_closed_form() {
    for name in ["so101", "so100", "koch", "omx"] {
        let robot = Robot::builtin(name).unwrap();
        assert!(Solver::for_robot(&robot).is_closed_form(), "{name}");
    }
}

#[test]
fn debug_round_trip() {
    for name in ["so101", "so100", "koch", "omx"] {
        let robot = Robot::builtin(name).unwrap();
        let solver = Solver::for_robot(&robot);
        let mut v = robot.home.clone();
        v[1] += 20.0;
        v[2] -= 15.0;
        v[0] += 10.0;
        v[3] += 10.0;
        let frame = robot.tcp_frame(&v);
        let held = vec![false; v.len()];
        let s = solver.solve(&robot, &ToolTarget::position(frame.t), &robot.home, &held);
        eprintln!("{name} pos-only {:?} want {:?} -> {:?}", frame.t, v, s);
        let s = solver.solve(
            &robot,
            &ToolTarget::pose(frame.t, frame.r),
            &robot.home,
            &held,
        );
        eprintln!("{name} pose {:?}", s);
    }
}
