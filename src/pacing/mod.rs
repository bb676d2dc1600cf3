//! Control-cycle pacing: absolute deadlines on a fixed grid, missed deadlines skipped; shared by
//! every loop that paces itself (playback, recording, jogging).
//!
//! Deadlines are `start + k·period`, so ordinary lateness never accumulates. When the process
//! stalls (SIGSTOP, a page fault, CPU steal, a burst of slow answers) the deadlines it missed
//! are skipped, not replayed back to back: replaying them is exactly the burst of goals, each a
//! full period's step apart by only a few milliseconds, that the velocity limits forbid. The
//! stall is measured here; the player hands it to the timeline, which resumes along the path
//! from the rate the arm actually followed during the stall. Stalls that come too often for
//! that to work ([`KeepUp`]) mean the machine cannot keep up with the rate, which is told at
//! once.

pub(crate) mod clock;
mod keep_up;
pub mod machine;
pub use machine::Load;
pub(crate) mod precise;
pub mod realtime;

pub use clock::{Clock, WallClock};
pub use keep_up::{KeepUp, Overrun, MAX_STALLS_PER_SECOND};

use crate::stop::StopSignal;
use std::time::Duration;

/// A cycle that starts more than this many periods after the previous one is a stall: the
/// goal was held for longer than one period, and the path rate is brought down accordingly.
/// Below it is scheduling jitter, which the absolute deadlines absorb.
pub const STALL_PERIODS: f64 = 1.5;

/// Control rates the player, recording and teaching accept, Hz: below 10 Hz the goals are too
/// coarse to follow smoothly, above 1 kHz no supported bus can keep up.
pub const RATE_RANGE_HZ: std::ops::RangeInclusive<f64> = 10.0..=1000.0;

/// How many cycles' lateness are kept for percentiles (the summary figures cover all cycles).
const KEPT_LATENESS: usize = 1 << 20;

/// The start of one control cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CycleStart {
    /// Clock time the cycle began, seconds.
    pub now: f64,
    /// How late it began against its own deadline, seconds.
    pub lateness: f64,
    /// Time since the previous cycle began, seconds (one period when on time; for the first
    /// cycle, one period).
    pub gap: f64,
    /// Deadlines passed over before this cycle.
    pub skipped: u64,
}

impl CycleStart {
    /// Whether the goal before this cycle was held long enough to count as a stall.
    pub fn stalled(&self, period: f64) -> bool {
        is_stall(self.gap, period)
    }
}

/// Whether a goal held `gap` seconds (from one goal to the next) counts as a stall.
pub(crate) fn is_stall(gap: f64, period: f64) -> bool {
    gap > STALL_PERIODS * period
}

/// The share of the path rate the arm really followed over a `gap` between two goals: after a
/// stall the first goal was held for the whole gap, so `period / gap`; otherwise all of it.
pub(crate) fn followed_share(gap: f64, period: f64) -> f64 {
    if is_stall(gap, period) {
        period / gap
    } else {
        1.0
    }
}

/// Lateness over a whole playback: summary figures over every cycle, and the lateness of the
/// first cycles for percentiles (bounded, so `--loop forever` cannot grow it without end).
#[derive(Debug, Clone, Default)]
pub struct LatenessSummary {
    /// Cycles run.
    pub cycles: u64,
    /// Cycles that began after a stall (see [`STALL_PERIODS`]).
    pub stalls: u64,
    /// Deadlines passed over after stalls.
    pub skipped_deadlines: u64,
    /// The longest time a goal was held beyond its period, seconds.
    pub longest_stall: f64,
    /// The latest any cycle began against its deadline, seconds.
    pub max_lateness: f64,
    /// Time by which stalls held the path, seconds: the timeline runs that much later.
    pub time_lost: f64,
    /// Lateness of the first cycles, seconds.
    pub lateness: Vec<f64>,
}

