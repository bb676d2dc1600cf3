//! Emulated servos whose shafts are an arm's (`keypose virtual-bus --physics`): the servos keep
//! their registers and their firmware's rules, and a [`Physics`] (MuJoCo, in `sim::servo_arm`)
//! moves the arm under gravity, contacts and load, each joint driven by its servo's motor as the
//! firmware commands it.
//!
//! The physics runs on the bus's clock: before the servos answer an instruction they are
//! brought up to now ([`PhysicsLink::advance_to`]), and a clock thread ([`super::VirtualBus`])
//! keeps them there between instructions, so that a limp arm falls while nobody reads it. After
//! each step the present registers carry what the motor did: its load, its current, its
//! winding's temperature (a first-order thermal model), and the firmware's protection runs on
//! them.

use super::servo::VirtualServo;
use crate::bus::protocol::motor::LoadSample;
use crate::robot::Robot;
use crate::servo::{Drive, LoadUnit};
use std::time::Instant;

/// One servo's motor as its firmware commands it, in the joint's units (degrees for a
/// revolute joint, the joint's own for a prismatic one) and per second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorCommand {
    /// Whether the motor is driven (torque on); a limp motor neither drives nor brakes.
    pub on: bool,
    /// Where the position loop is told to go.
    pub goal: f64,
    /// The firmware's profile between goals: acceleration, per second²; `None` none.
    pub acceleration: Option<f64>,
    /// The firmware's profile between goals: speed, per second; `None` none.
    pub velocity: Option<f64>,
    /// The loop's stiffness as a share of the servo's rating.
    pub stiffness_share: f64,
    /// The most the motor may push, as a share of its stall torque.
    pub force_share: f64,
    /// Where a hand pulls the joint (`virtual-bus --hand`), if one holds it.
    pub hand: Option<f64>,
}

/// One shaft after a step, in the joint's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaft {
    /// Where the joint is.
    pub position: f64,
    /// Per second.
    pub velocity: f64,
    /// The position loop's output at the servo's shaft, N·m: the stall torque times the duty
    /// the loop applies.
    pub output: f64,
    /// The torque the motor gives at the servo's shaft, N·m: the output less what its own
    /// speed takes (the torque-speed line); what its current is for.
    pub torque: f64,
}

/// Why the physics could not start or step.
#[derive(Debug, thiserror::Error)]
#[error("the emulated arm's physics failed: {message}")]
pub struct PhysicsError {
    /// What went wrong, as the physics says it.
    pub message: String,
    /// Whether the input is at fault (a robot without a model, a scene MuJoCo refuses)
    /// rather than the machine.
    pub bad_input: bool,
}

/// An arm's physics behind the emulated servos of one bus.
pub trait Physics: Send {
    /// Steps the arm to `until` seconds after its start with each servo's motor as
    /// `commands` says (one per servo, in the bus's order), and gives each shaft.
    fn advance(
        &mut self,
        until: f64,
        commands: &[MotorCommand],
    ) -> Result<Vec<Shaft>, PhysicsError>;
    /// Seconds of processor time per simulated second so far.
    fn cost(&self) -> f64;
    /// Seconds one physics step covers: an advance shorter than half of it steps nothing.
    fn step(&self) -> f64;
}

/// How a servo's shaft (its actual position, ticks) and its joint's value relate: fixed when
/// the arm is built, since a calibration rewrites the homing offset, not the shaft.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ShaftMap {
    actual: f64,
    value: f64,
    /// Joint units per tick of the shaft, signed.
    per_tick: f64,
}

impl ShaftMap {
    fn value_of(&self, actual: f64) -> f64 {
        self.value + (actual - self.actual) * self.per_tick
    }

    fn actual_of(&self, value: f64) -> f64 {
        self.actual + (value - self.value) / self.per_tick
    }
}

