//! Section 2: the player's lateness, at the cycle's start (what the player reports) and at the
//! goal write (what the servos feel), streaming a 10 s cubic on so101's shoulder_pan to the
//! wire-timed emulated bus with the native driver.
//!
//! The player runs on a [`RecordingClock`] over keypose's serial transport wrapped in
//! [`Stamped`]: the log holds, in order, every reading of the clock and every goal write. A cycle
//! reads the clock when it starts (its `now` after the wait for its deadline) and once more just
//! before the pose is computed and written, so the start of the cycle whose goals a write
//! carries is the second-to-last reading before that write. Its deadline is that start less the
//! lateness the player recorded for it, and the lateness at the write is the stamp less the
//! deadline. Each deadline found that way must lie on the player's grid (a whole number of
//! periods from the first one): a cycle that does not is counted as unmatched, and printed.

use super::stamps::{Event, Log, RecordingClock, Stamped};
use crate::common::{self, Spread};
use keypose::bus::NativeBus;
use keypose::plan::Trajectory;
use keypose::player::{play_with_clock, Outcome, PlayOptions, StopSignal};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::testing::PtyServer;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Interleaved repetitions of each configuration.
pub const REPS: usize = 3;

/// A slow cubic on one joint, 10 s long, well inside so101's limits (±110°, 115°/s): 0 → 30°
/// → 0 on shoulder_pan. The arm starts at home (0), so the approach ramp is the minimum 0.5 s.
const SLOW_PAN: &str = r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"cubic",
  "keyframes":[{"time":0,"joints":{"shoulder_pan":0}},{"time":5,"joints":{"shoulder_pan":30}},
  {"time":10,"joints":{"shoulder_pan":0}}]}"#;

/// A configuration of the player.
#[derive(Clone, Copy)]
pub struct Config {
    pub rate_hz: f64,
    pub readback_every: u32,
}

impl Config {
    pub fn label(&self) -> String {
        format!(
            "{:.0} Hz, read-back every {}",
            self.rate_hz, self.readback_every
        )
    }
}

/// p50, p99 and the largest of some latenesses, milliseconds.
#[derive(Clone, Copy)]
pub struct Tail {
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
}

impl Tail {
    fn of(seconds: &[f64]) -> Tail {
        let mut sorted: Vec<f64> = seconds.iter().map(|s| s * 1e3).collect();
        sorted.sort_by(f64::total_cmp);
        Tail {
            p50: common::quantile(&sorted, 0.5),
            p99: common::quantile(&sorted, 0.99),
            max: sorted.last().copied().unwrap_or(f64::NAN),
        }
    }
}

/// One playback's figures.
pub struct Playback {
    pub cycles: u64,
    pub wall_seconds: f64,
    /// Lateness at the cycle's start, as the player reports it.
    pub at_start: Tail,
    /// Lateness at the goal write.
    pub at_write: Tail,
    /// From the cycle's start to the write's return.
    pub start_to_write: Tail,
    /// How long the transport's write call took.
    pub write_call: Tail,
    /// Cycles whose goals went out more than one period after their deadline.
    pub late_by_a_period: usize,
    /// Cycles whose deadline could not be found on the grid.
    pub unmatched: usize,
    pub steal: String,
}

