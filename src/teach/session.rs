//! Carries out the state machine's [`BusCommand`]s on a [`ServoBus`] and reports [`Event`]s.
//!
//! Playback inside the session: `space` (move to a key) and `y` (play) both run
//! [`player::play`] — the same approach ramp, pacing, limit guard, fault handling and braking
//! stop as `keypose play` — on a thread that owns the bus for the motion's duration. The UI
//! thread keeps reading keys meanwhile; `y`/`Esc` raise the player's [`StopSignal`] (once:
//! decelerate along the path; twice: hold at once). The bus comes back with the thread's
//! result. While the thread has it, the present pose shown is what the player itself read back,
//! passed through a thin wrapper around the bus, so there is never a second user of the port.

use super::capture::tidy;
use super::messages::{BusCommand, Event};
use super::motion::MotionPlan;
use crate::bus::{BusError, ServoBus};
use crate::pacing::{Pacer, WallClock};
use crate::plan::Approach;
use crate::player::{self, Outcome, PlayError, StopSignal};
use crate::robot::Robot;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Poll period while waiting for the arm to settle.
const SETTLE_POLL: Duration = Duration::from_millis(10);
/// Readings in a row that must agree before a joint that has not reached its goal tick counts
/// as settled (a loaded real servo may rest a tick or two off its goal).
const SETTLE_STABLE_READS: u32 = 8;

/// What the motion thread observed, shared with the UI thread.
#[derive(Debug, Default)]
struct Observed {
    ticks: Option<Vec<i64>>,
    goals: Option<Vec<(u8, i64)>>,
}

fn lock(shared: &Mutex<Observed>) -> MutexGuard<'_, Observed> {
    // A poisoned lock only means the motion thread panicked mid-update; the data is still the
    // best there is, and the panic itself is reported when the thread is joined.
    shared.lock().unwrap_or_else(|e| e.into_inner())
}

/// The bus as the player uses it, recording what it reads and writes for the screen.
struct ObservedBus {
    inner: Box<dyn ServoBus>,
    ids: Vec<u8>,
    shared: Arc<Mutex<Observed>>,
}

impl ServoBus for ObservedBus {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn ping(&mut self, id: u8) -> Result<crate::bus::PingInfo, BusError> {
        self.inner.ping(id)
    }
    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        let ticks = self.inner.read_positions(ids)?;
        if ids == self.ids.as_slice() {
            lock(&self.shared).ticks = Some(ticks.clone());
        }
        Ok(ticks)
    }
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        self.inner.write_goals(goals)?;
        if goals.len() == self.ids.len() {
            lock(&self.shared).goals = Some(goals.to_vec());
        }
        Ok(())
    }
    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        self.inner.set_torque(ids, on)
    }
    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<crate::bus::Health>, BusError> {
        self.inner.read_health(ids)
    }
    fn read_homing_offsets(
        &mut self,
        servos: &[(u8, crate::robot::ServoModel)],
    ) -> Result<Vec<i64>, BusError> {
        self.inner.read_homing_offsets(servos)
    }
    fn read_setting(
        &mut self,
        ids: &[u8],
        setting: crate::bus::profile::Setting,
    ) -> Result<Vec<i64>, BusError> {
        self.inner.read_setting(ids, setting)
    }
    fn write_setting(
        &mut self,
        values: &[(u8, i64)],
        setting: crate::bus::profile::Setting,
    ) -> Result<(), BusError> {
        self.inner.write_setting(values, setting)
    }
}

type MotionResult = (Box<dyn ServoBus>, Result<Outcome, PlayError>);

struct RunningMotion {
    stop: StopSignal,
    shared: Arc<Mutex<Observed>>,
    handle: JoinHandle<MotionResult>,
}

/// A session's hold on the servos.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The motion thread died with the bus: nothing can be sent any more.
    #[error("the playback thread failed ({0}); the bus is lost: restart keypose teach (your edits are in the journal)")]
    BusLost(String),
}

/// Told the present pose while a jog ramps (the studio's 3D view follows the arm).
pub type PoseObserver = Box<dyn FnMut(&[f64]) + Send>;

/// While a jog ramps with an observer, the arm is read every this many control cycles (every
/// 20 ms at 100 Hz): a small share of the bus, often enough to watch.
const JOG_READ_EVERY: usize = 2;

