//! Rigid transforms and the rotation arithmetic that interpolation needs.
//!
//! Everything here is f64: the slerp/power-form agreement and the tick round trips are checked to
//! 1e-12, which single precision cannot hold. Angles always come from `atan2`, never `acos`,
//! because `acos` loses all precision near 0° and 180°, exactly where keys tend to sit.

use glam::{DQuat, DVec3};
use std::f64::consts::{PI, TAU};

/// A joint's pose relative to its zero pose: translation in metres, rotation as a unit quaternion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidTransform {
    /// Translation, metres.
    pub t: DVec3,
    /// Rotation, a unit quaternion.
    pub r: DQuat,
}

impl RigidTransform {
    /// No translation, no rotation: the zero pose.
    pub const IDENTITY: Self = Self {
        t: DVec3::ZERO,
        r: DQuat::IDENTITY,
    };

    /// The transform that rotates by `r`, then translates by `t` (metres).
    pub fn new(t: DVec3, r: DQuat) -> Self {
        Self { t, r }
    }

    /// Linear interpolation: lerp of the translations, slerp of the rotations.
    pub fn interpolate(&self, other: &Self, f: f64) -> Self {
        Self {
            t: lerp(self.t, other.t, f),
            r: slerp(self.r, other.r, f),
        }
    }

    /// Applies this transform to a point.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.r * p + self.t
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Self) -> Self {
        Self {
            t: self.r * other.t + self.t,
            r: (self.r * other.r).normalize(),
        }
    }
}

/// The point at fraction `f` of the straight line from `a` to `b` (`f` = 0 is `a`, 1 is `b`).
pub fn lerp(a: DVec3, b: DVec3, f: f64) -> DVec3 {
    a * (1.0 - f) + b * f
}

/// Returns `b` or `-b`, whichever lies in the same hemisphere as `a`: q and −q are the same
/// rotation, and interpolating towards the nearer one takes the short arc.
pub(crate) fn same_hemisphere(a: DQuat, b: DQuat) -> DQuat {
    if a.dot(b) < 0.0 {
        -b
    } else {
        b
    }
}

/// Spherical linear interpolation along the short arc.
///
/// The arc angle comes from `atan2(|a×b|, a·b)` over the 4-vectors, which stays accurate at both
/// ends of its range; the near-equal case falls back to a normalised lerp, where slerp and lerp
/// agree to far below f64 resolution.
pub fn slerp(a: DQuat, b: DQuat, f: f64) -> DQuat {
    let b = same_hemisphere(a, b);
    let dot = a.dot(b);
    let sin_half = (b - a * dot).length();
    let half = sin_half.atan2(dot);
    if half < 1e-9 {
        return (a * (1.0 - f) + b * f).normalize();
    }
    let s = half.sin();
    let wa = ((1.0 - f) * half).sin() / s;
    let wb = (f * half).sin() / s;
    (a * wa + b * wb).normalize()
}

/// The power form of slerp, `(b·a⁻¹)^f · a`, with the same short-arc rule.
pub fn slerp_power(a: DQuat, b: DQuat, f: f64) -> DQuat {
    let b = same_hemisphere(a, b);
    let delta = b * a.conjugate();
    (quat_exp(quat_log(delta) * f) * a).normalize()
}

/// Logarithm of a unit quaternion as the rotation vector (axis · angle, radians), angle in [0, 2π].
pub(crate) fn rotation_vector(q: DQuat) -> DVec3 {
    quat_log(q) * 2.0
}

