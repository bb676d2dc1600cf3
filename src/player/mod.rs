//! The real-time player: streams a trajectory to a [`ServoBus`] at a fixed rate.
//!
//! What it does, in the spirit of ROS 2's joint_trajectory_controller and PAL's play_motion2:
//! - it reads where the arm is and ramps from there to the first pose (never a jump);
//! - it paces cycles by absolute deadlines (`start + k·period`), so lateness never accumulates,
//!   and skips the deadlines a stall missed instead of replaying them;
//! - no goal step exceeds what the velocity and acceleration limits allow over one period, and
//!   no goal is outside the position limits, whatever the scheduler did;
//! - one sync write per cycle; present positions read back every N cycles, health periodically;
//! - a stop request decelerates along the path and holds with torque on; a second one holds at
//!   once where the arm is;
//! - a fault (alarm, failed write, repeated read failures, the port gone) stops streaming within
//!   the cycle and is reported with the servo and the reason; a stall longer than the bound
//!   brakes to rest first, and so do stalls too frequent for the path to come back up to speed
//!   between them (the machine cannot keep up with the rate: said at once, not at the end).

mod effort;
mod guard;
mod log;
mod playhead;
mod progress;
pub mod push;
mod run;
mod servo_profile;
mod warnings;

pub use crate::pacing::{Clock, LatenessSummary, Overrun, WallClock, MAX_STALLS_PER_SECOND};
pub(crate) use crate::plan::StepLimiter;
pub use crate::stop::StopSignal;
pub use effort::EffortError;
pub(crate) use guard::GoalGuard;
pub use guard::LimitBreach;
pub use log::{PlaybackLog, Row as LogRow};
pub use playhead::{Playhead, PlayheadAt};
pub use progress::print_progress_line;
pub use push::{Push, PushGuard};
pub(crate) use servo_profile::ProfileGuard;
pub use servo_profile::ServoProfileError;

use crate::bus::{joint_prefix, BusError, ServoBus, WriteOffsets};
use crate::plan::{Timeline, TimelineOptions, Trajectory};
use crate::robot::Robot;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How long `--release-at-end` waits for the arm to reach the final pose.
pub const RELEASE_WAIT: Duration = Duration::from_secs(3);
/// The longest a goal may be held beyond its period before the stall is a fault, seconds.
pub const DEFAULT_MAX_STALL: f64 = 0.25;

/// How to play a trajectory: rate, speed, loops, what to read back and log.
#[derive(Debug, Clone)]
pub struct PlayOptions {
    /// Control rate: goals written per second.
    pub rate_hz: f64,
    /// What is played when: speed, loops, ping-pong, the key to start from, the approach ramp
    /// and droop compensation's lead, as the timeline builds it from the trajectory.
    pub timeline: TimelineOptions,
    /// Torque off at the end, once the arm has reached the final pose (within
    /// [`RELEASE_WAIT`]).
    pub release_at_end: bool,
    /// Read present positions every N cycles (None: never during playback).
    pub readback_every: Option<u32>,
    /// Read temperatures, voltages and alarms every N cycles.
    pub health_every: u32,
    /// Write a CSV row per cycle to this file (`--log`).
    pub log: Option<PathBuf>,
    /// Redraw a progress line on stderr.
    pub progress: bool,
    /// A goal held this much longer than one period (seconds) is a fault: brake, then stop.
    pub max_stall: f64,
    /// Write the joints' limits into the servos' own motion profile for the playback, and put
    /// the previous values back afterwards, however the playback ends.
    pub servo_profile: bool,
    /// This many stalls within one second mean the machine cannot keep up with the rate: brake,
    /// then stop ([`crate::pacing::KeepUp`]). `None`: never judged (tests that stall on
    /// purpose).
    pub max_stalls_per_second: Option<usize>,
    /// Set every cycle to where the playback is, for a page that draws it (`None`: not
    /// followed).
    pub playhead: Option<Playhead>,
    /// Watch each servo's load with its position ([`push`]): a joint pushing on something
    /// stops and the arm brakes (only `--no-push-guard` turns it off).
    pub push_guard: bool,
}

