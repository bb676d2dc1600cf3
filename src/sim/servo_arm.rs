//! The arm behind emulated servos, in MuJoCo (`keypose virtual-bus --physics`, `--port virtual
//! --physics`): the robot's model with its servos as built ([`super::Simulation::start`]), each
//! joint driven by the motor its emulated servo's firmware commands ([`Physics`]), stepped by
//! the harness (`sim/sim_servos.py`) to the bus's clock.
//!
//! Each motor is the one `keypose sim` models: a position loop of the rating's stiffness
//! (times the firmware's gain share) bounded by the stall torque (times the share the
//! registers allow), less the torque-speed line's slope times the speed; a limp motor drives
//! and brakes nothing.

use super::wire::{self, Request, ServoDrive, ServosStepReply};
use super::{drives, to_model, to_model_one, SimError, Simulation};
use crate::bus::virtual_bus::{MotorCommand, Physics, PhysicsError, Shaft};
use crate::robot::{Joint, JointKind, Robot};
use std::path::Path;

/// Seconds a limp arm is given to come to rest before an emulated bus starts on it: a
/// stretched-out SO-101 lies on its table within about a second.
pub const SETTLE_S: f64 = 3.0;

/// One joint's motor at full rating, in the model's units.
#[derive(Debug, Clone, Copy)]
struct Rating {
    kp: f64,
    force: f64,
    damping: f64,
    /// Model units of the joint per radian of the servo's shaft (1 for a revolute joint).
    transmission: f64,
}

/// A robot's model in a running harness, its joints the shafts of emulated servos.
pub struct MujocoArm {
    sim: Simulation,
    joints: Vec<Joint>,
    ratings: Vec<Rating>,
    /// Processor seconds per simulated second, from the harness's last reply.
    cost: f64,
}

impl MujocoArm {
    /// Starts the harness with `robot`'s model (and the objects of `scene`), its joints at the
    /// robot's home pose, at rest. Every joint's servo needs a rating (`servo::Drive`).
    pub fn start(robot: &Robot, scene: Option<&Path>) -> Result<MujocoArm, SimError> {
        MujocoArm::start_settled(robot, scene, 0.0)
    }

    /// Like [`MujocoArm::start`], the arm lying where it comes to rest: let go limp at home, it
    /// falls for [`SETTLE_S`] first, as an arm lies when it is switched on (`virtual-bus
    /// --physics`: what LeRobot's calibration then finds does not depend on how long it took to
    /// connect).
    pub fn start_at_rest(robot: &Robot, scene: Option<&Path>) -> Result<MujocoArm, SimError> {
        MujocoArm::start_settled(robot, scene, SETTLE_S)
    }

    fn start_settled(
        robot: &Robot,
        scene: Option<&Path>,
        settle: f64,
    ) -> Result<MujocoArm, SimError> {
        let mut sim = Simulation::start_in_scene(robot, None, None, scene)?;
        let names = sim.joints.clone();
        let by_name = drives(robot, &names);
        let mut ratings = Vec::with_capacity(names.len());
        for (joint, name) in robot.joints.iter().zip(&names) {
            let drive = by_name.get(name.as_str()).ok_or_else(|| SimError::Model {
                model: sim.model.clone(),
                message: format!(
                    "joint {}: its servo has no drive data at its supply, so its motor cannot be emulated",
                    joint.name
                ),
            })?;
            ratings.push(Rating {
                kp: drive.kp,
                force: drive.force,
                damping: drive.damping,
                transmission: joint.servo.transmission(joint.kind),
            });
        }
        let start = Request::ServosStart {
            joints: &names,
            qpos: to_model(robot, &robot.home),
            settle,
        };
        sim.harness.request(&start)?;
        Ok(MujocoArm {
            sim,
            joints: robot.joints.clone(),
            ratings,
            cost: 0.0,
        })
    }

    fn drive(&self, joint: &Joint, rating: &Rating, command: &MotorCommand) -> ServoDrive {
        ServoDrive {
            on: command.on,
            goal: to_model_one(joint, command.goal),
            kp: rating.kp * command.stiffness_share,
            force: rating.force * command.force_share,
            damping: rating.damping,
            acceleration: command.acceleration.map(|a| to_model_one(joint, a)),
            velocity: command.velocity.map(|v| to_model_one(joint, v)),
            hand: command.hand.map(|h| to_model_one(joint, h)),
        }
    }
}

impl Physics for MujocoArm {
    fn advance(
        &mut self,
        until: f64,
        commands: &[MotorCommand],
    ) -> Result<Vec<Shaft>, PhysicsError> {
        let drives = self
            .joints
            .iter()
            .zip(&self.ratings)
            .zip(commands)
            .map(|((joint, rating), command)| self.drive(joint, rating, command))
            .collect();
        let failed = |e: &dyn std::fmt::Display| PhysicsError {
            message: e.to_string(),
            bad_input: false,
        };
        let reply = self
            .sim
            .harness
            .request(&Request::ServosStep { until, drives })
            .map_err(|e| failed(&e))?;
        let reply: ServosStepReply = wire::parse(reply, "servos_step").map_err(|e| failed(&e))?;
        let n = self.joints.len();
        if [&reply.q, &reply.v, &reply.output, &reply.torque]
            .iter()
            .any(|column| column.len() != n)
        {
            return Err(failed(&format!(
                "the reply to servos_step does not give {n} joints"
            )));
        }
        if reply.simulated > 0.0 {
            self.cost = reply.wall / reply.simulated;
        }
        Ok(self.shafts(&reply))
    }

    fn cost(&self) -> f64 {
        self.cost
    }

    fn step(&self) -> f64 {
        self.sim.timestep
    }
}

impl MujocoArm {
    /// The reply's joints in keypose's units, forces as torques at each servo's shaft.
    fn shafts(&self, reply: &ServosStepReply) -> Vec<Shaft> {
        let one = |joint: &Joint, value: f64| match joint.kind {
            JointKind::Revolute => value.to_degrees(),
            JointKind::Prismatic => value,
        };
        self.joints
            .iter()
            .zip(&self.ratings)
            .enumerate()
            .map(|(i, (joint, rating))| Shaft {
                position: one(joint, reply.q[i]),
                velocity: one(joint, reply.v[i]),
                output: reply.output[i] * rating.transmission,
                torque: reply.torque[i] * rating.transmission,
            })
            .collect()
    }
}
