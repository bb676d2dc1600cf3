//! Which faults end a loop that reads the bus, and which joint a fault names.
//!
//! Shared by everything that reads servos over time (playback, recording): the tolerance for a
//! lost answer is a property of the bus, not of what the reading is for.

use super::driver::{DEFAULT_READ_RETRIES, DEFAULT_TIMEOUT};
use super::{BusError, Health};
use crate::robot::Robot;
use std::time::{Duration, Instant};

/// Consecutive failed read-backs that count as a fault.
pub const MAX_READ_FAILURES: u32 = 3;

/// How long one read takes to fail on its own: every attempt waited out (3 × 40 ms).
const FAILED_READ: Duration = DEFAULT_TIMEOUT.saturating_mul(DEFAULT_READ_RETRIES + 1);

/// The shortest streak of failed reads that counts as a fault, from its first failure to the
/// one that ends it: as long as that takes when each of the [`MAX_READ_FAILURES`] reads fails
/// on its own ((3 − 1) × 3 × 40 ms). A read a cell cut short (see [`super::CellBus`]) fails
/// sooner, so a streak of those is a fault only once it has lasted this long: a bus that is
/// silent for a moment (a busy machine) is not taken for a dead one because its period is
/// short, and a dead one is found as soon as before.
pub const SILENT_FOR: Duration = FAILED_READ.saturating_mul(MAX_READ_FAILURES - 1);

/// Consecutive failed reads. One lost answer is skipped; [`MAX_READ_FAILURES`] in a row, over
/// at least [`SILENT_FOR`], are a fault, reported by the failure that began the streak: on a
/// shared bus a late answer from one servo delays the others' answers, so the later failures
/// name servos that did nothing wrong. A port that is gone, a hung bus (in a cell) or an alarm
/// is a fault at once.
///
/// A read a cell cut short ([`BusError::CutShort`]) is weaker evidence: on a busy machine a
/// healthy servo's answer may not have been read before its cycle's cut. So a streak names its
/// first failure that was waited out in full, and a streak of cut-short reads only names the
/// servo that failed most often in it (the earliest of equals): the silent servo fails every
/// cycle, a servo the machine kept waiting once or twice.
///
/// In a cell each arm's bus has a streak of its own ([`BusError::Arm`] says whose failure it
/// is): a lost answer on one bus says nothing of another, and the fault must name the arm
/// whose bus failed, since that is the arm that stops being served.
#[derive(Debug, Default)]
pub struct ReadStreak {
    buses: Vec<Streak>,
}

#[derive(Debug)]
struct Streak {
    /// None: the bus of a robot of one arm.
    arm: Option<String>,
    failures: u32,
    /// The first failure waited out in full.
    first_full: Option<BusError>,
    /// The failures cut short, in order (a streak lasts [`SILENT_FOR`] or so: a few dozen).
    cut_short: Vec<BusError>,
    /// When the first failure was counted.
    since: Instant,
}

impl Streak {
    fn new(arm: Option<String>, since: Instant) -> Streak {
        Streak {
            arm,
            failures: 0,
            first_full: None,
            cut_short: Vec::new(),
            since,
        }
    }

    fn count(&mut self, error: BusError) {
        self.failures += 1;
        if matches!(error.root(), BusError::CutShort { .. }) {
            self.cut_short.push(error);
        } else if self.first_full.is_none() {
            self.first_full = Some(error);
        }
    }

    /// The failure the streak is reported by (see [`ReadStreak`]).
    fn named(self) -> BusError {
        if let Some(full) = self.first_full {
            return full;
        }
        let times = |servo| self.cut_short.iter().filter(|e| e.servo() == servo).count();
        let most = (0..self.cut_short.len())
            .rev()
            .max_by_key(|&i| times(self.cut_short[i].servo()))
            .expect("a streak has a failure");
        self.cut_short
            .into_iter()
            .nth(most)
            .expect("an index of the list")
    }
}

impl ReadStreak {
    /// A read that every bus answered ends every streak.
    pub fn succeeded(&mut self) {
        self.buses.clear();
    }

    /// Counts a failed read; returns the error to stop with when it ends the tolerance.
    pub fn failed(&mut self, error: BusError) -> Option<BusError> {
        self.failed_at(error, Instant::now())
    }

    /// [`ReadStreak::failed`], the failure counted at `now`.
    fn failed_at(&mut self, error: BusError, now: Instant) -> Option<BusError> {
        if matches!(
            error.root(),
            BusError::Port { .. } | BusError::Alarm { .. } | BusError::Hung { .. }
        ) {
            return Some(error);
        }
        let arm = match &error {
            BusError::Arm { arm, .. } => Some(arm.clone()),
            _ => None,
        };
        let index = match self.buses.iter().position(|s| s.arm == arm) {
            Some(index) => index,
            None => {
                self.buses.push(Streak::new(arm, now));
                self.buses.len() - 1
            }
        };
        self.buses[index].count(error);
        self.ended(index, now)
    }

    /// The streak at `index`, when it has reached the tolerance: the failure it is reported
    /// by, and the streak begun again.
    fn ended(&mut self, index: usize, now: Instant) -> Option<BusError> {
        let streak = &self.buses[index];
        let lasted = now.saturating_duration_since(streak.since);
        let over = streak.failures >= MAX_READ_FAILURES && lasted >= SILENT_FOR;
        over.then(|| self.buses.remove(index).named())
    }
}

