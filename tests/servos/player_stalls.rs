//! The player on a clock that stalls: thousands of injected stalls (as SIGSTOP, page faults or
//! CPU steal would cause) and scheduling jitter, against emulated servos in process.
//!
//! The oracle is the joint limits themselves, applied to the goals decoded from the bytes the
//! virtual servos received, with the write times the clock gave. Per joint, between two
//! consecutive goals written `gap` seconds apart at control period `T` (`Δ₁` the step before):
//! - every goal is inside the position limits;
//! - a step is at most `v·T` (velocity limit over one period), whatever the gap;
//! - a step differs from the reference step by at most `a·T²` (acceleration limit over one
//!   period), the reference being `Δ₁`, or `Δ₁·T/gap` after a stall (`gap > 1.5·T`: the goal
//!   was held for the whole gap, so the arm followed the path at that rate);
//! - no two writes in a row come less than half a period after the one before: missed
//!   deadlines are skipped, not replayed in a burst.
//!
//! Goals travel as whole ticks (rounded towards the inside near a limit, else to the nearest),
//! so each decoded goal is within one tick of the value the player computed: the step bounds
//! get two ticks of slack, the step-change bound four.

use keypose::bus::{BusError, Health, PingInfo, ServoBus};
use keypose::plan::{retime, Trajectory};
use keypose::player::{play_with_clock, Clock, Outcome, PlayError, PlayOptions, StopSignal};
use keypose::robot::{Robot, ServoModel};
use keypose::sequence::Sequence;
use keypose::testing::VirtualBus;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Plays with no stop request on `clock` (also for tests whose subject is the goals sent,
/// on a virtual clock: they take no wall time and see an idle machine's timing).
pub(crate) fn play_on(
    bus: &mut dyn ServoBus,
    robot: &Robot,
    trajectory: &Trajectory,
    options: &PlayOptions,
    clock: &dyn Clock,
) -> Result<(Outcome, keypose::player::Stats), PlayError> {
    play_with_clock(
        bus,
        robot,
        trajectory,
        options,
        &StopSignal::default(),
        clock,
    )
}

/// A small deterministic generator (xorshift64*), so every case can be replayed by its seed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.next()
    }
}

/// Virtual time: waiting jumps to the deadline, plus jitter, plus now and then a stall. The
/// stall comes either before the thread wakes (the cycle begins late) or, with
/// `after_wake`, right after the thread has read the clock on waking (the cycle began on time,
/// then the thread was preempted before its goal went out).
struct StallingClock {
    state: Mutex<ClockState>,
}

struct ClockState {
    now: f64,
    rng: Rng,
    period: f64,
    /// Chance that a wait ends in a stall, and the stall lengths (seconds).
    stall_chance: f64,
    stall_range: (f64, f64),
    stalls: u64,
    after_wake: bool,
    /// A stall drawn at the last wait, due after the next reading of the clock.
    pending: f64,
}

impl StallingClock {
    fn new(seed: u64, period: f64, stall_chance: f64, stall_range: (f64, f64)) -> Self {
        Self {
            state: Mutex::new(ClockState {
                now: 0.0,
                rng: Rng::new(seed),
                period,
                stall_chance,
                stall_range,
                stalls: 0,
                after_wake: false,
                pending: 0.0,
            }),
        }
    }
    /// Stalls come right after the first reading of the clock that follows a wait.
    fn after_wake(self) -> Self {
        self.state.lock().unwrap().after_wake = true;
        self
    }
    fn seconds(&self) -> f64 {
        self.state.lock().unwrap().now
    }
    fn stalls(&self) -> u64 {
        self.state.lock().unwrap().stalls
    }
}

impl Clock for StallingClock {
    fn now(&self) -> Duration {
        let mut s = self.state.lock().unwrap();
        let now = s.now;
        s.now += std::mem::take(&mut s.pending);
        Duration::from_secs_f64(now)
    }
    fn sleep_until(&self, deadline: Duration, _: &StopSignal, _: u32) {
        let mut s = self.state.lock().unwrap();
        s.now = s.now.max(deadline.as_secs_f64());
        // Jitter up to 0.4 of a period: late, but never late enough to count as a stall.
        let jitter = s.rng.range(0.0, 0.4) * s.period;
        s.now += jitter;
        if s.rng.next() < s.stall_chance {
            let (low, high) = s.stall_range;
            let stall = s.rng.range(low, high);
            if s.after_wake {
                s.pending = stall;
            } else {
                s.now += stall;
            }
            s.stalls += 1;
        }
    }
}

