//! How a fit is measured: the worst sample over all joints, how far a change of keys reaches,
//! and the scores and bounds a judgement of a window works with.

use super::{BLOCK, SLIDE_AFTER, SLIDE_BEFORE};
use crate::curve::Interp;

/// The largest deviation of every sample over all joints, as a share of the joint's tolerance,
/// with per-block maxima so that the worst sample is found in O(N/BLOCK + BLOCK).
pub(super) struct Deviation {
    values: Vec<f64>,
    block_max: Vec<f64>,
}

impl Deviation {
    pub(super) fn new(n: usize) -> Self {
        Self {
            values: vec![0.0; n],
            block_max: vec![0.0; n.div_ceil(BLOCK)],
        }
    }

    /// Replaces the values from sample `start` on.
    pub(super) fn set(&mut self, start: usize, values: &[f64]) {
        if values.is_empty() {
            return;
        }
        self.values[start..start + values.len()].copy_from_slice(values);
        for block in start / BLOCK..=(start + values.len() - 1) / BLOCK {
            let end = ((block + 1) * BLOCK).min(self.values.len());
            self.block_max[block] = self.values[block * BLOCK..end]
                .iter()
                .copied()
                .fold(0.0, f64::max);
        }
    }

    /// The worst sample and its deviation.
    pub(super) fn worst(&self) -> (usize, f64) {
        let mut best_block = 0;
        for (b, &m) in self.block_max.iter().enumerate() {
            if m > self.block_max[best_block] {
                best_block = b;
            }
        }
        let start = best_block * BLOCK;
        let end = (start + BLOCK).min(self.values.len());
        let mut best = (start, self.values[start]);
        for k in start..end {
            if self.values[k] > best.1 {
                best = (k, self.values[k]);
            }
        }
        best
    }
}

/// How far a change of keys reaches, in segments and keys.
#[derive(Debug, Clone, Copy)]
pub(super) struct Window {
    /// Segments before and after the keys whose neighbours changed that can change shape.
    pub(super) before: usize,
    pub(super) after: usize,
    /// Keys of context beyond the judged segments, so that their keys get the slopes of the
    /// whole track.
    pub(super) context: usize,
}

impl Window {
    pub(super) fn for_modes(modes: &[Interp]) -> Window {
        if modes.contains(&Interp::Monotone) {
            // A key whose neighbour changed gets a new slope; monotone limiting of the segments
            // on either side of it can then scale the slopes of the keys beyond, which shape one
            // more segment on each side (and limiting runs left to right, so the slope of the key
            // before the judged segments depends on the segment before it too).
            Window {
                before: 2,
                after: 1,
                context: 2,
            }
        } else {
            // Catmull-Rom: a key's slope depends on its two neighbours only.
            Window {
                before: 1,
                after: 0,
                context: 1,
            }
        }
    }

    /// The segments to judge after the keys at positions `lo..=hi` of a list of `len` keys got
    /// new neighbours: (first, last), or None when there is no segment.
    pub(super) fn segments(&self, len: usize, lo: usize, hi: usize) -> Option<(usize, usize)> {
        if len < 2 {
            return None;
        }
        Some((
            lo.saturating_sub(self.before),
            (hi + self.after).min(len - 2),
        ))
    }

    /// The keys (first, last positions) of the sub-track that judges segments `first..=last`.
    pub(super) fn keys(&self, len: usize, first: usize, last: usize) -> (usize, usize) {
        (
            first.saturating_sub(self.context),
            (last + 1 + self.context).min(len - 1),
        )
    }

    /// Keys on either side of a removal-with-slides that its outcome depends on: the sliding
    /// keys, the segments their moves reach, and context.
    pub(super) fn slide_depends(&self) -> usize {
        SLIDE_BEFORE.max(SLIDE_AFTER) + 2 + self.before.max(self.after) + self.context
    }
}

/// Largest and sum of squared normalised deviations over a window.
#[derive(Debug, Clone, Copy)]
pub(super) struct Score {
    pub(super) max: f64,
    pub(super) squares: f64,
}

/// When a judgement may stop: once the largest deviation or the sum of squares passes these.
#[derive(Debug, Clone, Copy)]
pub(super) struct Bound {
    pub(super) max: f64,
    pub(super) squares: f64,
}

impl Bound {
    pub(super) const NONE: Bound = Bound {
        max: f64::INFINITY,
        squares: f64::INFINITY,
    };

    pub(super) fn max(max: f64) -> Bound {
        Bound {
            max,
            squares: f64::INFINITY,
        }
    }

    pub(super) fn squares(squares: f64) -> Bound {
        Bound {
            max: f64::INFINITY,
            squares,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_sample_is_found_across_blocks() {
        let mut d = Deviation::new(200);
        d.set(0, &[0.5; 200]);
        d.set(130, &[0.7, 2.0, 0.1]);
        assert_eq!(d.worst(), (131, 2.0));
        d.set(131, &[0.0]);
        assert_eq!(d.worst(), (130, 0.7));
    }
}
