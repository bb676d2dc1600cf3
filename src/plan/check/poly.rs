//! Polynomials of low degree on a span of time, and where they peak: what makes the limit check
//! exact. A segment's curve is a cubic in its path time (a quintic for a smooth segment); a
//! segment with a timing profile (`plan::timing`) runs through its path time as a quadratic of
//! real time between the profile's knots (a cubic for a jerk-limited S-curve profile), so its
//! curve is the quintic of a quadratic or of a cubic there: degree fifteen at most. Between
//! its ends a polynomial's extremes are at the roots of its derivative, found by isolating them
//! between the roots of the next derivative (down to a quadratic, in closed form) and bisecting
//! each to the last bit; between two such points it is monotone, so it crosses a level at most
//! once there.

/// Highest degree a span's polynomial has: a quintic path composed with a cubic timing.
pub const MAX_DEGREE: usize = 15;
/// Highest degree of a segment's curve in path time (`curve::Interp::Smooth`'s quintic).
const PATH_DEGREE: usize = 5;
const LEN: usize = MAX_DEGREE + 1;

/// `c0 + c1·x + … + c15·x¹⁵`, x in seconds from the start of the span it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Poly(pub [f64; LEN]);

impl Poly {
    pub const ZERO: Poly = Poly([0.0; LEN]);

    pub fn constant(value: f64) -> Poly {
        let mut c = [0.0; LEN];
        c[0] = value;
        Poly(c)
    }

    /// `c0 + c1·x + c2·x² + …` from its coefficients, lowest power first (at most
    /// [`MAX_DEGREE`] + 1 of them).
    pub fn new(c: &[f64]) -> Poly {
        let mut out = [0.0; LEN];
        out[..c.len()].copy_from_slice(c);
        Poly(out)
    }

    /// The cubic `c0 + c1·x + c2·x² + c3·x³`.
    pub fn cubic(c: [f64; 4]) -> Poly {
        Poly::new(&c)
    }

    /// The coefficients up to the highest power with one other than 0 (`[c0]` for a constant),
    /// lowest power first: what an export writes for a span (`interop::c_export`).
    pub fn coefficients(&self) -> &[f64] {
        &self.0[..=self.degree()]
    }

    /// The highest power with a coefficient other than 0 (0 for a constant).
    fn degree(&self) -> usize {
        (0..LEN).rev().find(|&k| self.0[k] != 0.0).unwrap_or(0)
    }

    pub fn eval(&self, x: f64) -> f64 {
        self.0[..=self.degree()]
            .iter()
            .rev()
            .fold(0.0, |sum, &c| sum * x + c)
    }

    pub fn derivative(&self) -> Poly {
        let mut c = [0.0; LEN];
        for k in 1..LEN {
            c[k - 1] = k as f64 * self.0[k];
        }
        Poly(c)
    }

    /// The same polynomial with its origin moved to `d`: `q(x) = p(x + d)` (Taylor shift by
    /// repeated synthetic division).
    pub fn shifted(&self, d: f64) -> Poly {
        let n = self.degree();
        let mut c = self.0;
        for i in 0..n {
            for k in (i..n).rev() {
                c[k] += d * c[k + 1];
            }
        }
        Poly(c)
    }

    /// `p(q(x))` for a cubic `q = q0 + q1·x + q2·x² + q3·x³`; `self` must be a quintic at
    /// most (a segment's curve), so the result stays within [`MAX_DEGREE`].
    pub fn of_cubic(&self, q: [f64; 4]) -> Poly {
        let degree = self.degree();
        debug_assert!(degree <= PATH_DEGREE, "{self:?}");
        let q = Poly::cubic(q);
        // Horner: ((c5·q + c4)·q + …)·q + c0.
        let mut out = Poly::constant(self.0[degree]);
        for k in (0..degree).rev() {
            out = out.times(&q);
            out.0[0] += self.0[k];
        }
        out
    }

