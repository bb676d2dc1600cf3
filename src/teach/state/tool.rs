//! The tool in teaching: moving it — a jog (a step of the tool point along a base axis) or a
//! target (the studio's tool handle, dragged) — solved into joint goals by the robot's inverse
//! kinematics from the present goals, so the arm stays on its branch; and capturing the
//! present pose as a tool key.

use super::*;
use crate::kinematics::{line::JOINT_JUMP_DEG, tool_joints, Solver, ToolTarget};
use crate::pose::rpy_from_quat;
use crate::sequence::{ToolKey, ToolOrientation};
use glam::DVec3;

/// How far one tool jog moves the tool point, metres.
pub const TOOL_JOG_M: f64 = 0.005;

impl TeachState {
    /// A new key after the current one holding the present pose as a tool key: the tool's
    /// position (rounded to 0.1 mm) and orientation (roll-pitch-yaw, rounded to 1e-4 rad), with
    /// the joints that do not move the tool (the gripper) as joint values.
    pub(super) fn new_tool_key(&mut self) -> Vec<Command> {
        let (values, note) = self.capture();
        let moving = tool_joints(&self.robot);
        let kept: Vec<(String, KeyValue)> = values
            .into_iter()
            .zip(&moving)
            .filter(|(_, &m)| !m)
            .map(|(v, _)| v)
            .collect();
        let frame = self.robot.tcp_frame(&self.present);
        let round = |x: f64, scale: f64| (x * scale).round() / scale;
        let xyz = DVec3::from_array(frame.t.to_array().map(|x| round(x, 10_000.0)));
        let (r, p, y) = rpy_from_quat(frame.r);
        let rpy = [r, p, y].map(|a| round(a, 10_000.0));
        self.list.insert_after(kept);
        self.list.set_tool(Some(ToolKey {
            xyz,
            orientation: Some(ToolOrientation::Rpy(rpy)),
        }));
        self.info(format!(
            "new {} as a tool key at x {:.1}  y {:.1}  z {:.1} mm{note} ({})",
            self.key_label(self.list.current_index()),
            xyz.x * 1000.0,
            xyz.y * 1000.0,
            xyz.z * 1000.0,
            format::count(self.list.len())
        ));
        self.edited()
    }

    /// Moves the tool point [`TOOL_JOG_M`] along base axis `axis` (0 x, 1 y, 2 z) by `sign`.
    pub(super) fn jog_tool(&mut self, axis: usize, sign: f64) -> Vec<Command> {
        let mut step = DVec3::ZERO;
        step[axis] = sign * TOOL_JOG_M;
        let target = self.robot.tcp_position(&self.goals) + step;
        self.reach_tool("tool jog", target)
    }

    /// Moves the tool point to `micrometres` (base frame): the studio's tool handle, dragged.
    /// Checked exactly as a jog; a refused target leaves the arm where it is.
    pub(super) fn move_tool_to(&mut self, micrometres: [i64; 3]) -> Vec<Command> {
        let target = DVec3::from_array(micrometres.map(|um| um as f64 * 1e-6));
        self.reach_tool("tool target", target)
    }

    /// Goals that put the tool point at `target`, solved from the present goals (so the arm
    /// stays on its branch) with the joints that do not move the tool held. Refused while
    /// moving, with a tool joint limp, out of reach (saying by how much and the nearest
    /// reachable point), or when any joint would move more than [`JOINT_JUMP_DEG`] (near a
    /// singularity); the session ramps the accepted goals as it ramps every jog.
    fn reach_tool(&mut self, what: &str, target: DVec3) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        let moving = tool_joints(&self.robot);
        if let Some(limp) = (0..moving.len()).find(|&j| moving[j] && !self.torque[j]) {
            return self.fail(format!(
                "{} is limp (torque off): T holds every joint for moving the tool",
                self.robot.joints[limp].name
            ));
        }
        let held: Vec<bool> = moving.iter().map(|m| !m).collect();
        let solver = Solver::for_robot(&self.robot);
        let target = ToolTarget::position(target);
        let solution = match solver.solve(&self.robot, &target, &self.goals, &held) {
            Ok(solution) => solution,
            Err(e) => return self.fail(format!("{what}: {e}")),
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
                "{what}: {} would jump {:.1}° (a singularity, or too far at once); \
                 move the tool in smaller steps or jog the joints",
                self.robot.joints[j].name,
                v - self.goals[j]
            ));
        }
        bus(BusCommand::Goals(goals))
    }
}
