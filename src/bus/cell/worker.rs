//! One arm's bus on a thread of its own, so the arms' transactions of one cycle run at the same
//! time instead of one after the other.
//!
//! The thread is started by the first transaction, from the thread that drives the cell: a
//! thread inherits its creator's scheduling, so under `--realtime` the workers run as the
//! control loop does.

use crate::bus::{BusError, ServoBus};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long dropping a worker waits for its thread to end.
const JOIN_WAIT: Duration = Duration::from_secs(1);

type Job = Box<dyn FnOnce(&mut dyn ServoBus) + Send>;

pub(super) struct Worker {
    name: String,
    /// The bus until the thread starts.
    idle: Option<Box<dyn ServoBus>>,
    jobs: Option<Sender<Job>>,
    thread: Option<JoinHandle<()>>,
}

/// A transaction under way on a worker.
pub(super) struct Pending<T>(Receiver<Result<T, BusError>>);

impl Worker {
    pub(super) fn new(name: &str, bus: Box<dyn ServoBus>) -> Worker {
        Worker {
            name: name.to_string(),
            idle: Some(bus),
            jobs: None,
            thread: None,
        }
    }

    /// Hands `job` to the thread; its result comes through [`Pending::wait`].
    pub(super) fn start<T: Send + 'static>(
        &mut self,
        job: impl FnOnce(&mut dyn ServoBus) -> Result<T, BusError> + Send + 'static,
    ) -> Pending<T> {
        let (done, result) = mpsc::sync_channel(1);
        let job: Job = Box::new(move |bus| {
            let _ = done.send(job(bus));
        });
        // A thread that cannot start or has ended drops the job, and with it `done`: the
        // wait then reports the bus as gone rather than hanging.
        if let Some(jobs) = self.jobs() {
            let _ = jobs.send(job);
        }
        Pending(result)
    }

    fn jobs(&mut self) -> Option<&Sender<Job>> {
        if let Some(mut bus) = self.idle.take() {
            let (jobs, inbox) = mpsc::channel::<Job>();
            let thread = std::thread::Builder::new()
                .name(format!("{} bus", self.name))
                .spawn(move || {
                    for job in inbox {
                        job(bus.as_mut());
                    }
                });
            if let Ok(thread) = thread {
                self.jobs = Some(jobs);
                self.thread = Some(thread);
            }
        }
        self.jobs.as_ref()
    }
}

impl<T> Pending<T> {
    /// The transaction's result, or [`BusError::Hung`] when it takes past `deadline`.
    pub(super) fn wait(self, deadline: Instant, allowed: Duration) -> Result<T, BusError> {
        let hung = || BusError::Hung {
            waited_ms: allowed.as_millis() as u64,
        };
        match self
            .0
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        {
            Ok(result) => result,
            Err(RecvTimeoutError::Timeout) => Err(hung()),
            Err(RecvTimeoutError::Disconnected) => {
                Err(BusError::Protocol("the bus's thread has ended".into()))
            }
        }
    }
}

impl Drop for Worker {
    /// Ends the thread once its queued transactions are done, so the port is closed when the
    /// cell is. A thread stuck in a hung transaction is waited for [`JOIN_WAIT`] only: it ends
    /// with the process.
    fn drop(&mut self) {
        self.jobs = None;
        let Some(thread) = self.thread.take() else {
            return;
        };
        let give_up = Instant::now() + JOIN_WAIT;
        while !thread.is_finished() && Instant::now() < give_up {
            std::thread::sleep(Duration::from_millis(1));
        }
        if thread.is_finished() {
            let _ = thread.join();
        }
    }
}
