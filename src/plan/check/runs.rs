//! Stretches of time where a quantity is outside its limits, found exactly on spans of
//! polynomials, and how far the quantity reaches.

use super::spans::Span;
use super::Cause;

/// A span of a quantity, the keyframe segment it is reported in and what it comes from.
#[derive(Debug, Clone, Copy)]
pub struct Attributed {
    pub span: Span,
    pub segment: usize,
    pub cause: Cause,
}

/// One stretch outside [low, high] in one segment, with its worst point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Run {
    pub segment: usize,
    /// What the worst point comes from.
    pub cause: Cause,
    pub from: f64,
    pub to: f64,
    pub peak_time: f64,
    pub peak: f64,
    /// The bound crossed: `low` or `high`.
    pub limit: f64,
    pub excess: f64,
}

/// Every stretch of `spans` outside [low, high] by more than rounding, merged where stretches
/// of the same segment past the same bound meet or overlap.
pub fn outside(spans: &[Attributed], low: f64, high: f64) -> Vec<Run> {
    // Tiny tolerance: a key exactly on a limit evaluates to the limit ± rounding.
    let slack = 1e-9 * (high - low).abs().max(1.0);
    let mut runs: Vec<Run> = spans
        .iter()
        .flat_map(|a| span_runs(a, low, high, slack))
        .collect();
    runs.sort_by(|a, b| a.from.total_cmp(&b.from));
    let mut merged: Vec<Run> = Vec::with_capacity(runs.len());
    for run in runs {
        // Any earlier run of the same segment and bound that reaches this one absorbs it.
        let joins = merged
            .iter_mut()
            .rev()
            .find(|m| m.segment == run.segment && m.limit == run.limit && run.from <= m.to + 1e-12);
        match joins {
            Some(m) => {
                m.to = m.to.max(run.to);
                if run.excess > m.excess {
                    m.peak = run.peak;
                    m.peak_time = run.peak_time;
                    m.excess = run.excess;
                    m.cause = run.cause;
                }
            }
            None => merged.push(run),
        }
    }
    merged
}

/// The stretches of one span outside [low − slack, high + slack]: on each stretch between
/// the roots of its derivative the polynomial is monotone, so it leaves a bound at most once.
fn span_runs(attributed: &Attributed, low: f64, high: f64, slack: f64) -> Vec<Run> {
    let Attributed {
        span,
        segment,
        cause,
    } = *attributed;
    let poly = span.poly;
    let breaks = poly.monotone_breaks(span.len());
    let mut runs = Vec::new();
    for w in breaks.windows(2) {
        let (xa, xb) = (w[0], w[1]);
        let (va, vb) = (poly.eval(xa), poly.eval(xb));
        for (limit, level, sign) in [(high, high + slack, 1.0), (low, low - slack, -1.0)] {
            let beyond = |v: f64| sign * (v - level) > 0.0;
            if !beyond(va) && !beyond(vb) {
                continue;
            }
            let (from, to) = match (beyond(va), beyond(vb)) {
                (true, true) => (xa, xb),
                (true, false) => (xa, poly.crossing(xa, xb, level)),
                _ => (poly.crossing(xa, xb, level), xb),
            };
            let (peak_x, peak) = if sign * (va - vb) >= 0.0 {
                (xa, va)
            } else {
                (xb, vb)
            };
            runs.push(Run {
                segment,
                cause,
                from: span.start + from,
                to: span.start + to,
                peak_time: span.start + peak_x,
                peak,
                limit,
                excess: sign * (peak - limit),
            });
        }
    }
    runs
}

/// The smallest and largest value of the spans (∞ and −∞ without any).
pub fn range(spans: &[Span]) -> (f64, f64) {
    spans
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |r, s| {
            s.poly
                .monotone_breaks(s.len())
                .into_iter()
                .map(|x| s.poly.eval(x))
                .fold(r, |(lo, hi), v| (lo.min(v), hi.max(v)))
        })
}

/// The largest magnitude on the spans (0 without any).
pub fn peak(spans: &[Span]) -> f64 {
    if spans.is_empty() {
        return 0.0;
    }
    let (lo, hi) = range(spans);
    lo.abs().max(hi.abs())
}