pub struct Session {
    robot: Robot,
    /// Told the present pose during jogs, when a front end asks.
    observer: Option<PoseObserver>,
    ids: Vec<u8>,
    description: String,
    /// `None` while a motion thread has it.
    bus: Option<Box<dyn ServoBus>>,
    motion: Option<RunningMotion>,
    torque: Vec<bool>,
    /// Last goal sent to each joint, for settling.
    goal_ticks: Vec<Option<i64>>,
}

impl Session {
    pub fn new(bus: Box<dyn ServoBus>, robot: &Robot) -> Session {
        let n = robot.joints.len();
        Session {
            ids: robot.joints.iter().map(|j| j.servo.id).collect(),
            description: bus.describe(),
            robot: robot.clone(),
            observer: None,
            bus: Some(bus),
            motion: None,
            torque: vec![false; n],
            goal_ticks: vec![None; n],
        }
    }

    /// From now on, `observer` hears the present pose while a jog ramps (the terminal needs
    /// none: it redraws once the jog is done).
    pub fn observe_jogs(&mut self, observer: PoseObserver) {
        self.observer = Some(observer);
    }

    /// Reads the arm for the observer, if there is one; a failed read is skipped (the next
    /// one, or the session's own reading after the jog, shows the pose).
    fn tell_observer(&mut self) {
        let (Some(observer), Some(bus)) = (self.observer.as_mut(), self.bus.as_mut()) else {
            return;
        };
        if let Ok(ticks) = bus.read_positions(&self.ids) {
            observer(&self.robot.values_of(&ticks));
        }
    }

    pub fn describe(&self) -> &str {
        &self.description
    }

    pub fn is_moving(&self) -> bool {
        self.motion.is_some()
    }

    /// The present pose: read from the bus, or while a motion runs, what the player last read.
    pub fn read(&mut self) -> Result<Option<Vec<f64>>, BusError> {
        if let Some(motion) = &self.motion {
            return Ok(lock(&motion.shared).ticks.as_ref().map(|t| self.values(t)));
        }
        let ids = self.ids.clone();
        let ticks = self.bus_mut()?.read_positions(&ids)?;
        Ok(Some(self.values(&ticks)))
    }

    fn values(&self, ticks: &[i64]) -> Vec<f64> {
        self.robot.values_of(ticks)
    }

    fn bus_mut(&mut self) -> Result<&mut Box<dyn ServoBus>, BusError> {
        // The state refuses bus commands while a motion has the bus, so the bus is missing
        // here only when a motion thread could not be started with it.
        self.bus
            .as_mut()
            .ok_or_else(|| BusError::Protocol("the bus is lost: restart keypose teach".into()))
    }

    /// Carries out one command; failures come back as [`Event::BusError`].
    pub fn execute(&mut self, command: BusCommand) -> Vec<Event> {
        let result = match command {
            BusCommand::Torque { joints, on: true } => self.hold(joints),
            BusCommand::Torque { joints, on: false } => self.release(joints),
            BusCommand::Goals(goals) => self.send_goals(goals),
            BusCommand::Run(plan) => self.run(*plan),
            BusCommand::Stop => {
                if let Some(motion) = &self.motion {
                    motion.stop.request();
                }
                Ok(Vec::new())
            }
        };
        result.unwrap_or_else(|e| vec![Event::BusError(e.to_string())])
    }

