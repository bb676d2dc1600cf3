//! The push guard: a joint whose servo pushes harder than the motion needs, towards a goal it
//! does not reach, is pressing on something (the table, an object, a person). Caught well
//! before the servo's own protection trips (2 s on the STS3215 from the factory, about 5 s on
//! the X series), the joint stops pushing and the others brake along the path.
//!
//! What the motion needs is the arm's inverse dynamics at the measured pose with the path's
//! velocity and acceleration, as a share of the servo's stall torque; where the servo's load
//! register measures its PWM duty (the STS3215, the XL430) the duty also carries the motor's
//! back-EMF, the shaft's speed over its no-load speed. A push is a load towards the goal of at
//! least the servo's continuous rating (a fifth of stall, [`CONTINUOUS_FRACTION`]) and beyond
//! that need by as much, lasting [`PUSH_WINDOW_S`]: an arm that rests on something, its
//! servos carrying less than its weight, is not pushing on it. An overload is a load towards
//! the goal at the servo's own overload threshold ([`OverloadRule`], Feetech's read from the
//! servo, since LeRobot lowers the gripper's) lasting half the servo's protection time: caught
//! with half of it to spare, whatever the model says. Every figure is the servo's rating or the
//! arm's model: nothing is tuned to a test.
//!
//! [`OverloadRule`]: crate::servo::OverloadRule
//!
//! The approach starts from where the arm is, and an arm switched on lies on its table: the
//! table carries part of its weight until it lifts off, which the model of the arm in free
//! space does not know. During the approach only overloads count, and for [`AFTER_STALL_S`]
//! after a stall of two periods or more (the arm stopped at the goal held and starts again).

use crate::bus::{BusError, ServoBus};
use crate::dynamics::Dynamics;
use crate::robot::Robot;
use crate::servo::{LoadUnit, Setting, CONTINUOUS_FRACTION};

/// How long a push must last before it is a fault, seconds: longer than the load of an
/// acceleration lasts beyond the model's, on a busy machine too, whose late goals give the arm
/// accelerations of its own (one held an excess 61 ms beside six busy loops), and a
/// twenty-fifth of the STS3215's factory protection time.
pub const PUSH_WINDOW_S: f64 = 0.08;
/// After a stall (a goal held beyond its period), or a change of a joint's effort, seconds
/// before pushes count again: the arm stopped at the held goal and starts again when the path
/// resumes, and a joint let loose from an effort limit catches up with its goal, accelerations
/// the path's own does not have.
pub const AFTER_STALL_S: f64 = 0.3;

/// Readings' times are sums of control periods, so a window of eight 10 ms periods may come
/// out at 0.0799…: durations are compared with this much slack, far below one period.
const TIME_SLACK_S: f64 = 1e-6;

/// Whether a time sum `reached` has come to `bound`, within [`TIME_SLACK_S`].
fn at_least(reached: f64, bound: f64) -> bool {
    reached + TIME_SLACK_S >= bound
}
/// The fewest readings a push must span: one reading is no evidence of a lasting push.
const MIN_READINGS: u32 = 3;
/// Ticks of error below which a servo is at its goal: its position reading's own noise.
const AT_GOAL_TICKS: f64 = 2.0;

/// One reading of the arm, by joint in the robot's order.
#[derive(Debug, Clone, Copy)]
pub struct Reading<'a> {
    /// Seconds since playback began; one or more periods after the last reading.
    pub time: f64,
    /// Where the arm should be (the path), and the cycles it advanced by since the last.
    pub path: &'a [f64],
    /// Control cycles since the last reading.
    pub cycles: u32,
    /// The goals the servos hold.
    pub goals: &'a [f64],
    /// The positions read (NaN where not read).
    pub measured: &'a [f64],
    /// The loads read, percent as the servos report them (`None` where not read).
    pub loads: &'a [Option<f64>],
    /// Whether the arm is free of its table's support as far as keypose knows (`false`
    /// during the approach).
    pub free: bool,
}

/// A joint found pushing.
#[derive(Debug, Clone, PartialEq)]
pub struct Push {
    /// Its index in the robot's joints.
    pub joint: usize,
    /// The hardest load seen during the push, percent of full output, in the joint's direction.
    pub load_percent: f64,
    /// What the motion needed then, percent, in the joint's direction (`None`: no model).
    pub needed_percent: Option<f64>,
    /// How long it had pushed, seconds.
    pub lasted: f64,
    /// Where the joint is held: its position when the push was caught.
    pub hold_at: f64,
}

