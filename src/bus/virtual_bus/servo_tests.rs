//! Register refusals and effects of one emulated servo, against the vendors' rules
//! (docs/protocols.md §1.8, §2.6).

use super::servo::VirtualServo;
use crate::bus::protocol::Refusal;
use crate::robot::ServoModel;
use std::time::Duration;

#[test]
fn dynamixel_refusals_change_nothing() {
    let mut servo = VirtualServo::new(1, ServoModel::Xl430W250, 2048.0);
    assert_eq!(servo.set("Operating_Mode", 5), Err(Refusal::DataRange));
    assert_eq!(servo.set("Operating_Mode", 0), Err(Refusal::DataRange));
    assert_eq!(servo.value("Operating_Mode"), 3);
    assert_eq!(
        servo.set("Homing_Offset", 1_044_480),
        Err(Refusal::DataRange)
    );
    assert_eq!(servo.set("Present_Position", 0), Err(Refusal::Access));
    assert_eq!(servo.set("Torque_Enable", 1), Ok(()));
    assert_eq!(servo.set("Max_Position_Limit", 3000), Err(Refusal::Access));
    assert_eq!(servo.value("Max_Position_Limit"), 4095);
    // RAM items stay writable with torque on.
    assert_eq!(servo.set("Profile_Velocity", 100), Ok(()));
    // A mode change resets the profile (e-Manual Operating Mode note).
    servo.set("Torque_Enable", 0).unwrap();
    servo.set("Operating_Mode", 4).unwrap();
    assert_eq!(servo.value("Profile_Velocity"), 0);
}

#[test]
fn return_delay_is_two_microseconds_per_unit_on_dynamixel_only() {
    let mut xl = VirtualServo::new(1, ServoModel::Xl330M288, 0.0);
    assert_eq!(xl.return_delay(), Duration::from_micros(500));
    xl.set("Return_Delay_Time", 0).unwrap();
    assert_eq!(xl.return_delay(), Duration::ZERO);
    // FT-MEM: the register has no function on STS.
    let sts = VirtualServo::new(1, ServoModel::Sts3215, 0.0);
    assert_eq!(sts.value("Return_Delay_Time"), 250);
    assert_eq!(sts.return_delay(), Duration::ZERO);
}

#[test]
fn positions_go_through_offset_and_limits() {
    // Dynamixel: Present = actual + offset. Placed at present 1000, offset 200 → shaft 800.
    let mut xm = VirtualServo::new(1, ServoModel::Xm430W350, 1000.0);
    xm.set("Homing_Offset", 200).unwrap();
    assert_eq!(xm.present_position(), 1200.0);
    // Feetech: Present = actual − offset, one turn in position mode: shaft 100, offset 300
    // reads 100 − 300 + 4096 = 3896.
    let mut sts = VirtualServo::new(1, ServoModel::Sts3215, 100.0);
    sts.set("Homing_Offset", 300).unwrap();
    assert_eq!(sts.present_position(), 3896.0);
    // Goals are clamped to the limits in position mode.
    sts.set("Homing_Offset", 0).unwrap();
    sts.set("Max_Position_Limit", 2000).unwrap();
    sts.set("Torque_Enable", 1).unwrap();
    sts.set("Goal_Position", 3000).unwrap();
    assert_eq!(sts.motion.goal, 2000.0);
}

/// The motor-side rules of each firmware against the numbers of its control table
/// (docs/protocols.md §6): what the registers let the motor push, when a protection trips.
mod motor_rules {
    use super::*;
    use crate::bus::protocol::motor::{LoadSample, ProtectionWatch};
    use crate::servo::drive::VARIANTS;