    /// Torque on without a jump: the goal is set to where each joint is (rounded as a captured
    /// value is, within a tick) before torque comes on.
    /// Torque on where the joints are (rounded, inside the limits). A joint pushed further past
    /// a limit than the player's start slack is left as it is: holding it would need a goal
    /// outside the limits, and pulling it inside at once would be a jump.
    fn hold(&mut self, joints: Vec<usize>) -> Result<Vec<Event>, BusError> {
        let ids: Vec<u8> = joints.iter().map(|&j| self.ids[j]).collect();
        let ticks = self.bus_mut()?.read_positions(&ids)?;
        let (mut held, mut values, mut goals, mut outside) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (&j, &tick) in joints.iter().zip(&ticks) {
            let joint = &self.robot.joints[j];
            let Some(value) = joint.hold_value(joint.servo.value(tick)) else {
                outside.push(joint.name.as_str());
                continue;
            };
            let value = tidy(joint, value);
            let goal = joint.goal_tick(value).map_err(|e| {
                BusError::Protocol(format!("joint {}: cannot hold: {e}", joint.name))
            })?;
            held.push(j);
            values.push(value);
            goals.push((joint.servo.id, goal));
        }
        let mut events = Vec::new();
        if !outside.is_empty() {
            events.push(Event::BusError(format!(
                "{} past the limits: left as is; move inside by hand, then t",
                outside.join(", ")
            )));
        }
        if held.is_empty() {
            return Ok(events);
        }
        let held_ids: Vec<u8> = goals.iter().map(|&(id, _)| id).collect();
        let bus = self.bus_mut()?;
        bus.write_goals(&goals)?;
        bus.set_torque(&held_ids, true)?;
        for (&j, &(_, goal)) in held.iter().zip(&goals) {
            self.torque[j] = true;
            self.goal_ticks[j] = Some(goal);
        }
        events.insert(
            0,
            Event::Held {
                joints: held,
                values,
            },
        );
        Ok(events)
    }

    fn release(&mut self, joints: Vec<usize>) -> Result<Vec<Event>, BusError> {
        let ids: Vec<u8> = joints.iter().map(|&j| self.ids[j]).collect();
        self.bus_mut()?.set_torque(&ids, false)?;
        for &j in &joints {
            self.torque[j] = false;
            self.goal_ticks[j] = None;
        }
        Ok(vec![Event::Released { joints }])
    }

    /// Moves the joints to new goals (a jog) along a minimum-jerk ramp at the control rate,
    /// from the goals they hold, within half their velocity and acceleration limits: a jog of
    /// 10° written at once would be a jump at the servo's top speed.
    fn send_goals(&mut self, goals: Vec<(usize, f64)>) -> Result<Vec<Event>, BusError> {
        let ramp = self.jog_ramp(&goals)?;
        let period = 1.0 / self.robot.control_hz;
        let clock = WallClock::new();
        let mut pacer = Pacer::new(&clock, period);
        let mut pose = vec![0.0; self.robot.joints.len()];
        let mut ticks = Vec::with_capacity(goals.len());
        let never = StopSignal::default();
        for k in 1.. {
            pacer.wait(&clock, &never, 0);
            let t = (k as f64 * period).min(ramp.duration);
            ramp.sample_into(t, &mut pose);
            ticks.clear();
            for &(j, _) in &goals {
                ticks.push((self.ids[j], self.goal_tick(j, pose[j])?));
            }
            self.bus_mut()?.write_goals(&ticks)?;
            if t >= ramp.duration {
                break;
            }
            if k % JOG_READ_EVERY == 0 {
                self.tell_observer();
            }
        }
        for (&(j, _), &(_, tick)) in goals.iter().zip(&ticks) {
            self.goal_ticks[j] = Some(tick);
        }
        Ok(vec![Event::GoalsSent(goals)])
    }

    /// The ramp from each jogged joint's present goal to its new one; the other joints stay.
    fn jog_ramp(&self, goals: &[(usize, f64)]) -> Result<Approach, BusError> {
        let mut from: Vec<f64> = self
            .goal_ticks
            .iter()
            .zip(&self.robot.joints)
            .map(|(tick, joint)| tick.map_or(0.0, |t| joint.servo.value(t)))
            .collect();
        let mut to = from.clone();
        for &(j, value) in goals {
            // The state clamps jogs; this is the last line before the wire, as in the player.
            self.goal_tick(j, value)?;
            match self.goal_ticks[j] {
                Some(tick) => from[j] = self.robot.joints[j].servo.value(tick),
                // No goal held (not expected: jogging needs torque on): start at the target,
                // which the ramp then holds.
                None => from[j] = value,
            }
            to[j] = value;
        }
        Ok(Approach::at_least(&self.robot, &from, &to, 0.0))
    }

    fn goal_tick(&self, j: usize, value: f64) -> Result<i64, BusError> {
        let joint = &self.robot.joints[j];
        joint.goal_tick(value).map_err(|e| {
            BusError::Protocol(format!(
                "refusing to send joint {}: {e} (nothing was sent)",
                joint.name
            ))
        })
    }

