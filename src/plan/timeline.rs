//! What the arm should do at each cycle: approach, play (looping, ping-pong), return between
//! loops, and braking after a stop request — as a state machine advanced by wall-clock steps.
//!
//! The rate at which the path is followed is a factor of the wall-clock rate:
//! - braking lowers it linearly from where it is to 0, so the arm slows down along the very path
//!   it was on instead of cutting across; the braking time keeps the extra deceleration within
//!   half of each joint's acceleration limit. A robot with jerk limits brakes along the path
//!   too, its factor lowered by the first half of an S-curve (`plan::scurve`: the rate of
//!   change of the factor ramps up and down at a bounded second derivative), so braking adds
//!   no acceleration jump; its time keeps the extra deceleration and jerk within half of each
//!   joint's limits;
//! - a stall (the process did not run for a while, so the last goal was held) lowers it to the
//!   rate the arm really followed, `period / gap` of it; it then climbs back to 1 no faster than
//!   each joint's acceleration limit leaves room for next to the path's own acceleration
//!   (under jerk limits along the first half of an S-curve, as braking falls, its jerk within
//!   half of each joint's limit, so the climb adds no acceleration jump). The sequence resumes
//!   along the path from where it was, later by the stall; it never jumps ahead to where the
//!   clock says it should be.

use super::lead::LeadFollower;
use super::scurve::{speed_change, SCurve};
use super::{Approach, Trajectory, MIN_APPROACH_SECONDS};
use crate::dynamics::Compensation;
use crate::robot::Robot;
use std::sync::Arc;

/// How many times the sequence is played.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loops {
    /// This many times (a ping-pong pass counts as one).
    Count(u32),
    /// Until a stop request.
    Forever,
}

/// How a trajectory is played: what the timeline needs to know, and nothing of buses or clocks.
#[derive(Debug, Clone)]
pub struct TimelineOptions {
    /// Time scale: 0.5 plays at half speed.
    pub speed: f64,
    /// How many times to play.
    pub loops: Loops,
    /// Forwards then backwards, each pass a loop, instead of ramping back to the start.
    pub ping_pong: bool,
    /// Keyframe index to start from.
    pub from_key: Option<usize>,
    /// Ramp from where the arm is to the first pose (off only with `--no-approach`).
    pub approach: bool,
    /// The approach's shortest duration, seconds: [`MIN_APPROACH_SECONDS`] for playback, whose
    /// start is an unknown pose; 0 for a teach jog of held joints, timed by the limits alone.
    pub shortest_approach: f64,
    /// Goals that lead the path by each servo's droop under its load (`--compensate-droop`),
    /// so that the arm rather than the goal follows it; `None`: the path itself is sent.
    pub compensation: Option<Arc<Compensation>>,
}

impl Default for TimelineOptions {
    fn default() -> Self {
        Self {
            speed: 1.0,
            loops: Loops::Count(1),
            ping_pong: false,
            from_key: None,
            approach: true,
            shortest_approach: MIN_APPROACH_SECONDS,
            compensation: None,
        }
    }
}

/// The phase of the commanded pose, as logged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// The ramp from where the arm rests to the first pose played.
    Approach,
    /// Following the trajectory.
    Play,
    /// Ramp from the last pose back to the first between loops.
    Return,
    /// Decelerating after a stop request.
    Stopping,
    /// Coming back up to speed along the path after a stall.
    Resuming,
}

impl Phase {
    /// Lower-case name, as the log and the progress line write it.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Approach => "approach",
            Phase::Play => "play",
            Phase::Return => "return",
            Phase::Stopping => "stopping",
            Phase::Resuming => "resuming",
        }
    }
}

#[derive(Debug, Clone)]
enum State {
    Ramp {
        ramp: Approach,
        t: f64,
        then_loop: u32,
    },
    Play,
    /// The final pose, sent once more before finishing.
    Final,
    Done,
}

/// Shortest braking time, seconds.
const MIN_BRAKE_SECONDS: f64 = 0.2;
/// Share of the acceleration limit braking may add.
const BRAKE_LIMIT_SHARE: f64 = 0.5;
/// Below this distance (joint units) no return ramp is needed between loops.
const SAME_POSE: f64 = 1e-6;
/// Share of the acceleration headroom (the limit less the path's own acceleration) that
/// coming back up to speed after a stall may use; the rest is margin for the step limiter.
const RESUME_HEADROOM_SHARE: f64 = 0.9;
/// Fastest return to full rate (per second), where the path hardly moves.
const MAX_RESUME_RATE: f64 = 20.0;
/// Step for the finite differences of the path's velocity and acceleration, seconds.
const DIFFERENCE_STEP: f64 = 1e-3;

