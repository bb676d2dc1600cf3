//! The start gate of a cell's goal write: every arm's thread waits at it until all of them have
//! arrived, then all write at once. Waiting for the last arrival, instead of for an instant
//! fixed ahead of time, costs each cycle only as long as the slowest thread takes to wake.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The longest a thread waits at the gate for the others: one that is later than this (its
/// bus still busy, the scheduler away) is not waited for, and the offset records how late it
/// was.
pub(super) const GATE_WAIT: Duration = Duration::from_millis(2);

#[derive(Debug)]
pub(super) struct Gate {
    expected: usize,
    arrived: AtomicUsize,
    give_up: Instant,
}

impl Gate {
    /// A gate for `expected` threads, opened for whoever waits past [`GATE_WAIT`] from now.
    pub(super) fn new(expected: usize) -> Gate {
        Gate::waiting(expected, GATE_WAIT)
    }

    /// A gate for `expected` threads, opened for whoever waits past `wait` from now.
    fn waiting(expected: usize, wait: Duration) -> Gate {
        Gate {
            expected,
            arrived: AtomicUsize::new(0),
            give_up: Instant::now() + wait,
        }
    }

    /// Arrives, and waits until every thread has (or the wait is over), yielding the CPU
    /// between looks rather than sleeping: a sleeping thread takes tens of microseconds to wake,
    /// which is the offset the gate is there to avoid, while a pure spin would hold a core the
    /// other arm's thread (or, on a virtual bus, its emulated servos) may need.
    pub(super) fn pass(&self) {
        self.arrived.fetch_add(1, Ordering::AcqRel);
        while self.arrived.load(Ordering::Acquire) < self.expected && Instant::now() < self.give_up
        {
            std::thread::yield_now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn the_gate_opens_when_the_last_thread_arrives() {
        // A wait no scheduler delay reaches: the gate opens by the arrival only.
        let gate = Arc::new(Gate::waiting(2, Duration::from_secs(600)));
        let early = {
            let gate = Arc::clone(&gate);
            std::thread::spawn(move || {
                gate.pass();
                Instant::now()
            })
        };
        // The early thread is waiting; it cannot have passed before the second arrival.
        std::thread::sleep(Duration::from_micros(500));
        let arrival = Instant::now();
        gate.pass();
        let passed = early.join().unwrap();
        assert!(
            passed >= arrival,
            "the first thread passed before the second arrived"
        );
    }

    #[test]
    fn a_thread_that_never_comes_is_not_waited_for_beyond_the_bound() {
        let gate = Gate::waiting(2, Duration::from_millis(20));
        // Returns although the second thread never arrives, and only once the wait is over.
        gate.pass();
        assert!(Instant::now() >= gate.give_up);
        assert_eq!(gate.arrived.load(Ordering::Acquire), 1);
    }
}