impl PlayOptions {
    /// The defaults at `rate_hz`: once at full speed, with the approach ramp, a read-back
    /// every cycle and health four times a second, no log.
    pub fn new(rate_hz: f64) -> Self {
        Self {
            rate_hz,
            timeline: TimelineOptions::default(),
            release_at_end: false,
            readback_every: Some(1),
            health_every: (rate_hz / 4.0).ceil().max(1.0) as u32,
            log: None,
            progress: false,
            max_stall: DEFAULT_MAX_STALL,
            servo_profile: false,
            max_stalls_per_second: Some(MAX_STALLS_PER_SECOND),
            playhead: None,
            push_guard: true,
        }
    }
}

/// How a playback that did not fail ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Played to the end.
    Finished,
    /// A stop request decelerated the arm to rest; it holds there with torque on.
    Stopped,
    /// A second stop request held the arm at once.
    Held,
}

/// Why a playback stopped before its end.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    /// The bus failed (alarm, failed write, repeated read failures, the port gone).
    #[error("{}{error} (at {at:.3} s)", joint_prefix(joint))]
    Fault {
        /// The joint whose servo failed; `None` when the error names no servo.
        joint: Option<String>,
        /// What failed.
        error: BusError,
        /// Playback time of the failure, seconds.
        at: f64,
    },
    /// A goal outside its joint's limits was about to be sent (a bug; it was not).
    #[error(transparent)]
    Limit(#[from] LimitBreach),
    /// The keys' effort limits cannot be played.
    #[error(transparent)]
    Effort(EffortError),
    /// A joint pushed harder than its motion needs without reaching its goal (the push
    /// guard, [`push`]): it stopped pushing and the arm braked to rest.
    #[error("{joint} pushing at {load:.0} % of its servo's output{} for {} ms without reaching its goal, at {at:.2} s: something is in the way. It stopped pushing where it was, the other joints braked to rest along the path, and the arm holds there, torque on; clear the way (or, if nothing is there, the arm carries more than its model says) and play again", needed.map_or(String::new(), |n| format!(" where the motion needs {n:.0} %")), (lasted * 1e3).round())]
    Pushing {
        /// The joint.
        joint: String,
        /// The hardest load seen, percent of full output, in the joint's direction.
        load: f64,
        /// What the motion needed then, percent (`None`: no model of the arm).
        needed: Option<f64>,
        /// How long it pushed before it was caught, seconds.
        lasted: f64,
        /// Playback time it was caught at, seconds.
        at: f64,
    },
    /// A joint measured too far outside its limits to start from.
    #[error("joint {joint} is at {value:.3} {unit}, outside its limits {min} … {max} by more than {slack}: move it inside by hand (torque off) and start again")]
    StartOutsideLimits {
        /// The joint's name.
        joint: String,
        /// Where it was measured.
        value: f64,
        /// Its lower limit.
        min: f64,
        /// Its upper limit.
        max: f64,
        /// "deg" or "m".
        unit: &'static str,
        /// How far outside a start is still accepted ([`JointKind::position_slack`]).
        ///
        /// [`JointKind::position_slack`]: crate::robot::JointKind::position_slack
        slack: f64,
    },
    /// The approach ramp from where the arm is to where playback starts would make a contact
    /// (the floor, the arm itself, another arm): nothing moved.
    #[error("refusing to start: on the approach from where the arm is to the first pose, {contact}: move the arm clear first (by hand with torque off, or with a jog) and start again")]
    ApproachContact {
        /// The contact, in words (`gripper touches the floor (4.2 mm deep)`).
        contact: String,
    },
    /// A goal held longer than [`PlayOptions::max_stall`] beyond its period.
    #[error("stalled: the goal was held {:.0} ms beyond its {:.0} ms period (the bound is {:.0} ms); braked to rest along the path and holding, torque on (at {at:.3} s); {}", held * 1e3, period * 1e3, bound * 1e3, stall_advice(*load))]
    Stall {
        /// Seconds the goal was held beyond its period.
        held: f64,
        /// The control period, seconds.
        period: f64,
        /// The bound it exceeded, seconds.
        bound: f64,
        /// Playback time, seconds.
        at: f64,
        /// How busy the machine was when it happened (None where the kernel does not say).
        load: Option<crate::pacing::Load>,
    },
    /// Stalls came too often for the path to come back up to speed between them.
    #[error("cannot keep up with {:.0} Hz: {} stalls within {:.2} s (goals held over 1.5 periods, the longest {:.1} ms beyond its {:.1} ms period), so the sequence would crawl; braked to rest along the path and holding, torque on (at {at:.3} s); {}", overrun.rate_hz, overrun.stalls, overrun.within, overrun.longest_hold * 1e3, 1e3 / overrun.rate_hz, keep_up_advice(overrun))]
    CannotKeepUp {
        /// How often and how long the stalls were, and the cycle's own work.
        overrun: Overrun,
        /// Playback time, seconds.
        at: f64,
    },
    /// A fault on one arm's bus in a cell: nothing more went to that bus, and the other arms
    /// braked to rest along the path.
    /// `fault` is said within the sentence, so it is not the error's `source()` as well.
    #[error("{fault}; nothing more was sent to the {arm} bus, and the other arms braked to rest along the path and hold there, torque on")]
    Isolated {
        /// The arm whose bus failed.
        arm: String,
        /// What failed there.
        fault: Box<PlayError>,
    },
    /// `--servo-profile` could not be set up or put back.
    #[error(transparent)]
    ServoProfile(#[from] ServoProfileError),
    /// The log file could not be written.
    #[error("cannot write log {path}")]
    Log {
        /// The log's path.
        path: String,
        /// Why.
        source: std::io::Error,
    },
}

impl PlayError {
    /// What kind of failure this is: a log that cannot be written is bad input (its path);
    /// anything else stopped the servos.
    pub fn kind(&self) -> crate::error::ErrorKind {
        match self {
            PlayError::Log { .. } => crate::error::ErrorKind::BadInput,
            PlayError::Effort(EffortError::AboveOverload { .. }) => {
                crate::error::ErrorKind::BadInput
            }
            // The motion was judged and refused, as a failed check is.
            PlayError::ApproachContact { .. } => crate::error::ErrorKind::VerdictFailed,
            _ => crate::error::ErrorKind::Hardware,
        }
    }
}

/// What the figures of an overrun point at: the cycle's own work, or the scheduler.
/// What to do about a stall: the process did not run, so say how busy the machine was and
/// what lets the control loop run (or tolerates it).
fn stall_advice(load: Option<crate::pacing::Load>) -> String {
    let busy = match load {
        Some(l) if l.overloaded() => format!(
            "the machine is busy (load average {:.1} on {} CPUs): ",
            l.average, l.cpus
        ),
        Some(l) => format!("load average {:.1} on {} CPUs: ", l.average, l.cpus),
        None => String::new(),
    };
    format!(
        "{busy}run with --realtime (keypose doctor says what the system allows), stop what \
         competes for the CPUs, or allow longer holds with --max-stall MS"
    )
}

fn keep_up_advice(overrun: &Overrun) -> String {
    let work = format!(
        "a cycle's own work (goal write, read-back, log) took {:.2} ms at the median",
        overrun.median_work * 1e3
    );
    let lower = match overrun.fitting_rate() {
        Some(rate) => format!("a lower rate ({rate:.0} Hz leaves that work half the period)"),
        None => "a lower rate".into(),
    };
    if overrun.work_bound() {
        format!("{work}, most of the period: play at {lower}, or read back less often")
    } else {
        format!("{work}, the rest was the thread waiting to run: use real-time scheduling, or play at {lower}")
    }
}

/// Figures from one playback, for the report and the benchmarks.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Control cycles run, approach included.
    pub cycles: u64,
    /// Lateness, stalls and skipped deadlines.
    pub pacing: LatenessSummary,
    /// Duration of the approach ramp, seconds.
    pub approach_seconds: f64,
    /// The largest tracking error (measured − commanded), in the units of its joint.
    pub max_tracking_error: f64,
    /// The joint it was on (robot order); None until a read-back has been compared.
    pub tracking_error_joint: Option<usize>,
    /// Goals the step limiter had to change (none in ordinary playback), and by how much at
    /// most, in joint units.
    pub limited_goals: u64,
    /// The largest change the step limiter made to a goal, in joint units.
    pub largest_limiter_correction: f64,
    /// The joint of that change and its kind (which says the unit); None when it made none.
    pub limiter_joint: Option<(String, crate::robot::JointKind)>,
    /// A cell: how far apart the arms' buses started each cycle's goal write.
    pub write_offsets: Option<WriteOffsets>,
    /// How much later than planned the sequence ran, seconds, as the clock saw it: what stalls
    /// held beyond their periods and what coming back up to speed after them lost
    /// ([`crate::plan::Timeline::resuming_lost`]).
    pub late: f64,
    /// Servos that came within [`HOT_MARGIN_C`] of their heat protection: (joint, the hottest
    /// reading, its protection's temperature), °C, each joint once.
    pub hot: Vec<(String, f64, f64)>,
    /// The keys' effort limits still in force at the end, in words (`None`: none).
    pub efforts_kept: Option<String>,
}

