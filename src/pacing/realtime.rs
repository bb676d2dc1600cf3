//! `--realtime`: the control thread under SCHED_FIFO and the process's memory locked, where the
//! system permits it; otherwise a one-line notice and the ordinary scheduler.
//!
//! Under SCHED_FIFO the control thread runs as soon as it wakes, ahead of every ordinary
//! process, so a busy machine no longer delays its deadlines; locked memory keeps a page fault
//! (a page swapped out, or touched for the first time) from stalling a cycle. Both need
//! privileges: root, CAP_SYS_NICE / CAP_IPC_LOCK, or the `rtprio` and `memlock` limits
//! (`/etc/security/limits.conf`, e.g. `@audio - rtprio 95` and `@audio - memlock unlimited`).

use std::io;

/// The SCHED_FIFO priority asked for (1 … 99): above the kernel's threaded interrupt handlers'
/// default of 50 would starve the serial adapter's own interrupts, so just below.
pub const PRIORITY: i32 = 49;

/// What `--realtime` obtained.
#[derive(Debug)]
pub struct Realtime {
    /// The SCHED_FIFO priority the calling thread runs at, or why it does not.
    pub scheduling: Result<i32, io::Error>,
    /// Whether the memory is locked, or why not.
    pub memory: Result<(), MemoryNotLocked>,
}

/// Why the memory was left unlocked.
#[derive(Debug, thiserror::Error)]
pub enum MemoryNotLocked {
    /// A finite limit: locking every later allocation too would make the one that crosses it
    /// fail. `limit_kib` is `None` when the limit could not be read.
    #[error("the memlock limit is {}, not unlimited: set `memlock unlimited` in /etc/security/limits.conf", limit_kib.map_or("unknown".to_string(), |l| format!("{l} KiB")))]
    Limited {
        /// The limit, KiB; `None` when it could not be read.
        limit_kib: Option<u64>,
    },
    /// The system refused to lock the memory: what it said.
    #[error("{0}")]
    Refused(io::Error),
}

impl Realtime {
    /// The one-line notices for what was refused (none when everything was granted).
    pub fn notices(&self) -> Vec<String> {
        let mut notices = Vec::new();
        if let Err(e) = &self.scheduling {
            notices.push(format!(
                "--realtime: SCHED_FIFO refused ({e}); running under the ordinary scheduler \
                 (see `keypose doctor`)"
            ));
        }
        if let Err(why) = &self.memory {
            notices.push(format!("--realtime: memory not locked ({why})"));
        }
        notices
    }
}

/// Puts the calling thread under SCHED_FIFO and locks the process's memory, as far as
/// permitted. Threads the caller starts afterwards inherit the policy: a helper thread that
/// must not compete with it calls [`leave`].
pub fn enter() -> Realtime {
    Realtime {
        scheduling: set_fifo(permitted_priority()),
        memory: lock_memory(),
    }
}

/// Puts the calling thread back under the ordinary scheduler (for helper threads started by a
/// real-time thread, such as the log writer).
pub fn leave() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: pid 0 is the calling thread; `param` is valid for SCHED_OTHER.
    unsafe { libc::sched_setscheduler(0, libc::SCHED_OTHER, &param) };
}

/// The priority to ask for: [`PRIORITY`], or lower when the `rtprio` limit says so (an
/// unprivileged process may only go up to its soft RLIMIT_RTPRIO).
fn permitted_priority() -> i32 {
    match rtprio_limit() {
        Some(limit) if limit > 0 && limit < PRIORITY as u64 && !is_root() => limit as i32,
        _ => PRIORITY,
    }
}

fn set_fifo(priority: i32) -> Result<i32, io::Error> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: pid 0 is the calling thread; `param` is a valid sched_param.
    if unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) } == 0 {
        Ok(priority)
    } else {
        Err(io::Error::last_os_error())
    }
}

/// The SCHED_FIFO priority of a thread that stands in for hardware ([`serve_promptly`]): the
/// lowest, below a `--realtime` control thread ([`PRIORITY`]).
pub const SERVING_PRIORITY: i32 = 1;

/// The nice value [`serve_promptly`] falls back to where SCHED_FIFO is refused.
pub const SERVING_NICE: i32 = -10;

/// The scheduling [`serve_promptly`] obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Serving {
    /// SCHED_FIFO at this priority.
    Fifo(i32),
    /// The ordinary scheduler at this nice value.
    Nice(i32),
}