/// What the guard knows of one joint's servo.
#[derive(Debug, Clone)]
struct JointServo {
    /// The servo's overload threshold, percent of full output.
    overload_percent: f64,
    /// How long an overload is let last: half the servo's protection time, seconds.
    overload_window: f64,
    /// Stall torque, N·m, and no-load speed, rad/s, at its supply (`None`: not rated).
    rating: Option<(f64, f64)>,
    /// Whether its load register measures PWM duty (back-EMF included) rather than current.
    measures_duty: bool,
    /// The joint's direction on the servo's shaft (the load is the shaft's).
    direction: f64,
    /// Error below which it is at its goal, joint units.
    at_goal: f64,
    /// The joint's velocity and acceleration limits, joint units per second (squared): the
    /// path's own never exceed them, so a difference that does is a stall's step.
    limits: (f64, f64),
}

/// One joint's watch over one condition.
#[derive(Debug, Clone, Default)]
struct Watch {
    /// When the condition began.
    since: Option<f64>,
    readings: u32,
    /// The hardest load while it lasted, and what was needed then.
    peak: f64,
    needed: Option<f64>,
}

impl Watch {
    /// One reading: the condition holds (`Some(load, need)`) or not. How long it has held,
    /// once it has held over [`MIN_READINGS`] readings.
    fn reading(&mut self, time: f64, holds: Option<(f64, Option<f64>)>) -> Option<f64> {
        let Some((load, need)) = holds else {
            *self = Watch::default();
            return None;
        };
        let began = *self.since.get_or_insert(time);
        self.readings += 1;
        if load.abs() >= self.peak.abs() {
            self.peak = load;
            self.needed = need;
        }
        (self.readings >= MIN_READINGS).then_some(time - began)
    }
}

/// The reading before, for the path's velocity and acceleration.
#[derive(Debug, Clone)]
struct Previous {
    time: f64,
    path: Vec<f64>,
    path_velocity: Vec<f64>,
}

/// The shaft's speed is the measured positions' change over at least this long, seconds: a
/// tick's step between two readings 10 ms apart is 9 °/s on a 4096-tick servo, 4 % of the
/// STS3215's back-EMF share.
const SPEED_BASELINE_S: f64 = 0.04;

/// Watches every joint's load against what its motion needs, reading by reading.
#[derive(Debug, Clone)]
pub struct PushGuard {
    servos: Vec<JointServo>,
    /// The arm's inverse dynamics (`None`: no model; only overloads count).
    dynamics: Option<Dynamics>,
    /// By joint: pushes beyond the need, and overloads.
    pushes: Vec<Watch>,
    overloads: Vec<Watch>,
    previous: Option<Previous>,
    /// Recent (time, measured positions), the oldest first, spanning [`SPEED_BASELINE_S`].
    recent: std::collections::VecDeque<(f64, Vec<f64>)>,
    /// The control period, seconds: the path advances by one between cycles, so its rates
    /// are differences over it (the wall clock between readings jitters).
    period: f64,
    /// What the last reading needed, by joint (empty: nothing known).
    needed: Vec<f64>,
    /// By joint: caught pushing already (it is held, and not watched again).
    caught: Vec<bool>,
    /// By joint: held to an effort below full (a grasp): it pushes on what it holds by
    /// design, so only an overload counts.
    limited: Vec<bool>,
    /// By joint: pushes count from this time on (after a stall, or a change of its effort).
    judged_from: Vec<f64>,
}

impl PushGuard {
    /// The guard for `robot`, with each Feetech servo's Overload_Torque and Protection_Time
    /// read from `bus` (a bus that cannot read them leaves the factory values).
    pub fn new(bus: &mut dyn ServoBus, robot: &Robot, period: f64) -> Result<Self, BusError> {
        let thresholds = overload_thresholds(bus, robot)?;
        let seconds = overload_seconds(bus, robot)?;
        let servos = robot
            .joints
            .iter()
            .zip(thresholds.iter().zip(&seconds))
            .map(|(joint, (&overload_percent, &seconds))| {
                let spec = joint.servo.model.spec();
                JointServo {
                    overload_percent,
                    overload_window: 0.5 * seconds,
                    rating: joint
                        .servo
                        .drive()
                        .map(|d| (d.stall_torque.value, d.no_load_speed.value)),
                    measures_duty: spec.table.load_unit == LoadUnit::TenthPercent,
                    direction: joint.servo.direction,
                    at_goal: AT_GOAL_TICKS * joint.servo.units_per_tick,
                    limits: (joint.limits.velocity, joint.limits.acceleration),
                }
            })
            .collect::<Vec<_>>();
        let dynamics = match Dynamics::for_robot(robot) {
            Ok(dynamics) => Some(dynamics),
            Err(e) => {
                eprintln!("note: the push guard has no model of the arm ({e}): only a load at a servo's overload threshold counts");
                None
            }
        };
        Ok(PushGuard {
            pushes: vec![Watch::default(); servos.len()],
            overloads: vec![Watch::default(); servos.len()],
            servos,
            dynamics,
            previous: None,
            recent: std::collections::VecDeque::new(),
            period,
            needed: Vec::new(),
            caught: vec![false; robot.joints.len()],
            limited: vec![false; robot.joints.len()],
            judged_from: vec![f64::NEG_INFINITY; robot.joints.len()],
        })
    }

