//! Interpolation against hand-derived values and closed-form geometry.

use glam::{DMat3, DQuat, DVec3};
use keypose::curve::{Interp, Place, Track, TrackKey};
use keypose::plan::Trajectory;
use keypose::pose::{self, slerp, slerp_power};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use proptest::prelude::*;
use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2, PI};

fn track(keys: &[(f64, f64)], mode: Interp) -> Track<f64> {
    let keys: Vec<_> = keys
        .iter()
        .map(|&(t, v)| TrackKey::new(t, v, mode))
        .collect();
    Track::new(&keys).expect("valid keys")
}

/// Central-difference derivative, independent of the curve's own slope bookkeeping. At a key the
/// second derivative jumps (by 7.5 /s² at t = 1 in the cubic test, by hand), which puts an error
/// of about |Δf''|·h/4 ≈ 2e-7 on the result at this step.
fn derivative(track: &Track<f64>, t: f64) -> f64 {
    let h = 1e-7;
    (track.sample(t + h) - track.sample(t - h)) / (2.0 * h)
}

#[test]
fn linear_keys_give_the_lerped_value_and_hold_outside() {
    let t = track(&[(0.0, 1.0), (3.0, 7.0), (6.0, 20.0)], Interp::Linear);
    assert_eq!(t.sample(1.5), 4.0);
    assert_eq!(t.sample(-0.5), 1.0);
    assert_eq!(t.sample(-100.0), 1.0);
    assert_eq!(t.sample(6.5), 20.0);
    assert_eq!(t.sample(1e9), 20.0);
}

#[test]
fn three_joints_keyed_one_hot_give_half_half_zero() {
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"linear",
      "keyframes":[
        {"time":0,"joints":{"shoulder_pan":1,"shoulder_lift":0,"elbow_flex":0}},
        {"time":3,"joints":{"shoulder_pan":0,"shoulder_lift":1,"elbow_flex":0}},
        {"time":6,"joints":{"shoulder_pan":0,"shoulder_lift":0,"elbow_flex":1}}]}"#;
    let sequence = Sequence::from_json("one_hot.json", text).unwrap();
    let robot = Robot::builtin("so101").unwrap();
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    let pose = trajectory.sample(1.5);
    assert_eq!(&pose[..3], &[0.5, 0.5, 0.0]);
}

#[test]
fn slerp_halfway_to_a_right_angle_about_x_is_45_degrees() {
    let a = DQuat::IDENTITY;
    let b = DQuat::from_rotation_x(FRAC_PI_2);
    let m = DMat3::from_quat(slerp(a, b, 0.5));
    // Rx(45°) = [[1,0,0],[0,c,-s],[0,s,c]] with c = s = √2/2.
    let expected = [
        [1.0, 0.0, 0.0],
        [0.0, FRAC_1_SQRT_2, -FRAC_1_SQRT_2],
        [0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2],
    ];
    for (row, expected_row) in expected.iter().enumerate() {
        for (col, e) in expected_row.iter().enumerate() {
            let got = m.col(col)[row];
            assert!(
                (got - e).abs() < 1e-15,
                "m[{row}][{col}] = {got}, expected {e}"
            );
        }
    }

    // Lerping the matrices entry by entry gives [[1,0,0],[0,.5,-.5],[0,.5,.5]]: its columns have
    // length √0.5, so it is not a rotation.
    let ma = DMat3::from_quat(a);
    let mb = DMat3::from_quat(b);
    let lerped = ma * 0.5 + mb * 0.5;
    let gram = lerped.transpose() * lerped;
    let off_identity = (gram - DMat3::IDENTITY).to_cols_array();
    assert!(
        off_identity.iter().any(|x| x.abs() > 0.1),
        "lerp stayed orthonormal"
    );
    assert!((lerped.col(1).length() - 0.5f64.sqrt()).abs() < 1e-15);
}

