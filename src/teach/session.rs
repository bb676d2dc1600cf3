//! Carries out the state machine's [`BusCommand`]s on a [`ServoBus`] and reports [`Event`]s.
//!
//! Every motion — `space` (move to a key), `y` (play) and every jog — runs [`player::play`]
//! (the same approach ramp, pacing, step limiter, limit guard, fault handling and braking stop
//! as `keypose play`) on a thread that owns the bus for the motion's duration; a jog drives
//! only its joints ([`crate::robot::Robot::only`]). The UI thread keeps reading keys
//! meanwhile, so `y`/`Esc` raise the player's [`StopSignal`] within a control period whatever
//! was queued (once: decelerate along the path; twice: hold at once), and so can any thread
//! through the session's [`Brake`]. The bus comes back with the thread's result. While the
//! thread has it, the present pose shown is what the player itself read back, passed through
//! a thin wrapper around the bus, so there is never a second user of the port. A playback
//! (`y`) also says where it is, cycle by cycle, through the session's [`player::Playhead`].

use super::capture::tidy;
use super::messages::{BusCommand, Event};
use super::motion::MotionPlan;
use crate::bus::{BusError, ServoBus};
use crate::error::ErrorKind;
use crate::player::{self, Outcome, PlayError, StopSignal};
use crate::robot::{Robot, TickError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Poll period while waiting for the arm to settle.
const SETTLE_POLL: Duration = Duration::from_millis(10);
/// Readings in a row that must agree before a joint that has not reached its goal tick counts
/// as settled (a loaded real servo may rest a tick or two off its goal).
const SETTLE_STABLE_READS: u32 = 8;

/// What the motion thread observed, shared with the UI thread: per joint of the session's
/// robot (a jog reads and writes its own joints only; the others keep what was known).
#[derive(Debug, Default)]
struct Observed {
    ticks: Vec<i64>,
    goals: Vec<Option<i64>>,
}

fn lock<T>(shared: &Mutex<T>) -> MutexGuard<'_, T> {
    // A poisoned lock only means the motion thread panicked mid-update; the data is still the
    // best there is, and the panic itself is reported when the thread is joined.
    shared.lock().unwrap_or_else(|e| e.into_inner())
}

/// The bus as the player uses it, recording what it reads and writes for the screen.
struct ObservedBus {
    inner: Box<dyn ServoBus>,
    /// The session's servo ids, in joint order.
    ids: Vec<u8>,
    shared: Arc<Mutex<Observed>>,
}

impl ObservedBus {
    /// The session's joint index of each servo in `ids`.
    /// Keeps the positions just read, for the session's screen.
    fn observe(&self, ids: &[u8], ticks: impl Iterator<Item = i64>) {
        let mut observed = lock(&self.shared);
        for (joint, tick) in self.joints(ids).zip(ticks) {
            if let Some(slot) = joint.and_then(|j| observed.ticks.get_mut(j)) {
                *slot = tick;
            }
        }
    }

    fn joints<'a>(&'a self, ids: &'a [u8]) -> impl Iterator<Item = Option<usize>> + 'a {
        ids.iter()
            .map(|id| self.ids.iter().position(|own| own == id))
    }
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
        self.observe(ids, ticks.iter().copied());
        Ok(ticks)
    }
    fn read_positions_loads(
        &mut self,
        ids: &[u8],
    ) -> Result<Vec<crate::bus::PositionLoad>, BusError> {
        let read = self.inner.read_positions_loads(ids)?;
        self.observe(ids, read.iter().map(|r| r.position));
        Ok(read)
    }
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        self.inner.write_goals(goals)?;
        let ids: Vec<u8> = goals.iter().map(|&(id, _)| id).collect();
        let mut observed = lock(&self.shared);
        for (joint, &(_, tick)) in self.joints(&ids).zip(goals) {
            if let Some(slot) = joint.and_then(|j| observed.goals.get_mut(j)) {
                *slot = Some(tick);
            }
        }
        Ok(())
    }
    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        self.inner.set_torque(ids, on)
    }
    fn pace(&mut self, period: Option<std::time::Duration>) {
        self.inner.pace(period)
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
        setting: crate::servo::Setting,
    ) -> Result<Vec<i64>, BusError> {
        self.inner.read_setting(ids, setting)
    }
    fn write_setting(
        &mut self,
        values: &[(u8, i64)],
        setting: crate::servo::Setting,
    ) -> Result<(), BusError> {
        self.inner.write_setting(values, setting)
    }
}