    /// One reading (see [`Reading`]). The first push or overload that has lasted its window
    /// over at least three readings is returned, once per joint.
    pub fn observe(&mut self, reading: &Reading) -> Option<Push> {
        let needed = self.needed(reading);
        self.needed.clear();
        self.needed.extend(needed.iter().flatten());
        let mut found = None;
        for j in 0..self.servos.len() {
            let need = needed.as_ref().map(|n| n[j]).filter(|n| n.is_finite());
            let caught = self.judge(j, reading, need);
            if let (None, Some(push)) = (&found, caught) {
                found = Some(push);
                self.caught[j] = true;
            }
        }
        found
    }

    /// Joint `j` at this reading, `need` being what its motion needs (percent): whether a push
    /// or an overload of it has lasted its window.
    fn judge(&mut self, j: usize, reading: &Reading, need: Option<f64>) -> Option<Push> {
        let servo = &self.servos[j];
        let (here, time) = (reading.measured[j], reading.time);
        let error = reading.goals[j] - here;
        let load = match (reading.loads[j], error.is_finite(), self.caught[j]) {
            (Some(load), true, false) => Some(load * servo.direction),
            _ => None,
        };
        // Towards a goal it is not at: a servo at its goal is not pushing on anything.
        let towards = load.filter(|&l| error.abs() >= servo.at_goal && l * error > 0.0);
        let judged = reading.free && !self.limited[j] && at_least(time, self.judged_from[j]);
        let line = CONTINUOUS_FRACTION * 100.0;
        let beyond_need = towards
            .filter(|&l| {
                need.is_some_and(|n| judged && l.abs() >= line && (l - n) * error.signum() >= line)
            })
            .map(|l| (l, need));
        let overloaded = towards
            .filter(|l| l.abs() >= servo.overload_percent)
            .map(|l| (l, need));
        let overload_window = servo.overload_window;
        let pushed = self.pushes[j].reading(time, beyond_need);
        let overloaded = self.overloads[j].reading(time, overloaded);
        let (watch, lasted) = match (pushed, overloaded) {
            (Some(lasted), _) if at_least(lasted, PUSH_WINDOW_S) => (&self.pushes[j], lasted),
            (_, Some(lasted)) if at_least(lasted, overload_window) => (&self.overloads[j], lasted),
            _ => return None,
        };
        Some(Push {
            joint: j,
            load_percent: watch.peak,
            needed_percent: watch.needed,
            lasted,
            hold_at: here,
        })
    }

    /// Each joint's overload threshold, percent of full output.
    pub fn thresholds(&self) -> Vec<f64> {
        self.servos.iter().map(|s| s.overload_percent).collect()
    }

    /// A stall that held the goal two periods or more ended at `time`: pushes are not judged
    /// for [`AFTER_STALL_S`] (overloads are).
    pub fn stalled(&mut self, time: f64) {
        for j in 0..self.pushes.len() {
            self.pause(j, time);
        }
    }

    /// Pushes of `joint` are not judged for [`AFTER_STALL_S`] from `time`.
    fn pause(&mut self, joint: usize, time: f64) {
        self.judged_from[joint] = time + AFTER_STALL_S;
        self.pushes[joint] = Watch::default();
    }

    /// Whether `joint` is held to an effort below full (a grasp), where it pushes by design,
    /// from `time` on; its pushes are not judged for [`AFTER_STALL_S`] after the change.
    pub fn set_limited(&mut self, joint: usize, limited: bool, time: f64) {
        self.limited[joint] = limited;
        self.pause(joint, time);
    }

    /// By joint, what the motion needed at the last reading, percent of full output in the
    /// joint's direction (NaN where not known; empty before a second reading, or without a
    /// model of the arm).
    pub fn needed_now(&self) -> &[f64] {
        &self.needed
    }

