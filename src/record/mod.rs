//! Recording by hand and turning a recording into keyframes, in two halves that share only the
//! [`Recording`]:
//!
//! - capture is live, on the bus: [`record`] limps the chosen joints (torque off) and
//!   samples the present pose of the whole arm at the control rate until a stop request or a
//!   duration, then makes the limp joints hold where they were left;
//! - fitting is pure: [`keyframes`] turns the recording into a keyframe list, the fewest keys
//!   whose curve stays within a tolerance of the recording ([`extract()`]), as a [`Sequence`]
//!   that passes `plan::check` — retimed where a hand moved faster than the limits allow,
//!   clamped where it pushed a joint past a software limit.
//!
//! [`Sequence`]: crate::sequence::Sequence

mod capture;
mod extract;
mod fit;

use crate::bus::joint_prefix;
use crate::bus::BusError;
use crate::json::InputError;

pub use capture::{record, HoldError, RecordOptions, MAX_RATE_HZ, MAX_SECONDS};
pub use extract::{deviations, extract, ExtractError, Fit, JointDeviation};
pub use fit::{
    keyframes, unfittable, Clamp, Deviation, Drift, KeyframeOptions, Keyframes, Retimed,
};

/// Why a recording ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// A stop was requested (Ctrl-C).
    Requested,
    /// The duration asked for passed.
    Duration,
    /// [`MAX_SECONDS`] reached.
    Longest,
}

/// The present pose of the whole arm over time.
#[derive(Debug)]
pub struct Recording {
    /// Seconds since the first sample, increasing (as measured: the middle of each read).
    pub times: Vec<f64>,
    /// `values[joint][sample]` for every joint of the robot, in its unit (degrees or metres).
    pub values: Vec<Vec<f64>>,
    /// Which joints were recorded (limp); the others kept their torque.
    pub recorded: Vec<bool>,
    /// Sampling rate asked for, hertz.
    pub rate_hz: f64,
    /// Why the recording ended.
    pub stopped: StopReason,
    /// Samples missing from the recording, and the longest gap between two.
    pub gaps: SampleGaps,
    /// Set when the recording is complete but the limp joints could not all be made to hold
    /// again: some may still be limp.
    pub hold_error: Option<HoldError>,
}

/// Why a recording, or the keyframes made from it, failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The options or the recording do not make sense (the message says which and why).
    #[error("{0}")]
    Invalid(String),
    /// The bus failed while recording; the limp joints were asked to hold where they were.
    #[error("{}{error} (at {at:.3} s)", joint_prefix(joint))]
    Fault {
        /// The joint whose servo failed; `None` when the error names no servo.
        joint: Option<String>,
        /// What failed.
        error: BusError,
        /// Recording time of the failure, seconds.
        at: f64,
    },
    /// The keys could not be extracted from the recording.
    #[error("keyframes: {0}")]
    Extract(#[from] ExtractError),
    /// The keyframes do not make a valid sequence for the robot (a bug if it happens).
    #[error(transparent)]
    Sequence(#[from] InputError),
}

impl RecordError {
    /// What kind of failure this is: a bus fault while recording is the hardware's; a
    /// recording that makes no keys is bad input.
    pub fn kind(&self) -> crate::error::ErrorKind {
        match self {
            RecordError::Fault { .. } => crate::error::ErrorKind::Hardware,
            _ => crate::error::ErrorKind::BadInput,
        }
    }
}

/// Where a recording has no samples for longer than one period: what the hand did there is
/// not known, and the keys are fitted across it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SampleGaps {
    /// Reads that failed (each one a sample missing).
    pub failed_reads: u64,
    /// Cycles that began late after a stall of the process, and the deadlines passed over.
    pub stalls: u64,
    /// Control deadlines passed over in those stalls (each one a sample missing).
    pub skipped_deadlines: u64,
    /// The longest time between two samples, seconds, and where it ended (recording time).
    pub longest: f64,
    /// Recording time at which the longest gap ended, seconds.
    pub longest_at: f64,
}

impl SampleGaps {
    fn sampled(&mut self, times: &[f64], t: f64) {
        if let Some(&previous) = times.last() {
            if t - previous > self.longest {
                self.longest = t - previous;
                self.longest_at = t;
            }
        }
    }

    /// Samples the recording should have and does not.
    pub fn missing(&self) -> u64 {
        self.failed_reads + self.skipped_deadlines
    }
}
