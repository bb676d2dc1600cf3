//! The local search over key sets: greedy insertion, removal, merging and sliding of keys,
//! each judged on the window of samples a change can reach (see the parent module's method).

use super::measure::{Bound, Deviation, Score, Window};
use super::{joint_track, MAX_START_SPAN, MAX_SWEEPS, SLIDE_AFTER, SLIDE_BEFORE, SLIDE_ROUNDS};
use crate::curve::{CurveError, Interp};
use std::collections::HashSet;

pub(super) struct Problem<'a> {
    times: &'a [f64],
    values: &'a [Vec<f64>],
    modes: &'a [Interp],
    inv_tolerance: Vec<f64>,
    window: Window,
    /// Per-sample deviations of the window being judged (reused between calls).
    scratch: Vec<f64>,
    /// Removals with slides that failed, by the keys they depended on: the same keys fail
    /// again, so later sweeps skip them.
    failed: HashSet<Vec<usize>>,
}

impl<'a> Problem<'a> {
    pub(super) fn new(
        times: &'a [f64],
        values: &'a [Vec<f64>],
        modes: &'a [Interp],
        tolerances: &[f64],
    ) -> Problem<'a> {
        Problem {
            times,
            values,
            modes,
            inv_tolerance: tolerances.iter().map(|t| 1.0 / t).collect(),
            window: Window::for_modes(modes),
            scratch: Vec::new(),
            failed: HashSet::new(),
        }
    }
}

