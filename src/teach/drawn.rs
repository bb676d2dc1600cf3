//! A drawn arm: what the session drives when no arm is attached (`keypose studio` without
//! `--port`). Nothing is sent anywhere. It stands in for the servos behind the same
//! [`ServoBus`] the player drives, so a jog, a move to a key or playback runs exactly as on an
//! arm — the approach ramp, the pacing at the control rate, the step limiter, the limit
//! guard, a stop braking along the path — and each goal the player writes becomes the pose at
//! once, as an ideal servo would reach it. What the page draws is then what the player
//! commands an arm to do.
//!
//! The arm starts at the robot's home pose. A joint released (`t`) stays where it was drawn:
//! there is no hand to move it.

use crate::bus::{BusError, Health, PingInfo, PositionLoad, ServoBus};
use crate::robot::{Robot, ServoModel};
use crate::servo::{Alarms, Setting};

/// Ideal servos, one per joint, that are wherever they were last told to be.
#[derive(Debug, Clone)]
pub struct DrawnArm {
    /// Each joint's servo id and model, in joint order.
    servos: Vec<(u8, ServoModel)>,
    /// Where each one is, in ticks.
    ticks: Vec<i64>,
    torque: Vec<bool>,
}

impl DrawnArm {
    /// The arm of `robot` at its home pose (each joint's home inside its limits, on a tick).
    pub fn new(robot: &Robot) -> DrawnArm {
        let ticks = robot
            .joints
            .iter()
            .zip(&robot.home)
            .map(|(joint, &home)| {
                let inside = home.clamp(joint.limits.min, joint.limits.max);
                joint
                    .goal_tick(inside)
                    .or_else(|_| joint.servo.tick(inside))
                    .unwrap_or(0)
            })
            .collect();
        DrawnArm {
            servos: robot
                .joints
                .iter()
                .map(|j| (j.servo.id, j.servo.model))
                .collect(),
            ticks,
            torque: vec![false; robot.joints.len()],
        }
    }

    /// The joint of servo `id`; an id no joint has is a servo that does not answer.
    fn joint(&self, id: u8) -> Result<usize, BusError> {
        self.servos
            .iter()
            .position(|&(own, _)| own == id)
            .ok_or(BusError::Timeout { id, timeout_ms: 0 })
    }
}

impl ServoBus for DrawnArm {
    fn describe(&self) -> String {
        "a drawn arm (no servos: nothing is sent)".into()
    }
    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        let (_, model) = self.servos[self.joint(id)?];
        Ok(PingInfo {
            id,
            model_number: model.spec().model_number,
            firmware: None,
            alarms: Alarms::default(),
        })
    }
    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        ids.iter()
            .map(|&id| self.joint(id).map(|j| self.ticks[j]))
            .collect()
    }
    /// A drawn arm carries no weight: its servos' load is 0, and the push guard watches it
    /// as it would a real arm's.
    fn read_positions_loads(&mut self, ids: &[u8]) -> Result<Vec<PositionLoad>, BusError> {
        Ok(PositionLoad::each(self.read_positions(ids)?, Some(0.0)))
    }
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        for &(id, tick) in goals {
            let j = self.joint(id)?;
            // A servo without torque does not drive to its goal.
            if self.torque[j] {
                self.ticks[j] = tick;
            }
        }
        Ok(())
    }
    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        for &id in ids {
            let j = self.joint(id)?;
            self.torque[j] = on;
        }
        Ok(())
    }
    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        ids.iter()
            .map(|&id| {
                self.joint(id).map(|_| Health {
                    id,
                    temperature_c: 25.0,
                    voltage_v: 12.0,
                    load_percent: 0.0,
                    current_a: None,
                    alarms: Alarms::default(),
                })
            })
            .collect()
    }
    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        servos
            .iter()
            .map(|&(id, _)| self.joint(id).map(|_| 0))
            .collect()
    }
    /// Ideal servos as they leave the factory: each register its factory value (the push
    /// guard reads the overload protection's settings from every servo).
    fn read_setting(&mut self, ids: &[u8], setting: Setting) -> Result<Vec<i64>, BusError> {
        ids.iter()
            .map(|&id| {
                let (_, model) = self.servos[self.joint(id)?];
                let spec = model.spec();
                let register = setting.register(spec.table);
                let item = register.and_then(|r| spec.item(r.name));
                match item.map(|i| i.default) {
                    Some(crate::servo::item::Default::Value(value)) => Ok(value),
                    _ => Err(BusError::MissingRegister {
                        id,
                        register: setting.name(),
                    }),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::teach::{BusCommand, Event, MotionKind, MotionPlan, Session};

    /// A jog of the drawn SO-101's pan by 10° through the session runs the player and ends
    /// with the arm drawn at 10° as a servo reaches it — 10° is 113.78 ticks of 4096 a turn,
    /// the nearest tick 114, read back as 114 · 360 / 4096 = 10.01953125° — every other joint
    /// where it was.
    #[test]
    fn a_jog_moves_the_drawn_arm_through_the_player() {
        let robot = Robot::builtin("so101").unwrap();
        let mut session = Session::drawn(&robot);
        let start = session.read().unwrap().unwrap();
        // Home, on the nearest tick (within half a tick, 360 / 4096 / 2 degrees).
        for (drawn, home) in start.iter().zip(&robot.home) {
            assert!((drawn - home).abs() <= 360.0 / 8192.0, "{start:?}");
        }
        let n = robot.joints.len();
        let held = session.execute(BusCommand::Torque {
            joints: (0..n).collect(),
            on: true,
        });
        assert!(matches!(held[..], [Event::Held { .. }]), "{held:?}");
        let plan = crate::teach::motion::jog(&robot, &start, &[(0, start[0] + 10.0)]).unwrap();
        assert_eq!(plan.kind, MotionKind::Jog);
        let started = session.execute(BusCommand::Run(Box::new(plan as MotionPlan)));
        assert!(matches!(started[..], [Event::MotionStarted { .. }]));
        let ended = session.wait_motion().unwrap().unwrap();
        assert!(
            matches!(ended, Event::MotionEnded { outcome: Ok(_), .. }),
            "{ended:?}"
        );
        let now = session.read().unwrap().unwrap();
        assert!((now[0] - 10.01953125).abs() < 1e-9, "{now:?}");
        assert_eq!(now[1..], start[1..]);
    }
}
