//! Inverse dynamics: the torque each servo gives to move the arm as asked.
//!
//! The masses are the robot's MuJoCo model's (`sim/models/`, the bodies' `<inertial>`), read by
//! the same reader as the collision model, so the check and the simulation weigh the same arm.
//! The load of each joint is the recursive Newton–Euler algorithm over that body tree: the
//! bodies' velocities and accelerations outwards from the base (gravity enters as the base
//! accelerating upwards), then each body's force and moment inwards, each joint taking the part
//! along its axis. To that the servo's rotor adds its reflected inertia times the joint's
//! acceleration (`servo::Drive::rotor_inertia`, MuJoCo's armature), and a payload at the TCP
//! adds its weight and inertia as a point mass.
//!
//! Left out, on purpose: the motor's back-EMF and viscous friction, which the servo's
//! torque-speed line already is, and Coulomb friction, which its published stall torque and
//! no-load speed were measured through. MuJoCo's `mj_inverse` with damping, friction loss and
//! constraints switched off is the oracle (tests/simulation/dynamics.rs).

use crate::collision::mjcf;
use crate::collision::Motion;
use crate::pose::RigidTransform;
use crate::robot::mjcf::Inertial;
use crate::robot::{JointKind, Payload, Robot};
use glam::{DMat3, DQuat, DVec3};
use std::ops::Range;

mod compensation;
pub use compensation::Compensation;

/// Standard gravity, as MuJoCo's default `<option gravity>`, m/s².
pub const GRAVITY: f64 = 9.81;

/// Why a robot has no inverse dynamics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// Only the built-in robots come with a model whose masses keypose trusts.
    #[error("robot {robot:?} has no built-in MuJoCo model, so its masses are unknown{hint}")]
    NoModel {
        /// The robot.
        robot: String,
        /// The built-in it is built like, in words ([`crate::robot::named_like_hint`]).
        hint: String,
    },
    /// A built-in model that does not read is a build defect.
    #[error("the built-in model of {robot:?} cannot be read: {reason}")]
    Unreadable {
        /// The robot.
        robot: String,
        /// What the reader found.
        reason: String,
    },
    /// Every moving body needs its mass.
    #[error("body {body:?} of the model of {robot:?} has no <inertial>")]
    NoMass {
        /// The robot.
        robot: String,
        /// The body without one.
        body: String,
    },
    /// The model and the robot file disagree on the joints.
    #[error("the model of {robot:?} has a joint {joint:?} the robot file does not name")]
    UnknownJoint {
        /// The robot.
        robot: String,
        /// The model's joint.
        joint: String,
    },
}

/// One body of an arm, in the arm's base frame.
#[derive(Debug, Clone)]
struct Link {
    parent: Option<usize>,
    origin: RigidTransform,
    motion: Motion,
    mass: f64,
    /// In the body's frame.
    com: DVec3,
    /// About the centre of mass, in the body's axes.
    inertia: DMat3,
}

/// One arm's body tree.
#[derive(Debug, Clone)]
struct Chain {
    links: Vec<Link>,
    /// Gravity in the arm's base frame (a cell may turn an arm's base).
    gravity: DVec3,
}

/// The inverse dynamics of a robot (each arm of a cell on its own).
#[derive(Debug, Clone)]
pub struct Dynamics {
    chains: Vec<Chain>,
    kinds: Vec<JointKind>,
    /// Each joint's rotor inertia reflected to the joint, SI (kg·m², or kg for a prismatic).
    armature: Vec<f64>,
    /// Each joint's [`super::Servo::transmission`].
    transmission: Vec<f64>,
}

/// A state of motion's kinematics per body, in the arm's base frame.
#[derive(Debug, Clone, Copy)]
struct BodyMotion {
    frame: RigidTransform,
    omega: DVec3,
    alpha: DVec3,
    /// Acceleration of the body's origin, gravity included (the base accelerates upwards).
    accel: DVec3,
}