impl Problem<'_> {
    /// Judges segments `first..=last` of the curve through `local` (a run of keys that, beyond
    /// the judged segments, carries context keys or reaches the true ends). Stops early once the
    /// score passes `bound`; with `store`, never stops and leaves every sample's deviation (over
    /// all joints) in `self.scratch`.
    fn score(
        &mut self,
        local: &[usize],
        first: usize,
        last: usize,
        bound: Bound,
        store: bool,
    ) -> Result<Score, CurveError> {
        let (from, to) = (local[first], local[last + 1]);
        if store {
            self.scratch.clear();
            self.scratch.resize(to - from + 1, 0.0);
        }
        let mut score = Score {
            max: 0.0,
            squares: 0.0,
        };
        for (j, series) in self.values.iter().enumerate() {
            let track = joint_track(self.times, series, self.modes, local)?;
            let mut cursor = track.cursor();
            let scale = self.inv_tolerance[j];
            let samples = self.times[from..=to].iter().zip(&series[from..=to]);
            for (i, (&t, &v)) in samples.enumerate() {
                let d = (cursor.sample(t) - v).abs() * scale;
                score.squares += d * d;
                score.max = score.max.max(d);
                if store {
                    let slot = &mut self.scratch[i];
                    *slot = slot.max(d);
                }
            }
            if !store && (score.max > bound.max || score.squares > bound.squares) {
                break;
            }
        }
        Ok(score)
    }

    /// Judges segments `first..=last` of the curve through all of `keys`, on a sub-track.
    fn score_keys(
        &mut self,
        keys: &[usize],
        first: usize,
        last: usize,
        bound: Bound,
    ) -> Result<Score, CurveError> {
        let (a, b) = self.window.keys(keys.len(), first, last);
        self.score(&keys[a..=b], first - a, last - a, bound, false)
    }

    /// The largest deviation of the curve in which `keys[from..to]` are replaced by
    /// `replacement` (samples strictly between `keys[from - 1]` and `keys[to]`), over the samples
    /// the change can reach. Stops early once past `bound`.
    fn trial(
        &mut self,
        keys: &[usize],
        from: usize,
        to: usize,
        replacement: &[usize],
        bound: f64,
    ) -> Result<f64, CurveError> {
        let len = keys.len() - (to - from) + replacement.len();
        let Some((first, last)) =
            self.window
                .segments(len, from.saturating_sub(1), from + replacement.len())
        else {
            return Ok(0.0);
        };
        let (lo, hi) = self.window.keys(len, first, last);
        let local: Vec<usize> = (lo..=hi)
            .map(|i| {
                if i < from {
                    keys[i]
                } else if i < from + replacement.len() {
                    replacement[i - from]
                } else {
                    keys[i - from - replacement.len() + to]
                }
            })
            .collect();
        Ok(self
            .score(&local, first - lo, last - lo, Bound::max(bound), false)?
            .max)
    }

    /// Every sample against the whole tracks into `deviation`; returns the largest deviation.
    fn evaluate_all(
        &mut self,
        keys: &[usize],
        deviation: &mut Deviation,
    ) -> Result<f64, CurveError> {
        if keys.len() < 2 {
            return Ok(0.0);
        }
        self.score(keys, 0, keys.len() - 2, Bound::NONE, true)?;
        deviation.set(0, &self.scratch);
        Ok(deviation.worst().1)
    }

    /// Step 1: a key at the worst sample until every sample fits (as far as windows tell).
    fn insert_until_fit(
        &mut self,
        keys: &mut Vec<usize>,
        deviation: &mut Deviation,
    ) -> Result<(), CurveError> {
        self.evaluate_all(keys, deviation)?;
        loop {
            let (sample, worst) = deviation.worst();
            if worst <= 1.0 {
                return Ok(());
            }
            let p = keys.partition_point(|&k| k < sample);
            keys.insert(p, sample);
            let Some((first, last)) = self.window.segments(keys.len(), p.saturating_sub(1), p + 1)
            else {
                return Ok(());
            };
            let (a, b) = self.window.keys(keys.len(), first, last);
            self.score(&keys[a..=b], first - a, last - a, Bound::NONE, true)?;
            deviation.set(keys[first], &self.scratch);
        }
    }

    /// Steps 1–3 (`slides` false) or 1–4 from `keys`, repeated until a sweep removes nothing and
    /// the whole tracks fit. After MAX_SWEEPS sweeps only insertion runs: a removal judged on a
    /// window that the whole tracks then reject could otherwise alternate with its repair.
    pub(super) fn search(
        &mut self,
        mut keys: Vec<usize>,
        slides: bool,
        deviation: &mut Deviation,
    ) -> Result<Vec<usize>, CurveError> {
        let mut sweeps = 0;
        loop {
            self.insert_until_fit(&mut keys, deviation)?;
            let mut changed = false;
            if sweeps < MAX_SWEEPS {
                let before = keys.len();
                self.remove_while_fit(&mut keys)?;
                self.merge_pairs(&mut keys)?;
                self.remove_while_fit(&mut keys)?;
                if slides {
                    self.remove_with_slides(&mut keys, 1)?;
                    self.remove_with_slides(&mut keys, 2)?;
                }
                // Every accepted move removes a key, so the same count means the same keys.
                changed = keys.len() != before;
                sweeps += 1;
            }
            // The whole tracks are the judge: windows are exact except where monotone limiting
            // carries a change further, which insertion then repairs.
            if self.evaluate_all(&keys, deviation)? <= 1.0 && !changed {
                return Ok(keys);
            }
        }
    }

    /// The recording's own slope at every sample of every joint (central differences; zero at
    /// the ends, where the curve rests).
    fn slopes(&self) -> Vec<Vec<f64>> {
        let t = self.times;
        let n = t.len();
        self.values
            .iter()
            .map(|v| {
                (0..n)
                    .map(|k| {
                        if k == 0 || k + 1 >= n {
                            0.0
                        } else {
                            (v[k + 1] - v[k - 1]) / (t[k + 1] - t[k - 1])
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Whether one segment from sample a to sample b, shaped with the recording's own slopes,
    /// stays within tolerance of the samples between.
    fn segment_fits(&self, slopes: &[Vec<f64>], a: usize, b: usize) -> bool {
        let (ta, h) = (self.times[a], self.times[b] - self.times[a]);
        let mode = self.modes[a];
        for (j, v) in self.values.iter().enumerate() {
            let c = match mode {
                Interp::Step => [v[a], 0.0, 0.0, 0.0],
                Interp::Linear => [v[a], v[b] - v[a], 0.0, 0.0],
                // Smooth is refused before a fit (`fit::unfittable`): here it is the cubic.
                Interp::Cubic | Interp::Monotone | Interp::Smooth => {
                    let (da, db) = (slopes[j][a] * h, slopes[j][b] * h);
                    let delta = v[b] - v[a];
                    [
                        v[a],
                        da,
                        3.0 * delta - 2.0 * da - db,
                        -2.0 * delta + da + db,
                    ]
                }
            };
            for (&t, &value) in self.times[a + 1..b].iter().zip(&v[a + 1..b]) {
                let f = (t - ta) / h;
                let x = c[0] + f * (c[1] + f * (c[2] + f * c[3]));
                if (x - value).abs() * self.inv_tolerance[j] > 1.0 {
                    return false;
                }
            }
        }
        true
    }

    /// A second starting point: the fewest segments when every key had the recording's own
    /// slope, so that a segment depends on its two keys only and the fewest keys are a shortest
    /// path. Assumes (as holds nearly always) that if a segment from a fits, so do the shorter
    /// ones: then the farthest end from each a, found by doubling then halving, is all it needs.
    pub(super) fn start_from_slopes(&self) -> Vec<usize> {
        let n = self.times.len();
        if n <= 2 {
            return (0..n).collect();
        }
        let slopes = self.slopes();
        // Count of segments to reach each sample, and from where.
        let mut count = vec![usize::MAX; n];
        let mut from = vec![0usize; n];
        count[0] = 0;
        for a in 0..n - 1 {
            if count[a] == usize::MAX {
                continue;
            }
            let limit = (n - 1).min(a + MAX_START_SPAN);
            let mut fits = a + 1;
            let mut step = 1;
            let mut fails = None;
            while fits < limit {
                let b = (a + 2 * step).min(limit);
                if self.segment_fits(&slopes, a, b) {
                    fits = b;
                    step *= 2;
                } else {
                    fails = Some(b);
                    break;
                }
            }
            if let Some(mut bad) = fails {
                while bad - fits > 1 {
                    let mid = fits + (bad - fits) / 2;
                    if self.segment_fits(&slopes, a, mid) {
                        fits = mid;
                    } else {
                        bad = mid;
                    }
                }
            }
            for b in a + 1..=fits {
                if count[a] + 1 < count[b] {
                    count[b] = count[a] + 1;
                    from[b] = a;
                }
            }
        }
        let mut keys = vec![n - 1];
        let mut k = n - 1;
        while k > 0 {
            k = from[k];
            keys.push(k);
        }
        keys.reverse();
        keys
    }

    /// The largest deviation without interior key `p` (infinite for the end keys).
    fn removal_cost(&mut self, keys: &[usize], p: usize) -> Result<f64, CurveError> {
        if p == 0 || p + 1 >= keys.len() {
            return Ok(f64::INFINITY);
        }
        self.trial(keys, p, p + 1, &[], f64::INFINITY)
    }

    /// Step 2: remove the key whose removal costs least, while the curve still fits.
    fn remove_while_fit(&mut self, keys: &mut Vec<usize>) -> Result<(), CurveError> {
        let mut cost = Vec::with_capacity(keys.len());
        for p in 0..keys.len() {
            cost.push(self.removal_cost(keys, p)?);
        }
        // A key's cost depends on the keys its window and context span.
        let radius = self.window.before + self.window.after + 2 * self.window.context + 3;
        loop {
            let Some((p, &c)) = cost.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)) else {
                return Ok(());
            };
            if c > 1.0 {
                return Ok(());
            }
            keys.remove(p);
            cost.remove(p);
            let (lo, hi) = (p.saturating_sub(radius), (p + radius).min(keys.len()));
            for (q, slot) in cost.iter_mut().enumerate().take(hi).skip(lo) {
                *slot = self.removal_cost(keys, q)?;
            }
        }
    }

    /// Step 3: one sweep replacing two neighbouring interior keys by the single key between
    /// their neighbours that fits best, where one fits.
    fn merge_pairs(&mut self, keys: &mut Vec<usize>) -> Result<(), CurveError> {
        let mut p = 1;
        while p + 2 < keys.len() {
            let (left, right) = (keys[p - 1], keys[p + 2]);
            let mut best: Option<(usize, f64)> = None;
            for s in left + 1..right {
                let bound = best.map_or(1.0, |b| b.1);
                let d = self.trial(keys, p, p + 2, &[s], bound)?;
                if d <= bound && best.is_none_or(|b| d < b.1) {
                    best = Some((s, d));
                }
            }
            if let Some((s, _)) = best {
                keys.splice(p..p + 2, [s]);
            }
            p += 1;
        }
        Ok(())
    }

    /// Moves interior key `q` to the sample between its neighbours that minimises the squared
    /// deviations of the segments it shapes (the others do not change as it moves): coarse
    /// steps first, then halving around the best. Returns whether it moved.
    fn slide(&mut self, keys: &mut [usize], q: usize) -> Result<bool, CurveError> {
        let (left, right) = (keys[q - 1], keys[q + 1]);
        let current = keys[q];
        let Some((first, last)) = self.window.segments(keys.len(), q - 1, q + 1) else {
            return Ok(false);
        };
        if right - left < 3 {
            return Ok(false);
        }
        let mut best = (
            self.score_keys(keys, first, last, Bound::NONE)?.squares,
            current,
        );
        let mut step = ((right - left) / 8).max(1);
        let mut s = left + 1;
        while s < right {
            self.try_slide(keys, q, s, (first, last), &mut best)?;
            s += step;
        }
        while step > 1 {
            step = step.div_ceil(2);
            let centre = best.1;
            for s in [centre.saturating_sub(step), centre + step] {
                if s > left && s < right {
                    self.try_slide(keys, q, s, (first, last), &mut best)?;
                }
            }
            if step == 1 {
                break;
            }
        }
        keys[q] = best.1;
        Ok(best.1 != current)
    }

    /// Key `q` at sample `s`: the new best (squares, sample) if it beats `best`.
    fn try_slide(
        &mut self,
        keys: &mut [usize],
        q: usize,
        s: usize,
        (first, last): (usize, usize),
        best: &mut (f64, usize),
    ) -> Result<(), CurveError> {
        keys[q] = s;
        let e = self
            .score_keys(keys, first, last, Bound::squares(best.0))?
            .squares;
        if e < best.0 {
            *best = (e, s);
        }
        Ok(())
    }

    /// Step 4: remove `count` neighbouring keys and let the keys around the gap slide to take up
    /// their work; keep the result if it fits. Tries every interior key once, cheapest plain
    /// removal first.
    fn remove_with_slides(
        &mut self,
        keys: &mut Vec<usize>,
        count: usize,
    ) -> Result<(), CurveError> {
        let mut order: Vec<(f64, usize)> = Vec::new();
        for p in 1..keys.len().saturating_sub(1) {
            order.push((self.removal_cost(keys, p)?, keys[p]));
        }
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let depends = self.window.slide_depends();
        for (_, sample) in order {
            let Ok(p) = keys.binary_search(&sample) else {
                continue;
            };
            if p == 0 || p + count >= keys.len() {
                continue;
            }
            // The move itself first: near the ends, several moves share one run of keys.
            let mut signature = vec![count, keys[p]];
            signature.extend_from_slice(
                &keys[p.saturating_sub(depends)..(p + count + depends).min(keys.len())],
            );
            if self.failed.contains(&signature) {
                continue;
            }
            let mut trial = keys.clone();
            trial.drain(p..p + count);
            // Sliding keys, by their new positions: the gap is between p − 1 and p.
            let sliding: Vec<usize> = (p.saturating_sub(SLIDE_BEFORE)..p + SLIDE_AFTER)
                .filter(|&q| q >= 1 && q + 1 < trial.len())
                .collect();
            let Some((first, last)) = self.window.segments(
                trial.len(),
                p.saturating_sub(SLIDE_BEFORE + 1),
                (p + SLIDE_AFTER).min(trial.len() - 1),
            ) else {
                continue;
            };
            for _ in 0..SLIDE_ROUNDS {
                let mut moved = false;
                for &q in &sliding {
                    moved |= self.slide(&mut trial, q)?;
                }
                if !moved {
                    break;
                }
            }
            if self.score_keys(&trial, first, last, Bound::max(1.0))?.max <= 1.0 {
                *keys = trial;
            } else {
                self.failed.insert(signature);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trial_judges_the_replaced_keys() {
        // A line with one sample 3 above it, in linear mode: without a key there, or with the
        // key beside it, that sample is 3 off.
        let times: Vec<f64> = (0..11).map(f64::from).collect();
        let line: Vec<f64> = times.iter().map(|t| 2.0 * t).collect();
        let mut bent = line.clone();
        bent[5] += 3.0;
        let values = vec![bent];
        let modes = vec![Interp::Linear; 11];
        let mut problem = Problem::new(&times, &values, &modes, &[1.0]);
        let keys = [0, 5, 10];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        let without_middle = problem.trial(&keys, 1, 2, &[], f64::INFINITY).unwrap();
        assert!(close(without_middle, 3.0), "{without_middle}");
        let moved = problem.trial(&keys, 1, 2, &[4], f64::INFINITY).unwrap();
        assert!(close(moved, 3.0), "{moved}");
        // A key on the bent sample pulls its neighbours off the line: 4/5 · 13 − 8 = 2.4.
        let inserted = problem.trial(&[0, 10], 1, 1, &[5], f64::INFINITY).unwrap();
        assert!(close(inserted, 2.4), "{inserted}");
    }
}
