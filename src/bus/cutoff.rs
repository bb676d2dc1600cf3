//! A moment, set from another thread, past which a bus stops waiting for answers.
//!
//! A cell drives each arm's bus on a thread of its own ([`super::cell`]); when one arm's read
//! is still waiting for answers after the others' are in, the cell cuts it short through this,
//! so that a silent bus frees its thread for the arm's next goal instead of holding every arm
//! for its whole timeout. The cell first says from when a cut may come ([`ReadCutoff::watch`]),
//! then, as soon as another arm's read is in, when it comes ([`ReadCutoff::cut`], ahead of
//! time). The driver waits for answers in one wait up to the cut, or up to when one may come
//! ([`super::driver::NativeBus`]); only while the cell has not decided yet (no arm's read in by
//! then: a busy machine) does it look again every [`LOOK_EVERY`]. A thread that wakes often
//! while it waits takes the processor from whoever is to answer it (an emulated bus on a busy
//! machine), which would turn a slow answer into a lost one.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How long a read waits at most between two looks at its cutoff, while a cut may come but
/// the cell has not said when.
pub const LOOK_EVERY: Duration = Duration::from_millis(4);

/// An instant not set.
const NONE: u64 = u64::MAX;

/// When a bus's read stops waiting for answers: set by the cell's thread of another arm,
/// waited up to by the driver ([`ServoBus::set_read_cutoff`](super::ServoBus::set_read_cutoff)).
#[derive(Debug)]
pub struct ReadCutoff {
    /// From when a cut may come, as nanoseconds after `base`; [`NONE`]: none will.
    watch_from: AtomicU64,
    /// The cut, as nanoseconds after `base`; [`NONE`] until there is one.
    at: AtomicU64,
    /// How long a request sent after the cut is still waited for, nanoseconds.
    grace: AtomicU64,
    base: Instant,
}

impl Default for ReadCutoff {
    fn default() -> Self {
        ReadCutoff {
            watch_from: AtomicU64::new(NONE),
            at: AtomicU64::new(NONE),
            grace: AtomicU64::new(0),
            base: Instant::now(),
        }
    }
}

impl ReadCutoff {
    /// A cut may come from `from` on; a request sent after the cut (its thread was not
    /// running: the scheduler's doing, not its bus's) will still get `grace` for its answers.
    pub(crate) fn watch(&self, from: Instant, grace: Duration) {
        self.grace.store(nanos(grace), Ordering::Release);
        self.at.store(NONE, Ordering::Release);
        self.watch_from
            .store(self.since_base(from), Ordering::Release);
    }

    /// Answers are no longer waited for from `at` on (now, or later).
    pub(crate) fn cut(&self, at: Instant) {
        self.at.store(self.since_base(at), Ordering::Release);
    }

    /// No cut will come: answers are waited for as long as the bus's own timeouts say.
    pub(crate) fn clear(&self) {
        self.watch_from.store(NONE, Ordering::Release);
        self.at.store(NONE, Ordering::Release);
    }

    /// From when a cut may come, if one may.
    pub(crate) fn watching(&self) -> Option<Instant> {
        self.instant(&self.watch_from)
    }

    /// Until when a reader that asked at `asked` may wait before it looks at the cutoff again;
    /// `None`: as long as its own deadline.
    pub(crate) fn next_look(&self, asked: Instant, now: Instant) -> Option<Instant> {
        if let Some(at) = self.instant(&self.at) {
            let grace = Duration::from_nanos(self.grace.load(Ordering::Acquire));
            return Some(at.max(asked + grace));
        }
        let from = self.watching()?;
        Some(if now < from { from } else { now + LOOK_EVERY })
    }

    /// Whether the cut has come by `now`: no new attempt is begun.
    pub(crate) fn reached(&self, now: Instant) -> bool {
        self.instant(&self.at).is_some_and(|at| now >= at)
    }

    /// Whether the answers to a request sent at `asked` are no longer waited for at `now`.
    pub(crate) fn passed(&self, asked: Instant, now: Instant) -> bool {
        let grace = Duration::from_nanos(self.grace.load(Ordering::Acquire));
        self.reached(now) && now >= asked + grace
    }

    fn since_base(&self, at: Instant) -> u64 {
        nanos(at.saturating_duration_since(self.base))
    }

    fn instant(&self, field: &AtomicU64) -> Option<Instant> {
        match field.load(Ordering::Acquire) {
            NONE => None,
            nanos => Some(self.base + Duration::from_nanos(nanos)),
        }
    }
}

fn nanos(duration: Duration) -> u64 {
    u64::try_from(duration.as_nanos()).unwrap_or(NONE - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn a_cutoff_is_passed_only_once_cut_and_reached() {
        let cutoff = ReadCutoff::default();
        let now = Instant::now();
        let later = now + Duration::from_secs(3600);
        assert_eq!(cutoff.watching(), None);
        assert!(!cutoff.passed(now, later));
        cutoff.watch(now + 2 * MS, Duration::ZERO);
        assert_eq!(cutoff.watching(), Some(now + 2 * MS));
        assert!(!cutoff.passed(now, later), "watched is not cut");
        cutoff.cut(now + 5 * MS);
        assert!(!cutoff.passed(now, now + 4 * MS));
        assert!(cutoff.passed(now, now + 5 * MS));
        cutoff.clear();
        assert_eq!(cutoff.watching(), None);
        assert!(!cutoff.passed(now, later));
    }

    #[test]
    fn a_reader_waits_in_one_go_up_to_the_cut_or_to_when_one_may_come() {
        let cutoff = ReadCutoff::default();
        let now = Instant::now();
        assert_eq!(cutoff.next_look(now, now), None);
        cutoff.watch(now + 9 * MS, 2 * MS);
        // Undecided: up to when a cut may come, then every LOOK_EVERY.
        assert_eq!(cutoff.next_look(now, now), Some(now + 9 * MS));
        assert_eq!(
            cutoff.next_look(now, now + 10 * MS),
            Some(now + 10 * MS + LOOK_EVERY)
        );
        // Decided: up to the cut, or the grace of a request sent after it.
        cutoff.cut(now + 9 * MS);
        assert_eq!(cutoff.next_look(now, now), Some(now + 9 * MS));
        assert_eq!(
            cutoff.next_look(now + 20 * MS, now + 20 * MS),
            Some(now + 22 * MS)
        );
    }

    #[test]
    fn a_request_sent_after_the_cut_still_gets_its_grace() {
        let cutoff = ReadCutoff::default();
        let now = Instant::now();
        cutoff.watch(now, 3 * MS);
        cutoff.cut(now);
        // Asked 10 ms after the cut: waited for until 13 ms.
        assert!(!cutoff.passed(now + 10 * MS, now + 12 * MS));
        assert!(cutoff.passed(now + 10 * MS, now + 13 * MS));
        // Asked before it: cut at the cut's instant, once its grace is over.
        assert!(cutoff.passed(now - 5 * MS, now));
        assert!(cutoff.reached(now));
    }
}