/// How fast the path is followed, as a share of the wall-clock rate.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PathRate {
    factor: f64,
    /// While braking: how the factor falls.
    braking: Option<Braking>,
    /// While climbing back to 1 after a stall under jerk limits: how the factor rises.
    climb: Option<RateRamp>,
}

/// The rate factor changing from `from` by `change` along the first half of an S-curve
/// (`ramp`: the S-curve's speed is the change so far), `elapsed` seconds in: its rate of
/// change ramps up and down at a bounded jerk, so the joints' acceleration does not jump.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RateRamp {
    from: f64,
    ramp: SCurve,
    elapsed: f64,
}

impl RateRamp {
    /// The ramp by `change` (either sign) whose rate of change stays within `rate` (per
    /// second) and its own change within `jerk` (per second squared), lasting at least
    /// `shortest` seconds.
    fn new(from: f64, change: f64, rate: f64, jerk: f64, shortest: f64) -> RateRamp {
        let [tj, ta] = speed_change(change.abs(), rate, jerk);
        // Without a jerk limit on a joint that moves, any shape within the rate will do: all
        // jerk phases, whose peak rate of change is twice the mean.
        let (shape, least) = if tj > 0.0 && (2.0 * tj + ta).is_finite() {
            ([tj, ta, 0.0], 2.0 * tj + ta)
        } else {
            ([1.0, 0.0, 0.0], 2.0 * change.abs() / rate)
        };
        // The whole S-curve whose first half reaches the speed `change` in `half` seconds
        // lasts twice that and covers `change · half` (its mean speed is half its peak).
        // Stretched to the shortest time, the same shape changes gentler.
        let half = least.max(shortest);
        RateRamp {
            from,
            ramp: SCurve::shaped(shape, 2.0 * half, change * half),
            elapsed: 0.0,
        }
    }

    /// How far the factor has changed from `from`.
    fn changed(&self) -> f64 {
        self.ramp.state_at(self.elapsed).velocity
    }

    /// Whether the first half of the S-curve is over.
    fn done(&self) -> bool {
        self.elapsed >= 2.0 * self.ramp.jerk_time + self.ramp.acceleration_time
    }
}

/// How the rate factor falls to 0 after a stop request.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Braking {
    /// By this much per second.
    Linear(f64),
    /// Along a [`RateRamp`] to 0 (jerk limits). A stall scales what is left.
    SCurve(RateRamp),
}

impl Braking {
    /// The factor after `dt` more seconds of braking (0 or less: at rest).
    fn advance(&mut self, factor: f64, dt: f64) -> f64 {
        match self {
            Braking::Linear(per_second) => factor - *per_second * dt,
            Braking::SCurve(ramp) => {
                let before = ramp.from + ramp.changed();
                ramp.elapsed += dt;
                if ramp.done() || before <= 0.0 {
                    return 0.0;
                }
                // In proportion, not the ramp's value itself: a stall while braking has
                // lowered the factor below the ramp's (`after_stall`), and it must not climb
                // back.
                factor * (ramp.from + ramp.changed()) / before
            }
        }
    }
}

/// Playback of a trajectory as a state machine: [`Timeline::sample_into`] gives the pose to
/// command now, [`Timeline::advance`] moves on by a control period of wall-clock time.
#[derive(Debug, Clone)]
pub struct Timeline<'a> {
    robot: &'a Robot,
    trajectory: &'a Trajectory,
    state: State,
    speed: f64,
    loops: Loops,
    loop_index: u32,
    ping_pong: bool,
    play_from: f64,
    direction: f64,
    tau: f64,
    rate: PathRate,
    stopped: bool,
    approach_seconds: f64,
    joints: usize,
    /// Wall-clock seconds lost coming back up to speed after stalls (the path followed at a
    /// share of the rate): the stalls themselves are counted by the pacer.
    resuming_lost: f64,
    compensation: Option<Arc<Compensation>>,
    /// The lead that went out, once the first goals have.
    lead: Option<LeadFollower>,
}

