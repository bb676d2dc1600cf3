//! Jogging the tool: a step of the tool point along a base axis, solved into joint goals by the
//! robot's inverse kinematics from the present goals (so the arm stays on its branch).

use super::*;
use crate::kinematics::{line::JOINT_JUMP_DEG, tool_joints, Solver, ToolTarget};
use glam::DVec3;

/// How far one tool jog moves the tool point, metres.
pub const TOOL_JOG_M: f64 = 0.005;

impl TeachState {
    /// Moves the tool point [`TOOL_JOG_M`] along base axis `axis` (0 x, 1 y, 2 z) by `sign`.
    /// Refused while moving, with a tool joint limp, out of reach, or when the step would need
    /// any joint to move more than [`JOINT_JUMP_DEG`] (near a singularity).
    pub(super) fn jog_tool(&mut self, axis: usize, sign: f64) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        let moving = tool_joints(&self.robot);
        if let Some(limp) = (0..moving.len()).find(|&j| moving[j] && !self.torque[j]) {
            return self.fail(format!(
                "{} is limp (torque off): T holds every joint for jogging the tool",
                self.robot.joints[limp].name
            ));
        }
        let mut step = DVec3::ZERO;
        step[axis] = sign * TOOL_JOG_M;
        let target = ToolTarget::position(self.robot.tcp_position(&self.goals) + step);
        let held: Vec<bool> = moving.iter().map(|m| !m).collect();
        let solver = Solver::for_robot(&self.robot);
        let solution = match solver.solve(&self.robot, &target, &self.goals, &held) {
            Ok(solution) => solution,
            Err(e) => return self.fail(format!("tool jog: {e}")),
        };
        let goals: Vec<(usize, f64)> = (0..moving.len())
            .filter(|&j| moving[j])
            .map(|j| (j, solution.values[j]))
            .collect();
        if let Some(&(j, v)) = goals
            .iter()
            .find(|&&(j, v)| (v - self.goals[j]).abs() > JOINT_JUMP_DEG)
        {
            return self.fail(format!(
                "tool jog: {} would jump {:.1}° (a singularity); jog the joints instead",
                self.robot.joints[j].name,
                v - self.goals[j]
            ));
        }
        bus(BusCommand::Goals(goals))
    }
}