impl Dynamics {
    /// The dynamics of `robot` (each arm of a cell) from its built-in model, with the
    /// servos' rotor inertias and the payload the robot carries.
    pub fn for_robot(robot: &Robot) -> Result<Dynamics, DynamicsError> {
        let mut chains = Vec::new();
        if robot.is_cell() {
            for arm in &robot.arms {
                let gravity = arm.base.r.inverse() * DVec3::new(0.0, 0.0, -GRAVITY);
                chains.push(chain(&arm.robot, arm.joints.clone(), gravity)?);
            }
        } else {
            let gravity = DVec3::new(0.0, 0.0, -GRAVITY);
            chains.push(chain(robot, 0..robot.joints.len(), gravity)?);
        }
        let transmission: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| j.servo.transmission(j.kind))
            .collect();
        let armature = robot
            .joints
            .iter()
            .zip(&transmission)
            .map(|(j, n)| {
                j.servo
                    .drive()
                    .map_or(0.0, |d| d.rotor_inertia.value / (n * n))
            })
            .collect();
        Ok(Dynamics {
            chains,
            kinds: robot.joints.iter().map(|j| j.kind).collect(),
            armature,
            transmission,
        })
    }

    /// Each joint's generalized force, N·m for a revolute joint and N for a prismatic one, to
    /// move at `values` with `velocities` and `accelerations` (joint units: degrees or metres,
    /// per second, per second squared; robot order).
    pub fn joint_forces(
        &self,
        values: &[f64],
        velocities: &[f64],
        accelerations: &[f64],
    ) -> Vec<f64> {
        let si = |v: &[f64]| -> Vec<f64> {
            self.kinds
                .iter()
                .zip(v)
                .map(|(&k, &x)| to_si(k, x))
                .collect()
        };
        let (q, qd, qdd) = (si(values), si(velocities), si(accelerations));
        let mut force = vec![0.0; self.kinds.len()];
        for chain in &self.chains {
            chain.add_forces(&q, &qd, &qdd, &mut force);
        }
        for ((f, a), x) in force.iter_mut().zip(&self.armature).zip(&qdd) {
            *f += a * x;
        }
        force
    }

    /// Each servo's torque at its output shaft, N·m: [`Dynamics::joint_forces`] through the
    /// joint's transmission.
    pub fn servo_torques(
        &self,
        values: &[f64],
        velocities: &[f64],
        accelerations: &[f64],
    ) -> Vec<f64> {
        let mut torque = self.joint_forces(values, velocities, accelerations);
        for (t, n) in torque.iter_mut().zip(&self.transmission) {
            *t *= n;
        }
        torque
    }

    /// Each servo's output speed, rad/s, at joint `velocities` (joint units per second).
    pub fn servo_speeds(&self, velocities: &[f64]) -> Vec<f64> {
        self.kinds
            .iter()
            .zip(velocities)
            .zip(&self.transmission)
            .map(|((&k, &v), n)| to_si(k, v) / n)
            .collect()
    }

    /// Each servo's torque holding the arm still at `values`: its weight alone.
    pub fn holding_torques(&self, values: &[f64]) -> Vec<f64> {
        let rest = vec![0.0; values.len()];
        self.servo_torques(values, &rest, &rest)
    }
}

impl Chain {
    /// Adds this arm's joints' forces (SI values in, robot order) into `force`.
    fn add_forces(&self, q: &[f64], qd: &[f64], qdd: &[f64], force: &mut [f64]) {
        let motions = self.outwards(q, qd, qdd);
        // Force and moment (about the body's origin) each body's subtree needs.
        let mut f = vec![DVec3::ZERO; self.links.len()];
        let mut n = vec![DVec3::ZERO; self.links.len()];
        for (i, link) in self.links.iter().enumerate().rev() {
            let m = &motions[i];
            let lever = m.frame.r * link.com;
            let accel_com = m.accel + m.alpha.cross(lever) + m.omega.cross(m.omega.cross(lever));
            let r = DMat3::from_quat(m.frame.r);
            let inertia = r * link.inertia * r.transpose();
            let own_force = link.mass * accel_com;
            f[i] += own_force;
            n[i] += inertia * m.alpha + m.omega.cross(inertia * m.omega) + lever.cross(own_force);
            if let Some((index, kind, axis, scale)) = joint_of(&link.motion) {
                let axis = m.frame.r * axis;
                let along = match kind {
                    JointKind::Revolute => axis.dot(n[i]),
                    JointKind::Prismatic => axis.dot(f[i]),
                };
                force[index] += scale * along;
            }
            if let Some(p) = link.parent {
                let offset = m.frame.t - motions[p].frame.t;
                let (fi, ni) = (f[i], n[i]);
                f[p] += fi;
                n[p] += ni + offset.cross(fi);
            }
        }
    }

    /// Every body's frame, angular velocity and acceleration and its origin's acceleration.
    fn outwards(&self, q: &[f64], qd: &[f64], qdd: &[f64]) -> Vec<BodyMotion> {
        let base = BodyMotion {
            frame: RigidTransform::IDENTITY,
            omega: DVec3::ZERO,
            alpha: DVec3::ZERO,
            accel: -self.gravity,
        };
        let mut out: Vec<BodyMotion> = Vec::with_capacity(self.links.len());
        for link in &self.links {
            let parent = link.parent.map_or(base, |p| out[p]);
            let (value, rate, accel) = match &link.motion {
                Motion::Fixed => (0.0, 0.0, 0.0),
                Motion::Joint { index, .. } => (q[*index], qd[*index], qdd[*index]),
                Motion::Mimic {
                    index,
                    offset,
                    scale,
                    ..
                } => (
                    offset + scale * q[*index],
                    scale * qd[*index],
                    scale * qdd[*index],
                ),
            };
            let placed = parent.frame.compose(&link.origin);
            let reach = placed.t - parent.frame.t;
            let mut body = BodyMotion {
                frame: placed,
                omega: parent.omega,
                alpha: parent.alpha,
                accel: parent.accel
                    + parent.alpha.cross(reach)
                    + parent.omega.cross(parent.omega.cross(reach)),
            };
            if let Some((_, kind, axis, _)) = joint_of(&link.motion) {
                let world = placed.r * axis;
                match kind {
                    JointKind::Revolute => {
                        body.frame.r = placed.r * DQuat::from_axis_angle(axis, value);
                        body.omega += world * rate;
                        body.alpha += world * accel + parent.omega.cross(world * rate);
                    }
                    JointKind::Prismatic => {
                        body.frame.t += world * value;
                        let slide = body.frame.t - parent.frame.t;
                        body.accel = parent.accel
                            + parent.alpha.cross(slide)
                            + parent.omega.cross(parent.omega.cross(slide))
                            + 2.0 * parent.omega.cross(world * rate)
                            + world * accel;
                    }
                }
            }
            out.push(body);
        }
        out
    }
}