impl<'a> Timeline<'a> {
    /// The playback of `trajectory` on `robot` with `options`, from the pose `measured` where
    /// the arm is (joint order and units): the approach ramp starts there.
    pub fn new(
        robot: &'a Robot,
        trajectory: &'a Trajectory,
        options: &TimelineOptions,
        measured: &[f64],
    ) -> Timeline<'a> {
        let play_from = trajectory.play_from(options.from_key);
        let first = trajectory.sample(play_from);
        let (state, approach_seconds) = if options.approach {
            let ramp = Approach::at_least(robot, measured, &first, options.shortest_approach);
            let seconds = ramp.duration;
            (
                State::Ramp {
                    ramp,
                    t: 0.0,
                    then_loop: 1,
                },
                seconds,
            )
        } else {
            (State::Play, 0.0)
        };
        Timeline {
            robot,
            trajectory,
            state,
            speed: options.speed,
            loops: options.loops,
            loop_index: 1,
            ping_pong: options.ping_pong,
            play_from,
            direction: 1.0,
            tau: play_from,
            rate: PathRate {
                factor: 1.0,
                braking: None,
                climb: None,
            },
            stopped: false,
            approach_seconds,
            joints: robot.joints.len(),
            resuming_lost: 0.0,
            compensation: options.compensation.clone(),
            lead: None,
        }
    }

    /// Duration of the first approach ramp, seconds (0 without one).
    pub fn approach_seconds(&self) -> f64 {
        self.approach_seconds
    }

    /// Whether a stop request braked the playback to rest (rather than it playing to the end).
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Seconds the timeline fell behind the clock while coming back up to speed after stalls
    /// (beside the stalls' own held time, which the pacer counts).
    pub fn resuming_lost(&self) -> f64 {
        self.resuming_lost
    }

    /// Sequence time of the commanded pose.
    pub fn sequence_time(&self) -> f64 {
        self.tau
    }

    /// The name of the present [`Phase`], or "done".
    pub fn phase_name(&self) -> &'static str {
        self.phase().map_or("done", Phase::name)
    }

    /// Which loop is playing, of how many: "2/3", "4/∞".
    pub fn loop_label(&self) -> String {
        match self.loops {
            Loops::Count(n) => format!("{}/{n}", self.loop_index),
            Loops::Forever => format!("{}/∞", self.loop_index),
        }
    }

    fn phase(&self) -> Option<Phase> {
        if !matches!(self.state, State::Done) {
            if self.rate.braking.is_some() {
                return Some(Phase::Stopping);
            }
            if self.rate.factor < 1.0 {
                return Some(Phase::Resuming);
            }
        }
        match self.state {
            State::Ramp { then_loop: 1, .. } => Some(Phase::Approach),
            State::Ramp { .. } => Some(Phase::Return),
            State::Play | State::Final => Some(Phase::Play),
            State::Done => None,
        }
    }

    /// The commanded pose now; `None` once the timeline is over.
    pub fn sample_into(&mut self, out: &mut [f64]) -> Option<Phase> {
        match &self.state {
            State::Ramp { ramp, t, .. } => ramp.sample_into(*t, out),
            State::Play | State::Final => self.trajectory.sample_into(self.tau, out),
            State::Done => return None,
        }
        self.phase()
    }

    /// Turns the pose [`Timeline::sample_into`] gave (after the player's step limiter) into
    /// the goals to send, `period` seconds after the last ones: the same pose, or with droop
    /// compensation each servo's lead over it for the weight it holds there (`lead`), faded
    /// in along the first approach ramp, which starts from where the arm rests under its
    /// weight.
    pub fn goals_into(&mut self, pose: &mut [f64], period: f64) {
        let Some(compensation) = &self.compensation else {
            return;
        };
        let weight = self.lead_weight();
        let target: Vec<f64> = compensation
            .leads(pose)
            .iter()
            .map(|lead| lead * weight)
            .collect();
        let robot = self.robot;
        self.lead
            .get_or_insert_with(|| LeadFollower::new(robot, period))
            .goals_into(pose, &target);
    }

    /// How much of the compensation's lead goes out now: rising smoothly from 0 to 1 along
    /// the first approach ramp, 1 after it.
    fn lead_weight(&self) -> f64 {
        match &self.state {
            State::Ramp {
                ramp,
                t,
                then_loop: 1,
            } if ramp.duration > 0.0 => {
                let x = (t / ramp.duration).clamp(0.0, 1.0);
                x * x * (3.0 - 2.0 * x)
            }
            _ => 1.0,
        }
    }

    /// The last goal was held through a stall: the path was followed at `share` of the rate
    /// (`period / gap`), and resumes from there.
    pub fn after_stall(&mut self, share: f64) {
        self.rate.factor *= share;
        // A climb under way starts again from the lower rate.
        self.rate.climb = None;
    }

    /// Moves on by `dt` seconds of wall-clock time.
    pub fn advance(&mut self, dt: f64) {
        let factor = match &mut self.rate.braking {
            Some(braking) => {
                self.rate.factor = braking.advance(self.rate.factor, dt);
                if self.rate.factor <= 0.0 {
                    self.state = State::Done;
                    self.stopped = true;
                    return;
                }
                self.rate.factor
            }
            None => {
                if self.rate.factor < 1.0 {
                    self.rate.factor = self.climbed(dt);
                    // The path moves dt · factor below: the rest of dt is lost.
                    self.resuming_lost += dt * (1.0 - self.rate.factor);
                }
                self.rate.factor
            }
        };
        match &mut self.state {
            State::Ramp { ramp, t, then_loop } => {
                *t += dt * factor;
                if *t >= ramp.duration {
                    self.loop_index = *then_loop;
                    self.tau = self.play_from;
                    self.direction = 1.0;
                    self.state = State::Play;
                }
            }
            State::Play => {
                self.tau += dt * self.speed * factor * self.direction;
                self.at_boundary();
            }
            State::Final => self.state = State::Done,
            State::Done => {}
        }
    }

    /// Handles the end (or, backwards, the start) of a pass.
    fn at_boundary(&mut self) {
        let (end, start) = (self.trajectory.end, self.play_from);
        let past_end = self.direction > 0.0 && self.tau >= end;
        let past_start = self.direction < 0.0 && self.tau <= start;
        if !(past_end || past_start) {
            return;
        }
        let edge = if past_end { end } else { start };
        let more = match self.loops {
            Loops::Forever => true,
            Loops::Count(n) => self.loop_index < n,
        };
        if !more {
            self.tau = edge;
            self.state = State::Final;
            return;
        }
        if self.ping_pong {
            // Reflect the overshoot so the pass continues smoothly in the other direction.
            self.tau = edge - (self.tau - edge);
            self.direction = -self.direction;
            self.loop_index += 1;
            return;
        }
        let last = self.trajectory.sample(end);
        let first = self.trajectory.sample(start);
        let distance = last
            .iter()
            .zip(&first)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if distance <= SAME_POSE {
            self.tau = start + (self.tau - end);
            self.loop_index += 1;
        } else {
            // A loop whose end differs from its start would jump; ramp back instead.
            self.tau = end;
            self.state = State::Ramp {
                ramp: Approach::new(self.robot, &last, &first),
                t: 0.0,
                then_loop: self.loop_index + 1,
            };
        }
    }

    /// Starts braking along the current path.
    pub fn request_stop(&mut self) {
        if self.rate.braking.is_some() || matches!(self.state, State::Done) {
            return;
        }
        let (velocity, _) = self.derivatives();
        if self.robot.joints.iter().any(|j| j.limits.jerk.is_some()) {
            self.rate.braking = Some(self.s_curve_braking(&velocity));
            return;
        }
        let seconds = self
            .robot
            .joints
            .iter()
            .zip(&velocity)
            .map(|(j, v)| v.abs() / (BRAKE_LIMIT_SHARE * j.limits.acceleration))
            .fold(MIN_BRAKE_SECONDS, f64::max);
        // From the rate the path is followed at now (lower after a stall) down to zero.
        self.rate.braking = Some(Braking::Linear(self.rate.factor / seconds));
    }

    /// Braking for a robot with jerk limits: the factor falls from where it is to 0 along the
    /// first half of an S-curve, its rate of change (times each joint's velocity at the full
    /// rate, the deceleration braking adds) within half the acceleration limit and that rate's
    /// own change (the jerk braking adds) within half the jerk limit, lasting at least
    /// [`MIN_BRAKE_SECONDS`].
    fn s_curve_braking(&self, velocity: &[f64]) -> Braking {
        let from = self.rate.factor;
        let change = self.least_over_velocity(velocity, &|l| BRAKE_LIMIT_SHARE * l.acceleration);
        let jerk = self.jerk_room(velocity);
        Braking::SCurve(RateRamp::new(from, -from, change, jerk, MIN_BRAKE_SECONDS))
    }

    /// The least of `limit` over each joint's velocity `velocity` (at the full rate): what a
    /// change of the rate factor may be, for each joint to keep `limit` (infinite for a joint
    /// at rest).
    fn least_over_velocity(
        &self,
        velocity: &[f64],
        limit: &dyn Fn(&crate::robot::Limits) -> f64,
    ) -> f64 {
        self.robot
            .joints
            .iter()
            .zip(velocity)
            .map(|(j, v)| limit(&j.limits) / v.abs())
            .fold(f64::INFINITY, f64::min)
    }

    /// How fast the rate of change of the factor may itself change (per second squared): the
    /// jerk it adds, `velocity · change²/dt²`, within half of each joint's jerk limit (infinite
    /// without jerk limits).
    fn jerk_room(&self, velocity: &[f64]) -> f64 {
        self.least_over_velocity(velocity, &|l| {
            BRAKE_LIMIT_SHARE * l.jerk.unwrap_or(f64::INFINITY)
        })
    }

    /// The factor `dt` seconds further into coming back to 1 after a stall: at
    /// [`Timeline::resume_rate`], or under jerk limits along a [`RateRamp`] from where the
    /// stall left it, planned at its start with the same rate and half the jerk limits.
    fn climbed(&mut self, dt: f64) -> f64 {
        if self.robot.joints.iter().all(|j| j.limits.jerk.is_none()) {
            return (self.rate.factor + self.resume_rate() * dt).min(1.0);
        }
        let mut climb = match self.rate.climb {
            Some(climb) => climb,
            None => {
                let (velocity, acceleration) = self.derivatives();
                let rate = self.resume_rate_at(&velocity, &acceleration);
                // The path's own acceleration leaves a joint no room to climb now: the factor
                // holds, and the climb is planned again next cycle (a ramp at a rate of 0
                // would never end).
                if rate <= 0.0 {
                    return self.rate.factor;
                }
                let from = self.rate.factor;
                RateRamp::new(from, 1.0 - from, rate, self.jerk_room(&velocity), 0.0)
            }
        };
        climb.elapsed += dt;
        self.rate.climb = (!climb.done()).then_some(climb);
        if climb.done() {
            return 1.0;
        }
        (climb.from + climb.changed()).min(1.0)
    }

    /// How fast the rate factor may climb back to 1 (per second): the extra acceleration it
    /// adds, `velocity · climb`, must fit within each joint's limit next to the path's own
    /// acceleration at the present factor, `factor² · acceleration`.
    fn resume_rate(&self) -> f64 {
        let (velocity, acceleration) = self.derivatives();
        self.resume_rate_at(&velocity, &acceleration)
    }

    /// [`Self::resume_rate`] where the path's joint `velocity` and `acceleration` are known.
    fn resume_rate_at(&self, velocity: &[f64], acceleration: &[f64]) -> f64 {
        let f2 = self.rate.factor * self.rate.factor;
        self.robot
            .joints
            .iter()
            .zip(velocity.iter().zip(acceleration))
            .map(|(j, (v, a))| {
                let headroom = (j.limits.acceleration - f2 * a.abs()).max(0.0);
                RESUME_HEADROOM_SHARE * headroom / v.abs().max(f64::MIN_POSITIVE)
            })
            .fold(MAX_RESUME_RATE, f64::min)
    }

    /// Joint velocities and accelerations of the commanded path now, at the full rate, per
    /// second of wall-clock time (central differences).
    fn derivatives(&self) -> (Vec<f64>, Vec<f64>) {
        let h = DIFFERENCE_STEP;
        let mut before = vec![0.0; self.joints];
        let mut here = vec![0.0; self.joints];
        let mut after = vec![0.0; self.joints];
        let rate = match &self.state {
            State::Ramp { ramp, t, .. } => {
                ramp.sample_into(t - h, &mut before);
                ramp.sample_into(*t, &mut here);
                ramp.sample_into(t + h, &mut after);
                1.0
            }
            State::Play | State::Final => {
                self.trajectory.sample_into(self.tau - h, &mut before);
                self.trajectory.sample_into(self.tau, &mut here);
                self.trajectory.sample_into(self.tau + h, &mut after);
                self.speed
            }
            State::Done => return (before, here),
        };
        let velocity = before
            .iter()
            .zip(&after)
            .map(|(a, b)| (b - a) / (2.0 * h) * rate)
            .collect();
        let acceleration = before
            .iter()
            .zip(&here)
            .zip(&after)
            .map(|((a, m), b)| (b - 2.0 * m + a) / (h * h) * rate * rate)
            .collect();
        (velocity, acceleration)
    }
}