/// Lets the calling thread answer promptly on a busy machine, for a thread that stands in for
/// hardware (the emulated servos): a real servo answers on time whatever the computer is
/// doing, and an emulator starved behind other processes would make its clients see timeouts
/// no real bus gives. SCHED_FIFO at [`SERVING_PRIORITY`] where permitted, else a nice value of
/// [`SERVING_NICE`], else nothing (an ordinary user: the thread runs as before). What it got,
/// for the caller to mention or not.
pub fn serve_promptly() -> Result<Serving, io::Error> {
    if let Ok(priority) = set_fifo(SERVING_PRIORITY) {
        return Ok(Serving::Fifo(priority));
    }
    // SAFETY: gettid has no preconditions; setpriority takes plain integers. PRIO_PROCESS with
    // a thread id sets that thread's nice value on Linux.
    let tid = unsafe { libc::gettid() };
    if unsafe { libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, SERVING_NICE) } == 0 {
        Ok(Serving::Nice(SERVING_NICE))
    } else {
        Err(io::Error::last_os_error())
    }
}

/// `mlockall(MCL_CURRENT | MCL_FUTURE)`, only where every later allocation can be locked too:
/// with a finite `memlock` limit, MCL_FUTURE makes the allocation that crosses it fail, which
/// would abort the process mid-playback, so the memory is then left unlocked.
fn lock_memory() -> Result<(), MemoryNotLocked> {
    let limit = memlock_limit();
    if limit != Some(libc::RLIM_INFINITY) && !is_root() {
        return Err(MemoryNotLocked::Limited {
            limit_kib: limit.map(|l| l / 1024),
        });
    }
    // SAFETY: mlockall takes flags only.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } == 0 {
        Ok(())
    } else {
        Err(MemoryNotLocked::Refused(io::Error::last_os_error()))
    }
}

fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

fn soft_limit(resource: libc::__rlimit_resource_t) -> Option<libc::rlim_t> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `limit` is a valid, writable rlimit.
    (unsafe { libc::getrlimit(resource, &mut limit) } == 0).then_some(limit.rlim_cur)
}

/// The value of an unlimited resource limit.
pub const UNLIMITED: u64 = libc::RLIM_INFINITY;

/// The soft RLIMIT_RTPRIO: the highest real-time priority an unprivileged process may take.
pub fn rtprio_limit() -> Option<u64> {
    soft_limit(libc::RLIMIT_RTPRIO)
}

/// The soft RLIMIT_MEMLOCK, bytes (`RLIM_INFINITY` when unlimited).
pub fn memlock_limit() -> Option<u64> {
    soft_limit(libc::RLIMIT_MEMLOCK)
}

/// Whether this process may put a thread under SCHED_FIFO, found by trying it on a thread
/// started for the purpose (the caller's own scheduling stays as it was); the error when not.
pub fn fifo_permitted() -> Result<i32, io::Error> {
    std::thread::spawn(|| set_fifo(permitted_priority()))
        .join()
        .unwrap_or_else(|_| Err(io::Error::other("the probe thread panicked")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refusal_is_told_in_one_line_naming_what_was_refused() {
        let refused = Realtime {
            scheduling: Err(io::Error::from_raw_os_error(libc::EPERM)),
            memory: Err(MemoryNotLocked::Limited {
                limit_kib: Some(8192),
            }),
        };
        let notices = refused.notices();
        assert_eq!(notices.len(), 2);
        assert_eq!(
            notices[1],
            "--realtime: memory not locked (the memlock limit is 8192 KiB, not unlimited: set \
             `memlock unlimited` in /etc/security/limits.conf)"
        );
        assert!(notices[0].contains("SCHED_FIFO refused") && notices[0].contains("not permitted"));
        assert!(notices.iter().all(|n| !n.contains('\n')));
        let granted = Realtime {
            scheduling: Ok(PRIORITY),
            memory: Ok(()),
        };
        assert!(granted.notices().is_empty());
    }

    #[test]
    fn the_probe_agrees_with_the_rtprio_limit() {
        // Unprivileged with a zero rtprio limit, the kernel refuses SCHED_FIFO with EPERM
        // (sched(7)). Otherwise it is granted, or refused with EPERM only (root in a container
        // without CAP_SYS_NICE): any other error (EINVAL) would mean a bad priority was asked.
        let probe = fifo_permitted();
        if !is_root() && rtprio_limit() == Some(0) {
            assert_eq!(probe.unwrap_err().raw_os_error(), Some(libc::EPERM));
        } else if let Err(e) = probe {
            assert_eq!(e.raw_os_error(), Some(libc::EPERM), "{e}");
        }
    }
}
