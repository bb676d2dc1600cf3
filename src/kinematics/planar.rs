//! The planar two-link problem under the pitch joints: two links turning about parallel axes,
//! the second carried by the first, reaching for a point in their plane.

use glam::DVec2;

/// Joint rotations (radians, counter-clockwise in the plane) that put the far end of the second
/// link at `target`, measured from the first joint: both elbow branches, or none when the point
/// is farther than the stretched arm or nearer than the folded one.
///
/// At zero rotation the links lie along `first` and `second`. The distance from the first joint
/// to the end depends only on the elbow angle (law of cosines), which gives the elbow's two
/// branches; the first joint then turns that end onto the target's direction.
pub fn two_link(first: DVec2, second: DVec2, target: DVec2) -> Option<[(f64, f64); 2]> {
    let (l1, l2) = (first.length(), second.length());
    let cos_bend = (target.length_squared() - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
    // A target on the boundary computed in floating point lands a few ulps outside it.
    const EDGE: f64 = 1e-12;
    if !cos_bend.is_finite() || cos_bend.abs() > 1.0 + EDGE {
        return None;
    }
    let cos_bend = cos_bend.clamp(-1.0, 1.0);
    let sin_bend = (1.0 - cos_bend * cos_bend).sqrt();
    // The angle from the first link's direction to the second's at zero rotation.
    let rest = angle_of(second) - angle_of(first);
    let branch = |sin: f64| {
        let elbow = sin.atan2(cos_bend) - rest;
        let end = first + DVec2::from_angle(elbow).rotate(second);
        let shoulder = angle_of(target) - angle_of(end);
        (shoulder, elbow)
    };
    Some([branch(sin_bend), branch(-sin_bend)])
}

pub fn angle_of(v: DVec2) -> f64 {
    v.y.atan2(v.x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit links along x reaching (1, 1): by hand the elbow bends ±90°, and the shoulder
    /// points the first link along +y (elbow −90°: 1·(0,1) + (1,0) = (1,1)) or along +x (elbow
    /// +90°: (1,0) + (0,1)).
    #[test]
    fn right_angle_reach_worked_by_hand() {
        let [(s1, e1), (s2, e2)] =
            two_link(DVec2::X, DVec2::X, DVec2::new(1.0, 1.0)).expect("reachable");
        let deg = |a: f64| a.to_degrees();
        assert!(
            (deg(e1) - 90.0).abs() < 1e-9 && deg(s1).abs() < 1e-9,
            "{s1} {e1}"
        );
        assert!(
            (deg(e2) + 90.0).abs() < 1e-9 && (deg(s2) - 90.0).abs() < 1e-9,
            "{s2} {e2}"
        );
    }

    #[test]
    fn beyond_the_stretched_arm_is_none() {
        assert!(two_link(DVec2::X, DVec2::X, DVec2::new(2.1, 0.0)).is_none());
        assert!(two_link(DVec2::X, DVec2::X * 0.5, DVec2::new(0.4, 0.0)).is_none());
    }
}
