//! The distance between two convex shapes by the Gilbert–Johnson–Keerthi algorithm: each
//! shape is a convex core (a point, a segment or a box) given by its support function, swept
//! by a radius (a sphere, a capsule; a box has none). When the cores overlap, how deep they
//! do is the least overlap of their projections on the separating-axis candidates (each
//! box's axes, the cross products of the cores' edges), which for boxes and segments is the
//! penetration depth.

use glam::DVec3;

/// A convex core in the world: the farthest point in a direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Core {
    /// A segment from `a` to `b` (a point when they coincide).
    Segment { a: DVec3, b: DVec3 },
    /// A box: its centre, its three half-axes (unit axis × half size).
    Box { centre: DVec3, axes: [DVec3; 3] },
}

impl Core {
    fn support(&self, d: DVec3) -> DVec3 {
        match *self {
            Core::Segment { a, b } => {
                if a.dot(d) >= b.dot(d) {
                    a
                } else {
                    b
                }
            }
            Core::Box { centre, axes } => {
                axes.iter().fold(centre, |p, h| p + h * h.dot(d).signum())
            }
        }
    }

    /// The directions of its edges.
    fn edges(&self) -> Vec<DVec3> {
        match *self {
            Core::Segment { a, b } => vec![b - a],
            Core::Box { axes, .. } => axes.to_vec(),
        }
    }

    /// The normals of its faces.
    fn faces(&self) -> Vec<DVec3> {
        match *self {
            Core::Segment { .. } => Vec::new(),
            Core::Box { axes, .. } => axes.to_vec(),
        }
    }

    /// The lowest z of the core.
    pub(crate) fn lowest(&self) -> f64 {
        self.support(DVec3::NEG_Z).z
    }
}

/// How many GJK steps at most: a box pair converges in a handful.
const MAX_STEPS: usize = 64;
/// Relative progress below which the distance is taken as found.
const TOLERANCE: f64 = 1e-10;

/// The distance between two cores (0 when they overlap).
pub(crate) fn distance(a: &Core, b: &Core) -> f64 {
    let support = |d: DVec3| a.support(d) - b.support(-d);
    let mut v = support(DVec3::X);
    let mut simplex: Vec<DVec3> = vec![v];
    for _ in 0..MAX_STEPS {
        if v.length_squared() < 1e-18 {
            return 0.0;
        }
        let w = support(-v);
        if v.length_squared() - v.dot(w) <= TOLERANCE * v.length_squared() {
            return v.length();
        }
        simplex.push(w);
        match closest(&simplex) {
            None => return 0.0,
            Some((point, kept)) => {
                v = point;
                simplex = kept;
            }
        }
    }
    v.length()
}

/// The distance between two cores, negative by how deep they overlap.
pub(crate) fn signed_distance(a: &Core, b: &Core) -> f64 {
    let apart = distance(a, b);
    if apart > 0.0 {
        return apart;
    }
    let mut axes = a.faces();
    axes.extend(b.faces());
    for e in a.edges() {
        for f in b.edges() {
            axes.push(e.cross(f));
        }
    }
    let overlap = |n: DVec3| {
        let n = n.normalize();
        let (a_max, a_min) = (a.support(n).dot(n), a.support(-n).dot(n));
        let (b_max, b_min) = (b.support(n).dot(n), b.support(-n).dot(n));
        (a_max - b_min).min(b_max - a_min)
    };
    -axes
        .into_iter()
        .filter(|n| n.length_squared() > 1e-20)
        .map(overlap)
        .fold(f64::INFINITY, f64::min)
        .max(0.0)
}

/// The point of the simplex nearest the origin and the smallest face that holds it; `None`
/// when the origin is inside a tetrahedron.
fn closest(simplex: &[DVec3]) -> Option<(DVec3, Vec<DVec3>)> {
    match simplex {
        [a] => Some((*a, vec![*a])),
        [a, b] => Some(segment(*a, *b)),
        [a, b, c] => Some(triangle(*a, *b, *c)),
        [a, b, c, d] => tetrahedron(*a, *b, *c, *d),
        _ => unreachable!("a simplex has one to four points"),
    }
}