/// The winding's heat: a first-order model of the copper losses against the case's cooling.
/// Neither maker publishes a thermal resistance or time constant: these are UNVERIFIED round
/// figures for a servo of this size (a stalled 5 V STS3215 reaches its 70 °C limit in about a
/// minute, a servo at its continuous rating stays far below it), to be tuned on an arm.
const THERMAL_RESISTANCE_K_PER_W: f64 = 8.0;
const THERMAL_TIME_CONSTANT_S: f64 = 120.0;
/// The room the arm works in, °C.
const AMBIENT_C: f64 = 25.0;

/// One servo's side of the physics: its shaft's map, its rating and its heat.
#[derive(Debug, Clone)]
struct PhysicalServo {
    map: ShaftMap,
    drive: &'static Drive,
    temperature_c: f64,
}

impl PhysicalServo {
    fn command(&self, servo: &VirtualServo) -> MotorCommand {
        let limits = servo.firmware().motor(servo, self.drive, &servo.watch);
        let per_tick = self.map.per_tick.abs();
        let profile = servo.motion.profile;
        MotorCommand {
            on: servo.motion.torque,
            goal: self.map.value_of(servo.motion.goal),
            acceleration: profile.acceleration.map(|a| a * per_tick),
            velocity: profile.max_speed.map(|v| v * per_tick),
            stiffness_share: limits.stiffness_share,
            force_share: limits.force_share,
            hand: servo.hand.map(|actual| self.map.value_of(actual)),
        }
    }

    /// The shaft where the physics put it, what the motor carried in the present registers,
    /// the heat it made, and the protection's verdict on it.
    fn apply(&mut self, servo: &mut VirtualServo, shaft: &Shaft, dt: f64) {
        servo.motion.position = self.map.actual_of(shaft.position);
        servo.motion.velocity = shaft.velocity / self.map.per_tick;
        let stall = self.drive.stall_torque.value;
        let current_a = (shaft.torque / stall).abs() * self.drive.stall_current.value;
        self.heat(current_a, dt);
        let load = LoadSample {
            output_share: shaft.output / stall,
            current_a,
            temperature_c: self.temperature_c,
        };
        self.report(servo, &load, shaft.torque.signum());
        if servo.motion.torque {
            servo.protect(&load, dt);
        }
        servo.refresh();
    }

    /// Copper losses I²R, R the winding's (the supply over the stall current).
    fn heat(&mut self, current_a: f64, dt: f64) {
        let resistance = self.drive.supply_v / self.drive.stall_current.value;
        let rise = current_a * current_a * resistance * THERMAL_RESISTANCE_K_PER_W;
        let settle = 1.0 - (-dt / THERMAL_TIME_CONSTANT_S).exp();
        self.temperature_c += (AMBIENT_C + rise - self.temperature_c) * settle;
    }

    /// The present registers. The load's sign is the shaft's direction (ticks), as a servo
    /// reports it, not the joint's: the two differ on a joint mounted reversed.
    fn report(&self, servo: &mut VirtualServo, load: &LoadSample, sign: f64) {
        let table = servo.table();
        let to_ticks = self.map.per_tick.signum();
        let value = match table.load_unit {
            LoadUnit::TenthPercent => to_ticks * load.output_share * 1000.0,
            LoadUnit::Current {
                milliamps_per_unit, ..
            } => to_ticks * sign * load.current_a * 1000.0 / milliamps_per_unit,
        };
        servo.set_present_load(value.round() as i64);
        servo.report_current(load.current_a);
        servo.store(table.present_temperature, self.temperature_c.round() as i64);
        servo.store(
            table.present_voltage,
            (self.drive.supply_v * 10.0).round() as i64,
        );
    }
}

/// Why a robot's servos cannot carry its arm's physics.
#[derive(Debug, thiserror::Error)]
pub enum PhysicalArmError {
    /// A joint's servo has no rating (no drive data for its variant and supply).
    #[error("joint {joint}: its servo ({servo}) has no drive data at its supply, so its motor cannot be emulated; name a variant and supply keypose rates (docs/robots.md §6)")]
    NoDrive {
        /// The joint's name.
        joint: String,
        /// Its servo's model.
        servo: String,
    },
}

