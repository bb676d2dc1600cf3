//! Robot descriptions against the published kinematics (world anchors and TCPs measured in
//! MuJoCo from the official models, docs/robots.md §1.3, §2.3, §3.3), hand-derived poses,
//! and servo encodings derived bit by bit from the protocol documents.

use glam::DVec3;
use keypose::robot::{
    import_lerobot_calibration, LimitsOrigin, PositionEncoding, Robot, BUILTIN_NAMES,
};

fn close(a: DVec3, b: [f64; 3], tol: f64) -> bool {
    (a - DVec3::from_array(b)).length() < tol
}

#[test]
fn every_builtin_robot_loads_and_matches_its_file_on_disk() {
    for name in BUILTIN_NAMES {
        let builtin = Robot::builtin(name).unwrap_or_else(|| panic!("{name} did not parse"));
        let path = format!("{}/robots/{name}.json", env!("CARGO_MANIFEST_DIR"));
        let on_disk = Robot::load(std::path::Path::new(&path)).unwrap();
        assert_eq!(builtin.joints, on_disk.joints);
        assert_eq!(builtin.name, name);
    }
}

#[test]
fn so101_tcp_and_anchors_at_zero_match_mujoco() {
    let robot = Robot::builtin("so101").unwrap();
    let zero = vec![0.0; robot.joints.len()];
    // TCP (0.39136, −0.00001, 0.22647); 0.1 mm covers the official files' rounded 1.5708.
    assert!(close(
        robot.tcp_position(&zero),
        [0.39136, -0.00001, 0.22647],
        1e-4
    ));
    let expected = [
        ([0.03884, 0.0, 0.06240], [0.0, 0.0, -1.0]),
        ([0.06923, -0.01828, 0.11660], [0.0, 1.0, 0.0]),
        ([0.09723, -0.01828, 0.22917], [0.0, 1.0, 0.0]),
        ([0.23213, -0.01828, 0.23437], [0.0, 1.0, 0.0]),
        ([0.29323, -0.00018, 0.23437], [-1.0, 0.0, 0.0]),
        ([0.31663, 0.01762, 0.25546], [0.0, -0.99882, -0.04866]),
    ];
    for ((anchor, axis), (want_anchor, want_axis)) in robot.joint_axes(&zero).iter().zip(expected) {
        assert!(
            close(*anchor, want_anchor, 1e-4),
            "anchor {anchor:?} vs {want_anchor:?}"
        );
        assert!(
            close(*axis, want_axis, 1e-4),
            "axis {axis:?} vs {want_axis:?}"
        );
    }
}

/// Joint anchors, joint axes and TCP of the official SO-100 model, measured in MuJoCo from
/// TheRobotStudio's `Simulation/SO100/so100.urdf` at official angles = middle of each range +
/// the keypose angles given (docs/robots.md §11.3); the TCP is the official Menagerie pad
/// midpoint carried on the same gripper frame (§11.2). Rounded to 0.01 mm and 1e-5.
type Measured = ([f64; 6], [([f64; 3], [f64; 3]); 6], [f64; 3]);
const SO100_MEASURED: [Measured; 3] = [
    (
        [0.0; 6],
        [
            ([0.0, -0.0452, 0.0165], [0.0, 0.00001, 1.0]),
            ([0.0, -0.0758, 0.119], [1.0, 0.0, 0.0]),
            ([0.0, -0.09814, 0.23283], [1.0, 0.0, 0.0]),
            ([0.0, -0.23261, 0.24477], [1.0, 0.0, 0.0]),
            ([0.0, -0.29221, 0.25251], [0.0, 0.99166, -0.12885]),
            ([0.0, -0.3138, 0.27569], [-1.0, 0.0, -0.00002]),
        ],
        [0.0, -0.39276, 0.26558],
    ),
    (
        [30.0, -25.0, 40.0, 20.0, -35.0, 10.0],
        [
            ([0.0, -0.0452, 0.0165], [0.0, 0.00001, 1.0]),
            ([0.0153, -0.0717, 0.119], [0.86603, 0.5, 0.0]),
            ([0.00137, -0.04757, 0.2316], [0.86603, 0.5, 0.0]),
            ([0.06786, -0.16273, 0.20833], [0.86603, 0.5, 0.0]),
            ([0.09449, -0.20886, 0.18049], [-0.44311, 0.7675, 0.46325]),
            ([0.0991, -0.24002, 0.18385], [-0.84226, -0.17946, -0.50833]),
        ],
        [0.13942, -0.28669, 0.13352],
    ),
    (
        [-60.0, 45.0, -50.0, -40.0, 70.0, -30.0],
        [
            ([0.0, -0.0452, 0.0165], [0.0, 0.00001, 1.0]),
            ([-0.0265, -0.0605, 0.119], [0.5, -0.86603, 0.00001]),
            ([-0.10989, -0.10864, 0.18369], [0.5, -0.86603, 0.00001]),
            ([-0.225, -0.1751, 0.2073], [0.5, -0.86603, 0.00001]),
            ([-0.25675, -0.19343, 0.25492], [0.52837, 0.30505, -0.79232]),
            ([-0.25541, -0.21458, 0.27847], [0.47376, 0.66848, 0.5733]),
        ],
        [-0.31033, -0.22437, 0.33526],
    ),
];

