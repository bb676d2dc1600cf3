//! LeRobot calibration text imported into the built-in SO-101 (Feetech) and Koch (Dynamixel).
//! Property: no panic; an import that succeeds only narrows limits, leaves them ordered, and
//! every goal tick of a calibrated joint maps back inside its (new) limits.
#![no_main]

use keypose::robot::import_lerobot_calibration;
use keypose_fuzz::builtin_named;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for name in ["so101", "koch"] {
        let original = builtin_named(name).unwrap();
        let mut robot = original.clone();
        let Ok(report) = import_lerobot_calibration(&mut robot, "calibration.json", text) else {
            continue;
        };
        for (before, after) in original.joints.iter().zip(&robot.joints) {
            let (min, max) = (after.limits.min, after.limits.max);
            assert!(min <= max, "{}: limits {min}..{max}", after.name);
            assert!(
                min >= before.limits.min && max <= before.limits.max,
                "{}: import widened {}..{} to {min}..{max}",
                after.name,
                before.limits.min,
                before.limits.max
            );
            if !report.calibrated.contains(&after.name) {
                continue;
            }
            for value in [min, max, (min + max) / 2.0] {
                if let Ok(tick) = after.goal_tick(value) {
                    assert!(after.limits.contains(after.servo.value(tick)));
                }
            }
        }
    }
});
