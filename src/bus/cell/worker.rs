//! One arm's bus on a thread of its own, so the arms' transactions of one cycle run at the same
//! time instead of one after the other.
//!
//! The thread is started by the first transaction, from the thread that drives the cell: a
//! thread inherits its creator's scheduling, so under `--realtime` the workers run as the
//! control loop does.

use crate::bus::{BusError, ServoBus};
use std::sync::mpsc::{self, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long dropping a worker waits for its thread to end.
const JOIN_WAIT: Duration = Duration::from_secs(1);

type Job = Box<dyn FnOnce(&mut dyn ServoBus) + Send>;

/// The result of part `.0` of a cell's transaction.
pub(super) type Done<T> = (usize, Result<T, BusError>);

pub(super) struct Worker {
    name: String,
    /// The bus until the thread starts.
    idle: Option<Box<dyn ServoBus>>,
    jobs: Option<Sender<Job>>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    pub(super) fn new(name: &str, bus: Box<dyn ServoBus>) -> Worker {
        Worker {
            name: name.to_string(),
            idle: Some(bus),
            jobs: None,
            thread: None,
        }
    }

    /// Hands `job` to the thread; its result comes to `results` as part `place`, so that the
    /// cell takes each arm's result as it comes.
    pub(super) fn start<T: Send + 'static>(
        &mut self,
        job: impl FnOnce(&mut dyn ServoBus) -> Result<T, BusError> + Send + 'static,
        results: &Sender<Done<T>>,
        place: usize,
    ) {
        let sender = results.clone();
        let job: Job = Box::new(move |bus| {
            let _ = sender.send((place, job(bus)));
        });
        let handed = self.jobs().is_some_and(|jobs| jobs.send(job).is_ok());
        if !handed {
            // A thread that cannot start or has ended: said at once rather than waited for.
            let ended = BusError::ThreadEnded;
            let _ = results.send((place, Err(ended)));
        }
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