    /// The shaft's velocity, joint units per second, over the readings of the last
    /// [`SPEED_BASELINE_S`] (`None` until they span it).
    fn shaft_velocity(&mut self, time: f64, here: &[f64]) -> Option<Vec<f64>> {
        self.recent.push_back((time, here.to_vec()));
        while self
            .recent
            .get(1)
            .is_some_and(|(t, _)| time - t >= SPEED_BASELINE_S)
        {
            self.recent.pop_front();
        }
        let (then, before) = self.recent.front()?;
        let span = time - then;
        (span >= SPEED_BASELINE_S).then(|| {
            here.iter()
                .zip(before)
                .map(|(a, b)| (a - b) / span)
                .collect()
        })
    }

    /// By joint, the load the motion needs now, percent of full output in the joint's
    /// direction: the inverse dynamics at the measured pose (the path's where not measured)
    /// with the path's velocity and acceleration, plus the back-EMF share where the load is a
    /// duty. `None` without a model, or at the first reading.
    fn needed(&mut self, reading: &Reading) -> Option<Vec<f64>> {
        let Reading {
            time,
            path,
            cycles,
            measured,
            ..
        } = *reading;
        let previous = self.previous.take();
        let here: Vec<f64> = measured
            .iter()
            .zip(path)
            .map(|(&m, &p)| if m.is_finite() { m } else { p })
            .collect();
        let (velocity, acceleration) = match &previous {
            Some(before) if time > before.time && cycles > 0 => {
                let step = self.period * f64::from(cycles);
                let rate = |now: &[f64], then: &[f64]| -> Vec<f64> {
                    now.iter().zip(then).map(|(a, b)| (a - b) / step).collect()
                };
                let mut velocity = rate(path, &before.path);
                let mut acceleration = rate(&velocity, &before.path_velocity);
                for ((v, a), servo) in velocity.iter_mut().zip(&mut acceleration).zip(&self.servos)
                {
                    let (v_max, a_max) = servo.limits;
                    *v = v.clamp(-v_max, v_max);
                    *a = a.clamp(-a_max, a_max);
                }
                (velocity, acceleration)
            }
            _ => (vec![0.0; path.len()], vec![0.0; path.len()]),
        };
        self.previous = Some(Previous {
            time,
            path: path.to_vec(),
            path_velocity: velocity.clone(),
        });
        let shaft_velocity = self.shaft_velocity(time, &here);
        let dynamics = self.dynamics.as_ref()?;
        let shaft_velocity = shaft_velocity?;
        let torques = dynamics.servo_torques(&here, &velocity, &acceleration);
        let speeds = dynamics.servo_speeds(&shaft_velocity);
        Some(
            self.servos
                .iter()
                .zip(torques.iter().zip(&speeds))
                .map(|(servo, (&torque, &speed))| match servo.rating {
                    Some((stall, no_load)) => {
                        let back_emf = if servo.measures_duty {
                            speed / no_load
                        } else {
                            0.0
                        };
                        100.0 * (torque / stall + back_emf)
                    }
                    // Not rated: nothing is known to be needed beyond what it carries.
                    None => f64::NAN,
                })
                .collect(),
        )
    }
}

/// Each joint's overload threshold, percent of full output: its servo's Overload_Torque where
/// the model keeps it in a register, the firmware's own elsewhere.
pub(super) fn overload_thresholds(
    bus: &mut dyn ServoBus,
    robot: &Robot,
) -> Result<Vec<f64>, BusError> {
    let configured = configured(bus, robot, Setting::OverloadTorque)?;
    Ok(robot
        .joints
        .iter()
        .zip(configured)
        .map(|(joint, value)| {
            joint
                .servo
                .model
                .spec()
                .table
                .overload
                .threshold_percent(value)
        })
        .collect())
}

/// Each joint's overload protection time, seconds: its servo's Protection_Time where the model
/// keeps it in a register, the firmware's own elsewhere.
fn overload_seconds(bus: &mut dyn ServoBus, robot: &Robot) -> Result<Vec<f64>, BusError> {
    let configured = configured(bus, robot, Setting::ProtectionTime)?;
    Ok(robot
        .joints
        .iter()
        .zip(configured)
        .map(|(joint, value)| joint.servo.model.spec().table.overload.seconds(value))
        .collect())
}