    /// The product; the caller keeps the degrees' sum within [`MAX_DEGREE`].
    fn times(&self, other: &Poly) -> Poly {
        let mut c = [0.0; LEN];
        for i in 0..=self.degree() {
            for j in 0..=other.degree() {
                if i + j < LEN {
                    c[i + j] += self.0[i] * other.0[j];
                }
            }
        }
        Poly(c)
    }

    /// `self + k·other`.
    pub fn add_scaled(&self, other: &Poly, k: f64) -> Poly {
        let mut c = self.0;
        for (a, b) in c.iter_mut().zip(&other.0) {
            *a += k * b;
        }
        Poly(c)
    }

    pub fn scaled(&self, k: f64) -> Poly {
        Poly::ZERO.add_scaled(self, k)
    }

    /// 0, the roots of the derivative inside (0, `len`) in order, and `len`: between two
    /// neighbours of this list the polynomial is monotone.
    pub fn monotone_breaks(&self, len: f64) -> Vec<f64> {
        let mut points = vec![0.0];
        points.extend(self.derivative().roots_inside(0.0, len));
        points.push(len);
        points
    }

    /// The largest magnitude over [0, `len`]: at an end or where the derivative vanishes.
    pub fn peak_magnitude(&self, len: f64) -> f64 {
        self.monotone_breaks(len)
            .into_iter()
            .map(|x| self.eval(x).abs())
            .fold(0.0, f64::max)
    }

    /// The roots inside (a, b) where the polynomial changes sign, in order. A quadratic's come
    /// in closed form; a higher degree's are isolated between the roots of its derivative (on
    /// each stretch between them it is monotone) and bisected.
    fn roots_inside(&self, a: f64, b: f64) -> Vec<f64> {
        let degree = self.degree();
        if degree <= 2 {
            let mut roots = quadratic_roots(self.0[2], self.0[1], self.0[0]);
            roots.retain(|x| *x > a && *x < b);
            roots.sort_by(f64::total_cmp);
            return roots;
        }
        let mut points = vec![a];
        points.extend(self.derivative().roots_inside(a, b));
        points.push(b);
        let mut roots = Vec::new();
        for w in points.windows(2) {
            let (fa, fb) = (self.eval(w[0]), self.eval(w[1]));
            if fa != 0.0 && fb != 0.0 && (fa < 0.0) != (fb < 0.0) {
                roots.push(self.crossing(w[0], w[1], 0.0));
            } else if fb == 0.0 && w[1] < b {
                roots.push(w[1]);
            }
        }
        roots.dedup();
        roots
    }

    /// Where the polynomial, monotone on [a, b] and on different sides of `level` at its ends,
    /// meets `level` (bisection to the last bit: the bracket never loses the crossing).
    pub fn crossing(&self, mut a: f64, mut b: f64, level: f64) -> f64 {
        let rising = self.eval(b) > self.eval(a);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if (self.eval(m) > level) == rising {
                b = m;
            } else {
                a = m;
            }
        }
        0.5 * (a + b)
    }
}