/// The native driver, with the clock time of every goal write noted (the goals themselves are
/// taken from the virtual servos' received bytes).
struct TimedWrites<'a> {
    inner: &'a mut dyn ServoBus,
    clock: &'a StallingClock,
    times: Vec<f64>,
}

impl ServoBus for TimedWrites<'_> {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        self.inner.ping(id)
    }
    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        self.inner.read_positions(ids)
    }
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        self.times.push(self.clock.seconds());
        self.inner.write_goals(goals)
    }
    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        self.inner.set_torque(ids, on)
    }
    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        self.inner.read_health(ids)
    }
    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        self.inner.read_homing_offsets(servos)
    }
}

/// The SO-101 as a robot file of another name would be, with no collision model: the random
/// poses below go through the desk and the arm itself, which the player's approach guard
/// refuses (tests/motion/clearance.rs has those refusals); the limiter under stalls is these
/// tests' subject.
fn so101_without_collision_model() -> Robot {
    let mut robot = Robot::builtin("so101").unwrap();
    robot.name = "so101-limiter-only".into();
    assert!(keypose::collision::CollisionModel::for_robot(&robot).is_none());
    robot
}

/// A random sequence over every joint of the SO-101, made to pass the limit check at `rate` by
/// retiming when `valid` (as `keypose play` requires); left as drawn otherwise.
fn random_trajectory(robot: &Robot, rng: &mut Rng, rate: f64, valid: bool) -> Trajectory {
    let modes = ["cubic", "monotone", "linear"];
    let mode = modes[(rng.next() * 3.0) as usize % 3];
    let keys = 3 + (rng.next() * 4.0) as usize;
    let mut time = 0.0;
    let mut text = Vec::new();
    for _ in 0..keys {
        let joints: Vec<String> = robot
            .joints
            .iter()
            .map(|j| {
                let value = rng.range(j.limits.min, j.limits.max) * 0.8;
                format!("\"{}\":{value}", j.name)
            })
            .collect();
        text.push(format!(
            "{{\"time\":{time},\"joints\":{{{}}}}}",
            joints.join(",")
        ));
        time += rng.range(0.2, 0.9);
    }
    let json = format!(
        "{{\"format\":\"keypose-sequence/1\",\"robot\":\"so101\",\"interpolation\":\"{mode}\",\"keyframes\":[{}]}}",
        text.join(",")
    );
    let mut sequence = Sequence::from_json("random.json", &json).unwrap();
    if valid {
        sequence = retime(&sequence, robot, rate).unwrap().sequence;
    }
    Trajectory::build(&sequence, robot).unwrap()
}

/// Decoded goals (joint values per write) with their write times, checked against the bounds.
struct Checked {
    /// Largest step as a share of `v·T`, and largest step change as a share of `a·T²` (over
    /// the tick slack), in the second after a stall.
    step_after_stall: f64,
    step_after_stall_net: f64,
    change_after_stall: f64,
    stalls_seen: u64,
}

