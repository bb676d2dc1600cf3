//! Stop requests (Ctrl-C, a test, the teach UI), counted: the first decelerates, the second
//! holds at once; and the process's one signal handler.
//!
//! A request also wakes whoever is waiting for the next control cycle: the player sleeps on
//! this signal instead of in a plain `sleep`, so a stop is acted on at once at any control
//! rate, not after the rest of a long period.
//!
//! A process can register only one handler for SIGINT, SIGTERM and SIGHUP. It is installed
//! here, once, and does what the command running now asked for ([`stop_on_signal`] or
//! [`on_signal`]), so that a second command in the same process (tests) is not left with the
//! first one's handler.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock, PoisonError};
use std::time::{Duration, Instant};

type Action = Box<dyn Fn() + Send>;

/// What the handler does now.
static ACTION: Mutex<Option<Action>> = Mutex::new(None);
/// Whether the handler could be installed (it cannot where another library already has one).
static INSTALLED: OnceLock<bool> = OnceLock::new();

/// A fresh stop signal that Ctrl-C (and SIGTERM, SIGHUP) requests from now on.
pub fn stop_on_signal() -> StopSignal {
    let stop = StopSignal::default();
    let requester = stop.clone();
    on_signal(move || requester.request());
    stop
}

/// Runs `action` on Ctrl-C, SIGTERM or SIGHUP from now on, instead of what ran before. Returns
/// false if no handler could be installed in this process.
pub fn on_signal(action: impl Fn() + Send + 'static) -> bool {
    *ACTION.lock().unwrap_or_else(PoisonError::into_inner) = Some(Box::new(action));
    *INSTALLED.get_or_init(|| {
        ctrlc::set_handler(|| {
            if let Some(action) = ACTION
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .as_ref()
            {
                action();
            }
        })
        .is_ok()
    })
}

/// A count of stop requests shared by clones: the one who asks and the ones who act, across
/// threads.
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

    /// Raises the count of requests to `requests` (a no-op when that many were made already):
    /// what a front end asks for when a stop may already have been requested by a quicker
    /// path (the studio's HTTP thread, a signal), so that one press is never counted twice
    /// and a first "decelerate" never becomes a second "hold at once".
    pub fn request_to(&self, requests: u32) {
        let mut count = self.lock();
        if *count < requests {
            *count = requests;
            self.0.changed.notify_all();
        }
    }

    /// The first request only: decelerate along the path, unless a stop is already under way.
    pub fn soft_stop(&self) {
        self.request_to(1);
    }

    /// How many stops were requested so far: 0 none, 1 decelerate, 2 or more hold at once.
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
    fn a_signal_requests_the_stop_of_the_latest_signal_only() {
        let first = stop_on_signal();
        let second = stop_on_signal();
        assert!(INSTALLED.get().copied().unwrap_or(false));
        // What the handler runs: the latest action.
        ACTION.lock().unwrap().as_ref().unwrap()();
        assert_eq!((first.count(), second.count()), (0, 1));
    }

    #[test]
    fn a_stop_asked_for_twice_by_two_paths_counts_once() {
        let stop = StopSignal::default();
        stop.soft_stop();
        stop.request_to(1);
        assert_eq!(stop.count(), 1, "still decelerating, not holding at once");
        stop.request_to(2);
        stop.soft_stop();
        assert_eq!(stop.count(), 2);
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
