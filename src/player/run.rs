//! One playback, step by step: start (measure, hold, torque on), then one cycle per control
//! period (pace, stalls, stop requests, the commanded pose through the limiter and the guard,
//! read-back, health, log), then finish (summary, release).

use super::effort::Efforts;
use super::log::{PlaybackLog, Row};
use super::push::{Push, PushGuard, Reading};
use super::{
    clamp_start, measured_pose, print_progress, release_when_reached, GoalGuard, Outcome,
    PlayError, PlayOptions, Stats, StepLimiter, HOT_MARGIN_C,
};
use crate::bus::{alarm_error, faulty_joint, BusError, Health, PositionLoad, ReadStreak, ServoBus};
use crate::pacing::{followed_share, is_stall, Clock, CycleStart, KeepUp, Pacer};
use crate::plan::{Phase, Timeline, Trajectory};
use crate::robot::Robot;
use crate::stop::StopSignal;
use std::time::{Duration, Instant};

/// How often the progress line is redrawn.
const PROGRESS_EVERY: Duration = Duration::from_millis(100);

pub(super) struct Run<'a> {
    bus: &'a mut dyn ServoBus,
    robot: &'a Robot,
    trajectory: &'a Trajectory,
    options: &'a PlayOptions,
    /// The servos still served, in joint order: all of them, unless an arm of a cell was
    /// isolated after a fault.
    ids: Vec<u8>,
    /// By joint: its arm's bus was isolated after a fault, so it is neither written nor read.
    lost: Vec<bool>,
    guard: GoalGuard<'a>,
    timeline: Timeline<'a>,
    pacer: Pacer,
    /// Whether stalls leave the path time to come back up to speed (None: not judged).
    keep_up: Option<KeepUp>,
    limiter: StepLimiter,
    log: Option<PlaybackLog>,
    stats: Stats,
    period: f64,
    /// Clock time playback began, seconds.
    t0: f64,
    /// Where the arm should be this cycle: the timeline's pose, through the step limiter.
    path: Vec<f64>,
    /// This cycle's goals: the path, or with droop compensation the path and its lead.
    pose: Vec<f64>,
    /// This cycle's goals, (id, tick): allocated once.
    goals: Vec<(u8, i64)>,
    /// Clock time of the first cycle's goal, for how late the sequence ran.
    first_write: Option<f64>,
    /// Clock time at which the last goal went out (None before the first cycle's), seconds.
    last_write: Option<f64>,
    last_goal: Vec<f64>,
    reads: ReadStreak,
    stops_seen: u32,
    /// A stall beyond the bound, or a fault on an isolated arm's bus: braking, then this is
    /// the result.
    pending_fault: Option<PlayError>,
    last_progress: Option<Instant>,
    cycle: u64,
    /// Watches loads against position errors (`None`: `--no-push-guard`, or a bus that
    /// reads no load).
    push: Option<PushGuard>,
    /// By joint: where a joint caught pushing is held instead of following the path.
    pinned: Vec<Option<f64>>,
    /// By joint: the load read with this cycle's positions, percent.
    loads: Vec<Option<f64>>,
    /// By joint: the health read this cycle.
    health: Vec<Option<Health>>,
    /// The keys' effort limits, as written.
    efforts: Efforts,
}

/// What one cycle did to the arm.
struct Commanded {
    phase: Phase,
    /// After a stall: how much longer than one period the previous goal was held, seconds.
    stall: Option<f64>,
}