/// A servo this close to the temperature at which its heat protection trips (°C) is warned
/// about: the protection unloads an STS3215 and shuts an X series servo down until a reboot.
pub const HOT_MARGIN_C: f64 = 10.0;

impl Stats {
    /// Takes in one read-back. Degrees and metres do not compare, so joints are compared by
    /// their error as a share of their position slack (2° or 2 mm, what "reached" means).
    fn track(&mut self, robot: &Robot, measured: &[f64], commanded: &[f64]) {
        let share = |j: usize, error: f64| error / robot.joints[j].kind.position_slack();
        for (j, (m, c)) in measured.iter().zip(commanded).enumerate() {
            // An isolated arm's joints are not measured.
            if !m.is_finite() {
                continue;
            }
            let error = (m - c).abs();
            let larger = match self.tracking_error_joint {
                Some(k) => share(j, error) > share(k, self.max_tracking_error),
                None => true,
            };
            if larger {
                self.max_tracking_error = error;
                self.tracking_error_joint = Some(j);
            }
        }
    }
}

/// Plays `trajectory` on the servos behind `bus`: measures the arm, holds it, turns torque on,
/// ramps to the first pose, streams every control period until the end, a stop request or a
/// fault.
///
/// ```
/// use keypose::testing::VirtualBus;
/// use keypose::plan::Trajectory;
/// use keypose::player::{play, Outcome, PlayOptions, StopSignal};
/// use keypose::robot::Robot;
/// use keypose::sequence::Sequence;
///
/// let robot = Robot::builtin("so101").unwrap();
/// let sequence = Sequence::from_json(
///     "tilt.json",
///     r#"{"format": "keypose-sequence/1", "robot": "so101",
///         "keyframes": [{"time": 0, "joints": {"wrist_flex": 0}},
///                       {"time": 1, "joints": {"wrist_flex": 15}}]}"#,
/// )
/// .unwrap();
/// let trajectory = Trajectory::build(&sequence, &robot).unwrap();
/// // Emulated servos behind the real driver and packet code, in memory.
/// let (mut bus, servos) = VirtualBus::in_process(&robot);
/// let options = PlayOptions::new(100.0);
/// let (outcome, stats) = play(&mut bus, &robot, &trajectory, &options, &StopSignal::default())
///     .unwrap();
/// assert_eq!(outcome, Outcome::Finished);
/// // The 0.5 s approach ramp (the arm rests at the first pose already) and 1 s of motion at
/// // 100 Hz, plus the final pose sent once more.
/// assert!(stats.cycles >= 150);
/// // The last goal the wrist's servo received is the last key, to half a tick.
/// let wrist = &robot.joints[3];
/// let (_, tick) = *servos.lock().goals_received().iter().rev()
///     .find(|(id, _)| *id == wrist.servo.id).unwrap();
/// assert!((wrist.servo.value(tick) - 15.0).abs() <= 360.0 / 4096.0 / 2.0);
/// ```
pub fn play(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
    stop: &StopSignal,
) -> Result<(Outcome, Stats), PlayError> {
    play_with_clock(bus, robot, trajectory, options, stop, &WallClock::new())
}