#[test]
fn uniform_spacing_of_2000_ms_at_3700_ms_is_key_1_to_2_at_f_085() {
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"linear",
      "key_interval":2.0,
      "keyframes":[{"joints":{"elbow_flex":0}},{"joints":{"elbow_flex":10}},
                   {"joints":{"elbow_flex":20}},{"joints":{"elbow_flex":0}}]}"#;
    let sequence = Sequence::from_json("uniform.json", text).unwrap();
    let trajectory = Trajectory::build(&sequence, &Robot::builtin("so101").unwrap()).unwrap();
    let elbow = &trajectory.tracks()[2];
    match elbow.place(3.7) {
        Place::Moving(segment, f) => {
            assert_eq!(segment, 1);
            assert!((f - 0.85).abs() < 1e-12, "f = {f}");
        }
        other => panic!("expected a moving segment, found {other:?}"),
    }
    assert!((trajectory.sample(3.7)[2] - 18.5).abs() < 1e-12);
}

#[test]
fn slerp_takes_the_short_arc_when_the_dot_product_is_negative() {
    let a = DQuat::IDENTITY;
    // The same 60° rotation about z, written in the other hemisphere: dot(a, b) < 0.
    let b = -DQuat::from_rotation_z(PI / 3.0);
    assert!(a.dot(b) < 0.0);
    let (axis, angle) = slerp(a, b, 0.5).to_axis_angle();
    assert!(
        (angle - PI / 6.0).abs() < 1e-12,
        "went the long way: {angle}"
    );
    assert!((axis - DVec3::Z).length() < 1e-12);

    // A 200° rotation is a −160° one the short way round: halfway is −80°.
    let c = DQuat::from_rotation_z(200f64.to_radians());
    assert!(a.dot(c) < 0.0);
    let half = slerp(a, c, 0.5);
    let (twist, _) = pose::twist_swing(half, DVec3::Z);
    assert!(
        (twist.to_degrees() + 80.0).abs() < 1e-9,
        "{}",
        twist.to_degrees()
    );
}

fn unit_quat() -> impl Strategy<Value = DQuat> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_filter("not near zero", |(w, x, y, z)| {
            w * w + x * x + y * y + z * z > 0.01
        })
        .prop_map(|(w, x, y, z)| DQuat::from_xyzw(x, y, z, w).normalize())
}

proptest! {
    #[test]
    fn power_form_agrees_with_slerp(a in unit_quat(), b in unit_quat(), f in 0.0f64..=1.0) {
        let s = slerp(a, b, f);
        let p = slerp_power(a, b, f);
        // q and −q are the same rotation; both forms take the short arc, so compare directly.
        prop_assert!((s - p).length() < 1e-12 || (s + p).length() < 1e-12,
            "slerp {s:?} vs power {p:?}");
    }

    #[test]
    fn monotone_never_leaves_its_neighbouring_keys(
        gaps in prop::collection::vec(0.05f64..3.0, 2..12),
        values in prop::collection::vec(-180.0f64..180.0, 12),
        probes in prop::collection::vec(0.0f64..1.0, 40),
    ) {
        let mut t = 0.0;
        let mut keys = vec![(0.0, values[0])];
        for (i, gap) in gaps.iter().enumerate() {
            t += gap;
            keys.push((t, values[i + 1]));
        }
        let tr = track(&keys, Interp::Monotone);
        for w in keys.windows(2) {
            let (lo, hi) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
            for &p in &probes {
                let v = tr.sample(w[0].0 + p * (w[1].0 - w[0].0));
                prop_assert!(v >= lo - 1e-9 && v <= hi + 1e-9,
                    "{v} outside [{lo}, {hi}] between keys {w:?}");
            }
        }
    }

    #[test]
    fn rotation_about_a_fixed_axis_equals_the_scalar_curve(
        axis in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
            .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 0.01),
        steps in prop::collection::vec(-80.0f64..80.0, 2..7),
        gaps in prop::collection::vec(0.2f64..2.0, 7),
        mode in prop::sample::select(Interp::ALL.to_vec()),
        probe in 0.0f64..1.0,
    ) {
        let axis = DVec3::new(axis.0, axis.1, axis.2).normalize();
        // Angles that move less than 80° per key, so every spherical step is a short arc.
        let mut angle = 0.0f64;
        let mut time = 0.0;
        let mut scalar_keys = vec![TrackKey::new(0.0, 0.0, mode)];
        let mut rotation_keys = vec![TrackKey::new(0.0, DQuat::IDENTITY, mode)];
        for (step, gap) in steps.iter().zip(&gaps) {
            angle += step;
            time += gap;
            scalar_keys.push(TrackKey::new(time, angle, mode));
            rotation_keys.push(TrackKey::new(time, DQuat::from_axis_angle(axis, angle.to_radians()), mode));
        }
        let scalar = Track::new(&scalar_keys).unwrap();
        let rotation = Track::new(&rotation_keys).unwrap();
        let t = probe * time;
        let expected = DQuat::from_axis_angle(axis, scalar.sample(t).to_radians());
        let got = rotation.sample(t);
        prop_assert!((got - expected).length() < 1e-9 || (got + expected).length() < 1e-9,
            "{mode}: at t={t} rotation {got:?} vs scalar {expected:?}");
    }

    #[test]
    fn cursor_and_binary_search_agree(
        values in prop::collection::vec(-90.0f64..90.0, 2..30),
        probes in prop::collection::vec(-1.0f64..40.0, 1..80),
    ) {
        let keys: Vec<(f64, f64)> = values.iter().enumerate().map(|(i, v)| (i as f64 * 1.3, *v)).collect();
        let tr = track(&keys, Interp::Cubic);
        let mut sorted = probes.clone();
        sorted.sort_by(f64::total_cmp);
        let mut cursor = tr.cursor();
        for t in sorted.iter().chain(probes.iter()) {
            prop_assert_eq!(cursor.sample(*t), tr.sample(*t));
        }
    }
}

