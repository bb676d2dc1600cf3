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