#[test]
fn so100_anchors_axes_and_tcp_match_the_official_model_at_zero_and_two_poses() {
    let robot = Robot::builtin("so100").unwrap();
    for (q, joints, tcp) in SO100_MEASURED {
        // 0.1 mm and 1e-4: the sheet's rounding plus the URDF's 5-digit pi/2.
        let got = robot.tcp_position(&q);
        assert!(close(got, tcp, 1e-4), "{q:?}: tcp {got:?} vs {tcp:?}");
        for ((anchor, axis), (want_anchor, want_axis)) in robot.joint_axes(&q).iter().zip(joints) {
            assert!(
                close(*anchor, want_anchor, 1e-4),
                "{q:?}: anchor {anchor:?} vs {want_anchor:?}"
            );
            assert!(
                close(*axis, want_axis, 1e-4),
                "{q:?}: axis {axis:?} vs {want_axis:?}"
            );
        }
    }
}

#[test]
fn koch_tcp_and_anchors_at_zero_match_mujoco() {
    let robot = Robot::builtin("koch").unwrap();
    let zero = vec![0.0; 6];
    assert!(close(
        robot.tcp_position(&zero),
        [-0.2150, 0.0059, 0.1678],
        1e-4
    ));
    let anchors = [
        [0.01200, 0.0, 0.04090],
        [0.01200, -0.02090, 0.05630],
        [-0.00280, -0.01440, 0.16460],
        [-0.10328, -0.01435, 0.16730],
        [-0.14828, -0.00125, 0.16730],
        [-0.16143, -0.00875, 0.18180],
    ];
    for ((anchor, _), want) in robot.joint_axes(&zero).iter().zip(anchors) {
        assert!(close(*anchor, want, 1e-4), "{anchor:?} vs {want:?}");
    }
}

#[test]
fn omx_tcp_at_zero_and_with_the_base_turned_a_quarter() {
    let robot = Robot::builtin("omx").unwrap();
    let mut q = vec![0.0; 5];
    assert!(close(robot.tcp_position(&q), [0.2860, 0.0, 0.2045], 1e-4));
    // Joint1 turns about world z through x = 0.012: the TCP, 0.274 m in front of that axis,
    // swings to y = +0.274 at +90° (right-handed about +z).
    q[0] = 90.0;
    assert!(close(robot.tcp_position(&q), [0.012, 0.274, 0.2045], 1e-9));
    // Joint2 at +90° (about +y) tips the whole arm above it forward: the part above Joint2,
    // which at q = 0 reaches (0.274, 0.128) in (x, z) from Joint2's anchor (0.012, 0.0765), maps
    // (x, z) → (z, −x).
    let mut q = vec![0.0; 5];
    q[1] = 90.0;
    let tcp = robot.tcp_position(&q);
    assert!(
        close(tcp, [0.012 + 0.128, 0.0, 0.0765 - 0.274], 1e-9),
        "{tcp:?}"
    );
}

#[test]
fn angle_tick_angle_round_trips_for_both_conventions() {
    let dxl = Robot::builtin("koch").unwrap().joints[0].servo.clone();
    let sts = Robot::builtin("so101").unwrap().joints[0].servo.clone();
    let half_tick = 360.0 / 4096.0 / 2.0;
    for servo in [&dxl, &sts] {
        for deg in [-200.0, -179.9, -90.0, -0.04, 0.0, 0.05, 45.0, 179.99, 300.0] {
            let tick = servo.tick(deg).unwrap();
            assert!(
                (servo.value(tick) - deg).abs() <= half_tick + 1e-12,
                "{deg}°"
            );
        }
    }
    // 90° is 1024 ticks from the zero tick (4096 per turn).
    assert_eq!(dxl.tick(90.0).unwrap(), 2048 + 1024);
    assert_eq!(sts.tick(-90.0).unwrap(), 2047 - 1024);
}