/// Each joint's `setting` where its model has the register (`None` elsewhere, and where the
/// bus cannot read it: the factory value stands).
fn configured(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    setting: Setting,
) -> Result<Vec<Option<i64>>, BusError> {
    let mut values = vec![None; robot.joints.len()];
    let in_registers: Vec<usize> = (0..robot.joints.len())
        .filter(|&j| {
            setting
                .register(robot.joints[j].servo.model.spec().table)
                .is_some()
        })
        .collect();
    if in_registers.is_empty() {
        return Ok(values);
    }
    let ids: Vec<u8> = in_registers
        .iter()
        .map(|&j| robot.joints[j].servo.id)
        .collect();
    match bus.read_setting(&ids, setting) {
        Ok(read) => {
            for (&j, value) in in_registers.iter().zip(read) {
                values[j] = Some(value);
            }
        }
        // A bus that cannot reach the register (the vendor-SDK bridge, LeRobot's classes)
        // reads no load either: the guard is off there, and says so at the first read-back.
        Err(BusError::Unreachable { .. }) => {}
        Err(e) => return Err(e),
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SO-101 held still at its home pose, its pan 2° short of its goal and its servo
    /// reporting `pan_load` percent, read every 10 ms from 0 s while `free`: when (if ever)
    /// the guard catches the pan within `seconds`. The pan turns about the vertical: holding
    /// still, it carries no weight, so the motion needs 0 % of it.
    fn pan_caught(pan_load: f64, free: bool, seconds: f64) -> Option<(f64, Push)> {
        let robot = Robot::builtin("so101").unwrap();
        let mut arm = crate::teach::DrawnArm::new(&robot);
        let mut guard = PushGuard::new(&mut arm, &robot, 0.01).unwrap();
        let path = vec![0.0; robot.joints.len()];
        let mut goals = path.clone();
        goals[0] = 2.0;
        let mut loads = vec![Some(0.0); robot.joints.len()];
        loads[0] = Some(pan_load);
        for k in 0..=(seconds / 0.01).round() as u32 {
            let t = f64::from(k) * 0.01;
            let reading = Reading {
                time: t,
                path: &path,
                cycles: 1,
                goals: &goals,
                measured: &path,
                loads: &loads,
                free,
            };
            if let Some(push) = guard.observe(&reading) {
                return Some((t, push));
            }
        }
        None
    }

    #[test]
    fn the_guard_takes_each_servos_own_overload_settings_as_lerobot_leaves_them() {
        // LeRobot lowers the SO-101 gripper's Overload_Torque to 25 %; this one's protection
        // time is also set to 0.5 s (50 × 10 ms). Read over the real serial code from
        // emulated servos.
        let robot = Robot::builtin("so101").unwrap();
        let mut connection =
            crate::bus::connect(&robot, "virtual", crate::bus::Driver::Native, None).unwrap();
        {
            let server = connection.virtual_bus.as_ref().unwrap();
            let mut servos = server.bus().lock();
            let gripper = servos.servo_mut(6).unwrap();
            gripper.set("Overload_Torque", 25).unwrap();
            gripper.set("Protection_Time", 50).unwrap();
        }
        let guard = PushGuard::new(connection.bus.as_mut(), &robot, 0.01).unwrap();
        assert_eq!(guard.thresholds(), [80.0, 80.0, 80.0, 80.0, 80.0, 25.0]);
        let windows: Vec<f64> = guard.servos.iter().map(|s| s.overload_window).collect();
        // Half of each protection time: the factory 2 s, the gripper's 0.5 s.
        assert_eq!(windows, [1.0, 1.0, 1.0, 1.0, 1.0, 0.25]);
    }

    #[test]
    fn a_push_past_the_need_by_a_fifth_of_stall_is_caught_after_the_window() {
        let (at, push) = pan_caught(25.0, true, 1.0).expect("caught");
        // Readings from 0 s; the need is known from the second reading (10 ms) on, when the
        // shaft's speed is, 40 ms on: the push counts from 0.04 s and lasts the window.
        assert!((at - (0.04 + PUSH_WINDOW_S)).abs() < 1e-9, "caught at {at}");
        assert_eq!(push.joint, 0);
        assert_eq!(push.load_percent, 25.0);
        assert!(push.needed_percent.unwrap().abs() < 1e-9, "{push:?}");
        assert_eq!(push.hold_at, 0.0);
    }

    #[test]
    fn a_load_within_a_fifth_of_stall_of_the_need_is_no_push() {
        assert_eq!(pan_caught(19.0, true, 5.0), None);
        // Away from the goal (the servo is being pushed, it is not pushing): no push either.
        assert_eq!(pan_caught(-60.0, true, 5.0), None);
    }

    #[test]
    fn during_the_approach_only_an_overload_counts_and_only_for_half_the_protection_time() {
        assert_eq!(pan_caught(60.0, false, 5.0), None);
        // The STS3215's factory overload: 80 % for 2 s; caught after half of it.
        let (at, push) = pan_caught(85.0, false, 5.0).expect("caught");
        assert!((at - 1.0).abs() < 1e-9, "caught at {at}");
        assert_eq!(push.load_percent, 85.0);
    }
}