impl LatenessSummary {
    fn add(&mut self, start: &CycleStart, period: f64) {
        self.cycles += 1;
        self.skipped_deadlines += start.skipped;
        self.max_lateness = self.max_lateness.max(start.lateness);
        if start.stalled(period) {
            self.stalls += 1;
            let held = start.gap - period;
            self.longest_stall = self.longest_stall.max(held);
            self.time_lost += held;
        }
        if self.lateness.len() < KEPT_LATENESS {
            self.lateness.push(start.lateness);
        }
    }
}

/// The deadlines of one paced loop, and how late its cycles began.
#[derive(Debug)]
pub(crate) struct Pacer {
    period: f64,
    /// Clock time of deadline 0, seconds.
    anchor: f64,
    /// Index of the next deadline on the grid.
    next: u64,
    previous_start: Option<f64>,
    /// Deadlines passed over by [`Pacer::served_until`] since the last cycle began.
    served_over: u64,
    /// Lateness of every cycle so far.
    pub summary: LatenessSummary,
}

impl Pacer {
    /// Deadlines every `period` seconds from the clock's present time.
    pub fn new(clock: &dyn Clock, period: f64) -> Self {
        Self {
            period,
            anchor: clock.now().as_secs_f64(),
            next: 0,
            previous_start: None,
            served_over: 0,
            summary: LatenessSummary::default(),
        }
    }

    fn deadline(&self, index: u64) -> f64 {
        // u64 · period in f64: exact to well below a microsecond for centuries of cycles.
        self.anchor + index as f64 * self.period
    }

    /// Waits for the next deadline (waking early on a new stop request) and starts a cycle.
    pub fn wait(&mut self, clock: &dyn Clock, stop: &StopSignal, seen: u32) -> CycleStart {
        let due = self.deadline(self.next);
        if clock.now().as_secs_f64() < due {
            clock.sleep_until(Duration::from_secs_f64(due), stop, seen);
        }
        let now = clock.now().as_secs_f64();
        // Past the deadline after this one too: skip to the latest deadline that has passed.
        let latest = self.index_at(now);
        let skipped = latest.saturating_sub(self.next) + std::mem::take(&mut self.served_over);
        let start = CycleStart {
            now,
            lateness: (now - due).max(0.0),
            gap: self.previous_start.map_or(self.period, |p| now - p),
            skipped,
        };
        self.next = self.next.max(latest) + 1;
        self.previous_start = Some(now);
        self.summary.add(&start, self.period);
        start
    }

    /// The cycle's work was done at `at` (clock time, seconds), later than it began when the
    /// thread was delayed after waking: the deadlines up to then are served by it, so the next
    /// cycle waits for the first one after `at` instead of running at once, a second goal
    /// right behind the late one.
    pub fn served_until(&mut self, at: f64) {
        let after = self.index_at(at) + 1;
        if after > self.next {
            self.served_over += after - self.next;
            self.next = after;
        }
    }