/// "joint NAME: " before a fault's message, when the fault names a servo.
pub fn joint_prefix(joint: &Option<String>) -> String {
    joint
        .as_ref()
        .map(|j| format!("joint {j}: "))
        .unwrap_or_default()
}

/// The joint whose servo a bus error names, if it names one.
pub fn faulty_joint(robot: &Robot, error: &BusError) -> Option<String> {
    error
        .servo()
        .and_then(|id| robot.joint_of_servo(id))
        .map(str::to_owned)
}

/// The fault of a servo whose health shows an alarm. In a cell the alarm is its arm's
/// ([`BusError::Arm`]): the servo by its own id on the arm's bus inside, by its cell id outside.
pub fn alarm_error(robot: &Robot, health: &Health) -> BusError {
    let alarm = |id| BusError::Alarm {
        id,
        alarms: health.alarms,
    };
    let index = robot.joints.iter().position(|j| j.servo.id == health.id);
    let Some((arm, index)) = index.and_then(|i| robot.arm_of_joint(i).map(|arm| (arm, i))) else {
        return alarm(health.id);
    };
    let own = arm.robot.joints[index - arm.joints.start].servo.id;
    BusError::Arm {
        arm: arm.name.clone(),
        servo: Some(health.id),
        source: Box::new(alarm(own)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timeout(arm: &str, id: u8) -> BusError {
        BusError::Arm {
            arm: arm.into(),
            servo: Some(id),
            source: Box::new(BusError::Timeout { id, timeout_ms: 40 }),
        }
    }

    fn cut_short(arm: &str, id: u8) -> BusError {
        BusError::Arm {
            arm: arm.into(),
            servo: Some(id),
            source: Box::new(BusError::CutShort { id, waited_ms: 3 }),
        }
    }

    #[test]
    fn a_streak_of_cut_short_reads_names_the_servo_that_failed_most_a_full_wait_first() {
        let t0 = Instant::now();
        let period = Duration::from_millis(10);
        let at = |k: u32| t0 + period * k;
        // A busy machine kept servo 1's answer from being read once; then servo 4 is silent
        // every cycle.
        let mut streak = ReadStreak::default();
        assert!(streak.failed_at(cut_short("right", 1), at(0)).is_none());
        let mut fault = None;
        for k in 1..100 {
            fault = fault.or(streak.failed_at(cut_short("right", 4), at(k)));
        }
        assert_eq!(fault.expect("a fault").servo(), Some(4));
        // Equals: the earliest.
        let mut streak = ReadStreak::default();
        let mut fault = None;
        for k in 0..100 {
            let id = if k % 2 == 0 { 2 } else { 5 };
            fault = fault.or(streak.failed_at(cut_short("right", id), at(k)));
        }
        assert_eq!(fault.expect("a fault").servo(), Some(2));
        // A read waited out in full is stronger evidence than any number cut short.
        let mut streak = ReadStreak::default();
        assert!(streak.failed_at(cut_short("right", 4), at(0)).is_none());
        assert!(streak.failed_at(timeout("right", 6), at(1)).is_none());
        let mut fault = None;
        for k in 2..100 {
            fault = fault.or(streak.failed_at(cut_short("right", 4), at(k)));
        }
        assert_eq!(fault.expect("a fault").servo(), Some(6));
    }

    #[test]
    fn each_arms_bus_keeps_its_own_streak() {
        let mut streak = ReadStreak::default();
        // Reads one failed read's time apart (each waited out its three attempts).
        let t0 = Instant::now();
        let at = |k: u32| t0 + FAILED_READ * k;
        // One lost answer on the left, then the right bus fails three times in a row.
        assert!(streak.failed_at(timeout("left", 1), at(0)).is_none());
        assert!(streak.failed_at(timeout("right", 4), at(1)).is_none());
        assert!(streak.failed_at(timeout("right", 10), at(2)).is_none());
        let fault = streak.failed_at(timeout("right", 11), at(3)).unwrap();
        // The right bus's first failure, not the left's.
        assert!(matches!(&fault, BusError::Arm { arm, servo: Some(4), .. } if arm == "right"));
        // The left streak goes on; a read every bus answered ends it.
        assert!(streak.failed_at(timeout("left", 2), at(4)).is_none());
        streak.succeeded();
        assert!(streak.failed_at(timeout("left", 3), at(5)).is_none());
        assert!(streak.failed_at(timeout("left", 3), at(6)).is_none());
        assert!(streak.failed_at(timeout("left", 3), at(7)).is_some());
    }

    #[test]
    fn reads_cut_short_fail_as_a_streak_only_once_it_has_lasted_a_read_s_attempts() {
        let mut streak = ReadStreak::default();
        let t0 = Instant::now();
        // A cell at 100 Hz cuts a silent arm's read within its 10 ms period: one failure a
        // period. Three of them in 20 ms are not yet a dead bus, nor any number short of the
        // time three reads take to fail on their own.
        let period = Duration::from_millis(10);
        let periods = SILENT_FOR.as_millis() / period.as_millis();
        for k in 0..periods as u32 {
            assert!(
                streak
                    .failed_at(cut_short("right", 1), t0 + period * k)
                    .is_none(),
                "a fault after {k} periods"
            );
        }
        // (3 − 1) × 3 × 40 ms after the first failure, it is.
        let fault = streak.failed_at(cut_short("right", 1), t0 + SILENT_FOR);
        assert!(matches!(fault, Some(BusError::Arm { arm, .. }) if arm == "right"));
    }
}
