//! Where the player's time comes from.
//!
//! The player asks a [`Clock`] what time it is and to wait for the next deadline, instead of
//! calling `Instant::now` and `sleep` itself, so that a test can make time stall (as a
//! SIGSTOP, a page fault or CPU steal would) at chosen cycles, thousands of times, without
//! waiting for any of it.

use crate::stop::StopSignal;
use std::time::{Duration, Instant};

/// A source of time for a paced loop: the wall clock, or a virtual one in tests.
pub trait Clock: Send + Sync {
    /// Time since the clock began; never goes backwards.
    fn now(&self) -> Duration;
    /// Waits until `deadline` (a [`Clock::now`] value) or until a stop request beyond the
    /// `seen` ones arrives, whichever comes first.
    fn sleep_until(&self, deadline: Duration, stop: &StopSignal, seen: u32);
}

/// How long before a deadline [`WallClock`] leaves the interruptible wait for the precise sleep:
/// a stop request in that stretch waits for the deadline, at most this long.
const PRECISE_LAST: Duration = Duration::from_millis(2);

/// The monotonic wall clock, waking early on a stop request.
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    epoch: Instant,
}

impl WallClock {
    /// A clock whose time starts at 0 now.
    pub fn new() -> Self {
        Self {
            epoch: Instant::now(),
        }
    }
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for WallClock {
    fn now(&self) -> Duration {
        self.epoch.elapsed()
    }

    fn sleep_until(&self, deadline: Duration, stop: &StopSignal, seen: u32) {
        // `checked_add` keeps an absurd deadline from panicking; such a wait is then only
        // ended by a stop request, which is still acted on at once.
        let Some(at) = self.epoch.checked_add(deadline) else {
            stop.wait_for(Duration::from_secs(3600), seen);
            return;
        };
        // On the stop signal's condition variable until shortly before the deadline, so that
        // a stop request wakes the wait at once; the condition variable's wake-up is too
        // coarse for the deadline itself, so the last stretch is the precise sleep.
        if let Some(coarse_until) = at.checked_sub(PRECISE_LAST) {
            if Instant::now() < coarse_until && stop.wait_until(coarse_until, seen) > seen {
                return;
            }
        }
        if stop.count() > seen {
            return;
        }
        super::precise::sleep_until(at);
    }
}

/// Time that passes only by waiting: each wait ends at once, at its deadline. On it the player
/// sends exactly what it would on a machine that never kept it waiting, as fast as it can
/// compute it, so a test of what reaches the servos (not of the scheduler) neither waits the
/// sequence out nor depends on how busy the machine is.
#[derive(Debug, Default)]
pub struct VirtualClock {
    now: std::sync::Mutex<Duration>,
}

impl VirtualClock {
    /// A clock at time 0.
    pub fn new() -> Self {
        Self::default()
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Duration {
        *self
            .now
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn sleep_until(&self, deadline: Duration, _stop: &StopSignal, _seen: u32) {
        let mut now = self
            .now
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        *now = (*now).max(deadline);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_virtual_clock_moves_only_to_the_deadlines_it_waits_for() {
        let clock = VirtualClock::new();
        let stop = StopSignal::default();
        assert_eq!(clock.now(), Duration::ZERO);
        clock.sleep_until(Duration::from_millis(10), &stop, 0);
        assert_eq!(clock.now(), Duration::from_millis(10));
        // A deadline already past leaves the time where it is: it never goes backwards.
        clock.sleep_until(Duration::from_millis(4), &stop, 0);
        assert_eq!(clock.now(), Duration::from_millis(10));
    }
}