#[test]
fn negative_ticks_on_the_wire() {
    let dxl = PositionEncoding::TwosComplement32;
    let sts = PositionEncoding::SignMagnitude16 { sign_bit: 15 };
    // Two's complement: −1 is all ones; −2048 is 0xFFFFF800.
    assert_eq!(dxl.encode(-1).unwrap(), 0xFFFF_FFFF);
    assert_eq!(dxl.encode(-2048).unwrap(), 0xFFFF_F800);
    // Sign-magnitude, bit 15: −1 is 0x8001, −2048 is 0x8800, +2048 is 0x0800.
    assert_eq!(sts.encode(-1).unwrap(), 0x8001);
    assert_eq!(sts.encode(-2048).unwrap(), 0x8800);
    assert_eq!(sts.encode(2048).unwrap(), 0x0800);
    assert!(sts.encode(40_000).is_err());
    // The homing-offset register puts its sign at bit 11.
    let offset = PositionEncoding::SignMagnitude16 { sign_bit: 11 };
    assert_eq!(offset.encode(-5).unwrap(), 0x0805);
    for tick in [-32767i64, -4095, -1, 0, 1, 4095, 32767] {
        assert_eq!(sts.decode(sts.encode(tick).unwrap()), tick);
    }
    for tick in [i32::MIN as i64, -1_048_575, -1, 0, 4095, i32::MAX as i64] {
        assert_eq!(dxl.decode(dxl.encode(tick).unwrap()), tick);
    }
}

#[test]
fn lerobot_calibration_sets_zero_at_the_range_midpoint() {
    let mut robot = Robot::builtin("so101").unwrap();
    // A calibration as LeRobot writes it (values typical of an SO-101 follower).
    // The joints not examined here record the whole turn (0 … 4095), wider than their limits.
    let text = r#"{
      "shoulder_pan": {"id": 1, "drive_mode": 0, "homing_offset": -1470, "range_min": 758, "range_max": 3292},
      "shoulder_lift": {"id": 2, "drive_mode": 0, "homing_offset": 0, "range_min": 0, "range_max": 4095},
      "elbow_flex": {"id": 3, "drive_mode": 1, "homing_offset": 1200, "range_min": 1000, "range_max": 3000},
      "wrist_flex": {"id": 4, "drive_mode": 0, "homing_offset": 0, "range_min": 0, "range_max": 4095},
      "wrist_roll": {"id": 5, "drive_mode": 0, "homing_offset": 0, "range_min": 0, "range_max": 4095},
      "gripper": {"id": 6, "drive_mode": 0, "homing_offset": 0, "range_min": 0, "range_max": 4095}
    }"#;
    let report = import_lerobot_calibration(&mut robot, "calibration.json", text).unwrap();
    assert_eq!(
        report.calibrated,
        [
            "shoulder_pan",
            "shoulder_lift",
            "elbow_flex",
            "wrist_flex",
            "wrist_roll",
            "gripper"
        ]
    );
    let pan = &robot.joints[0];
    // Midpoint (758 + 3292)/2 = 2025; the range is ±1267 ticks = ±111.357421875°: the limits,
    // although wider than the robot's ±110°, since the recorded range is what the arm was
    // moved through (and what LeRobot writes into the servo's position limits).
    assert_eq!(pan.servo.zero_tick, 2025.0);
    assert_eq!(pan.servo.tick(0.0).unwrap(), 2025);
    assert_eq!(pan.servo.homing_offset, Some(-1470));
    assert_eq!(pan.limits.min, -111.357421875);
    assert_eq!(pan.limits.max, 111.357421875);
    // elbow: midpoint 2000; drive_mode 1 does not reverse it, since LeRobot's degrees never
    // apply drive_mode (docs/robots.md §8): 10° is 10 · 4096/360 = 113.8 ticks above the
    // midpoint. ±1000 ticks = ±87.89°, narrower than ±96.83°.
    let elbow = &robot.joints[2];
    assert_eq!(elbow.servo.tick(10.0).unwrap(), 2000 + 114);
    let limit = 1000.0 * 360.0 / 4096.0;
    assert!((elbow.limits.max - limit).abs() < 1e-9 && (elbow.limits.min + limit).abs() < 1e-9);
    assert_eq!(
        elbow.limits_origin,
        LimitsOrigin::RecordedRange {
            file: "calibration.json".into()
        }
    );
}

#[test]
fn lerobot_calibration_with_an_unknown_motor_is_refused_with_its_path() {
    let mut robot = Robot::builtin("so101").unwrap();
    let text = r#"{"elbow": {"id": 3, "drive_mode": 0, "homing_offset": 0, "range_min": 0, "range_max": 4095}}"#;
    let err = import_lerobot_calibration(&mut robot, "cal.json", text).unwrap_err();
    let message = err.to_string();
    assert!(
        message.starts_with("cal.json: $.elbow: motor \"elbow\""),
        "{message}"
    );
    assert!(message.contains("elbow_flex"), "{message}");
}