#[test]
fn cubic_passes_through_keys_rests_at_the_ends_and_uses_central_differences() {
    // Keys t = 0, 1, 3, 4 with v = 0, 2, 1, 5. By hand:
    //   m0 = 0, m1 = (1 − 0)/(3 − 0) = 1/3, m2 = (5 − 2)/(4 − 1) = 1, m3 = 0.
    // Segment 1 (t 1→3, h = 2) at f = ½, Hermite basis (½, ⅛, ½, −⅛):
    //   ½·2 + ⅛·(⅓·2) + ½·1 − ⅛·(1·2) = 1 + 1/12 + ½ − ¼ = 4/3.
    let tr = track(
        &[(0.0, 0.0), (1.0, 2.0), (3.0, 1.0), (4.0, 5.0)],
        Interp::Cubic,
    );
    for (t, v) in [(0.0, 0.0), (1.0, 2.0), (3.0, 1.0), (4.0, 5.0)] {
        assert!((tr.sample(t) - v).abs() < 1e-12, "key at {t}");
    }
    assert!(
        (tr.sample(2.0) - 4.0 / 3.0).abs() < 1e-12,
        "{}",
        tr.sample(2.0)
    );
    // One-sided at the ends (the track holds outside), so the difference carries an error of
    // f''·h/2, about 1.1e-6 here at h = 1e-7 (|f''| = 22 at t = 4 by hand).
    let h = 1e-7;
    assert!(((tr.sample(h) - tr.sample(0.0)) / h).abs() < 1e-5);
    assert!(((tr.sample(4.0) - tr.sample(4.0 - h)) / h).abs() < 1e-5);
    assert!((derivative(&tr, 1.0) - 1.0 / 3.0).abs() < 1e-6);
    assert!((derivative(&tr, 3.0) - 1.0).abs() < 1e-6);
}

#[test]
fn monotone_flattens_at_a_local_extremum_where_cubic_overshoots() {
    // 0 → 10 → 10.5 → 0: the cubic's slope at t=1 is (10.5 − 0)/2 = 5.25 and carries it past
    // 10.5; the monotone curve must stay within each pair of keys.
    let keys = [(0.0, 0.0), (1.0, 10.0), (2.0, 10.5), (3.0, 0.0)];
    let cubic = track(&keys, Interp::Cubic);
    let monotone = track(&keys, Interp::Monotone);
    let peak = |tr: &Track<f64>| {
        (0..=3000)
            .map(|k| tr.sample(k as f64 / 1000.0))
            .fold(f64::MIN, f64::max)
    };
    assert!(
        peak(&cubic) > 10.5 + 1e-3,
        "cubic did not overshoot: {}",
        peak(&cubic)
    );
    assert!(peak(&monotone) <= 10.5 + 1e-12);
}

