//! `--servo-profile` on the in-process virtual bus (the real driver and packet code, emulated
//! servos): the profile registers receive the joints' limits in the servos' units, and the
//! values found before are back afterwards, at the end of a playback and after a fault.
//!
//! The writes are checked in the instruction packets the emulated servos received, decoded
//! here from the sync-write layout of docs/protocols.md (not with keypose's decoder), and the
//! values the servos hold are read back from them afterwards.

use keypose::bus::ServoBus;
use keypose::pacing::Clock;
use keypose::plan::Trajectory;
use keypose::player::{
    play, play_with_clock, Outcome, PlayError, PlayOptions, ServoProfileError, StopSignal,
};
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use keypose::servo::Setting;
use keypose::testing::VirtualBus;
use std::sync::Mutex;
use std::time::Duration;

/// SYNC WRITE's instruction code, the same in Feetech STS and Dynamixel 2.0.
const SYNC_WRITE: u8 = 0x83;

/// A short wrist tilt, valid on every built-in robot that has a wrist_flex joint.
fn trajectory(robot: &Robot) -> Trajectory {
    let json = format!(
        r#"{{"format":"keypose-sequence/1","robot":"{}","keyframes":[
        {{"time":0,"joints":{{"wrist_flex":0}}}},{{"time":0.3,"joints":{{"wrist_flex":5}}}}]}}"#,
        robot.name
    );
    let sequence = Sequence::from_json("tilt.json", &json).unwrap();
    Trajectory::build(&sequence, robot).unwrap()
}

/// Every sync write to `address` the servos received, as (id, value) lists, in order.
/// Feetech params: address, length, then id + `length` little-endian bytes per servo;
/// Dynamixel: address and length as 2 little-endian bytes each, then the same blocks.
fn sync_writes_to(bus: &VirtualBus, address: u16, wide_fields: bool) -> Vec<Vec<(u8, i64)>> {
    let servos = bus.lock();
    servos
        .received
        .iter()
        .filter(|p| p.instruction_code() == Some(SYNC_WRITE))
        .filter_map(|p| {
            let (at, length, blocks) = if wide_fields {
                let at = u16::from_le_bytes([p.params[0], p.params[1]]);
                let length = u16::from_le_bytes([p.params[2], p.params[3]]) as usize;
                (at, length, &p.params[4..])
            } else {
                (u16::from(p.params[0]), p.params[1] as usize, &p.params[2..])
            };
            (at == address).then(|| {
                blocks
                    .chunks(1 + length)
                    .map(|b| {
                        let value = b[1..]
                            .iter()
                            .rev()
                            .fold(0i64, |v, &x| (v << 8) | i64::from(x));
                        (b[0], value)
                    })
                    .collect()
            })
        })
        .collect()
}

fn ids(robot: &Robot) -> Vec<u8> {
    robot.joints.iter().map(|j| j.servo.id).collect()
}

#[test]
fn so101_gets_its_acceleration_limit_in_sts_units_and_its_old_values_back() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let ids = ids(&robot);
    // LeRobot's setting (254) as the value found before playback.
    let before: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 254)).collect();
    bus.write_setting(&before, Setting::Acceleration).unwrap();
    let mut options = PlayOptions::new(100.0);
    options.servo_profile = true;
    let (outcome, _) = play(
        &mut bus,
        &robot,
        &trajectory(&robot),
        &options,
        &StopSignal::default(),
    )
    .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    // so101's joints: 344 °/s². 344 · 4096/360 = 3913.96 steps/s², / 100 steps/s² per unit =
    // 39.14, rounded down to 39 (never above the joint's limit).
    let writes = sync_writes_to(&virtual_bus, 41, false);
    let during: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 39)).collect();
    assert_eq!(writes, [before.clone(), during, before.clone()]);
    // And the servos hold the old values again.
    assert_eq!(
        bus.read_setting(&ids, Setting::Acceleration).unwrap(),
        vec![254; 6]
    );
}

/// Virtual time that jumps `seconds` at the `at_wait`-th wait: a stall beyond the bound.
struct OneStall {
    now: Mutex<(f64, u64)>,
    at_wait: u64,
    seconds: f64,
}

impl Clock for OneStall {
    fn now(&self) -> Duration {
        Duration::from_secs_f64(self.now.lock().unwrap().0)
    }
    fn sleep_until(&self, deadline: Duration, _: &StopSignal, _: u32) {
        let mut now = self.now.lock().unwrap();
        now.0 = now.0.max(deadline.as_secs_f64());
        now.1 += 1;
        if now.1 == self.at_wait {
            now.0 += self.seconds;
        }
    }
}

