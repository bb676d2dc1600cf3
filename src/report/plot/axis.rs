//! Axis maths: data extents, the value-to-pixel map and round 1/2/5 ticks with exact labels.
//!
//! Knows nothing about SVG, text widths or the page layout.

/// Data beyond this magnitude is treated as this magnitude when choosing the axis range, so the
/// span (hi - lo) and the padding can never overflow to infinity.
pub(super) const RANGE_LIMIT: f64 = 1e150;
/// Pixel coordinates are clamped here: wild outliers are clipped anyway, and this keeps the
/// numbers short and finite.
pub(super) const PX_LIMIT: f64 = 1e5;

/// Running min/max over finite values only, so a single NaN sample cannot poison the axis.
pub(super) struct Extent {
    lo: f64,
    hi: f64,
}

impl Extent {
    pub fn new() -> Self {
        Extent {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
        }
    }

    pub fn add(&mut self, v: f64) {
        if v.is_finite() {
            let v = v.clamp(-RANGE_LIMIT, RANGE_LIMIT);
            self.lo = self.lo.min(v);
            self.hi = self.hi.max(v);
        }
    }

    /// Final (lo, hi) with padding; degenerate or empty extents are widened so that every axis
    /// has a strictly positive, finite span and the pixel mapping never divides by zero.
    pub fn finish(self, pad_frac: f64, fallback: (f64, f64)) -> (f64, f64) {
        if self.lo > self.hi {
            return fallback;
        }
        let (lo, hi) = (self.lo, self.hi);
        let span = hi - lo;
        let scale = lo.abs().max(hi.abs());
        // Relative threshold: a span of 1e-12 around 1e6 would round away in f64 and produce
        // duplicate ticks, so treat it like a flat line.
        if span <= scale * 1e-9 {
            let mid = 0.5 * (lo + hi);
            let half = (mid.abs() * 0.1).max(1.0);
            (mid - half, mid + half)
        } else {
            let pad = span * pad_frac;
            (lo - pad, hi + pad)
        }
    }
}

/// Linear map from a value range to a pixel range (`px0` is where `lo` lands).
#[derive(Debug, Clone, Copy)]
pub(super) struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub px0: f64,
    pub px1: f64,
}

impl Axis {
    pub fn px(&self, v: f64) -> f64 {
        let p = self.px0 + (v - self.lo) / (self.hi - self.lo) * (self.px1 - self.px0);
        // NaN cannot reach here (callers filter), but an overflowing ratio can be ±inf.
        p.clamp(-PX_LIMIT, PX_LIMIT)
    }
}

/// A 1/2/5 × 10^k tick step: `mant` × 10^`exp`. Kept in integer form so labels are printed exactly
/// (no `0.30000000000000004`) and so every label on one axis gets the same number of decimals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Step {
    pub mant: i64,
    pub exp: i32,
}

impl Step {
    fn value(self) -> f64 {
        self.mant as f64 * 10f64.powi(self.exp)
    }
}

pub(super) fn nice_step(span: f64, target: f64) -> Step {
    let raw = span / target;
    let mut exp = raw.log10().floor() as i32;
    let f = raw / 10f64.powi(exp);
    let mant = if f <= 1.0 {
        1
    } else if f <= 2.0 {
        2
    } else if f <= 5.0 {
        5
    } else {
        exp += 1;
        1
    };
    Step { mant, exp }
}

/// Ticks inside [lo, hi] with their labels; about `target` of them.
pub(super) fn nice_ticks(lo: f64, hi: f64, target: f64) -> Vec<(f64, String)> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let step = nice_step(span, target);
    let s = step.value();
    // The epsilon keeps a tick that lands exactly on a bound despite rounding in lo / s.
    let first = (lo / s - 1e-9).ceil();
    let last = (hi / s + 1e-9).floor();
    if !(first.is_finite() && last.is_finite()) || last < first || last - first > 50.0 {
        return Vec::new();
    }
    let sci = step.exp >= 6 || step.exp <= -5 || lo.abs().max(hi.abs()) >= 1e7;
    let count = (last - first) as i64;
    (0..=count)
        .map(|k| {
            let i = first as i64 + k;
            let n = i as i128 * step.mant as i128;
            (i as f64 * s, tick_label(n, step.exp, sci))
        })
        .collect()
}

/// Label for the value `n` × 10^`exp`.
fn tick_label(n: i128, exp: i32, sci: bool) -> String {
    if n == 0 {
        return if sci || exp >= 0 {
            "0".to_string()
        } else {
            format!("0.{}", "0".repeat((-exp) as usize))
        };
    }
    let sign = if n < 0 { "-" } else { "" };
    if sci {
        let mut m = n.unsigned_abs();
        let mut e = exp;
        // Move trailing zeros into the exponent so 1500 × 10^4 prints as 1.5e7, not 1.500e7.
        while m != 0 && m / 10 * 10 == m {
            m /= 10;
            e += 1;
        }
        let digits = m.to_string();
        let magnitude = e + digits.len() as i32 - 1;
        let (a, b) = digits.split_at(1);
        return if b.is_empty() {
            format!("{sign}{a}e{magnitude}")
        } else {
            format!("{sign}{a}.{b}e{magnitude}")
        };
    }
    let digits = n.unsigned_abs().to_string();
    if exp >= 0 {
        return format!("{sign}{digits}{}", "0".repeat(exp as usize));
    }
    let frac = (-exp) as usize;
    if digits.len() > frac {
        let (a, b) = digits.split_at(digits.len() - frac);
        format!("{sign}{a}.{b}")
    } else {
        format!("{sign}0.{}{digits}", "0".repeat(frac - digits.len()))
    }
}