#[test]
fn step_holds_the_first_key_until_the_next() {
    let tr = track(&[(0.0, 1.0), (2.0, 5.0)], Interp::Step);
    assert_eq!(tr.sample(1.999), 1.0);
    assert_eq!(tr.sample(2.0), 5.0);
}

#[test]
fn per_key_interp_overrides_the_segment_after_it() {
    let keys = [
        TrackKey::new(0.0, 0.0, Interp::Step),
        TrackKey::new(1.0, 10.0, Interp::Linear),
        TrackKey::new(2.0, 20.0, Interp::Linear),
    ];
    let tr = Track::new(&keys).unwrap();
    assert_eq!(tr.sample(0.5), 0.0);
    assert!((tr.sample(1.5) - 15.0).abs() < 1e-12);
}

#[test]
fn translation_tracks_lerp_component_wise() {
    let keys = [
        TrackKey::new(0.0, DVec3::new(0.0, 1.0, 2.0), Interp::Linear),
        TrackKey::new(2.0, DVec3::new(2.0, 1.0, 0.0), Interp::Linear),
    ];
    let tr = Track::new(&keys).unwrap();
    assert!((tr.sample(0.5) - DVec3::new(0.5, 1.0, 1.5)).length() < 1e-15);
}

/// A one-joint robot with ±175° limits, for the unwrapping test.
const WIDE_JOINT_ROBOT: &str = r#"{"format":"keypose-robot/1","name":"spinner",
  "bus":{"protocol":"dynamixel-2","baud":1000000},"control_hz":100,
  "joints":[{"name":"turn","kind":"revolute","axis":[0,0,1],"origin":{"xyz":[0,0,0]},
    "limits":{"min":-175,"max":175,"velocity":400,"acceleration":4000},
    "servo":{"id":1,"model":"xm430-w350","zero_tick":2048,"direction":1}}]}"#;

#[test]
fn keys_at_minus_170_and_plus_170_pass_through_zero_not_180() {
    let robot = Robot::from_json("spinner.json", WIDE_JOINT_ROBOT).unwrap();
    // As rotations the two keys are only 20° apart the short way (through 180°), which is
    // through the joint's stop. Unwrapping inside the limits must take the long way, via 0°.
    let q = |deg: f64| DQuat::from_rotation_z(deg.to_radians());
    let (a, b) = (q(-170.0), q(170.0));
    let text = format!(
        r#"{{"format":"keypose-sequence/1","robot":"spinner","interpolation":"linear","keyframes":[
          {{"time":0,"transforms":{{"turn":{{"r":{{"w":{},"x":0,"y":0,"z":{}}}}}}}}},
          {{"time":4,"transforms":{{"turn":{{"r":{{"w":{},"x":0,"y":0,"z":{}}}}}}}}}]}}"#,
        a.w, a.z, b.w, b.z
    );
    let sequence = Sequence::from_json("spin.json", &text).unwrap();
    let trajectory = Trajectory::build(&sequence, &robot).unwrap();
    assert!((trajectory.sample(0.0)[0] + 170.0).abs() < 1e-9);
    assert!((trajectory.sample(4.0)[0] - 170.0).abs() < 1e-9);
    assert!(trajectory.sample(2.0)[0].abs() < 1e-9, "midpoint is not 0°");
    for k in 0..=400 {
        let v = trajectory.sample(k as f64 / 100.0)[0];
        assert!(v.abs() <= 170.0 + 1e-9, "passed {v}° at sample {k}");
    }
}

