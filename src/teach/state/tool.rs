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
const TOOL_JOG_M: f64 = 0.005;

/// The arm the tool commands act on: on a cell the arm of the selected joint, on a robot of one
/// arm the robot itself. Its tool is in its own base frame, as a cell's tool keys are.
struct ToolArm {
    /// The arm alone (its own joints, limits and tcp).
    robot: Robot,
    /// Where its joints start among the robot's.
    offset: usize,
    /// Its name on a cell.
    name: Option<String>,
}

impl ToolArm {
    fn of(robot: &Robot, selected: usize) -> ToolArm {
        match robot.arm_of_joint(selected) {
            Some(arm) => ToolArm {
                robot: arm.robot.clone(),
                offset: arm.joints.start,
                name: Some(arm.name.clone()),
            },
            None => ToolArm {
                robot: robot.clone(),
                offset: 0,
                name: None,
            },
        }
    }

    /// Its part of the robot's values.
    fn values<'v>(&self, all: &'v [f64]) -> &'v [f64] {
        &all[self.offset..self.offset + self.robot.joints.len()]
    }

    /// What a message calls `what` done with its tool: `tool jog`, or `tool jog (right)`.
    fn label(&self, what: &str) -> String {
        match &self.name {
            Some(arm) => format!("{what} ({arm})"),
            None => what.to_string(),
        }
    }
}

/// Where each arm's tool point is at `values`, each in its own base frame: the robot's tcp, or
/// on a cell every arm's, with the arm's name.
pub fn tool_positions<'r>(robot: &'r Robot, values: &[f64]) -> Vec<(Option<&'r str>, DVec3)> {
    let positions = robot.tool_positions(values);
    if !robot.is_cell() {
        return positions.into_iter().map(|p| (None, p)).collect();
    }
    robot
        .arms
        .iter()
        .map(|arm| Some(arm.name.as_str()))
        .zip(positions)
        .collect()
}

/// The tool of the arm the tool commands act on with joint `selected` selected (see
/// [`tool_positions`]): the arm's name on a cell, and the tool point in its base frame.
pub(crate) fn selected_tool<'r>(
    robot: &'r Robot,
    selected: usize,
    values: &[f64],
) -> (Option<&'r str>, DVec3) {
    let arm = robot.arm_of_joint(selected).map(|a| a.name.as_str());
    tool_positions(robot, values)
        .into_iter()
        .find(|(name, _)| *name == arm)
        .unwrap_or((None, robot.tcp_position(values)))
}

impl TeachState {
    /// A new key after the current one holding the present pose as a tool key of the selected
    /// joint's arm: the tool's position (rounded to 0.1 mm) and orientation (roll-pitch-yaw,
    /// rounded to 1e-4 rad) in that arm's base frame, with every other joint (the gripper,
    /// another arm's) as a joint value.
    pub(super) fn new_tool_key(&mut self) -> Vec<Command> {
        let arm = ToolArm::of(&self.robot, self.selected);
        let (values, note) = self.capture();
        let moving = tool_joints(&arm.robot);
        let moves_tool = |j: usize| j >= arm.offset && moving.get(j - arm.offset) == Some(&true);
        let kept: Vec<(String, KeyValue)> = values
            .into_iter()
            .enumerate()
            .filter(|&(j, _)| !moves_tool(j))
            .map(|(_, v)| v)
            .collect();
        let frame = arm.robot.tcp_frame(arm.values(&self.present));
        let round = |x: f64, scale: f64| (x * scale).round() / scale;
        let xyz = DVec3::from_array(frame.t.to_array().map(|x| round(x, 10_000.0)));
        let (r, p, y) = rpy_from_quat(frame.r);
        let rpy = [r, p, y].map(|a| round(a, 10_000.0));
        let tool = ToolKey {
            xyz,
            orientation: Some(ToolOrientation::Rpy(rpy)),
            approach: None,
        };
        self.list.insert_after(kept);
        match &arm.name {
            Some(name) => self.list.set_arm_tool(name, tool),
            None => self.list.set_tool(Some(tool)),
        };
        self.info(format!(
            "new {} as a {} at x {:.1}  y {:.1}  z {:.1} mm{note} ({})",
            self.key_label(self.list.current_index()),
            arm.label("tool key"),
            xyz.x * 1000.0,
            xyz.y * 1000.0,
            xyz.z * 1000.0,
            format::count(self.list.len())
        ));
        self.edited()
    }

    /// Moves the tool point of the selected joint's arm [`TOOL_JOG_M`] along its base axis
    /// `axis` (0 x, 1 y, 2 z) by `sign`.
    pub(super) fn jog_tool(&mut self, axis: usize, sign: f64) -> Vec<Command> {
        let arm = ToolArm::of(&self.robot, self.selected);
        let mut step = DVec3::ZERO;
        step[axis] = sign * TOOL_JOG_M;
        let target = arm.robot.tcp_position(arm.values(&self.goals)) + step;
        self.reach_tool(&arm, "tool jog", target)
    }

    /// Moves the tool point of the selected joint's arm to `micrometres` (that arm's base
    /// frame): the studio's tool handle, dragged. Checked exactly as a jog; a refused target
    /// leaves the arm where it is.
    pub(super) fn move_tool_to(&mut self, micrometres: [i64; 3]) -> Vec<Command> {
        let arm = ToolArm::of(&self.robot, self.selected);
        let target = DVec3::from_array(micrometres.map(|um| um as f64 * 1e-6));
        self.reach_tool(&arm, "tool target", target)
    }

    /// Goals that put `arm`'s tool point at `target`, solved from the present goals (so the arm
    /// stays on its branch) with the joints that do not move the tool held, and every other
    /// arm's left alone. Refused while moving, with a tool joint limp, out of reach (saying by
    /// how much and the nearest reachable point), or when any joint would move more than
    /// [`JOINT_JUMP_DEG`] (near a singularity), or into a contact (`contact`); the session
    /// ramps the accepted goals as it ramps every jog.
    fn reach_tool(&mut self, arm: &ToolArm, what: &str, target: DVec3) -> Vec<Command> {
        if let Some(refused) = self.refuse_while_moving() {
            return refused;
        }
        let what = arm.label(what);
        let moving = tool_joints(&arm.robot);
        if let Some(limp) = (0..moving.len()).find(|&j| moving[j] && !self.torque[arm.offset + j]) {
            return self.fail(format!(
                "{} is limp (torque off): T holds every joint for moving the tool",
                self.robot.joints[arm.offset + limp].name
            ));
        }
        let held: Vec<bool> = moving.iter().map(|m| !m).collect();
        let solver = Solver::for_robot(&arm.robot);
        let target = ToolTarget::position(target);
        let seed = arm.values(&self.goals);
        let solution = match solver.solve(&arm.robot, &target, seed, &held) {
            Ok(solution) => solution,
            Err(e) => return self.fail(format!("{what}: {e}")),
        };
        let goals: Vec<(usize, f64)> = (0..moving.len())
            .filter(|&j| moving[j])
            .map(|j| (arm.offset + j, solution.values[j]))
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
        if let Some(touch) = self.contact_refusal(&goals) {
            return self.fail(format!("{what}: the arm would collide: {touch}"));
        }
        self.jog_to(&goals)
    }
}