fn check_goals(robot: &Robot, rate: f64, times: &[f64], goals: &[(u8, i64)]) -> Checked {
    let period = 1.0 / rate;
    let n = robot.joints.len();
    assert_eq!(
        goals.len(),
        times.len() * n,
        "one sync write per goal write"
    );
    let tick = 360.0 / 4096.0;
    let values: Vec<Vec<f64>> = goals
        .chunks(n)
        .map(|cycle| {
            cycle
                .iter()
                .zip(&robot.joints)
                .map(|(&(id, t), joint)| {
                    assert_eq!(id, joint.servo.id);
                    joint.servo.value(t)
                })
                .collect()
        })
        .collect();
    let mut result = Checked {
        step_after_stall: 0.0,
        step_after_stall_net: 0.0,
        change_after_stall: 0.0,
        stalls_seen: 0,
    };
    let mut last_stall = f64::NEG_INFINITY;
    for k in 0..values.len() {
        for (j, joint) in robot.joints.iter().enumerate() {
            assert!(
                joint.limits.contains(values[k][j]),
                "{} received {}",
                joint.name,
                values[k][j]
            );
        }
        if k == 0 {
            continue;
        }
        if k == 1 {
            // The first cycle repeats the goal written to hold the arm before torque came on.
            assert_eq!(values[1], values[0], "the first cycle moved");
            continue;
        }
        let gap = times[k] - times[k - 1];
        // Absolute deadlines: after a late cycle the next one comes early, once. A replay of
        // missed deadlines is a run of writes back to back.
        let short = |g: f64| g < 0.5 * period;
        assert!(
            !(short(gap) && short(times[k - 1] - times[k - 2])),
            "goals {} and {k} came in a burst: {:.4} s and {:.4} s apart (period {period})",
            k - 1,
            times[k - 1] - times[k - 2],
            gap
        );
        let stalled = gap > 1.5 * period;
        if stalled {
            last_stall = times[k];
            result.stalls_seen += 1;
        }
        let after_stall = times[k] - last_stall <= 1.0;
        for (j, joint) in robot.joints.iter().enumerate() {
            let (v, a) = (joint.limits.velocity, joint.limits.acceleration);
            let step = values[k][j] - values[k - 1][j];
            assert!(
                step.abs() <= v * period + 2.0 * tick,
                "{}: step {step:.4}° at goal {k} ({:.3} s) beyond v·T = {:.4}°",
                joint.name,
                times[k],
                v * period
            );
            let previous = values[k - 1][j] - values[k - 2][j];
            let reference = if stalled {
                previous * period / gap
            } else {
                previous
            };
            let change = step - reference;
            assert!(
                change.abs() <= a * period * period + 4.0 * tick,
                "{}: step change {change:.4}° at goal {k} ({:.3} s, gap {gap:.4} s) beyond a·T² = {:.4}°",
                joint.name,
                times[k],
                a * period * period
            );
            if after_stall {
                result.step_after_stall = result.step_after_stall.max(step.abs() / (v * period));
                result.step_after_stall_net = result
                    .step_after_stall_net
                    .max((step.abs() - 2.0 * tick).max(0.0) / (v * period));
                result.change_after_stall = result
                    .change_after_stall
                    .max((change.abs() - 4.0 * tick).max(0.0) / (a * period * period));
            }
        }
    }
    result
}

#[test]
fn after_thousands_of_stalls_no_goal_step_exceeds_the_limits_over_one_period() {
    let robot = so101_without_collision_model();
    let rates = [25.0, 50.0, 100.0, 200.0];
    let mut stalls = 0;
    let mut worst_step: f64 = 0.0;
    let mut worst_step_net: f64 = 0.0;
    let mut worst_change: f64 = 0.0;
    for case in 0..24u64 {
        let mut rng = Rng::new(case + 1);
        let rate = rates[case as usize % rates.len()];
        // Every third case plays a sequence as drawn, breaking the limits: the limiter's bound
        // must hold for it too.
        let valid = case % 3 != 0;
        let trajectory = random_trajectory(&robot, &mut rng, rate, valid);
        let period = 1.0 / rate;
        // Stalls from just over the 1.5-period threshold to 0.6 s, in about one wait in eight.
        let clock = StallingClock::new(case + 101, period, 0.12, (0.6 * period, 0.6));
        let (mut native, virtual_bus) = VirtualBus::in_process(&robot);
        let mut bus = TimedWrites {
            inner: &mut native,
            clock: &clock,
            times: Vec::new(),
        };
        let options = PlayOptions {
            readback_every: Some(4),
            max_stall: 10.0,
            // Stalls in one wait in eight on purpose: not a machine to judge.
            max_stalls_per_second: None,
            ..PlayOptions::new(rate)
        };
        let (outcome, stats) = play_on(&mut bus, &robot, &trajectory, &options, &clock)
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        assert_eq!(outcome, Outcome::Finished, "case {case}");
        let times = bus.times.clone();
        let checked = check_goals(&robot, rate, &times, &virtual_bus.lock().goals_received());
        // The player counted the stalls the test saw; the cycle that finds the timeline over
        // writes nothing, so it may have counted one more.
        let unseen = stats.pacing.stalls - checked.stalls_seen;
        assert!(
            unseen <= 1,
            "case {case}: {unseen} stalls not seen on the wire"
        );
        assert!(stats.pacing.time_lost > 0.0);
        // How late the playback really ran, on the test's clock: from the first goal to the
        // last, against the approach and the trajectory's own time. What the player tells
        // says the same, to a few periods (each end's cycle, the approach's last step); the
        // stalls' held time alone falls seconds short of it (the time lost coming back up to
        // speed after each).
        let wall = times.last().unwrap() - times.first().unwrap();
        let planned = stats.approach_seconds + trajectory.duration();
        let late = wall - planned;
        assert!(
            (late - stats.late).abs() <= 3.0 * period,
            "case {case}: ran {late:.3} s late, told {:.3} s ({:.3} s of stalls)",
            stats.late,
            stats.pacing.time_lost
        );
        stalls += clock.stalls();
        worst_step = worst_step.max(checked.step_after_stall);
        worst_step_net = worst_step_net.max(checked.step_after_stall_net);
        worst_change = worst_change.max(checked.change_after_stall);
        eprintln!(
            "case {case}: {rate} Hz, {} trajectory, {} stalls, {} deadlines skipped, {:.2} s lost, limiter engaged {} times",
            if valid { "valid" } else { "limit-breaking" },
            clock.stalls(),
            stats.pacing.skipped_deadlines,
            stats.pacing.time_lost,
            stats.limited_goals
        );
    }
    eprintln!(
        "{stalls} stalls: within 1 s after a stall, the largest step is {:.3} of v·T on the wire ({:.3} beyond the two ticks of rounding), the largest step change {:.3} of a·T² beyond its four ticks",
        worst_step, worst_step_net, worst_change
    );
    assert!(stalls >= 1000, "only {stalls} stalls injected");
}