impl<'a> Run<'a> {
    /// Reads where the arm is, holds it there, turns torque on: enabling torque moves nothing.
    pub(super) fn start(
        bus: &'a mut dyn ServoBus,
        robot: &'a Robot,
        trajectory: &'a Trajectory,
        options: &'a PlayOptions,
        clock: &dyn Clock,
    ) -> Result<Run<'a>, PlayError> {
        let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
        let guard = GoalGuard::new(robot);
        let fault = |error| fault(robot, error, 0.0);
        let measured = clamp_start(robot, &measured_pose(bus, robot, &ids).map_err(fault)?)?;
        if options.timeline.approach {
            let first = trajectory.sample(trajectory.play_from(options.timeline.from_key));
            if let Some(contact) = crate::plan::approach_refusal(robot, &measured, &first) {
                return Err(PlayError::ApproachContact { contact });
            }
        }
        let push = match options.push_guard {
            true => Some(PushGuard::new(bus, robot, 1.0 / options.rate_hz).map_err(fault)?),
            false => None,
        };
        let thresholds = match (&push, trajectory.efforts.is_empty()) {
            (_, true) => Vec::new(),
            (Some(guard), false) => guard.thresholds(),
            (None, false) => super::push::overload_thresholds(bus, robot).map_err(fault)?,
        };
        let efforts = Efforts::start(bus, robot, trajectory, &thresholds)?;
        bus.write_goals(&guard.goals(&measured)?).map_err(fault)?;
        bus.set_torque(&ids, true).map_err(fault)?;
        let timeline = Timeline::new(robot, trajectory, &options.timeline, &measured);
        let log = match &options.log {
            Some(path) => Some(PlaybackLog::create(path, robot)?),
            None => None,
        };
        let period = 1.0 / options.rate_hz;
        // From here on, a cell does not let one arm's late answers hold the others' goals.
        bus.pace(Some(Duration::from_secs_f64(period)));
        Ok(Run {
            stats: Stats {
                approach_seconds: timeline.approach_seconds(),
                ..Stats::default()
            },
            pacer: Pacer::new(clock, period),
            keep_up: options
                .max_stalls_per_second
                .map(|bound| KeepUp::new(options.rate_hz, bound)),
            t0: clock.now().as_secs_f64(),
            limiter: StepLimiter::new(robot, period, &measured),
            path: vec![0.0; robot.joints.len()],
            pose: vec![0.0; robot.joints.len()],
            goals: Vec::with_capacity(robot.joints.len()),
            first_write: None,
            last_write: None,
            last_goal: measured,
            bus,
            robot,
            trajectory,
            options,
            lost: vec![false; ids.len()],
            ids,
            guard,
            timeline,
            log,
            period,
            reads: ReadStreak::default(),
            stops_seen: 0,
            pending_fault: None,
            last_progress: None,
            cycle: 0,
            push,
            pinned: vec![None; robot.joints.len()],
            loads: vec![None; robot.joints.len()],
            health: vec![None; robot.joints.len()],
            efforts,
        })
    }

    /// Runs cycles until the timeline is over, a second stop holds, or a fault.
    pub(super) fn cycles(
        &mut self,
        stop: &StopSignal,
        clock: &dyn Clock,
    ) -> Result<Outcome, PlayError> {
        loop {
            let start = self.pacer.wait(clock, stop, self.stops_seen);
            if let Some(outcome) = self.cycle(&start, stop, clock)? {
                return Ok(outcome);
            }
            if let Some(keep_up) = &mut self.keep_up {
                keep_up.worked(clock.now().as_secs_f64() - start.now);
            }
        }
    }

    fn cycle(
        &mut self,
        start: &CycleStart,
        stop: &StopSignal,
        clock: &dyn Clock,
    ) -> Result<Option<Outcome>, PlayError> {
        let elapsed = start.now - self.t0;
        if let Some(outcome) = self.on_stop_requests(stop, elapsed)? {
            return Ok(Some(outcome));
        }
        // The goal goes out now: what counts is how long the arm has held the last one, which
        // a delay after the cycle began (the thread preempted between its wake-up and here)
        // makes longer than the gap between cycle starts. Only the pose's computation lies
        // between this reading and the write.
        let write_at = clock.now().as_secs_f64();
        let gap = self.last_write.map_or(self.period, |last| write_at - last);
        let stall = is_stall(gap, self.period).then_some(gap - self.period);
        if let Some(held) = stall {
            self.after_stall(gap, held, elapsed);
        }
        if self.cycle > 0 {
            self.timeline.advance(self.period);
        }
        let Some(phase) = self.timeline.sample_into(&mut self.path) else {
            return Ok(Some(if self.timeline.stopped() {
                Outcome::Stopped
            } else {
                Outcome::Finished
            }));
        };
        self.first_write.get_or_insert(write_at);
        self.last_write = Some(write_at);
        self.pacer.served_until(write_at);
        self.command(followed_share(gap, self.period), elapsed)?;
        let measured = self.read_back(elapsed, phase)?;
        self.check_health(elapsed)?;
        self.apply_efforts(elapsed)?;
        self.record(
            start,
            elapsed,
            &Commanded { phase, stall },
            measured.as_deref(),
        )?;
        self.cycle += 1;
        self.stats.cycles = self.cycle;
        Ok(None)
    }

    /// The last goal was held for the whole `gap` (`held` beyond its period): resume from the
    /// rate really followed, and brake to a stop when the stall was beyond the bound or the
    /// stalls come too often for the machine to keep up with the rate.
    fn after_stall(&mut self, gap: f64, held: f64, elapsed: f64) {
        self.timeline.after_stall(followed_share(gap, self.period));
        // A goal held two periods or more beyond its own stops the arm, which then starts
        // again as the path resumes; a shorter hold only delays the goals a little.
        match &mut self.push {
            Some(guard) if held >= 2.0 * self.period => guard.stalled(elapsed),
            _ => {}
        }
        let overrun = self
            .keep_up
            .as_mut()
            .and_then(|keep_up| keep_up.stalled(self.t0 + elapsed, held));
        if self.pending_fault.is_some() {
            return;
        }
        let fault = if held > self.options.max_stall {
            PlayError::Stall {
                held,
                period: self.period,
                bound: self.options.max_stall,
                at: elapsed,
                load: crate::pacing::Load::now(),
            }
        } else if let Some(overrun) = overrun.filter(|_| self.stops_seen == 0) {
            // Already braking on request, the arm is coming to rest anyway.
            PlayError::CannotKeepUp {
                overrun,
                at: elapsed,
            }
        } else {
            return;
        };
        self.pending_fault = Some(fault);
        self.timeline.request_stop();
    }

    /// A first request brakes along the path; a second holds at once.
    fn on_stop_requests(
        &mut self,
        stop: &StopSignal,
        elapsed: f64,
    ) -> Result<Option<Outcome>, PlayError> {
        let requests = stop.count();
        if requests >= 2 {
            self.hold_here()
                .map_err(|e| fault(self.robot, e, elapsed))?;
            return Ok(Some(Outcome::Held));
        }
        if requests > self.stops_seen {
            self.stops_seen = requests;
            self.timeline.request_stop();
        }
        Ok(None)
    }

    /// The pose of this cycle, through the step limiter, the droop compensation's lead and
    /// the position guard, to the servos.
    fn command(&mut self, followed: f64, elapsed: f64) -> Result<(), PlayError> {
        // A joint caught pushing eases back (through the limiter) to where it stopped, with
        // no lead: it no longer pushes.
        let pin = |values: &mut [f64], pinned: &[Option<f64>]| {
            for (value, pin) in values.iter_mut().zip(pinned) {
                if let Some(at) = pin {
                    *value = *at;
                }
            }
        };
        pin(&mut self.path, &self.pinned);
        self.limiter.limit(&mut self.path, followed);
        self.pose.copy_from_slice(&self.path);
        self.timeline.goals_into(&mut self.pose, self.period);
        if self.pinned.iter().any(Option::is_some) {
            for ((pose, path), pin) in self.pose.iter_mut().zip(&self.path).zip(&self.pinned) {
                if pin.is_some() {
                    *pose = *path;
                }
            }
        }
        self.guard.goals_into(&self.pose, &mut self.goals)?;
        self.served_only();
        let written = self.bus.write_goals(&self.goals);
        // The arms still served received theirs even when another arm's write failed.
        self.last_goal.copy_from_slice(&self.pose);
        written.or_else(|e| self.on_fault(e, elapsed))
    }

    /// Drops the goals of joints whose arm is isolated (goals are in joint order).
    fn served_only(&mut self) {
        if self.lost.iter().any(|&lost| lost) {
            let mut lost = self.lost.iter();
            self.goals
                .retain(|_| !lost.next().copied().unwrap_or(false));
        }
    }

    /// Joint values of positions read from the servos still served; not a number for the
    /// joints of an isolated arm.
    fn served_values(&self, ticks: &[i64]) -> Vec<f64> {
        let mut ticks = ticks.iter();
        self.robot
            .joints
            .iter()
            .zip(&self.lost)
            .map(|(joint, &lost)| match lost {
                false => ticks
                    .next()
                    .map_or(f64::NAN, |&tick| joint.servo.value(tick)),
                true => f64::NAN,
            })
            .collect()
    }

    /// A bus fault. In a cell, the bus can isolate the faulty arm: the others then brake along
    /// the path to rest and the fault is the result at the end. Otherwise it ends playback now.
    fn on_fault(&mut self, error: BusError, elapsed: f64) -> Result<(), PlayError> {
        let arm = match &error {
            BusError::Arm { arm, .. } => Some(arm.clone()),
            _ => None,
        };
        let isolated = self.bus.isolate(&error);
        let mut now = fault(self.robot, error, elapsed);
        if let (Some(ids), Some(arm)) = (isolated, arm) {
            for (joint, lost) in self.robot.joints.iter().zip(&mut self.lost) {
                *lost |= ids.contains(&joint.servo.id);
            }
            self.ids.retain(|id| !ids.contains(id));
            now = PlayError::Isolated {
                arm,
                fault: Box::new(now),
            };
            self.timeline.request_stop();
            match &self.pending_fault {
                // The first fault is what stopped the cell; this one is said beside it.
                Some(first) => eprintln!("warning: while braking after \"{first}\": {now}"),
                None => self.pending_fault = Some(now),
            }
            return Ok(());
        }
        if let Some(first) = self.pending_fault.take() {
            eprintln!("warning: this came while braking after: {first}");
        }
        Err(now)
    }

    /// Second stop: command the pose the arm is at now (or, where it cannot be read, the last
    /// goal).
    fn hold_here(&mut self) -> Result<(), BusError> {
        let here: Vec<f64> = match self.bus.read_positions(&self.ids) {
            Ok(ticks) => self
                .served_values(&ticks)
                .iter()
                .zip(&self.last_goal)
                .zip(&self.robot.joints)
                .map(|((&v, &last), j)| {
                    if v.is_finite() {
                        v.clamp(j.limits.min, j.limits.max)
                    } else {
                        last
                    }
                })
                .collect(),
            Err(_) => self.last_goal.clone(),
        };
        if self.guard.goals_into(&here, &mut self.goals).is_err() {
            return Ok(());
        }
        self.served_only();
        self.bus.write_goals(&self.goals)
    }

    /// Present positions every `readback_every` cycles; a lost answer is skipped, a streak of
    /// them is a fault.
    fn read_back(&mut self, elapsed: f64, phase: Phase) -> Result<Option<Vec<f64>>, PlayError> {
        let due = self
            .options
            .readback_every
            .is_some_and(|n| self.cycle % u64::from(n) == 0);
        if !due {
            return Ok(None);
        }
        // Loads come with the positions whether the push guard judges them or not: the log
        // shows them either way.
        let read = self.bus.read_positions_loads(&self.ids);
        match read {
            Ok(read) => {
                self.reads.succeeded();
                let ticks: Vec<i64> = read.iter().map(|r| r.position).collect();
                let values = self.served_values(&ticks);
                self.served_loads(&read);
                self.stats.track(self.robot, &values, &self.path);
                self.watch_pushes(&values, elapsed, phase);
                Ok(Some(values))
            }
            Err(e) => self.read_failed(e, elapsed).map(|()| None),
        }
    }

    /// Loads read from the servos still served, by joint.
    fn served_loads(&mut self, read: &[PositionLoad]) {
        let mut read = read.iter();
        for (load, &lost) in self.loads.iter_mut().zip(&self.lost) {
            *load = match lost {
                false => read.next().and_then(|r| r.load_percent),
                true => None,
            };
        }
    }

    /// The push guard's look at this reading; a bus that reads no load turns it off.
    fn watch_pushes(&mut self, measured: &[f64], elapsed: f64, phase: Phase) {
        let Some(guard) = &mut self.push else {
            return;
        };
        if self.loads.iter().all(Option::is_none) && !self.lost.iter().any(|&l| l) {
            eprintln!(
                "note: {} reads no load: the push guard is off",
                self.bus.describe()
            );
            self.push = None;
            return;
        }
        let reading = Reading {
            time: elapsed,
            path: &self.path,
            cycles: self.options.readback_every.unwrap_or(1),
            goals: &self.last_goal,
            measured,
            loads: &self.loads,
            free: phase != Phase::Approach,
        };
        if let Some(push) = guard.observe(&reading) {
            self.on_push(push, elapsed);
        }
    }

    /// A joint pushing: it is held where it stopped, and the arm brakes to rest.
    fn on_push(&mut self, push: Push, elapsed: f64) {
        let joint = &self.robot.joints[push.joint];
        self.pinned[push.joint] = Some(push.hold_at.clamp(joint.limits.min, joint.limits.max));
        let error = PlayError::Pushing {
            joint: joint.name.clone(),
            load: push.load_percent,
            needed: push.needed_percent,
            lasted: push.lasted,
            at: elapsed,
        };
        match &self.pending_fault {
            Some(first) => eprintln!("warning: while braking after \"{first}\": {error}"),
            None => self.pending_fault = Some(error),
        }
        self.timeline.request_stop();
    }

    /// Temperatures, voltages and alarms every `health_every` cycles; an alarm is a fault.
    fn check_health(&mut self, elapsed: f64) -> Result<(), PlayError> {
        self.health.fill(None);
        if self.cycle == 0 || self.cycle % u64::from(self.options.health_every) != 0 {
            return Ok(());
        }
        match self.bus.read_health(&self.ids) {
            Ok(health) => {
                for (slot, joint) in self.health.iter_mut().zip(&self.robot.joints) {
                    *slot = health.iter().find(|h| h.id == joint.servo.id).copied();
                }
                self.watch_heat();
                match health.iter().find(|h| h.alarms.any()) {
                    Some(h) => self.on_fault(alarm_error(self.robot, h), elapsed),
                    None => Ok(()),
                }
            }
            // A health read is a read like the others: it counts in the same streak.
            Err(e) => self.read_failed(e, elapsed),
        }
    }

    /// The effort limits of the segment the playback is in, written where they change.
    fn apply_efforts(&mut self, elapsed: f64) -> Result<(), PlayError> {
        let t = self.timeline.sequence_time().max(self.trajectory.start);
        let push = &mut self.push;
        let mut limited = |j: usize, on: bool| {
            if let Some(guard) = push.as_mut() {
                guard.set_limited(j, on, elapsed);
            }
        };
        let written = self
            .efforts
            .apply(self.bus, self.robot, self.trajectory, t, &mut limited);
        written.or_else(|e| self.on_fault(e, elapsed))
    }

    /// A servo within [`HOT_MARGIN_C`] of its heat protection is said at once, and in the
    /// closing lines with the hottest it got.
    fn watch_heat(&mut self) {
        for (joint, health) in self.robot.joints.iter().zip(&self.health) {
            let (Some(h), Some(limit)) = (
                health,
                joint.servo.model.spec().factory_temperature_limit_c(),
            ) else {
                continue;
            };
            if h.temperature_c < limit - HOT_MARGIN_C {
                continue;
            }
            match self
                .stats
                .hot
                .iter_mut()
                .find(|(name, ..)| *name == joint.name)
            {
                Some((_, hottest, _)) => *hottest = hottest.max(h.temperature_c),
                None => {
                    eprintln!(
                        "warning: {}",
                        super::warnings::hot_warning(&joint.name, h.temperature_c, limit)
                    );
                    let entry = (joint.name.clone(), h.temperature_c, limit);
                    self.stats.hot.push(entry);
                }
            }
        }
    }

    fn read_failed(&mut self, error: BusError, elapsed: f64) -> Result<(), PlayError> {
        match self.reads.failed(error) {
            Some(error) => self.on_fault(error, elapsed),
            None => Ok(()),
        }
    }

    /// The log row, the progress line and the playhead of this cycle.
    fn record(
        &mut self,
        start: &CycleStart,
        elapsed: f64,
        commanded: &Commanded,
        measured: Option<&[f64]>,
    ) -> Result<(), PlayError> {
        if let Some(log) = &mut self.log {
            log.row(&Row {
                time: elapsed,
                phase: commanded.phase,
                sequence_time: self.timeline.sequence_time(),
                commanded: &self.pose,
                measured,
                lateness: start.lateness,
                stall: commanded.stall,
                loads: match measured {
                    Some(_) => &self.loads,
                    None => &[],
                },
                health: &self.health,
                needed: match (measured, &self.push) {
                    (Some(_), Some(guard)) => guard.needed_now(),
                    _ => &[],
                },
            })?;
        }
        if let Some(playhead) = &self.options.playhead {
            let time = self.timeline.sequence_time();
            playhead.set(self.timeline.phase_name(), time, &self.path);
        }
        if self.options.progress
            && self
                .last_progress
                .is_none_or(|p| p.elapsed() >= PROGRESS_EVERY)
        {
            self.last_progress = Some(Instant::now());
            print_progress(&self.timeline, self.trajectory);
        }
        Ok(())
    }

    /// How much later than planned the sequence ran: the time from the first goal to the last
    /// beyond the periods the timeline advanced by (stalls held goals longer; a deadline after
    /// a stall may come sooner), plus what it lost coming back up to speed. Braking is not
    /// lateness: its slowing is not counted.
    fn late(&self) -> f64 {
        match (self.first_write, self.last_write) {
            (Some(first), Some(last)) => {
                let advanced = self.cycle.saturating_sub(1) as f64 * self.period;
                (last - first - advanced) + self.timeline.resuming_lost()
            }
            _ => 0.0,
        }
    }

    /// The summary, the log closed, and `--release-at-end` once the arm has arrived.
    pub(super) fn finish(mut self, outcome: Outcome) -> Result<(Outcome, Stats), PlayError> {
        self.stats.pacing = std::mem::take(&mut self.pacer.summary);
        self.stats.late = self.late();
        self.stats.limited_goals = self.limiter.engaged;
        self.stats.largest_limiter_correction = self.limiter.largest_correction;
        self.stats.limiter_joint = self.limiter.largest_joint.map(|j| {
            let joint = &self.robot.joints[j];
            (joint.name.clone(), joint.kind)
        });
        if self.options.progress {
            print_progress(&self.timeline, self.trajectory);
            eprintln!();
        }
        if let Some(log) = &mut self.log {
            log.finish()?;
        }
        self.stats.efforts_kept = self.efforts.still_limited(self.robot);
        self.stats.write_offsets = self.bus.write_offsets();
        if let Some(pending) = self.pending_fault.take() {
            // The stats are not returned with a fault: a grasp still limited is said here.
            if let Some(kept) = &self.stats.efforts_kept {
                eprintln!("note: {kept}");
            }
            return Err(pending);
        }
        if outcome == Outcome::Finished && self.options.release_at_end {
            release_when_reached(self.bus, self.robot, &self.ids, &self.last_goal)
                .map_err(|e| fault(self.robot, e, 0.0))?;
        }
        Ok((outcome, self.stats))
    }
}

/// A bus error as a playback fault, naming the joint whose servo it names.
fn fault(robot: &Robot, error: BusError, at: f64) -> PlayError {
    PlayError::Fault {
        joint: faulty_joint(robot, &error),
        error,
        at,
    }
}
