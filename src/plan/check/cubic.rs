//! Polynomials of degree three at most on a span of time, and where they peak: what makes the
//! limit check exact. Between its ends a polynomial's extremes are at the roots of its
//! derivative, a quadratic, found in closed form; between two such points it is monotone, so it
//! crosses a level at most once there.

/// `c0 + c1·x + c2·x² + c3·x³`, x in seconds from the start of the span it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cubic(pub [f64; 4]);

impl Cubic {
    pub const ZERO: Cubic = Cubic([0.0; 4]);

    pub fn constant(value: f64) -> Cubic {
        Cubic([value, 0.0, 0.0, 0.0])
    }

    pub fn eval(&self, x: f64) -> f64 {
        let c = &self.0;
        c[0] + x * (c[1] + x * (c[2] + x * c[3]))
    }

    pub fn derivative(&self) -> Cubic {
        let c = &self.0;
        Cubic([c[1], 2.0 * c[2], 3.0 * c[3], 0.0])
    }

    /// The same polynomial with its origin moved to `d`: `q(x) = p(x + d)`.
    pub fn shifted(&self, d: f64) -> Cubic {
        let c = &self.0;
        Cubic([
            self.eval(d),
            c[1] + d * (2.0 * c[2] + d * 3.0 * c[3]),
            c[2] + d * 3.0 * c[3],
            c[3],
        ])
    }

    /// `self + k·other`.
    pub fn add_scaled(&self, other: &Cubic, k: f64) -> Cubic {
        let mut c = self.0;
        for (a, b) in c.iter_mut().zip(&other.0) {
            *a += k * b;
        }
        Cubic(c)
    }

    pub fn scaled(&self, k: f64) -> Cubic {
        Cubic::ZERO.add_scaled(self, k)
    }

    /// 0, the roots of the derivative inside (0, `len`) in order, and `len`: between two
    /// neighbours of this list the polynomial is monotone.
    pub fn monotone_breaks(&self, len: f64) -> Vec<f64> {
        let d = self.derivative().0;
        let mut points = vec![0.0];
        let mut roots = quadratic_roots(d[2], d[1], d[0]);
        roots.retain(|x| *x > 0.0 && *x < len);
        roots.sort_by(f64::total_cmp);
        points.extend(roots);
        points.push(len);
        points
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
        let p = Cubic([0.0, 0.0, 3.0, -2.0]);
        assert_eq!(p.monotone_breaks(1.0), vec![0.0, 1.0]);
        // Its slope 6x − 6x² peaks at x = ½ with 1.5.
        let v = p.derivative();
        assert_eq!(v.monotone_breaks(1.0), vec![0.0, 0.5, 1.0]);
        assert_eq!(v.eval(0.5), 1.5);
    }

    #[test]
    fn shifting_moves_the_origin() {
        let p = Cubic([1.0, -2.0, 0.5, 3.0]);
        let q = p.shifted(0.75);
        for x in [-1.0, 0.0, 0.3, 2.0] {
            assert!((q.eval(x) - p.eval(x + 0.75)).abs() < 1e-12);
        }
    }

    #[test]
    fn a_crossing_is_found_to_the_last_bit() {
        // x² − 2 crosses 0 at √2 on [1, 2].
        let p = Cubic([-2.0, 0.0, 1.0, 0.0]);
        assert!((p.crossing(1.0, 2.0, 0.0) - 2f64.sqrt()).abs() < 1e-15);
        // Falling the other way: 2 − x² crosses 1 at 1.
        let p = Cubic([2.0, 0.0, -1.0, 0.0]);
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