/// The physics of one bus's servos: the arm, its clock and each servo's side of it.
pub struct PhysicsLink {
    physics: Box<dyn Physics>,
    started: Instant,
    /// Seconds of the bus's clock the physics has reached.
    time: f64,
    /// Whether the servos have had the shafts' state once (the arm may have settled first).
    synced: bool,
    servos: Vec<PhysicalServo>,
}

impl PhysicsLink {
    /// `physics` behind the servos of `robot`, as [`super::VirtualServos::for_robot`] built
    /// them (`servos`, in its joints' order), the clock starting now.
    pub(super) fn new(
        robot: &Robot,
        servos: &[VirtualServo],
        physics: Box<dyn Physics>,
    ) -> Result<PhysicsLink, PhysicalArmError> {
        let servos = robot
            .joints
            .iter()
            .zip(servos)
            .map(|(joint, servo)| {
                let drive = joint
                    .servo
                    .drive()
                    .ok_or_else(|| PhysicalArmError::NoDrive {
                        joint: joint.name.clone(),
                        servo: joint.servo.model.spec().name.to_string(),
                    })?;
                Ok(PhysicalServo {
                    map: shaft_map(joint, servo),
                    drive,
                    temperature_c: AMBIENT_C,
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(PhysicsLink {
            physics,
            started: Instant::now(),
            time: 0.0,
            synced: false,
            servos,
        })
    }

    /// Brings the arm up to `until` seconds of the bus's clock, or to now if that is sooner: a
    /// clock never runs ahead of the wall's.
    pub(super) fn advance_to(
        &mut self,
        servos: &mut [VirtualServo],
        until: f64,
    ) -> Result<(), PhysicsError> {
        let to_now = until.is_infinite();
        let until = until.min(self.started.elapsed().as_secs_f64());
        let dt = until - self.time;
        // Up to now, less than half a step would step nothing: the request is saved (a sync
        // write and the sync read after it come within a millisecond). A moment asked for is
        // always reached.
        if self.synced && (dt <= 0.0 || (to_now && dt < 0.5 * self.physics.step())) {
            return Ok(());
        }
        let commands: Vec<MotorCommand> = servos
            .iter()
            .zip(&self.servos)
            .map(|(servo, physical)| physical.command(servo))
            .collect();
        let shafts = self.physics.advance(until, &commands)?;
        self.time = until;
        self.synced = true;
        for ((servo, physical), shaft) in servos.iter_mut().zip(&mut self.servos).zip(&shafts) {
            physical.apply(servo, shaft, dt);
        }
        Ok(())
    }

    /// Seconds of processor time per simulated second so far.
    pub fn cost(&self) -> f64 {
        self.physics.cost()
    }

    /// Seconds of the bus's clock the physics has reached.
    pub fn time(&self) -> f64 {
        self.time
    }
}

/// Each joint's servo's rating at its supply: what its motor is emulated from. Checked before
/// any physics starts.
pub fn ratings(robot: &Robot) -> Result<Vec<&'static Drive>, PhysicalArmError> {
    robot
        .joints
        .iter()
        .map(|joint| {
            joint
                .servo
                .drive()
                .ok_or_else(|| PhysicalArmError::NoDrive {
                    joint: joint.name.clone(),
                    servo: joint.servo.model.spec().name.to_string(),
                })
        })
        .collect()
}

/// The map of `servo`'s shaft to `joint`'s values, as the servo sits at the joint's home.
fn shaft_map(joint: &crate::robot::Joint, servo: &VirtualServo) -> ShaftMap {
    let actual = servo.motion.position;
    let firmware = servo.firmware();
    let present = firmware.present_of(servo, actual);
    // One tick of the shaft is one tick of the present frame, in its direction; taken away
    // from the wrap of one turn.
    let step = if actual >= 1.0 { -1.0 } else { 1.0 };
    let direction = (firmware.present_of(servo, actual + step) - present) * step;
    let value = joint.servo.value_exact(present);
    let per_present_tick = joint.servo.value_exact(present + 1.0) - value;
    ShaftMap {
        actual,
        value,
        per_tick: per_present_tick * direction.signum(),
    }
}
