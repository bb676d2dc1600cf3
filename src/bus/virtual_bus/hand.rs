//! A hand for the virtual servos: it moves limp servos along a path, as a user moves a real arm
//! with torque off, so that `keypose record` can be tried and tested without an arm.
//!
//! The hand first places the servos at the start of the path, then waits until one of them is
//! told to go limp (a torque-off write, as `record` sends when it starts) and from then on
//! pushes every one of them along the path at about 1 kHz. A servo with torque on resists the
//! hand (its shaft stays where its goal holds it), as a real one does. At the end of the path
//! the hand lets go: the servos stay where it left them. Paths are in Present Position ticks
//! (after each servo's homing offset).

use super::VirtualBus;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

/// How often the hand moves the servos: faster than any control rate keypose samples at, so a
/// recording sees a continuous motion, not the hand's steps.
const PUSH_PERIOD: Duration = Duration::from_millis(1);

/// Where the hand holds each servo at time `t` seconds after it starts moving, in ticks, one
/// per servo in the order given to [`Hand::start`].
pub type HandPath = Box<dyn FnMut(f64, &mut [f64]) + Send>;

/// A running hand; dropping it stops it.
pub struct Hand {
    stop: Arc<AtomicBool>,
    /// The wall-clock instant the hand began to move (none yet), for a test that times what
    /// another process (a browser) shows of the motion against it.
    started_at: Arc<Mutex<Option<SystemTime>>>,
    thread: Option<JoinHandle<()>>,
}

impl Hand {
    /// Starts a hand on `ids` that follows `path` for `duration` seconds once one of them goes
    /// limp.
    pub fn start(bus: VirtualBus, ids: Vec<u8>, duration: f64, path: HandPath) -> Hand {
        let stop = Arc::new(AtomicBool::new(false));
        let started_at = Arc::new(Mutex::new(None));
        let thread = {
            let stop = stop.clone();
            let at = started_at.clone();
            std::thread::spawn(move || {
                // The hand is outside the computer: it moves on time however busy it is (as
                // far as the system lets this thread run first).
                let _ = crate::pacing::realtime::serve_promptly();
                run(&bus, &ids, duration, path, &stop, &at)
            })
        };
        Hand {
            stop,
            started_at,
            thread: Some(thread),
        }
    }

    /// Whether the hand has begun to move the servos.
    pub fn started(&self) -> bool {
        self.started_at().is_some()
    }

    /// When the hand began to move the servos (the wall clock, which other processes on the
    /// machine share), if it has.
    pub fn started_at(&self) -> Option<SystemTime> {
        *self.started_at.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether the hand has finished its path (or was stopped).
    pub fn finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }
}

impl Drop for Hand {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

fn push(bus: &VirtualBus, ids: &[u8], ticks: &[f64]) {
    let mut servos = bus.lock();
    for (&id, &tick) in ids.iter().zip(ticks) {
        if let Some(servo) = servos.servo_mut(id) {
            servo.push_to(tick);
        }
    }
}

fn releases(bus: &VirtualBus, ids: &[u8]) -> u32 {
    let mut servos = bus.lock();
    ids.iter()
        .filter_map(|&id| servos.servo_mut(id).map(|s| s.releases))
        .sum()
}

fn run(
    bus: &VirtualBus,
    ids: &[u8],
    duration: f64,
    mut path: HandPath,
    stop: &AtomicBool,
    started_at: &Mutex<Option<SystemTime>>,
) {
    let mut ticks = vec![0.0; ids.len()];
    path(0.0, &mut ticks);
    push(bus, ids, &ticks);
    let before = releases(bus, ids);
    while releases(bus, ids) == before {
        if stop.load(Ordering::SeqCst) {
            return;
        }
        std::thread::sleep(PUSH_PERIOD);
    }
    let start = Instant::now();
    *started_at.lock().unwrap_or_else(|e| e.into_inner()) = Some(SystemTime::now());
    while !stop.load(Ordering::SeqCst) {
        let t = start.elapsed().as_secs_f64().min(duration);
        path(t, &mut ticks);
        push(bus, ids, &ticks);
        if t >= duration {
            return;
        }
        std::thread::sleep(PUSH_PERIOD);
    }
}
