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
        match self.epoch.checked_add(deadline) {
            Some(at) => {
                stop.wait_until(at, seen);
            }
            None => {
                stop.wait_for(Duration::from_secs(3600), seen);
            }
        }
    }
}