    fn drive(variant: &str) -> &'static crate::servo::Drive {
        &VARIANTS.iter().find(|v| v.name == variant).unwrap().drives[0]
    }

    fn load(output_share: f64, current_a: f64) -> LoadSample {
        LoadSample {
            output_share,
            current_a,
            temperature_c: 30.0,
        }
    }

    /// The interval the protection is stepped in: a trip is due within one of its time.
    const STEP: f64 = 0.01 + 1e-9;

    /// Steps the protection in 10 ms intervals for `seconds`; the time of the first trip.
    fn first_trip(servo: &mut VirtualServo, sample: LoadSample, seconds: f64) -> Option<f64> {
        let mut watch = ProtectionWatch::default();
        let dt = 0.01;
        for step in 1..=(seconds / dt).round() as usize {
            let trip = servo.firmware().protect(servo, &mut watch, &sample, dt);
            if trip.any() {
                return Some(step as f64 * dt);
            }
        }
        None
    }

    #[test]
    fn the_sts3215s_output_is_its_torque_limit_and_its_stiffness_its_p_coefficient_over_16() {
        let mut servo = VirtualServo::new(1, ServoModel::Sts3215, 2048.0);
        let c001 = drive("c001");
        let watch = ProtectionWatch::default();
        // Factory: Torque_Limit 1000 (100 %), P_Coefficient 32 (twice LeRobot's 16).
        let limits = servo.firmware().motor(&servo, c001, &watch);
        assert_eq!((limits.force_share, limits.stiffness_share), (1.0, 2.0));
        servo.set("Torque_Limit", 500).unwrap();
        servo.set("Torque_Enable", 0).unwrap();
        servo.set("P_Coefficient", 16).unwrap();
        let limits = servo.firmware().motor(&servo, c001, &watch);
        assert_eq!((limits.force_share, limits.stiffness_share), (0.5, 1.0));
    }

    #[test]
    fn an_sts3215_overloaded_past_its_protection_time_unloads_or_holds_its_protective_torque() {
        let mut servo = VirtualServo::new(1, ServoModel::Sts3215, 2048.0);
        // Overload_Torque 80 %, Protection_Time 200 × 10 ms: 85 % trips at 2.00 s, 75 % never.
        let trip_at = first_trip(&mut servo, load(0.85, 0.5), 3.0).unwrap();
        assert!((2.0..=2.0 + STEP).contains(&trip_at), "{trip_at}");
        assert_eq!(first_trip(&mut servo, load(0.75, 0.5), 3.0), None);
        let mut watch = ProtectionWatch {
            overloaded_s: 2.0,
            ..ProtectionWatch::default()
        };
        let trip = servo
            .firmware()
            .protect(&servo, &mut watch, &load(-0.9, 0.5), 0.01);
        assert!(trip.alarms.overload && trip.torque_off, "{trip:?}");
        // Unloading_Condition without bit 5: held to Protective_Torque (20 %) instead.
        servo.set("Unloading_Condition", 44 & !0x20).unwrap();
        let mut watch = ProtectionWatch {
            overloaded_s: 2.0,
            ..ProtectionWatch::default()
        };
        let trip = servo
            .firmware()
            .protect(&servo, &mut watch, &load(0.9, 0.5), 0.01);
        assert!(trip.alarms.overload && !trip.torque_off, "{trip:?}");
        assert_eq!(watch.limited_to, Some(0.2));
        let limits = servo.firmware().motor(&servo, drive("c001"), &watch);
        assert_eq!(limits.force_share, 0.2);
    }

    #[test]
    fn an_sts3215_over_its_protection_current_trips_after_its_over_current_time() {
        let mut servo = VirtualServo::new(1, ServoModel::Sts3215, 2048.0);
        // Protection_Current 500 × 6.5 mA = 3.25 A, for Over_Current_Protection_Time 2 s.
        let trip_at = first_trip(&mut servo, load(0.1, 3.3), 3.0).unwrap();
        assert!((2.0..=2.0 + STEP).contains(&trip_at), "{trip_at}");
        assert_eq!(first_trip(&mut servo, load(0.1, 3.2), 3.0), None);
    }

    #[test]
    fn an_x_series_servo_overloads_after_5_s_above_40_percent_and_shuts_down() {
        let mut servo = VirtualServo::new(1, ServoModel::Xm430W350, 2048.0);
        let trip_at = first_trip(&mut servo, load(0.45, 1.0), 6.0).unwrap();
        assert!((5.0..=5.0 + STEP).contains(&trip_at), "{trip_at}");
        assert_eq!(first_trip(&mut servo, load(0.35, 1.0), 6.0), None);
        let mut watch = ProtectionWatch {
            overloaded_s: 5.0,
            ..ProtectionWatch::default()
        };
        let trip = servo
            .firmware()
            .protect(&servo, &mut watch, &load(0.5, 1.0), 0.01);
        // Shutdown's factory value has bit 5: torque off.
        assert!(trip.alarms.overload && trip.torque_off, "{trip:?}");
    }

    #[test]
    fn a_koch_gripper_in_current_based_position_pushes_at_most_its_goal_current() {
        let mut servo = VirtualServo::new(6, ServoModel::Xl330M288, 2048.0);
        servo.set("Operating_Mode", 5).unwrap();
        // LeRobot's Koch gripper: Goal_Current 300 × 1 mA of the 1.47 A stall current.
        servo.set("Goal_Current", 300).unwrap();
        let watch = ProtectionWatch::default();
        let limits = servo.firmware().motor(&servo, drive("xl330-m288"), &watch);
        assert!(
            (limits.force_share - 300.0 / 1470.0).abs() < 1e-9,
            "{limits:?}"
        );
        // In position mode Goal_Current bounds nothing; PWM_Limit 885 is the full supply.
        servo.set("Operating_Mode", 3).unwrap();
        let limits = servo.firmware().motor(&servo, drive("xl330-m288"), &watch);
        assert_eq!(limits.force_share, 1.0);
    }

    #[test]
    fn goal_pwm_caps_the_output_in_position_mode_within_pwm_limit() {
        // e-Manual: "In other control modes, this value is used to limit PWM value"; a grasp's
        // effort of 30 % is written as 266 of 885.
        let mut servo = VirtualServo::new(6, ServoModel::Xl430W250, 2048.0);
        let watch = ProtectionWatch::default();
        servo.set("Goal_PWM", 266).unwrap();
        let limits = servo.firmware().motor(&servo, drive("xl430-w250"), &watch);
        assert!(
            (limits.force_share - 266.0 / 885.0).abs() < 1e-9,
            "{limits:?}"
        );
        // Within PWM_Limit: a Goal_PWM above a lower PWM_Limit is bounded by the limit (the
        // EEPROM limit is written with the torque off, as the firmware requires).
        servo.set("Goal_PWM", 885).unwrap();
        servo.set("PWM_Limit", 442).unwrap();
        let limits = servo.firmware().motor(&servo, drive("xl430-w250"), &watch);
        assert!(
            (limits.force_share - 442.0 / 885.0).abs() < 1e-9,
            "{limits:?}"
        );
    }
}