#[test]
fn a_delay_after_a_cycle_began_on_time_is_bounded_by_the_time_since_the_last_write() {
    // The cycle begins on time, then the thread is preempted before its goal goes out: the gap
    // between cycle starts looks ordinary, but the arm held the last goal for the whole delay.
    // The same oracle as above, with the write times the clock gave, must hold.
    let robot = so101_without_collision_model();
    let mut late_writes = 0;
    for case in 0..12u64 {
        let mut rng = Rng::new(case + 1);
        let rate = [50.0, 100.0][case as usize % 2];
        let period = 1.0 / rate;
        let trajectory = random_trajectory(&robot, &mut rng, rate, case % 3 != 0);
        let clock = StallingClock::new(case + 301, period, 0.12, (0.6 * period, 0.3)).after_wake();
        let (mut native, virtual_bus) = VirtualBus::in_process(&robot);
        let mut bus = TimedWrites {
            inner: &mut native,
            clock: &clock,
            times: Vec::new(),
        };
        let options = PlayOptions {
            readback_every: Some(4),
            max_stall: 10.0,
            // Stalls in one wait in eight on purpose: not a machine to judge.
            max_stalls_per_second: None,
            ..PlayOptions::new(rate)
        };
        let (outcome, _) = play_on(&mut bus, &robot, &trajectory, &options, &clock)
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        assert_eq!(outcome, Outcome::Finished, "case {case}");
        let times = bus.times.clone();
        let checked = check_goals(&robot, rate, &times, &virtual_bus.lock().goals_received());
        late_writes += checked.stalls_seen;
    }
    assert!(late_writes >= 100, "only {late_writes} late writes");
}

#[test]
fn ordinary_playback_with_jitter_never_needs_the_limiter() {
    // The examples pass `keypose check`; with jitter but no stall the limiter must stay idle,
    // so what the arm does is exactly the checked curve.
    for (file, robot_name) in [
        ("sequences/so101_wave.json", "so101"),
        ("sequences/so101_pick_place.json", "so101"),
        ("sequences/koch_wave.json", "koch"),
        ("sequences/omx_reach.json", "omx"),
    ] {
        let robot = Robot::builtin(robot_name).unwrap();
        let sequence = Sequence::load(std::path::Path::new(file)).unwrap();
        let trajectory = Trajectory::build(&sequence, &robot).unwrap();
        let rate = robot.control_hz;
        let clock = StallingClock::new(7, 1.0 / rate, 0.0, (0.0, 0.0));
        let (mut bus, _virtual_bus) = VirtualBus::in_process(&robot);
        let options = PlayOptions {
            readback_every: Some(10),
            ..PlayOptions::new(rate)
        };
        let (outcome, stats) = play_on(&mut bus, &robot, &trajectory, &options, &clock).unwrap();
        assert_eq!(outcome, Outcome::Finished);
        assert_eq!(stats.pacing.stalls, 0, "{file}");
        assert_eq!(
            stats.limited_goals, 0,
            "{file}: limiter changed goals by up to {}",
            stats.largest_limiter_correction
        );
    }
}

