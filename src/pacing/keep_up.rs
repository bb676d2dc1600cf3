//! Whether the machine keeps up with the control rate.
//!
//! After a stall the player resumes along the path from the rate the arm really followed and
//! climbs back to full rate within the joints' acceleration limits, which takes a tenth of a
//! second or more. Stalls that come more often than that keep the path from ever getting back
//! up to speed: the sequence crawls (at 1 kHz on a loaded machine, 2.9 s of sequence in 132 s,
//! told only at the end). That is not jitter to ride out but a rate this machine cannot serve,
//! so it is told as soon as it shows, with what the cycles took.

use std::collections::VecDeque;

/// Stalls within one second at which the machine does not keep up with the rate: one every
/// 20 ms, when the path needs a tenth of a second or more to come back to full rate after each,
/// holds it at a small fraction of its rate (a crawl). At 100 Hz and below that takes every
/// cycle running two periods late (a stall is a goal held over 1.5 periods); at 500 Hz and
/// 1 kHz the ordinary scheduling delays of a loaded machine are enough. A single long stall,
/// or the few a second of a busy machine at 100 Hz (about 20 beside six busy loops), stay
/// below it.
pub const MAX_STALLS_PER_SECOND: usize = 50;

/// How many cycles' work durations are kept for the median.
const KEPT_WORK: usize = 256;

/// The machine did not keep up: `stalls` stalls within `within` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Overrun {
    /// The loop's rate, hertz.
    pub rate_hz: f64,
    /// Stalls within `within` seconds (the bound the loop was judged by).
    pub stalls: usize,
    /// Seconds from the first of those stalls to the last.
    pub within: f64,
    /// The longest time one of them held a goal beyond its period, seconds.
    pub longest_hold: f64,
    /// The median time a cycle's own work took (from its start to its end: the goal write,
    /// read-backs, the log), seconds; 0 when no cycle had ended yet.
    pub median_work: f64,
}

impl Overrun {
    /// The highest usual control rate below the one asked for whose period leaves the cycle's
    /// own work at most half of it; `None` when even 10 Hz does not.
    pub fn fitting_rate(&self) -> Option<f64> {
        [500.0, 250.0, 200.0, 100.0, 50.0, 25.0, 10.0]
            .into_iter()
            .find(|&rate| rate < self.rate_hz && 2.0 * self.median_work <= 1.0 / rate)
    }

    /// Whether the cycles' own work fills most of the period (a lower rate is the cure), rather
    /// than the scheduler waking the thread late (real-time scheduling is).
    pub fn work_bound(&self) -> bool {
        2.0 * self.median_work * self.rate_hz > 1.0
    }
}

/// Counts stalls over a sliding second and keeps the recent cycles' work durations.
#[derive(Debug, Clone)]
pub struct KeepUp {
    rate_hz: f64,
    bound: usize,
    /// Clock time and hold of the latest stalls, at most `bound` of them.
    stalls: VecDeque<(f64, f64)>,
    work: VecDeque<f64>,
}

impl KeepUp {
    /// Judges a loop at `rate_hz`: `bound` stalls within one second are an overrun.
    pub fn new(rate_hz: f64, bound: usize) -> Self {
        Self {
            rate_hz,
            bound: bound.max(1),
            stalls: VecDeque::with_capacity(bound.max(1)),
            work: VecDeque::with_capacity(KEPT_WORK),
        }
    }

    /// A cycle's own work took `seconds`.
    pub fn worked(&mut self, seconds: f64) {
        if self.work.len() == KEPT_WORK {
            self.work.pop_front();
        }
        self.work.push_back(seconds);
    }

    /// A stall at clock time `at` held a goal `held` seconds beyond its period. Returns the
    /// overrun once `bound` stalls fall within one second.
    pub fn stalled(&mut self, at: f64, held: f64) -> Option<Overrun> {
        if self.stalls.len() == self.bound {
            self.stalls.pop_front();
        }
        self.stalls.push_back((at, held));
        let (first, _) = *self.stalls.front()?;
        if self.stalls.len() < self.bound || at - first > 1.0 {
            return None;
        }
        Some(Overrun {
            rate_hz: self.rate_hz,
            stalls: self.stalls.len(),
            within: at - first,
            longest_hold: self.stalls.iter().map(|&(_, h)| h).fold(0.0, f64::max),
            median_work: self.median_work(),
        })
    }

    fn median_work(&self) -> f64 {
        let mut work: Vec<f64> = self.work.iter().copied().collect();
        work.sort_by(f64::total_cmp);
        work.get(work.len() / 2).copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifty_stalls_within_a_second_are_an_overrun_and_spread_out_they_are_not() {
        let mut keep_up = KeepUp::new(1000.0, MAX_STALLS_PER_SECOND);
        // One stall every 25 ms for 5 s: 40–41 in any second, never 50.
        for k in 0..200 {
            assert_eq!(keep_up.stalled(f64::from(k) * 0.025, 0.001), None, "{k}");
        }
        // Then one every 16 ms: the 50th within a second of the first of them is an overrun.
        let mut keep_up = KeepUp::new(1000.0, MAX_STALLS_PER_SECOND);
        for _ in 0..9 {
            keep_up.worked(0.0009);
        }
        for k in 0..49 {
            assert_eq!(keep_up.stalled(f64::from(k) * 0.016, 0.002), None, "{k}");
        }
        let overrun = keep_up.stalled(0.784, 0.003).unwrap();
        assert_eq!(overrun.stalls, 50);
        assert!((overrun.within - 0.784).abs() < 1e-12);
        assert_eq!(overrun.longest_hold, 0.003);
        assert_eq!(overrun.median_work, 0.0009);
        // 0.9 ms of work fills most of a 1 ms period; 500 Hz leaves it under half of 2 ms.
        assert!(overrun.work_bound());
        assert_eq!(overrun.fitting_rate(), Some(500.0));
    }

    #[test]
    fn light_work_points_at_the_scheduler_not_at_the_rate() {
        let overrun = Overrun {
            rate_hz: 100.0,
            stalls: 50,
            within: 0.5,
            longest_hold: 0.03,
            median_work: 0.0004,
        };
        assert!(!overrun.work_bound());
        assert_eq!(overrun.fitting_rate(), Some(50.0));
    }
}