/// A moving body's joint: the robot joint whose force it adds to, its kind, its axis in the
/// body's frame, and how much of the body's joint force reaches the robot's joint (a mimic's
/// coefficient, by virtual work).
fn joint_of(motion: &Motion) -> Option<(usize, JointKind, DVec3, f64)> {
    match *motion {
        Motion::Fixed => None,
        Motion::Joint { index, kind, axis } => Some((index, kind, axis, 1.0)),
        Motion::Mimic {
            index,
            kind,
            axis,
            scale,
            ..
        } => Some((index, kind, axis, scale)),
    }
}

/// One arm's chain from its built-in model, its joints at `joints` of the robot, its payload
/// hung from the TCP's body.
fn chain(robot: &Robot, joints: Range<usize>, gravity: DVec3) -> Result<Chain, DynamicsError> {
    let text = crate::robot::builtin_mjcf(&robot.name).ok_or_else(|| DynamicsError::NoModel {
        robot: robot.name.clone(),
        hint: crate::robot::named_like_hint(robot),
    })?;
    let parsed = mjcf::parse(text).map_err(|e| DynamicsError::Unreadable {
        robot: robot.name.clone(),
        reason: e.to_string(),
    })?;
    let mut links = Vec::with_capacity(parsed.bodies.len() + 1);
    for body in &parsed.bodies {
        let motion =
            Motion::of(body.joint.as_ref(), &parsed, robot, joints.start).ok_or_else(|| {
                DynamicsError::UnknownJoint {
                    robot: robot.name.clone(),
                    joint: body
                        .joint
                        .as_ref()
                        .map(|j| j.name.clone())
                        .unwrap_or_default(),
                }
            })?;
        let inertial = match body.inertial {
            Some(i) => i,
            // A fixed body without mass carries nothing that moves.
            None if motion == Motion::Fixed => Inertial {
                mass: 0.0,
                com: DVec3::ZERO,
                inertia: DMat3::ZERO,
            },
            None => {
                return Err(DynamicsError::NoMass {
                    robot: robot.name.clone(),
                    body: body.name.clone(),
                })
            }
        };
        links.push(Link {
            parent: body.parent,
            origin: body.origin,
            motion,
            mass: inertial.mass,
            com: inertial.com,
            inertia: inertial.inertia,
        });
    }
    if let Some(payload) = robot.payload {
        links.push(payload_link(robot, &parsed, payload));
    }
    Ok(Chain { links, gravity })
}

/// The payload as a point mass on the body that moves with the TCP's joint (the last body
/// where the robot has no TCP).
fn payload_link(robot: &Robot, parsed: &mjcf::Model, payload: Payload) -> Link {
    let (joint, at) = match &robot.tcp {
        Some(tcp) => (tcp.parent, tcp.origin),
        None => (robot.joints.len() - 1, RigidTransform::IDENTITY),
    };
    let name = &robot.joints[joint].name;
    let body = parsed
        .bodies
        .iter()
        .position(|b| b.joint.as_ref().is_some_and(|j| &j.name == name))
        .unwrap_or(parsed.bodies.len() - 1);
    Link {
        parent: Some(body),
        origin: RigidTransform::IDENTITY,
        motion: Motion::Fixed,
        mass: payload.mass,
        com: at.t + at.r * payload.com,
        inertia: DMat3::ZERO,
    }
}

/// A joint value (or rate) in SI: radians or metres.
fn to_si(kind: JointKind, value: f64) -> f64 {
    match kind {
        JointKind::Revolute => value.to_radians(),
        JointKind::Prismatic => value,
    }
}

/// A joint's SI value (radians or metres) in its unit (degrees or metres).
pub fn from_si(kind: JointKind, value: f64) -> f64 {
    match kind {
        JointKind::Revolute => value.to_degrees(),
        JointKind::Prismatic => value,
    }
}
