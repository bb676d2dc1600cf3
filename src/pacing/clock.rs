//! Where the player's time comes from.
//!
//! The player asks a [`Clock`] what time it is and to wait for the next deadline, instead of
//! calling `Instant::now` and `sleep` itself, so that a test can make time stall (as a
//! SIGSTOP, a page fault or CPU steal would) at chosen cycles, thousands of times, without
//! waiting for any of it.

use crate::stop::StopSignal;
use std::time::{Duration, Instant};

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