/// The bus back, and how the motion ended with the player's warnings (stalls: it ran late).
type MotionResult = (Box<dyn ServoBus>, Result<(Outcome, Vec<String>), PlayError>);

struct RunningMotion {
    stop: StopSignal,
    /// The joints the player drives (robot order).
    joints: Vec<usize>,
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

/// Why a bus command of the session (or a read of the pose) failed; its words become an
/// [`Event::BusError`].
#[derive(Debug, thiserror::Error)]
pub enum BusCommandError {
    /// The bus failed.
    #[error(transparent)]
    Bus(#[from] BusError),
    /// The bus went with a motion thread that could not be started.
    #[error("the bus is lost: restart keypose teach")]
    NoBus,
    /// A motion was asked for while one runs (the state refuses that before it gets here).
    #[error("the arm is already moving")]
    Moving,
    /// A joint's goal that has no tick.
    #[error("joint {joint}: cannot hold: {error}")]
    Unholdable {
        /// The joint's name.
        joint: String,
        /// Why its value has no goal tick.
        error: TickError,
    },
    /// The system refused a thread for the motion.
    #[error("cannot start the motion thread: {error}")]
    NoThread {
        /// What the system said.
        error: std::io::Error,
    },
}

impl BusCommandError {
    /// What kind of failure this is: the bus's own, or the hardware's.
    pub fn kind(&self) -> ErrorKind {
        match self {
            BusCommandError::Bus(e) => e.kind(),
            _ => ErrorKind::Hardware,
        }
    }
}

/// Why a motion of the session ended in a fault: the player's error, its source ([`Report`]
/// says both), shared so that the [`Event::MotionEnded`] that carries it can be cloned.
///
/// [`Report`]: crate::error::Report
#[derive(Debug, Clone, thiserror::Error)]
#[error("motion stopped")]
pub struct MotionError(#[source] pub Arc<PlayError>);

/// Two failures are equal when they say the same (a player's error has no equality of its own).
impl PartialEq for MotionError {
    fn eq(&self, other: &Self) -> bool {
        crate::error::Report(self).to_string() == crate::error::Report(other).to_string()
    }
}

/// Brakes whatever motion the session runs, from any thread (the studio's HTTP threads, a
/// signal handler) without waiting for the thread that carries out the keys: the first stop
/// request of the running motion, decelerating along its path; nothing when the arm is idle
/// or a stop is under way. The state's own stop request that follows is the same request
/// ([`StopSignal::request_to`]), so it is never counted twice.
#[derive(Debug, Clone, Default)]
pub struct Brake(Arc<Mutex<Option<StopSignal>>>);

impl Brake {
    /// Asks the running motion, if any, to decelerate along its path (its first stop request).
    pub fn soft_stop(&self) {
        if let Some(stop) = lock(&self.0).as_ref() {
            stop.soft_stop();
        }
    }

    /// Waits until no motion plays (the player has returned), for at most `longest`.
    pub fn wait_until_at_rest(&self, longest: Duration) {
        let give_up = Instant::now() + longest;
        while lock(&self.0).is_some() && Instant::now() < give_up {
            std::thread::sleep(SETTLE_POLL);
        }
    }

    fn set(&self, running: Option<StopSignal>) {
        *lock(&self.0) = running;
    }
}

/// The session's hold on the servos: carries out the state's [`BusCommand`]s, runs motions on
/// the player's thread and reads the present pose.
pub struct Session {
    robot: Robot,
    ids: Vec<u8>,
    description: String,
    /// `None` while a motion thread has it.
    bus: Option<Box<dyn ServoBus>>,
    motion: Option<RunningMotion>,
    brake: Brake,
    /// Where a playback (`y`) is while it plays; cleared when it ends.
    playhead: player::Playhead,
    torque: Vec<bool>,
    /// Last goal sent to each joint, for settling.
    goal_ticks: Vec<Option<i64>>,
    /// The user's stall bound, seconds: every motion tolerates a stall at least this long.
    max_stall: Option<f64>,
}

impl Session {
    /// A session of `robot` on `bus`, every joint's torque taken as off until a hold.
    pub fn new(bus: Box<dyn ServoBus>, robot: &Robot) -> Session {
        let n = robot.joints.len();
        Session {
            ids: robot.joints.iter().map(|j| j.servo.id).collect(),
            description: bus.describe(),
            robot: robot.clone(),
            bus: Some(bus),
            motion: None,
            brake: Brake::default(),
            playhead: player::Playhead::default(),
            torque: vec![false; n],
            goal_ticks: vec![None; n],
            max_stall: None,
        }
    }

    /// The session with every motion tolerating a stall of at least `seconds` (`None`: each
    /// motion's own bound, [`crate::player::PlayOptions`]'s default for a playback).
    pub fn with_max_stall(mut self, seconds: Option<f64>) -> Session {
        self.max_stall = seconds;
        self
    }

    /// A session without servos: the arm is drawn only ([`super::DrawnArm`]), at the robot's
    /// home pose, and every command is carried out as on an arm, with nothing sent anywhere.
    pub fn drawn(robot: &Robot) -> Session {
        Session::new(Box::new(super::drawn::DrawnArm::new(robot)), robot)
    }

    /// The session's brake, for threads other than the one carrying out its commands.
    pub fn brake(&self) -> Brake {
        self.brake.clone()
    }

    /// Where the running playback is (the sequence time, the commanded pose), for the
    /// studio's timeline; empty while no playback runs. A handle: it follows every playback.
    pub fn playhead(&self) -> player::Playhead {
        self.playhead.clone()
    }

    /// The bus as it describes itself (port, driver), for the screen.
    pub fn describe(&self) -> &str {
        &self.description
    }

    /// A motion thread runs (it has the bus).
    pub fn is_moving(&self) -> bool {
        self.motion.is_some()
    }

    /// The present pose: read from the bus, or while a motion runs, what the player last read.
    pub fn read(&mut self) -> Result<Option<Vec<f64>>, BusCommandError> {
        if let Some(motion) = &self.motion {
            return Ok(Some(self.values(&lock(&motion.shared).ticks)));
        }
        let ids = self.ids.clone();
        let ticks = self.bus_mut()?.read_positions(&ids)?;
        Ok(Some(self.values(&ticks)))
    }

    fn values(&self, ticks: &[i64]) -> Vec<f64> {
        self.robot.values_of(ticks)
    }

    fn bus_mut(&mut self) -> Result<&mut Box<dyn ServoBus>, BusCommandError> {
        // The state refuses bus commands while a motion has the bus, so the bus is missing
        // here only when a motion thread could not be started with it.
        self.bus.as_mut().ok_or(BusCommandError::NoBus)
    }

    /// Carries out one command; failures come back as [`Event::BusError`].
    pub fn execute(&mut self, command: BusCommand) -> Vec<Event> {
        let result = match command {
            BusCommand::Torque { joints, on: true } => self.hold(joints),
            BusCommand::Torque { joints, on: false } => self.release(joints),
            BusCommand::Run(plan) => self.run(*plan),
            BusCommand::Stop { requests } => {
                if let Some(motion) = &self.motion {
                    motion.stop.request_to(requests);
                }
                Ok(Vec::new())
            }
            BusCommand::Reverse { joint } => {
                // Only the mapping turns: the ticks on the servos stay, and the next reading
                // says the value they stand for now.
                if let Some(servo) = self.robot.joints.get_mut(joint).map(|j| &mut j.servo) {
                    servo.direction = -servo.direction;
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
    fn hold(&mut self, joints: Vec<usize>) -> Result<Vec<Event>, BusCommandError> {
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
            let goal = joint
                .goal_tick(value)
                .map_err(|error| BusCommandError::Unholdable {
                    joint: joint.name.clone(),
                    error,
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

    fn release(&mut self, joints: Vec<usize>) -> Result<Vec<Event>, BusCommandError> {
        let ids: Vec<u8> = joints.iter().map(|&j| self.ids[j]).collect();
        self.bus_mut()?.set_torque(&ids, false)?;
        for &j in &joints {
            self.torque[j] = false;
            self.goal_ticks[j] = None;
        }
        Ok(vec![Event::Released { joints }])
    }

    fn run(&mut self, plan: MotionPlan) -> Result<Vec<Event>, BusCommandError> {
        if self.motion.is_some() {
            return Err(BusCommandError::Moving);
        }
        // What the screen shows of the joints the motion does not drive: where they are now.
        let ids = self.ids.clone();
        let ticks = self.bus_mut()?.read_positions(&ids)?;
        let inner = self.bus.take().ok_or(BusCommandError::NoBus)?;
        let shared = Arc::new(Mutex::new(Observed {
            ticks,
            goals: self.goal_ticks.clone(),
        }));
        let stop = StopSignal::default();
        let MotionPlan {
            kind,
            robot,
            joints,
            trajectory,
            mut options,
            end_pose,
        } = plan;
        if matches!(kind, super::MotionKind::Play { .. }) {
            options.playhead = Some(self.playhead.clone());
        }
        if let Some(bound) = self.max_stall {
            options.max_stall = options.max_stall.max(bound);
        }
        let thread_stop = stop.clone();
        let brake = self.brake.clone();
        // Armed before the thread starts, which disarms it when the player returns.
        self.brake.set(Some(stop.clone()));
        let mut bus = ObservedBus {
            inner,
            ids,
            shared: shared.clone(),
        };
        let handle = std::thread::Builder::new()
            .name("keypose-teach-motion".into())
            .spawn(move || {
                let result = player::play(&mut bus, &robot, &trajectory, &options, &thread_stop)
                    .map(|(outcome, stats)| (outcome, stats.warnings()));
                // At rest (or given up on): nothing more for the brake to stop.
                brake.set(None);
                (bus.inner, result)
            });
        let handle = match handle {
            Ok(handle) => handle,
            Err(error) => {
                // The closure (and the bus in it) is gone with the failed spawn.
                self.brake.set(None);
                return Err(BusCommandError::NoThread { error });
            }
        };
        self.motion = Some(RunningMotion {
            stop,
            joints: joints.clone(),
            shared,
            handle,
        });
        Ok(vec![Event::MotionStarted {
            kind,
            end_pose,
            joints,
        }])
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
        self.brake.set(None);
        self.playhead.clear();
        let (bus, result) = motion
            .handle
            .join()
            .map_err(|panic| SessionError::BusLost(panic_message(panic.as_ref())))?;
        self.bus = Some(bus);
        let observed = lock(&motion.shared);
        // The player turned torque on for the joints it drives; its last goals are what those
        // servos hold.
        for &j in &motion.joints {
            self.torque[j] = true;
            self.goal_ticks[j] = observed.goals[j];
        }
        let last_goals = self
            .goal_ticks
            .iter()
            .zip(&observed.ticks)
            .zip(&self.robot.joints)
            .map(|((goal, &present), joint)| joint.servo.value(goal.unwrap_or(present)))
            .collect();
        let (outcome, warnings) = match result {
            Ok((outcome, warnings)) => (Ok(outcome), warnings),
            Err(e) => (Err(MotionError(Arc::new(e))), Vec::new()),
        };
        Ok(Event::MotionEnded {
            outcome,
            last_goals: Some(last_goals),
            warnings,
        })
    }

    /// Waits until every held joint reads its goal tick (or its reading stays put), for at
    /// most `timeout`; false when it ran out. Script steps use this so that a capture after a
    /// jog sees where the jog went, whatever the machine's speed.
    pub fn settle(&mut self, timeout: Duration) -> Result<bool, BusCommandError> {
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

/// What a thread's panic said (its payload is a message for every `panic!` with one).
pub(crate) fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "panic".into())
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