/// Real roots of `a·x² + b·x + c` (none when it is identically zero), by the form that does not
/// cancel: `q = −(b + sign(b)·√disc)/2`, roots `q/a` and `c/q`.
fn quadratic_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    if a == 0.0 {
        return if b == 0.0 { Vec::new() } else { vec![-c / b] };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return Vec::new();
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        // b = 0 and c = 0: a double root at 0.
        return vec![0.0];
    }
    vec![q / a, c / q]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_smoothstep_peaks_in_the_middle_and_is_monotone_elsewhere() {
        // 3x² − 2x³ on [0, 1]: its derivative 6x − 6x² vanishes at 0 and 1 only.
        let p = Poly::cubic([0.0, 0.0, 3.0, -2.0]);
        assert_eq!(p.monotone_breaks(1.0), vec![0.0, 1.0]);
        // Its slope 6x − 6x² peaks at x = ½ with 1.5.
        let v = p.derivative();
        assert_eq!(v.monotone_breaks(1.0), vec![0.0, 0.5, 1.0]);
        assert_eq!(v.eval(0.5), 1.5);
    }

    #[test]
    fn shifting_moves_the_origin() {
        let p = Poly::new(&[1.0, -2.0, 0.5, 3.0, -1.0, 0.25, 0.5]);
        let q = p.shifted(0.75);
        for x in [-1.0, 0.0, 0.3, 2.0] {
            let (a, b) = (q.eval(x), p.eval(x + 0.75));
            assert!((a - b).abs() < 1e-12 * b.abs().max(1.0), "{a} {b}");
        }
    }

    #[test]
    fn a_cubic_of_a_quadratic_or_of_a_cubic_is_composed() {
        // p(u) = u³ − u, q(x) = 1 + 2x − x²: p(q(x)) at a few points, by hand.
        let p = Poly::cubic([0.0, -1.0, 0.0, 1.0]);
        let c = p.of_cubic([1.0, 2.0, -1.0, 0.0]);
        for x in [-1.0, 0.0, 0.5, 2.0] {
            let u: f64 = 1.0 + 2.0 * x - x * x;
            assert!((c.eval(x) - (u * u * u - u)).abs() < 1e-12, "x = {x}");
        }
        // Of a cubic, q(x) = x³ − x: degree nine.
        let c = p.of_cubic([0.0, -1.0, 0.0, 1.0]);
        for x in [-1.5, 0.3, 1.2] {
            let u: f64 = x * x * x - x;
            assert!((c.eval(x) - (u * u * u - u)).abs() < 1e-9, "x = {x}");
        }
    }

    #[test]
    fn the_breaks_of_a_sextic_are_its_derivatives_roots() {
        // (x − 1)²(x − 2)²(x − 3)² has slope zero at 1, 2, 3 and between each pair, at
        // 2 ± 1/√3 (the roots of 3x² − 12x + 11, the derivative of (x − 1)(x − 2)(x − 3)).
        let f = |r: f64| Poly::cubic([-r, 1.0, 0.0, 0.0]);
        let p = f(1.0).times(&f(1.0)).times(&f(2.0)).times(&f(2.0));
        let p = p.times(&f(3.0)).times(&f(3.0));
        let breaks = p.monotone_breaks(4.0);
        let third = 1.0 / 3f64.sqrt();
        let expected = [0.0, 1.0, 2.0 - third, 2.0, 2.0 + third, 3.0, 4.0];
        assert_eq!(breaks.len(), expected.len(), "{breaks:?}");
        for (b, e) in breaks.iter().zip(expected) {
            assert!((b - e).abs() < 1e-7, "{breaks:?}");
        }
    }

    #[test]
    fn a_crossing_is_found_to_the_last_bit() {
        // x² − 2 crosses 0 at √2 on [1, 2].
        let p = Poly::cubic([-2.0, 0.0, 1.0, 0.0]);
        assert!((p.crossing(1.0, 2.0, 0.0) - 2f64.sqrt()).abs() < 1e-15);
        // Falling the other way: 2 − x² crosses 1 at 1.
        let p = Poly::cubic([2.0, 0.0, -1.0, 0.0]);
        assert!((p.crossing(0.0, 1.5, 1.0) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn quadratic_roots_do_not_cancel() {
        // x² − 1e8·x + 1: roots ≈ 1e8 and 1e-8; the naive formula loses the small one.
        let mut r = quadratic_roots(1.0, -1e8, 1.0);
        r.sort_by(f64::total_cmp);
        assert!((r[0] - 1e-8).abs() < 1e-20, "{r:?}");
        assert!(quadratic_roots(1.0, 0.0, 1.0).is_empty());
        assert_eq!(quadratic_roots(0.0, 2.0, -1.0), vec![0.5]);
    }
}