/// Unit quaternion from a rotation vector (axis · angle, radians).
/// `ṙ` from an angular velocity `w` (parent frame) of `exp(r)·a` at rotation vector `r`: the
/// inverse of SO(3)'s left Jacobian applied to `w`,
/// `w − ½ r×w + (1/θ² − (1 + cos θ)/(2θ sin θ)) r×(r×w)`, θ = |r|. Along `r` (a rotation about
/// a fixed axis) it is `w` itself.
pub(crate) fn rotation_vector_rate(r: DVec3, w: DVec3) -> DVec3 {
    let theta = r.length();
    let cross = r.cross(w);
    // Near θ = 0 the factor's series: 1/12 + θ²/720.
    let k = if theta < 1e-4 {
        1.0 / 12.0 + theta * theta / 720.0
    } else {
        1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    w - 0.5 * cross + k * r.cross(cross)
}

pub(crate) fn from_rotation_vector(v: DVec3) -> DQuat {
    quat_exp(v * 0.5)
}

/// Quaternion logarithm of a unit quaternion: half-angle times axis.
fn quat_log(q: DQuat) -> DVec3 {
    let v = DVec3::new(q.x, q.y, q.z);
    let sin_half = v.length();
    if sin_half < 1e-15 {
        return DVec3::ZERO;
    }
    let half = sin_half.atan2(q.w);
    v * (half / sin_half)
}

/// Quaternion exponential of a pure vector part: the inverse of [`quat_log`].
fn quat_exp(v: DVec3) -> DQuat {
    let half = v.length();
    if half < 1e-15 {
        return DQuat::from_xyzw(v.x, v.y, v.z, 1.0).normalize();
    }
    let s = half.sin() / half;
    DQuat::from_xyzw(v.x * s, v.y * s, v.z * s, half.cos())
}

/// The twist of `q` about the unit `axis` and the size of what is left (the swing), both in
/// radians. Twist is `2·atan2(r_xyz·axis, r_w)`, wrapped to (−π, π].
pub fn twist_swing(q: DQuat, axis: DVec3) -> (f64, f64) {
    let projection = DVec3::new(q.x, q.y, q.z).dot(axis);
    let twist = wrap_pi(2.0 * projection.atan2(q.w));
    let twist_q = DQuat::from_axis_angle(axis, twist);
    let swing_q = q * twist_q.conjugate();
    let swing_v = DVec3::new(swing_q.x, swing_q.y, swing_q.z).length();
    let swing = 2.0 * swing_v.atan2(swing_q.w.abs());
    (twist, swing)
}

/// Wraps an angle in radians to (−π, π].
pub(crate) fn wrap_pi(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

/// Of the angles `angle + k·period`, the one inside `[min, max]` nearest to `previous`.
///
/// A revolute joint cannot pass through its mechanical stop, so the representative must lie
/// inside the limits; among those, the one continuous with the previous sample is the one the
/// arm actually reaches without a full turn. `None` when no representative lies inside.
pub(crate) fn unwrap_within(
    angle: f64,
    previous: f64,
    min: f64,
    max: f64,
    period: f64,
) -> Option<f64> {
    if !(angle.is_finite() && previous.is_finite() && min <= max && period > 0.0) {
        return None;
    }
    // Turns that bring `angle` into [min, max]: k ∈ [ceil((min−angle)/p), floor((max−angle)/p)].
    let k_low = ((min - angle) / period).ceil();
    let k_high = ((max - angle) / period).floor();
    if k_low > k_high {
        return None;
    }
    let k_near = ((previous - angle) / period).round().clamp(k_low, k_high);
    Some(angle + k_near * period)
}

/// Rotation from URDF roll-pitch-yaw: R = Rz(yaw)·Ry(pitch)·Rx(roll).
pub fn quat_from_rpy(roll: f64, pitch: f64, yaw: f64) -> DQuat {
    (DQuat::from_rotation_z(yaw) * DQuat::from_rotation_y(pitch) * DQuat::from_rotation_x(roll))
        .normalize()
}

/// URDF roll-pitch-yaw of a rotation, the inverse of [`quat_from_rpy`] (pitch in [−π/2, π/2]).
pub fn rpy_from_quat(q: DQuat) -> (f64, f64, f64) {
    // Intrinsic Z-Y-X angles are the URDF's extrinsic X-Y-Z ones: (yaw, pitch, roll).
    let (yaw, pitch, roll) = q.normalize().to_euler(glam::EulerRot::ZYX);
    (roll, pitch, yaw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_from_quat_inverts_quat_from_rpy() {
        for (r, p, y) in [
            (0.3, -0.4, 1.2),
            (-2.0, 1.0, -3.0),
            (0.0, 0.0, 0.0),
            (3.0, 0.2, 0.1),
        ] {
            let (r2, p2, y2) = rpy_from_quat(quat_from_rpy(r, p, y));
            assert!((r2 - r).abs() < 1e-12 && (p2 - p).abs() < 1e-12 && (y2 - y).abs() < 1e-12);
        }
        // Yaw alone: +90° about z takes +x to +y.
        let (r, p, y) = rpy_from_quat(DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2));
        assert!(
            r.abs() < 1e-12 && p.abs() < 1e-12 && (y - std::f64::consts::FRAC_PI_2).abs() < 1e-12
        );
    }

    #[test]
    fn unwrap_prefers_inside_limits_then_continuity() {
        let d = f64::to_radians;
        // +170° after −170° on a ±175° joint: 170 − 360 = −190 is outside, so 170 it is.
        let a = unwrap_within(d(170.0), d(-170.0), d(-175.0), d(175.0), TAU).unwrap();
        assert!((a - d(170.0)).abs() < 1e-12);
        // A joint with 400° of travel picks the turn nearest to the previous sample.
        let b = unwrap_within(d(10.0), d(350.0), d(-200.0), d(400.0), TAU).unwrap();
        assert!((b - d(370.0)).abs() < 1e-12);
        assert!(unwrap_within(d(90.0), 0.0, d(-45.0), d(45.0), TAU).is_none());
    }

    #[test]
    fn twist_of_pure_axis_rotation_has_no_swing() {
        let axis = DVec3::new(0.0, 1.0, 0.0);
        let q = DQuat::from_axis_angle(axis, 2.5);
        let (twist, swing) = twist_swing(q, axis);
        assert!((twist - 2.5).abs() < 1e-12);
        assert!(swing < 1e-12);
        let tilted = DQuat::from_rotation_x(0.1) * q;
        assert!(twist_swing(tilted, axis).1 > 0.09);
    }
}
