//! Waking at a deadline to within a few microseconds: an absolute sleep on the monotonic clock
//! (`clock_nanosleep` with `TIMER_ABSTIME`), then a short spin.
//!
//! A relative sleep (`std::thread::sleep`) measures its duration from whenever the thread got
//! to call it, so the time spent before the call adds to every wait; an absolute sleep names
//! the instant itself. Even so the kernel wakes a sleeping thread late, by its timer slack
//! (50 µs for an ordinary thread) plus the scheduling delay, so the last [`SPIN`] before the
//! deadline is spent polling the clock instead of sleeping.
//!
//! A thread that wakes often for others' sake (the emulated servos answer every bus cycle)
//! would burn a good part of a core in those spins; a [`Waker`] learns how late the kernel
//! wakes its thread at the least and sleeps until that much before the deadline, so that it
//! mostly wakes just after the deadline and seldom spins, and then only for a few microseconds.

use std::cell::Cell;
use std::time::{Duration, Instant};

/// The stretch before a deadline that is spun rather than slept.
pub const SPIN: Duration = Duration::from_micros(50);

/// Sleeps until `deadline`, waking within a few microseconds of it.
pub fn sleep_until(deadline: Instant) {
    reduce_timer_slack();
    if let Some(spin_from) = deadline.checked_sub(SPIN) {
        if Instant::now() < spin_from {
            sleep_absolute(spin_from);
        }
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}

/// Sleeps until `deadline` without spinning: the wake-up may come late by the kernel's
/// scheduling delay, for waits whose lateness nobody measures (an answer that only precedes
/// others of the same exchange).
pub(crate) fn sleep_roughly_until(deadline: Instant) {
    reduce_timer_slack();
    if Instant::now() < deadline {
        sleep_absolute(deadline);
    }
}

/// A thread's precise wake-ups with next to no spin: it sleeps until the deadline less the
/// lateness the kernel's wake-ups have lately had at the least (down at once to an earlier
/// wake-up seen, up by an eighth of the difference after each later one, never above
/// [`SPIN`]), and spins whatever is left. So it mostly wakes a little after the deadline (by
/// how much more than the least the kernel is late this time) and seldom spins, and then only
/// as long as it woke early; it never returns before the deadline.
///
/// On a virtual machine whose timers woke a thread 25–50 µs late (median, measured beside
/// other work), [`sleep_until`] spins for most of its 50 µs every time; the emulated bus's
/// answers, woken by a `Waker`, came 5 µs after their instants at the median (15 µs at the
/// 90th percentile), with next to no spin.
#[derive(Debug, Clone, Default)]
pub(crate) struct Waker {
    lead: Duration,
}

impl Waker {
    /// Sleeps until `deadline`, waking at it or after it by the spread of the kernel's lateness.
    pub(crate) fn sleep_until(&mut self, deadline: Instant) {
        reduce_timer_slack();
        if let Some(wake) = deadline.checked_sub(self.lead) {
            if Instant::now() < wake {
                sleep_absolute(wake);
                self.learn(Instant::now().saturating_duration_since(wake));
            }
        }
        while Instant::now() < deadline {
            std::hint::spin_loop();
        }
    }

    /// Takes in how late the kernel woke the thread this time.
    fn learn(&mut self, late: Duration) {
        let late = late.min(SPIN);
        self.lead = if late <= self.lead {
            late
        } else {
            self.lead + (late - self.lead) / 8
        };
    }
}

/// `clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)` until `deadline` (restarted after a
/// signal). `Instant` reads the same clock on Linux, but exposes no timespec, so the deadline
/// is carried over as an offset from a reading of both clocks taken together.
fn sleep_absolute(deadline: Instant) {
    let Some(target) = monotonic_timespec_of(deadline) else {
        std::thread::sleep(deadline.saturating_duration_since(Instant::now()));
        return;
    };
    loop {
        // SAFETY: `target` is a valid timespec; the remaining-time pointer may be null for an
        // absolute sleep.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &target,
                std::ptr::null_mut(),
            )
        };
        if rc != libc::EINTR {
            return;
        }
    }
}

/// `deadline` as a CLOCK_MONOTONIC timespec.
fn monotonic_timespec_of(deadline: Instant) -> Option<libc::timespec> {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `now` is a valid, writable timespec.
    if unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut now) } != 0 {
        return None;
    }
    let ahead = deadline.saturating_duration_since(Instant::now());
    let nanos = i128::from(now.tv_nsec) + ahead.subsec_nanos() as i128;
    let seconds = i128::from(now.tv_sec) + ahead.as_secs() as i128 + nanos / 1_000_000_000;
    Some(libc::timespec {
        tv_sec: libc::time_t::try_from(seconds).ok()?,
        tv_nsec: (nanos % 1_000_000_000) as libc::c_long,
    })
}

thread_local! {
    static SLACK_REDUCED: Cell<bool> = const { Cell::new(false) };
}

/// Asks the kernel to wake this thread's timers without slack (1 ns instead of 50 µs), once per
/// thread; a refusal only leaves the default slack, which the spin absorbs.
fn reduce_timer_slack() {
    SLACK_REDUCED.with(|done| {
        if !done.replace(true) {
            // SAFETY: PR_SET_TIMERSLACK takes one integer argument and affects this thread only.
            unsafe {
                libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deadline_converts_to_the_monotonic_clock_it_lies_on() {
        // Two seconds ahead of now, as a timespec: compared with a clock_gettime reading taken
        // right after, the difference is two seconds less the time between the two readings.
        let deadline = Instant::now() + Duration::from_secs(2);
        let target = monotonic_timespec_of(deadline).unwrap();
        let mut now = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut now) };
        let ahead =
            (target.tv_sec - now.tv_sec) as f64 + (target.tv_nsec - now.tv_nsec) as f64 * 1e-9;
        assert!((0.0..=2.0).contains(&ahead) && ahead > 1.0, "{ahead}");
        assert!((0..1_000_000_000).contains(&target.tv_nsec));
    }

    #[test]
    fn a_waker_leads_by_the_least_lateness_lately_seen_and_never_more_than_spin() {
        let us = Duration::from_micros;
        let mut waker = Waker::default();
        assert_eq!(waker.lead, Duration::ZERO);
        // Later wake-ups raise the lead by an eighth of the difference each: 0 → 4 → 7.5 µs.
        waker.learn(us(32));
        assert_eq!(waker.lead, us(4));
        waker.learn(us(32));
        assert_eq!(waker.lead, Duration::from_nanos(7_500));
        // An earlier one lowers it at once.
        waker.learn(us(3));
        assert_eq!(waker.lead, us(3));
        // Wake-ups always 40 µs late: the lead approaches 40 µs from below.
        for _ in 0..100 {
            waker.learn(us(40));
        }
        assert!(
            waker.lead > us(39) && waker.lead <= us(40),
            "{:?}",
            waker.lead
        );
        // A very late one counts as SPIN only.
        for _ in 0..1000 {
            waker.learn(us(5_000));
        }
        assert!(waker.lead <= SPIN, "{:?}", waker.lead);
    }

    #[test]
    fn sleeping_until_a_past_deadline_returns_without_waiting_for_anything() {
        // Not a timing check: a deadline already passed must not block (the loop ends).
        sleep_until(Instant::now() - Duration::from_millis(1));
        sleep_until(Instant::now());
        Waker::default().sleep_until(Instant::now() - Duration::from_millis(1));
        sleep_roughly_until(Instant::now() - Duration::from_millis(1));
    }
}