/// [`play`] on a given clock (tests make it stall).
pub fn play_with_clock(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
    stop: &StopSignal,
    clock: &dyn Clock,
) -> Result<(Outcome, Stats), PlayError> {
    if !options.servo_profile {
        return stream(bus, robot, trajectory, options, stop, clock);
    }
    let mut profile = ProfileGuard::apply(bus, robot)?;
    let played = stream(profile.bus(), robot, trajectory, options, stop, clock);
    let restored = profile.restore().map_err(ServoProfileError::Restore);
    match (played, restored) {
        (Ok(result), Ok(())) => Ok(result),
        (Ok(_), Err(e)) => Err(e.into()),
        (Err(e), Ok(())) => Err(e),
        // The playback's own error is the one to report; the lost profile is said too.
        (Err(e), Err(restore)) => {
            eprintln!("warning: {}", crate::error::Report(&restore));
            Err(e)
        }
    }
}

/// The playback itself: start, cycles, finish.
fn stream(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
    stop: &StopSignal,
    clock: &dyn Clock,
) -> Result<(Outcome, Stats), PlayError> {
    let played = run::Run::start(bus, robot, trajectory, options, clock).and_then(|mut run| {
        let outcome = run.cycles(stop, clock)?;
        run.finish(outcome)
    });
    // What follows (restoring the servos' profile, a teach session's jogs) waits for every arm.
    bus.pace(None);
    played
}