pub fn playback(config: Config) -> Result<Playback, String> {
    let robot = Robot::builtin("so101").expect("so101 is built in");
    let sequence = Sequence::from_json("slow_pan.json", SLOW_PAN).map_err(|e| e.to_string())?;
    let trajectory = Trajectory::build(&sequence, &robot).map_err(|e| e.to_string())?;
    let server = PtyServer::start(&robot).map_err(|e| e.to_string())?;
    let log: Log = Arc::new(Mutex::new(Vec::new()));
    let transport = Stamped::open(&robot, server.path(), Arc::clone(&log))?;
    let mut bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &robot.servos());
    let clock = RecordingClock::new(Arc::clone(&log));
    let mut options = PlayOptions::new(config.rate_hz);
    options.progress = false;
    options.readback_every = Some(config.readback_every);
    let started = Instant::now();
    let cpu_before = super::steal::cpu_ticks();
    let (outcome, stats) = play_with_clock(
        &mut bus,
        &robot,
        &trajectory,
        &options,
        &StopSignal::default(),
        &clock,
    )
    .map_err(|e| format!("playback failed: {e}"))?;
    let wall_seconds = started.elapsed().as_secs_f64();
    let steal = super::steal::steal_since(cpu_before);
    drop(bus);
    drop(server);
    if outcome != Outcome::Finished {
        return Err(format!("playback ended {outcome:?}"));
    }
    let lateness = &stats.pacing.lateness;
    let period = 1.0 / config.rate_hz;
    let events = log.lock().unwrap_or_else(|p| p.into_inner()).clone();

    // Per goal write: the clock readings since the previous one.
    let mut readings: Vec<f64> = Vec::new();
    let mut writes: Vec<(Vec<f64>, Instant, Instant)> = Vec::new();
    for event in events {
        match event {
            Event::Now(t) => readings.push(t.as_secs_f64()),
            Event::GoalWrite { called, returned } => {
                writes.push((std::mem::take(&mut readings), called, returned))
            }
        }
    }
    // The first goal write holds the arm where it is, before the first cycle.
    let cycles = writes.iter().skip(1).zip(lateness);
    let (mut at_write, mut start_to_write, mut write_call) = (Vec::new(), Vec::new(), Vec::new());
    let (mut first_deadline, mut unmatched) = (None, 0);
    for ((readings, called, returned), &late) in cycles {
        let [.., start, _write_at] = readings[..] else {
            unmatched += 1;
            continue;
        };
        let deadline = start - late;
        let first = *first_deadline.get_or_insert(deadline);
        let periods = (deadline - first) / period;
        if (periods - periods.round()).abs() > 1e-4 {
            unmatched += 1;
            continue;
        }
        let written = clock.seconds_at(*returned);
        at_write.push(written - deadline);
        start_to_write.push(written - start);
        write_call.push((*returned - *called).as_secs_f64());
    }
    if writes.len() != stats.cycles as usize + 1 {
        println!(
            "  (note: {} goal writes for {} cycles and the hold before them)",
            writes.len(),
            stats.cycles
        );
    }
    Ok(Playback {
        cycles: stats.cycles,
        wall_seconds,
        at_start: Tail::of(&lateness[..lateness.len().min(stats.cycles as usize)]),
        late_by_a_period: at_write.iter().filter(|&&l| l > period).count(),
        at_write: Tail::of(&at_write),
        start_to_write: Tail::of(&start_to_write),
        write_call: Tail::of(&write_call),
        unmatched,
        steal,
    })
}

/// Every configuration's repetitions, interleaved. A playback the player ended (on a loaded
/// machine it brakes when it cannot keep up with the rate) is kept as its reason.
pub fn playbacks(configs: &[Config], reps: usize) -> Vec<Vec<Result<Playback, String>>> {
    let mut out: Vec<Vec<Result<Playback, String>>> = configs.iter().map(|_| Vec::new()).collect();
    for _ in 0..reps {
        for (config, runs) in configs.iter().zip(&mut out) {
            runs.push(playback(*config));
        }
    }
    out
}

/// The playbacks that finished, and the first reason of those that did not.
pub fn finished(runs: &[Result<Playback, String>]) -> (Vec<&Playback>, usize, Option<&str>) {
    let done: Vec<&Playback> = runs.iter().filter_map(|r| r.as_ref().ok()).collect();
    let failed = runs.len() - done.len();
    let reason = runs
        .iter()
        .find_map(|r| r.as_ref().err().map(String::as_str));
    (done, failed, reason)
}

/// "p50 / p99 / max" over the repeats, each as its median (range), milliseconds.
pub fn show_tail(runs: &[&Playback], tail: impl Fn(&Playback) -> Tail) -> String {
    format!(
        "{} / {} / {} ms",
        Spread::over(runs, |r| tail(r).p50).show(3),
        Spread::over(runs, |r| tail(r).p99).show(3),
        Spread::over(runs, |r| tail(r).max).show(2),
    )
}