#[test]
fn koch_gets_profile_velocity_and_acceleration_and_both_are_restored_after_a_fault() {
    let robot = Robot::builtin("koch").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let ids = ids(&robot);
    // Values found before: the factory 0 (no profile) for both.
    let mut options = PlayOptions::new(100.0);
    options.servo_profile = true;
    let clock = OneStall {
        now: Mutex::new((0.0, 0)),
        at_wait: 20,
        seconds: 2.0,
    };
    let played = play_with_clock(
        &mut bus,
        &robot,
        &trajectory(&robot),
        &options,
        &StopSignal::default(),
        &clock,
    );
    assert!(matches!(played, Err(PlayError::Stall { .. })), "{played:?}");
    // Dynamixel X units: Profile_Velocity 0.229 rev/min = 1.374 °/s; Profile_Acceleration
    // 214.577 rev/min² = 21.4577 °/s². Koch's XL430 joints (ids 1, 2): 220 °/s → 160.1 → 160,
    // 688 °/s² → 32.06 → 32; its XL330 joints (3–6): 370 °/s → 269.3 → 269, 1146 °/s² → 53.4
    // → 53. All rounded down.
    let velocity: Vec<(u8, i64)> = ids
        .iter()
        .map(|&id| (id, if id <= 2 { 160 } else { 269 }))
        .collect();
    let acceleration: Vec<(u8, i64)> = ids
        .iter()
        .map(|&id| (id, if id <= 2 { 32 } else { 53 }))
        .collect();
    let zeros: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 0)).collect();
    assert_eq!(
        sync_writes_to(&virtual_bus, 112, true),
        [velocity, zeros.clone()]
    );
    assert_eq!(
        sync_writes_to(&virtual_bus, 108, true),
        [acceleration, zeros]
    );
    assert_eq!(
        bus.read_setting(&ids, Setting::ProfileVelocity).unwrap(),
        vec![0; 6]
    );
    assert_eq!(
        bus.read_setting(&ids, Setting::ProfileAcceleration)
            .unwrap(),
        vec![0; 6]
    );
}

#[test]
fn a_stop_request_ends_playback_with_the_old_values_back() {
    // Two requests already pending (Ctrl-C twice): the first cycle holds at once.
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let ids = ids(&robot);
    let before: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 200)).collect();
    bus.write_setting(&before, Setting::Acceleration).unwrap();
    let stop = StopSignal::default();
    stop.request();
    stop.request();
    let mut options = PlayOptions::new(100.0);
    options.servo_profile = true;
    let (outcome, _) = play(&mut bus, &robot, &trajectory(&robot), &options, &stop).unwrap();
    assert_eq!(outcome, Outcome::Held);
    let during: Vec<(u8, i64)> = ids.iter().map(|&id| (id, 39)).collect();
    assert_eq!(
        sync_writes_to(&virtual_bus, 41, false),
        [before.clone(), during, before]
    );
    assert_eq!(
        bus.read_setting(&ids, Setting::Acceleration).unwrap(),
        vec![200; 6]
    );
}

/// A Dynamixel servo in the time-based profile (Drive_Mode bit 2, value 4, as ROBOTIS sets up
/// the OpenMANIPULATOR-X) takes Profile_Velocity and Profile_Acceleration as milliseconds: the
/// limits would become move times. The playback is refused before anything is written.
#[test]
fn a_dynamixel_servo_in_the_time_based_profile_is_refused_and_nothing_is_written() {
    let robot = Robot::builtin("koch").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    // Drive_Mode (address 10) is in EEPROM: written while the torque is off, as at rest.
    virtual_bus.lock().servos[2].set("Drive_Mode", 4).unwrap();
    let mut options = PlayOptions::new(100.0);
    options.servo_profile = true;
    let played = play(
        &mut bus,
        &robot,
        &trajectory(&robot),
        &options,
        &StopSignal::default(),
    );
    match played {
        Err(PlayError::ServoProfile(ServoProfileError::TimeBased {
            servo, drive_mode, ..
        })) => assert_eq!((servo, drive_mode), (3, 4)),
        other => panic!("{other:?}"),
    }
    assert!(sync_writes_to(&virtual_bus, 112, true).is_empty());
    assert!(sync_writes_to(&virtual_bus, 108, true).is_empty());
    assert!(
        virtual_bus.lock().goals_received().is_empty(),
        "nothing moved"
    );
}