/// The present pose in joint values, clamped into the limits when it is only just outside.
fn measured_pose(bus: &mut dyn ServoBus, robot: &Robot, ids: &[u8]) -> Result<Vec<f64>, BusError> {
    Ok(robot.values_of(&bus.read_positions(ids)?))
}

/// Checks a measured start pose and clamps it into the limits (for the ramp's first goal).
pub fn clamp_start(robot: &Robot, measured: &[f64]) -> Result<Vec<f64>, PlayError> {
    robot
        .joints
        .iter()
        .zip(measured)
        .map(|(j, &v)| {
            let outside = (j.limits.min - v).max(v - j.limits.max);
            let slack = j.kind.position_slack();
            if outside > slack {
                Err(PlayError::StartOutsideLimits {
                    joint: j.name.clone(),
                    value: v,
                    min: j.limits.min,
                    max: j.limits.max,
                    unit: j.kind.unit(),
                    slack,
                })
            } else {
                Ok(v.clamp(j.limits.min, j.limits.max))
            }
        })
        .collect()
}

/// `--release-at-end`: torque off only once the arm has reached the final pose.
fn release_when_reached(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    ids: &[u8],
    goal: &[f64],
) -> Result<(), BusError> {
    let give_up = Instant::now() + RELEASE_WAIT;
    while Instant::now() < give_up {
        let pose = measured_pose(bus, robot, ids)?;
        let reached = pose
            .iter()
            .zip(goal)
            .zip(&robot.joints)
            .all(|((p, g), joint)| (p - g).abs() <= joint.kind.position_slack());
        if reached {
            return bus.set_torque(ids, false);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    eprintln!(
        "warning: the arm did not reach the final pose within {} s; torque stays on",
        RELEASE_WAIT.as_secs()
    );
    Ok(())
}

fn print_progress(timeline: &Timeline, trajectory: &Trajectory) {
    print_progress_line(
        timeline.phase_name(),
        timeline.sequence_time(),
        &timeline.loop_label(),
        trajectory,
    );
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_stall_says_how_busy_the_machine_was_and_what_to_do() {
        let error = super::PlayError::Stall {
            held: 0.603,
            period: 0.01,
            bound: 0.25,
            at: 1.5,
            load: Some(crate::pacing::Load {
                average: 7.25,
                cpus: 2,
            }),
        };
        let text = error.to_string();
        assert!(text.contains("held 603 ms beyond its 10 ms period (the bound is 250 ms)"));
        assert!(
            text.contains("the machine is busy (load average 7.2 on 2 CPUs)"),
            "{text}"
        );
        assert!(
            text.contains("--realtime") && text.contains("--max-stall MS"),
            "{text}"
        );
    }
}
