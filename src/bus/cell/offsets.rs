//! How far apart in time the arms' buses of a cell start the goal write of one cycle.
//!
//! Kept as a histogram of 1 µs bins (and the exact largest offset), so a playback that loops
//! for hours keeps a fixed amount of memory and the percentiles still cover every cycle.

use std::time::{Duration, Instant};

/// Offsets at or beyond this share the last bin (the exact maximum is kept apart).
const RANGE: Duration = Duration::from_millis(50);
const BIN: Duration = Duration::from_micros(1);

/// The spread of the goal writes' start times, over every cycle written to two buses or more.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WriteOffsets {
    /// Cycles measured.
    pub cycles: u64,
    /// The median spread.
    pub median: Duration,
    /// The 99th percentile.
    pub p99: Duration,
    /// The largest.
    pub max: Duration,
}

#[derive(Debug)]
pub(super) struct OffsetRecord {
    bins: Vec<u32>,
    cycles: u64,
    max: Duration,
}

impl Default for OffsetRecord {
    fn default() -> Self {
        OffsetRecord {
            bins: vec![0; (RANGE.as_nanos() / BIN.as_nanos()) as usize],
            cycles: 0,
            max: Duration::ZERO,
        }
    }
}

impl OffsetRecord {
    /// Takes in one cycle: the instants each bus began its write. One bus alone has no offset.
    pub(super) fn add(&mut self, starts: &[Instant]) {
        let (Some(first), Some(last)) = (starts.iter().min(), starts.iter().max()) else {
            return;
        };
        if starts.len() < 2 {
            return;
        }
        let offset = *last - *first;
        let bin = (offset.as_nanos() / BIN.as_nanos()) as usize;
        let last_bin = self.bins.len() - 1;
        self.bins[bin.min(last_bin)] = self.bins[bin.min(last_bin)].saturating_add(1);
        self.cycles += 1;
        self.max = self.max.max(offset);
    }

    pub(super) fn summary(&self) -> WriteOffsets {
        WriteOffsets {
            cycles: self.cycles,
            median: self.quantile(0.5),
            p99: self.quantile(0.99),
            max: self.max,
        }
    }

    /// The nearest-rank quantile `q`, to the bin (never above the exact maximum).
    fn quantile(&self, q: f64) -> Duration {
        if self.cycles == 0 {
            return Duration::ZERO;
        }
        let rank = ((q * self.cycles as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (bin, &count) in self.bins.iter().enumerate() {
            seen += u64::from(count);
            if seen >= rank {
                return (BIN * bin as u32).min(self.max);
            }
        }
        self.max
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_hand_counted_offsets() {
        let t0 = Instant::now();
        let mut record = OffsetRecord::default();
        // 100 cycles: 98 offsets of 10 µs, one of 300 µs, one of 80 ms (beyond the range).
        for _ in 0..98 {
            record.add(&[t0, t0 + Duration::from_micros(10)]);
        }
        record.add(&[t0 + Duration::from_micros(300), t0]);
        record.add(&[
            t0,
            t0 + Duration::from_millis(80),
            t0 + Duration::from_millis(1),
        ]);
        // A cycle written to one bus has no offset.
        record.add(&[t0]);
        let summary = record.summary();
        assert_eq!(summary.cycles, 100);
        assert_eq!(summary.median, Duration::from_micros(10));
        // Rank 99 of 100 is the 300 µs offset.
        assert_eq!(summary.p99, Duration::from_micros(300));
        assert_eq!(summary.max, Duration::from_millis(80));
    }

    #[test]
    fn no_cycle_no_offset() {
        assert_eq!(OffsetRecord::default().summary(), WriteOffsets::default());
    }
}
