//! Stop requests (Ctrl-C, a test, the teach UI), counted: the first decelerates, the second
//! holds at once.
//!
//! A request also wakes whoever is waiting for the next control cycle: the player sleeps on
//! this signal instead of in a plain `sleep`, so a stop is acted on at once at any control
//! rate, not after the rest of a long period.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

#[derive(Debug, Clone, Default)]
pub struct StopSignal(Arc<Shared>);

#[derive(Debug, Default)]
struct Shared {
    requests: Mutex<u32>,
    changed: Condvar,
}

impl StopSignal {
    /// Asks for a stop. Safe to call from the Ctrl-C handler's thread.
    pub fn request(&self) {
        let mut requests = self.lock();
        *requests = requests.saturating_add(1);
        self.0.changed.notify_all();
    }

    pub fn count(&self) -> u32 {
        *self.lock()
    }

    /// Sleeps until `deadline`, or until there are more than `seen` requests, whichever comes
    /// first; returns the number of requests then.
    pub fn wait_until(&self, deadline: Instant, seen: u32) -> u32 {
        let mut requests = self.lock();
        loop {
            let now = Instant::now();
            if *requests > seen || now >= deadline {
                return *requests;
            }
            requests = self
                .0
                .changed
                .wait_timeout(requests, deadline - now)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }

    /// [`StopSignal::wait_until`] for a duration.
    pub fn wait_for(&self, duration: Duration, seen: u32) -> u32 {
        self.wait_until(Instant::now() + duration, seen)
    }

    fn lock(&self) -> MutexGuard<'_, u32> {
        // A counter cannot be left inconsistent by a panicking holder.
        self.0
            .requests
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_wakes_a_long_wait_at_once() {
        let stop = StopSignal::default();
        let requester = stop.clone();
        let started = Instant::now();
        let thread = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            requester.request();
        });
        // Without the wake-up this would sleep the whole minute.
        assert_eq!(stop.wait_for(Duration::from_secs(60), 0), 1);
        thread.join().unwrap();
        assert!(started.elapsed() < Duration::from_secs(60));
    }

    #[test]
    fn requests_already_seen_do_not_cut_a_wait_short() {
        let stop = StopSignal::default();
        stop.request();
        let deadline = Instant::now() + Duration::from_millis(30);
        assert_eq!(stop.wait_until(deadline, 1), 1);
        assert!(Instant::now() >= deadline);
    }
}