    fn run(&mut self, plan: MotionPlan) -> Result<Vec<Event>, BusError> {
        if self.motion.is_some() {
            return Err(BusError::Protocol("the arm is already moving".into()));
        }
        let inner = self
            .bus
            .take()
            .ok_or_else(|| BusError::Protocol("the bus is lost: restart keypose teach".into()))?;
        let shared = Arc::new(Mutex::new(Observed::default()));
        let stop = StopSignal::default();
        let MotionPlan {
            kind,
            trajectory,
            options,
            end_pose,
        } = plan;
        let robot = self.robot.clone();
        let thread_stop = stop.clone();
        let mut bus = ObservedBus {
            inner,
            ids: self.ids.clone(),
            shared: shared.clone(),
        };
        let handle = std::thread::Builder::new()
            .name("keypose-teach-motion".into())
            .spawn(move || {
                let result = player::play(&mut bus, &robot, &trajectory, &options, &thread_stop)
                    .map(|(outcome, _)| outcome);
                (bus.inner, result)
            })
            .map_err(|e| BusError::Protocol(format!("cannot start the motion thread: {e}")))?;
        self.motion = Some(RunningMotion {
            stop,
            shared,
            handle,
        });
        Ok(vec![Event::MotionStarted { kind, end_pose }])
    }

    /// The end of a finished motion, if it has finished; never blocks.
    pub fn poll(&mut self) -> Result<Option<Event>, SessionError> {
        match &self.motion {
            Some(motion) if motion.handle.is_finished() => self.join().map(Some),
            _ => Ok(None),
        }
    }

    /// Waits for the running motion to end (script mode runs one step at a time).
    pub fn wait_motion(&mut self) -> Result<Option<Event>, SessionError> {
        if self.motion.is_some() {
            self.join().map(Some)
        } else {
            Ok(None)
        }
    }

    fn join(&mut self) -> Result<Event, SessionError> {
        let Some(motion) = self.motion.take() else {
            return Err(SessionError::BusLost("no motion".into()));
        };
        let (bus, result) = motion.handle.join().map_err(|panic| {
            let message = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into());
            SessionError::BusLost(message)
        })?;
        self.bus = Some(bus);
        // The player turned torque on everywhere; its last goals are what the servos hold.
        self.torque.iter_mut().for_each(|t| *t = true);
        let observed = lock(&motion.shared);
        let last_goals = observed.goals.as_ref().map(|goals| {
            for (slot, &(_, tick)) in self.goal_ticks.iter_mut().zip(goals) {
                *slot = Some(tick);
            }
            self.values(&goals.iter().map(|&(_, t)| t).collect::<Vec<_>>())
        });
        let outcome = result.map_err(|e| format!("motion stopped: {e}"));
        Ok(Event::MotionEnded {
            outcome,
            last_goals,
        })
    }

    /// Waits until every held joint reads its goal tick (or its reading stays put), for at
    /// most `timeout`; false when it ran out. Script steps use this so that a capture after a
    /// jog sees where the jog went, whatever the machine's speed.
    pub fn settle(&mut self, timeout: Duration) -> Result<bool, BusError> {
        let give_up = Instant::now() + timeout;
        let mut previous: Option<Vec<i64>> = None;
        let mut stable = 0;
        loop {
            let ids = self.ids.clone();
            let ticks = self.bus_mut()?.read_positions(&ids)?;
            let reached = ticks
                .iter()
                .zip(&self.goal_ticks)
                .zip(&self.torque)
                .all(|((&tick, goal), &on)| !on || goal.is_none_or(|g| g == tick));
            if reached {
                return Ok(true);
            }
            stable = if previous.as_ref() == Some(&ticks) {
                stable + 1
            } else {
                0
            };
            if stable >= SETTLE_STABLE_READS {
                return Ok(true);
            }
            if Instant::now() >= give_up {
                return Ok(false);
            }
            previous = Some(ticks);
            std::thread::sleep(SETTLE_POLL);
        }
    }
}

impl Drop for Session {
    /// A session that ends with the arm moving (an error in the UI) holds it at once rather
    /// than leave a thread streaming with nobody watching.
    fn drop(&mut self) {
        if let Some(motion) = self.motion.take() {
            motion.stop.request();
            motion.stop.request();
            let _ = motion.handle.join();
        }
    }
}
