//! LeRobot calibration text imported into the built-in SO-101 (Feetech) and Koch (Dynamixel).
//! Property: no panic; an import that succeeds leaves the limits ordered and within the range
//! the calibration gives each joint (its recorded range, or the whole turn), and every goal
//! tick of a calibrated joint maps back inside its (new) limits.
#![no_main]

use keypose::robot::import_lerobot_calibration;
use keypose_fuzz::builtin_named;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for name in ["so101", "koch"] {
        let mut robot = builtin_named(name).unwrap().clone();
        let Ok(report) = import_lerobot_calibration(&mut robot, "calibration.json", text) else {
            continue;
        };
        for after in &robot.joints {
            let (min, max) = (after.limits.min, after.limits.max);
            assert!(min <= max, "{}: limits {min}..{max}", after.name);
            if !report.calibrated.contains(&after.name) {
                continue;
            }
            let range = after
                .calibrated_range
                .expect("a calibrated joint keeps its range");
            let (low, high) = (range.at_0.min(range.at_100), range.at_0.max(range.at_100));
            assert!(
                min >= low && max <= high,
                "{}: limits {min}..{max} outside the calibration's range {low}..{high}",
                after.name
            );
            for value in [min, max, (min + max) / 2.0] {
                if let Ok(tick) = after.goal_tick(value) {
                    assert!(after.limits.contains(after.servo.value(tick)));
                }
            }
        }
    }
});
