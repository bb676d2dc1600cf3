//! Where a playback is, for whoever draws it while it plays (the studio's timeline): the
//! sequence time, the phase and the pose commanded, set by the player every cycle and read
//! from another thread.

use std::sync::{Arc, Mutex, PoisonError};

/// A playback's position, shared: the player sets it each cycle ([`PlayOptions::playhead`]),
/// any thread reads it.
///
/// [`PlayOptions::playhead`]: super::PlayOptions::playhead
#[derive(Debug, Clone, Default)]
pub struct Playhead(Arc<Mutex<Option<PlayheadAt>>>);

/// One cycle's position.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayheadAt {
    /// What the timeline was doing ([`crate::plan::Timeline::phase_name`]).
    pub phase: &'static str,
    /// The sequence time of the commanded pose (during a ramp, where the ramp leads), as the
    /// playback log has it.
    pub sequence_time: f64,
    /// The pose commanded in that cycle, in the played robot's joint order and units.
    pub commanded: Vec<f64>,
}

impl Playhead {
    /// The last cycle's position; `None` before the first cycle or once cleared.
    pub fn at(&self) -> Option<PlayheadAt> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Forgets the position (the playback is over).
    pub fn clear(&self) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = None;
    }

    pub(super) fn set(&self, phase: &'static str, sequence_time: f64, commanded: &[f64]) {
        let mut at = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        match at.as_mut() {
            Some(at) => {
                at.phase = phase;
                at.sequence_time = sequence_time;
                at.commanded.clear();
                at.commanded.extend_from_slice(commanded);
            }
            None => {
                *at = Some(PlayheadAt {
                    phase,
                    sequence_time,
                    commanded: commanded.to_vec(),
                })
            }
        }
    }
}