fn segment(a: DVec3, b: DVec3) -> (DVec3, Vec<DVec3>) {
    let ab = b - a;
    let t = -a.dot(ab) / ab.length_squared().max(1e-30);
    if t <= 0.0 {
        (a, vec![a])
    } else if t >= 1.0 {
        (b, vec![b])
    } else {
        (a + ab * t, vec![a, b])
    }
}

/// Ericson, Real-Time Collision Detection §5.1.5, with the origin as the point.
fn triangle(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Vec<DVec3>) {
    let (ab, ac, ap) = (b - a, c - a, -a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, vec![a]);
    }
    let bp = -b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, vec![b]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), vec![a, b]);
    }
    let cp = -c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, vec![c]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), vec![a, c]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * t, vec![b, c]);
    }
    let denom = 1.0 / (va + vb + vc);
    (a + ab * (vb * denom) + ac * (vc * denom), vec![a, b, c])
}

/// The nearest of the faces the origin is outside of; `None` when it is outside of none.
fn tetrahedron(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<(DVec3, Vec<DVec3>)> {
    let outside = |p: DVec3, q: DVec3, r: DVec3, opposite: DVec3| {
        let n = (q - p).cross(r - p);
        // The origin and the opposite vertex on different sides of the face's plane.
        (-p).dot(n) * (opposite - p).dot(n) < 0.0
    };
    [(a, b, c, d), (a, c, d, b), (a, b, d, c), (b, c, d, a)]
        .into_iter()
        .filter(|&(p, q, r, o)| outside(p, q, r, o))
        .map(|(p, q, r, _)| triangle(p, q, r))
        .min_by(|x, y| x.0.length_squared().total_cmp(&y.0.length_squared()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(centre: DVec3) -> Core {
        Core::Box {
            centre,
            axes: [DVec3::X, DVec3::Y, DVec3::Z].map(|a| a * 0.5),
        }
    }

    /// Hand-computed distances: two unit cubes 3 apart along x face each other 2 apart; a
    /// segment above a cube's edge; overlapping cubes touch.
    #[test]
    fn distances_between_boxes_and_segments() {
        let a = unit_box(DVec3::ZERO);
        assert!((distance(&a, &unit_box(DVec3::new(3.0, 0.0, 0.0))) - 2.0).abs() < 1e-9);
        // Corner to corner: (1, 1, 1) apart once each cube's half is taken off.
        let diagonal = distance(&a, &unit_box(DVec3::splat(2.0)));
        assert!((diagonal - 3f64.sqrt()).abs() < 1e-9, "{diagonal}");
        let above = Core::Segment {
            a: DVec3::new(-2.0, 0.5, 2.5),
            b: DVec3::new(2.0, 0.5, 2.5),
        };
        assert!((distance(&a, &above) - 2.0).abs() < 1e-9);
        assert_eq!(distance(&a, &unit_box(DVec3::new(0.5, 0.2, 0.1))), 0.0);
        // Overlapping by 0.5 along x (the least of 0.5, 0.8, 0.9).
        let deep = signed_distance(&a, &unit_box(DVec3::new(0.5, 0.2, 0.1)));
        assert!((deep + 0.5).abs() < 1e-9, "{deep}");
        let skew = Core::Segment {
            a: DVec3::new(0.0, -1.0, 1.0),
            b: DVec3::new(0.0, 1.0, 1.0),
        };
        let cross = Core::Segment {
            a: DVec3::new(-1.0, 0.0, 0.0),
            b: DVec3::new(1.0, 0.0, 0.0),
        };
        assert!((distance(&skew, &cross) - 1.0).abs() < 1e-9);
    }
}