    /// The index of the latest deadline at or before clock time `at` (0 before the first).
    fn index_at(&self, at: f64) -> u64 {
        ((at - self.anchor) / self.period).floor().max(0.0) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// A clock that jumps: sleeping moves it to the deadline at once; `stall` adds time.
    #[derive(Default)]
    struct Jumps(Mutex<Duration>);

    impl Jumps {
        fn stall(&self, seconds: f64) {
            *self.0.lock().unwrap() += Duration::from_secs_f64(seconds);
        }
    }

    impl Clock for Jumps {
        fn now(&self) -> Duration {
            *self.0.lock().unwrap()
        }
        fn sleep_until(&self, deadline: Duration, _: &StopSignal, _: u32) {
            let mut now = self.0.lock().unwrap();
            *now = (*now).max(deadline);
        }
    }

    #[test]
    fn on_time_cycles_follow_the_grid() {
        let clock = Jumps::default();
        let stop = StopSignal::default();
        let mut pacer = Pacer::new(&clock, 0.01);
        for k in 0..5 {
            let start = pacer.wait(&clock, &stop, 0);
            assert!((start.now - k as f64 * 0.01).abs() < 1e-12);
            assert_eq!(start.skipped, 0);
            assert!(!start.stalled(0.01));
        }
        assert_eq!(pacer.summary.stalls, 0);
    }

    #[test]
    fn a_stall_skips_the_missed_deadlines_instead_of_replaying_them() {
        let clock = Jumps::default();
        let stop = StopSignal::default();
        let mut pacer = Pacer::new(&clock, 0.01);
        pacer.wait(&clock, &stop, 0); // t = 0
        pacer.wait(&clock, &stop, 0); // t = 0.01
        clock.stall(0.5); // t = 0.51: deadlines 0.02 … 0.51 have all passed
        let late = pacer.wait(&clock, &stop, 0);
        assert!((late.now - 0.51).abs() < 1e-9);
        assert!((late.gap - 0.5).abs() < 1e-9);
        assert!((late.lateness - 0.49).abs() < 1e-9, "{late:?}");
        // Deadlines 0.02 … 0.50 (49 of them) are passed over; this cycle is deadline 0.51's.
        assert_eq!(late.skipped, 49);
        // The next cycle waits for the following deadline: no burst.
        let next = pacer.wait(&clock, &stop, 0);
        assert!((next.now - 0.52).abs() < 1e-9, "{next:?}");
        assert!((next.gap - 0.01).abs() < 1e-9);
        let summary = &pacer.summary;
        assert_eq!((summary.stalls, summary.skipped_deadlines), (1, 49));
        assert!((summary.time_lost - 0.49).abs() < 1e-9);
        assert!((summary.longest_stall - 0.49).abs() < 1e-9);
    }

    #[test]
    fn a_cycle_whose_work_went_out_late_serves_the_deadlines_up_to_then() {
        let clock = Jumps::default();
        let stop = StopSignal::default();
        let mut pacer = Pacer::new(&clock, 0.01);
        pacer.wait(&clock, &stop, 0); // t = 0
        let on_time = pacer.wait(&clock, &stop, 0); // t = 0.01, on time
        assert_eq!(on_time.skipped, 0);
        // Preempted after waking: the work went out at 0.255 s.
        clock.stall(0.245);
        pacer.served_until(0.255);
        // The next cycle is deadline 0.26's, not one at once for 0.25's: deadlines 0.02 …
        // 0.25 (24 of them) were served by the late one.
        let next = pacer.wait(&clock, &stop, 0);
        assert!((next.now - 0.26).abs() < 1e-9, "{next:?}");
        assert_eq!(next.skipped, 24);
        // Work done on time changes nothing.
        pacer.served_until(0.2601);
        let after = pacer.wait(&clock, &stop, 0);
        assert!((after.now - 0.27).abs() < 1e-9, "{after:?}");
        assert_eq!(after.skipped, 0);
    }

    #[test]
    fn deadlines_stay_exact_after_weeks_of_cycles() {
        // Six weeks at 1 kHz is 3.6e9 cycles, past u32::MAX (a 32-bit cycle counter wraps at
        // 49.7 days of 1 kHz and would send the deadlines back in time: a burst).
        let clock = Jumps::default();
        let stop = StopSignal::default();
        let mut pacer = Pacer::new(&clock, 0.001);
        pacer.wait(&clock, &stop, 0);
        let six_weeks = 6.0 * 7.0 * 86_400.0;
        clock.stall(six_weeks);
        let late = pacer.wait(&clock, &stop, 0);
        assert_eq!(late.skipped, 3_628_799_999);
        // The next deadline is one period on, to well within a microsecond.
        let next = pacer.wait(&clock, &stop, 0);
        assert!(
            (next.now - (six_weeks + 0.001)).abs() < 1e-6,
            "{}",
            next.now
        );
        assert!((next.gap - 0.001).abs() < 1e-6);
    }
}