#[test]
fn a_stall_beyond_the_bound_brakes_to_rest_and_is_a_fault_naming_the_stall() {
    let robot = Robot::builtin("so101").unwrap();
    let sequence = Sequence::load(std::path::Path::new("sequences/so101_wave.json")).unwrap();
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    // One stall of 0.4 s about two seconds in (a wait in ~200 at 100 Hz); no jitter.
    let clock = Arc::new(OneStall {
        now: Mutex::new(0.0),
        waits: Mutex::new(0),
        at_wait: 200,
        seconds: 0.4,
    });
    let (mut native, virtual_bus) = VirtualBus::in_process(&robot);
    let error = play_on(
        &mut native,
        &robot,
        &trajectory,
        &PlayOptions::new(100.0),
        clock.as_ref(),
    )
    .expect_err("a 400 ms stall is beyond the 250 ms bound");
    match &error {
        PlayError::Stall { held, bound, .. } => {
            // Held 0.4 s beyond its 10 ms period (the cycle began 0.41 s after the last).
            assert!((held - 0.4).abs() < 1e-6, "{held}");
            assert_eq!(*bound, 0.25);
        }
        other => panic!("expected a stall fault, got {other}"),
    }
    assert!(error.to_string().contains("stalled"), "{error}");
    // It braked along the path: goals after the stall come to rest, torque stays on.
    let goals = virtual_bus.lock().goals_received();
    let n = robot.joints.len();
    let cycles = goals.len() / n;
    let at_rest = |k: usize| (0..n).all(|j| goals[k * n + j].1 == goals[(k - 1) * n + j].1);
    assert!(at_rest(cycles - 1), "still moving at the end");
    assert!(cycles > 201, "no braking after the stall: {cycles} writes");
    assert!(virtual_bus.lock().servos.iter().all(|s| s.motion.torque));
}

#[test]
fn a_rate_the_machine_cannot_keep_up_with_is_said_within_the_first_second_and_braked() {
    // Every wait ends 1.2 periods late (as at 1 kHz on a machine that wakes the thread 1.2 ms
    // late): every goal is held two periods, and the path never gets back up to speed.
    let robot = Robot::builtin("so101").unwrap();
    let sequence = Sequence::load(std::path::Path::new("sequences/so101_wave.json")).unwrap();
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    let rate = 1000.0;
    let clock = Overrunning {
        now: Mutex::new(0.0),
        overrun: 1.2 / rate,
    };
    let (mut native, virtual_bus) = VirtualBus::in_process(&robot);
    let played = play_on(
        &mut native,
        &robot,
        &trajectory,
        &PlayOptions::new(rate),
        &clock,
    );
    let error = match played {
        Err(error) => error,
        Ok((outcome, stats)) => panic!(
            "played on ({outcome:?}) through {} stalls, {:.1} s late",
            stats.pacing.stalls, stats.pacing.time_lost
        ),
    };
    match &error {
        PlayError::CannotKeepUp { overrun, at } => {
            // Told within the first second of playback: 50 stalls, one per cycle.
            assert!(*at <= 1.0, "told at {at} s");
            assert_eq!(overrun.stalls, 50);
            assert_eq!(overrun.rate_hz, 1000.0);
        }
        other => panic!("expected the machine not to keep up, got {other}"),
    }
    let text = error.to_string();
    assert!(text.contains("cannot keep up with 1000 Hz"), "{text}");
    assert!(text.contains("lower rate"), "{text}");
    // It braked along the path to rest, torque on.
    let goals = virtual_bus.lock().goals_received();
    let n = robot.joints.len();
    let cycles = goals.len() / n;
    let at_rest = |k: usize| (0..n).all(|j| goals[k * n + j].1 == goals[(k - 1) * n + j].1);
    assert!(at_rest(cycles - 1), "still moving at the end");
    assert!(virtual_bus.lock().servos.iter().all(|s| s.motion.torque));
}

/// Virtual time in which every wait ends `overrun` after its deadline.
struct Overrunning {
    now: Mutex<f64>,
    overrun: f64,
}

impl Clock for Overrunning {
    fn now(&self) -> Duration {
        Duration::from_secs_f64(*self.now.lock().unwrap())
    }
    fn sleep_until(&self, deadline: Duration, _: &StopSignal, _: u32) {
        let mut now = self.now.lock().unwrap();
        *now = now.max(deadline.as_secs_f64()) + self.overrun;
    }
}

/// Virtual time with a single stall at one chosen wait.
struct OneStall {
    now: Mutex<f64>,
    waits: Mutex<u64>,
    at_wait: u64,
    seconds: f64,
}

impl Clock for OneStall {
    fn now(&self) -> Duration {
        Duration::from_secs_f64(*self.now.lock().unwrap())
    }
    fn sleep_until(&self, deadline: Duration, _: &StopSignal, _: u32) {
        let mut now = self.now.lock().unwrap();
        *now = now.max(deadline.as_secs_f64());
        let mut waits = self.waits.lock().unwrap();
        *waits += 1;
        if *waits == self.at_wait {
            *now += self.seconds;
        }
    }
}
