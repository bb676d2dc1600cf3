//! What the player asks for across a discontinuity, at every phase of its control period.
//!
//! The player sends the curve's value once per period `T`. Where the curve is smooth, the
//! velocity and acceleration it asks for (first and second differences of the goals over `T`)
//! are averages of the curve's own derivatives over one or two periods, so the curve's peaks
//! bound them at any rate and phase. Across a step the velocity is unbounded and across a linear
//! corner the acceleration is: there the player's differences are what the servo is asked for,
//! the step or the corner turned within one period. As functions of the phase `t`,
//!
//! - velocity `(p(t + T/2) − p(t − T/2)) / T` and
//! - acceleration `(p(t + T) − 2·p(t) + p(t − T)) / T²`
//!
//! are polynomials of degree three at most between the times where one of their terms crosses a
//! span boundary, so their worst over every phase is found exactly as the curve's own.

use super::poly::Poly;
use super::spans::{JointCurve, Span};

/// A difference over the control period: the terms `(offset in periods, weight)` and the power
/// of the period it is divided by.
#[derive(Debug, Clone, Copy)]
pub struct Stencil {
    terms: &'static [(f64, f64)],
    power: i32,
}

/// The velocity of the goals, centred on the period it spans.
pub const VELOCITY: Stencil = Stencil {
    terms: &[(0.5, 1.0), (-0.5, -1.0)],
    power: 1,
};

/// The acceleration of the goals, centred on the middle one of three.
pub const ACCELERATION: Stencil = Stencil {
    terms: &[(1.0, 1.0), (0.0, -2.0), (-1.0, 1.0)],
    power: 2,
};

impl Stencil {
    /// How far from its phase the stencil reaches, in periods.
    pub fn reach(&self) -> f64 {
        self.terms.iter().fold(0.0, |m, (o, _)| m.max(o.abs()))
    }
}

/// The stencil's value over every phase in `windows` (sorted, not overlapping), as spans.
pub fn differences(
    curve: &JointCurve,
    stencil: Stencil,
    period: f64,
    windows: &[(f64, f64)],
) -> Vec<Span> {
    let scale = period.powi(-stencil.power);
    let mut out = Vec::new();
    for &(a, b) in windows {
        let cuts = phase_breaks(curve, stencil, period, a, b);
        for w in cuts.windows(2) {
            let (u0, u1) = (w[0], w[1]);
            if u1 <= u0 {
                continue;
            }
            let middle = 0.5 * (u0 + u1);
            let poly = stencil
                .terms
                .iter()
                .fold(Poly::ZERO, |sum, &(offset, weight)| {
                    let at = offset * period;
                    let span = curve.span_at(middle + at);
                    sum.add_scaled(&span.origin_at(u0 + at), weight)
                });
            out.push(Span {
                start: u0,
                end: u1,
                poly: poly.scaled(scale),
            });
        }
    }
    out
}

/// a, b and every phase inside where a term of the stencil meets a span boundary.
fn phase_breaks(curve: &JointCurve, stencil: Stencil, period: f64, a: f64, b: f64) -> Vec<f64> {
    let reach = stencil.reach() * period;
    let spans = &curve.extended;
    let first = spans.partition_point(|s| s.end < a - reach);
    let mut cuts = vec![a, b];
    for span in spans[first..].iter().take_while(|s| s.start <= b + reach) {
        for &(offset, _) in stencil.terms {
            for edge in [span.start, span.end] {
                let t = edge - offset * period;
                if t > a && t < b {
                    cuts.push(t);
                }
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts
}

/// The phases whose stencil reaches one of `times`, merged into sorted disjoint windows.
pub fn windows_around(times: &[f64], stencil: Stencil, period: f64) -> Vec<(f64, f64)> {
    let reach = stencil.reach() * period;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for &t in times {
        let (a, b) = (t - reach, t + reach);
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}