#[test]
fn rigid_transform_tracks_lerp_translation_and_slerp_rotation_together() {
    use keypose::pose::RigidTransform;
    let a = RigidTransform::new(DVec3::new(0.0, 0.0, 0.0), DQuat::IDENTITY);
    let b = RigidTransform::new(
        DVec3::new(0.2, 0.0, -0.1),
        DQuat::from_rotation_x(FRAC_PI_2),
    );
    let tr = Track::new(&[
        TrackKey::new(0.0, a, Interp::Linear),
        TrackKey::new(2.0, b, Interp::Linear),
    ])
    .unwrap();
    let mid = tr.sample(1.0);
    assert!((mid.t - DVec3::new(0.1, 0.0, -0.05)).length() < 1e-15);
    let (axis, angle) = mid.r.to_axis_angle();
    assert!((angle - PI / 4.0).abs() < 1e-12 && (axis - DVec3::X).length() < 1e-12);
    // The cubic of a transform is the cubic of its parts: at the midpoint of a two-key cubic the
    // Hermite basis gives exactly the halfway value (symmetric, zero end slopes).
    let cubic = Track::new(&[
        TrackKey::new(0.0, a, Interp::Cubic),
        TrackKey::new(2.0, b, Interp::Cubic),
    ])
    .unwrap();
    let mid = cubic.sample(1.0);
    assert!((mid.t - DVec3::new(0.1, 0.0, -0.05)).length() < 1e-15);
    assert!((mid.r.to_axis_angle().1 - PI / 4.0).abs() < 1e-12);
}

/// An eased linear segment (the studio's easing handles, `SegmentTiming::eased`) is a
/// trapezoidal velocity profile along its straight path, worked out by hand: elbow 0° → 60° in
/// 3 s, speeding up over 20 % of the way and slowing down over 30 %. The steady speed is
/// (1 + 0.2 + 0.3) × 60 / 3 = 30 °/s, reached at 2·0.2 / 1.5 × 3 = 0.8 s (12° done: 20 % of
/// the way, ½·30·0.8) and held until 3 − 2·0.3 / 1.5 × 3 = 1.8 s (42°), then braked evenly to
/// rest at 3 s. The keys' times and poses are unchanged.
#[test]
fn an_eased_linear_segment_is_the_hand_worked_trapezoid() {
    use keypose::sequence::SegmentTiming;
    let robot = Robot::builtin("so101").unwrap();
    let mut sequence = Sequence::from_json(
        "t.json",
        r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "linear",
            "keyframes": [{"time": 0, "joints": {"elbow_flex": 0}},
                          {"time": 3, "joints": {"elbow_flex": 60}}]}"#,
    )
    .unwrap();
    sequence.keyframes[0].timing = SegmentTiming::eased(3.0, 0.2, 0.3);
    let back = Sequence::from_json("t.json", &sequence.to_json()).expect("written and read back");
    let trajectory = Trajectory::build(&back, &robot).unwrap();
    let elbow = robot.joint_index("elbow_flex").unwrap();
    let at = |t: f64| trajectory.sample(t)[elbow];
    let speed = |t: f64| (at(t + 1e-6) - at(t - 1e-6)) / 2e-6;
    for (t, want) in [(0.0, 0.0), (0.8, 12.0), (1.8, 42.0), (3.0, 60.0)] {
        assert!(
            (at(t) - want).abs() < 1e-6,
            "{t} s: {} ° vs {want} °",
            at(t)
        );
    }
    // Even acceleration from rest: 30 / 0.8 = 37.5 °/s², so 0.4 s in, 15 °/s and 3°.
    assert!((speed(0.4) - 15.0).abs() < 1e-4, "{}", speed(0.4));
    assert!((at(0.4) - 3.0).abs() < 1e-6);
    for t in [1.0, 1.3, 1.7] {
        assert!((speed(t) - 30.0).abs() < 1e-4, "{t} s: {}", speed(t));
    }
    // Braking at 30 / 1.2 = 25 °/s²: 0.6 s before the end, 15 °/s.
    assert!((speed(2.4) - 15.0).abs() < 1e-4, "{}", speed(2.4));
    assert!(speed(3.0 - 1e-5).abs() < 1e-2, "at rest at the key");
}
