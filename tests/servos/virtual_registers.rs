//! The emulated servos' registers seen from outside, through the vendors' own SDKs
//! (`dynamixel_sdk`, `scservo_sdk`, driven by `sim/sdk_bridge.py`) on a pseudo-terminal. The
//! oracles are the published factory values and conventions, written here with their source:
//! ROBOTIS e-Manual control tables (XL430-W250, XL330-M288) and the Feetech STS memory table
//! (FT-MEM), see docs/protocols.md §1.8 and §2.6; the LeRobot flows follow LeRobot's
//! `_get_half_turn_homings` and `record_ranges_of_motion`.

use keypose::python::{Harness, HarnessError, HarnessOptions, PyConfig};
use keypose::robot::{Protocol, ServoModel};
use keypose::testing::{PtyServer, VirtualBus, VirtualServo, VirtualServos, WireTiming};
use serde_json::{json, Value};
use std::time::{Duration, Instant};

/// How long a servo may take to get somewhere; never a pass/fail threshold on speed.
const PATIENCE: Duration = Duration::from_secs(20);
/// Dynamixel status error numbers (e-Manual Protocol 2.0, "Error").
const DATA_RANGE: u64 = 0x04;
const ACCESS: u64 = 0x07;
/// LeRobot's half turn: (4096 − 1) / 2, integer division.
const HALF_TURN: i64 = 2047;

/// The SDK bridge in the suites' shared Python environment.
fn bridge_on(port: &str, protocol: Protocol) -> Harness {
    let cache = crate::common::python_cache();
    let config = PyConfig::with_cache_dir(&cache);
    config.ensure_python().unwrap_or_else(|e| {
        panic!("these tests need keypose's Python environment (python3 with venv, PyPI): {e}")
    });
    let mut harness = Harness::start_in(&config, "sdk_bridge.py", HarnessOptions::default())
        .unwrap_or_else(|e| panic!("the SDK bridge did not start: {e}"));
    let open = json!({"op": "open", "port": port, "baud": 1_000_000, "protocol": protocol.name()});
    ok(harness.request(&open), &open);
    harness
}

fn ok(result: Result<Value, HarnessError>, request: &Value) -> Value {
    result.unwrap_or_else(|e| panic!("{request}: {e}"))
}

struct Sdk(Harness);

impl Sdk {
    fn read(&mut self, id: u8, addr: u16, len: u8) -> u64 {
        let request = json!({"op": "read", "id": id, "addr": addr, "len": len});
        let reply = ok(self.0.request(&request), &request);
        reply["value"].as_u64().expect("a value")
    }

    fn write(&mut self, id: u8, addr: u16, len: u8, value: u64) {
        let request = json!({"op": "write", "id": id, "addr": addr, "len": len, "value": value});
        ok(self.0.request(&request), &request);
    }

    /// The status error byte of a write the servo refuses.
    fn refused(&mut self, id: u8, addr: u16, len: u8, value: u64) -> u64 {
        let request = json!({"op": "write", "id": id, "addr": addr, "len": len, "value": value});
        match self.0.request(&request) {
            Err(HarnessError::Failed { reply, .. }) if reply["kind"] == json!("servo") => {
                reply["servo_error_code"].as_u64().expect("an error code")
            }
            other => panic!("{request}: expected a refusal, got {other:?}"),
        }
    }

    fn request(&mut self, request: Value) -> Value {
        ok(self.0.request(&request), &request)
    }
}

/// Servos fresh from the factory (but for their ids), shafts at `actual`, on a pty.
fn factory_bus(protocol: Protocol, servos: &[(u8, ServoModel, f64)]) -> (PtyServer, Sdk) {
    let servos = servos
        .iter()
        .map(|&(id, model, actual)| VirtualServo::new(id, model, actual))
        .collect();
    let bus = VirtualBus::new(VirtualServos::new(protocol, servos));
    // Timed as the real wire at the SDK's 1 Mbps, factory return delays included.
    let wire = Some(WireTiming::at(1_000_000));
    let server = PtyServer::serve(bus, wire).expect("virtual bus on a pseudo-terminal");
    let sdk = Sdk(bridge_on(server.path(), protocol));
    (server, sdk)
}

fn poll_until(what: &str, mut probe: impl FnMut() -> i64, done: impl Fn(i64) -> bool) -> i64 {
    let deadline = Instant::now() + PATIENCE;
    loop {
        let found = probe();
        if done(found) {
            return found;
        }
        assert!(Instant::now() < deadline, "{what}: still {found}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Two's complement of a 4-byte Dynamixel value.
fn dxl(raw: u64) -> i64 {
    i64::from(raw as u32 as i32)
}

fn dxl_raw(value: i64) -> u64 {
    u64::from(value as i32 as u32)
}

/// Feetech sign-magnitude (`scservo_sdk` `SCS_TOHOST` / `SCS_TOSCS`).
fn sts(raw: u64, sign_bit: u32) -> i64 {
    let magnitude = (raw & ((1 << sign_bit) - 1)) as i64;
    if raw & (1 << sign_bit) != 0 {
        -magnitude
    } else {
        magnitude
    }
}

fn sts_raw(value: i64, sign_bit: u32) -> u64 {
    if value < 0 {
        value.unsigned_abs() | (1 << sign_bit)
    } else {
        value as u64
    }
}

// Dynamixel X-series addresses (e-Manual control tables).
const DXL_OPERATING_MODE: u16 = 11;
const DXL_DRIVE_MODE: u16 = 10;
const DXL_HOMING_OFFSET: u16 = 20;
const DXL_MAX_LIMIT: u16 = 48;
const DXL_TORQUE: u16 = 64;
const DXL_PROFILE_VELOCITY: u16 = 112;
const DXL_GOAL: u16 = 116;
const DXL_PRESENT_VELOCITY: u16 = 128;
const DXL_PRESENT: u16 = 132;

#[test]
fn dynamixel_factory_values_access_and_ranges() {
    let (_server, mut sdk) = factory_bus(
        Protocol::Dynamixel2,
        &[
            (1, ServoModel::Xl430W250, 1000.0),
            (2, ServoModel::Xl330M288, 3000.0),
        ],
    );
    // (address, size, XL430-W250 value, XL330-M288 value): the e-Manual "Initial Value"s.
    let factory = [
        (9, 1, 250, 250),    // Return Delay Time: 500 µs
        (11, 1, 3, 3),       // Operating Mode: position
        (24, 4, 10, 10),     // Moving Threshold
        (31, 1, 72, 70),     // Temperature Limit
        (32, 2, 140, 70),    // Max Voltage Limit
        (44, 4, 265, 445),   // Velocity Limit
        (48, 4, 4095, 4095), // Max Position Limit
        (52, 4, 0, 0),       // Min Position Limit
        (63, 1, 52, 53),     // Shutdown
        (68, 1, 2, 2),       // Status Return Level
        (84, 2, 640, 400),   // Position P Gain
    ];
    for (addr, len, xl430, xl330) in factory {
        assert_eq!(sdk.read(1, addr, len), xl430, "XL430 address {addr}");
        assert_eq!(sdk.read(2, addr, len), xl330, "XL330 address {addr}");
    }
    assert_eq!(sdk.read(2, 38, 2), 1750, "XL330 Current Limit");
    // The XL430 has no current-based position mode (5); the XL330 has.
    assert_eq!(sdk.refused(1, DXL_OPERATING_MODE, 1, 5), DATA_RANGE);
    assert_eq!(
        sdk.read(1, DXL_OPERATING_MODE, 1),
        3,
        "the refused mode is not kept"
    );
    sdk.write(2, DXL_OPERATING_MODE, 1, 5);
    sdk.write(2, DXL_OPERATING_MODE, 1, 3);
    // Out of range: Max Position Limit 0–4095, Return Delay Time 0–254.
    assert_eq!(sdk.refused(1, DXL_MAX_LIMIT, 4, 4096), DATA_RANGE);
    assert_eq!(sdk.refused(1, 9, 1, 255), DATA_RANGE);
    // Read-only, and EEPROM while the torque is on: Access Error.
    assert_eq!(sdk.refused(1, DXL_PRESENT, 4, 0), ACCESS);
    sdk.write(1, DXL_TORQUE, 1, 1);
    assert_eq!(sdk.refused(1, DXL_HOMING_OFFSET, 4, 100), ACCESS);
    sdk.write(1, DXL_TORQUE, 1, 0);
    assert_eq!(sdk.read(1, DXL_HOMING_OFFSET, 4), 0);
}

#[test]
fn dynamixel_offset_limits_profile_and_bulk() {
    let (server, mut sdk) = factory_bus(
        Protocol::Dynamixel2,
        &[
            (1, ServoModel::Xl430W250, 1000.0),
            (2, ServoModel::Xl330M288, 3000.0),
        ],
    );
    // Present Position = Actual Position + Homing Offset.
    assert_eq!(dxl(sdk.read(1, DXL_PRESENT, 4)), 1000);
    sdk.write(1, DXL_HOMING_OFFSET, 4, dxl_raw(-400));
    assert_eq!(dxl(sdk.read(1, DXL_PRESENT, 4)), 600);
    // In position mode an offset beyond ±1024 is ignored.
    sdk.write(1, DXL_HOMING_OFFSET, 4, dxl_raw(1500));
    assert_eq!(dxl(sdk.read(1, DXL_PRESENT, 4)), 1000);

    // LeRobot's half-turn homing on a Koch arm: extended position mode, offset 0, read,
    // offset = 2047 − present; the present position then reads 2047.
    sdk.write(2, DXL_OPERATING_MODE, 1, 4);
    sdk.write(2, DXL_HOMING_OFFSET, 4, 0);
    let present = dxl(sdk.read(2, DXL_PRESENT, 4));
    assert_eq!(present, 3000);
    sdk.write(2, DXL_HOMING_OFFSET, 4, dxl_raw(HALF_TURN - present));
    assert_eq!(dxl(sdk.read(2, DXL_PRESENT, 4)), HALF_TURN);

    // Bulk Read: a different span of each servo in one instruction, as read one by one.
    let reply = sdk.request(json!({"op": "bulk_read", "reads": [[1, 132, 4], [2, 0, 2]]}));
    assert_eq!(
        reply["values"],
        json!([1000, 1200]),
        "present 1000, XL330 model 1200"
    );
    // Bulk Write: Profile Velocity to one, LED to the other.
    sdk.request(json!({"op": "bulk_write", "writes": [[1, 112, 4, 10], [2, 65, 1, 1]]}));
    assert_eq!(sdk.read(1, DXL_PROFILE_VELOCITY, 4), 10);
    assert_eq!(sdk.read(2, 65, 1), 1);

    // A goal past Max Position Limit stops at the limit (position mode, offset back to 0).
    sdk.write(1, DXL_HOMING_OFFSET, 4, 0);
    sdk.write(1, DXL_MAX_LIMIT, 4, 1200);
    sdk.write(1, DXL_TORQUE, 1, 1);
    sdk.write(1, DXL_PROFILE_VELOCITY, 4, 10);
    sdk.write(1, DXL_GOAL, 4, 3000);
    // While it moves, Present Velocity stays within Profile Velocity (both 0.229 rpm units).
    let speed = poll_until(
        "XL430 moving",
        || dxl(sdk.read(1, DXL_PRESENT_VELOCITY, 4)),
        |v| v != 0,
    );
    assert!((1..=10).contains(&speed), "Present Velocity {speed}");
    poll_until(
        "XL430 at its Max Position Limit",
        || dxl(sdk.read(1, DXL_PRESENT, 4)),
        |p| (p - 1200).abs() <= 1,
    );
    poll_until(
        "XL430 settled",
        || sdk.read(1, 122, 1) as i64,
        |moving| moving == 0,
    );
    assert!((dxl(sdk.read(1, DXL_PRESENT, 4)) - 1200).abs() <= 1);

    // Drive Mode reverse: a higher goal turns the shaft the other way (CCW negative).
    sdk.write(1, DXL_TORQUE, 1, 0);
    let shaft_before = server.bus().lock().servos[0].motion.position;
    sdk.write(1, DXL_DRIVE_MODE, 1, 1);
    sdk.write(1, DXL_MAX_LIMIT, 4, 4095);
    sdk.write(1, DXL_TORQUE, 1, 1);
    let present = dxl(sdk.read(1, DXL_PRESENT, 4));
    sdk.write(1, DXL_GOAL, 4, dxl_raw(present + 100));
    poll_until(
        "reversed XL430 at its goal",
        || dxl(sdk.read(1, DXL_PRESENT, 4)),
        |p| (p - (present + 100)).abs() <= 1,
    );
    let shaft_after = server.bus().lock().servos[0].motion.position;
    // 100 ticks the other way, within the ±1 tick the polls accept at either end.
    assert!(
        (shaft_after - (shaft_before - 100.0)).abs() <= 3.0,
        "shaft {shaft_before} → {shaft_after}"
    );
}

// Feetech STS3215 addresses (FT-MEM).
const STS_MAX_LIMIT: u16 = 11;
const STS_HOMING_OFFSET: u16 = 31;
const STS_OPERATING_MODE: u16 = 33;
const STS_TORQUE: u16 = 40;
const STS_GOAL: u16 = 42;
const STS_GOAL_SPEED: u16 = 46;
const STS_PRESENT: u16 = 56;
const STS_PRESENT_VELOCITY: u16 = 58;

#[test]
fn feetech_factory_values_offset_limits_and_speed() {
    let (_server, mut sdk) = factory_bus(
        Protocol::FeetechSts,
        &[
            (1, ServoModel::Sts3215, 1000.0),
            (2, ServoModel::Sts3215, 3000.0),
        ],
    );
    // (address, size, value): FT-MEM initial values.
    let factory = [
        (6, 1, 0),     // Baud rate: 1 Mbps
        (7, 1, 250),   // Return delay (no function on STS)
        (8, 1, 1),     // Response status level: answer everything
        (11, 2, 4095), // Max angle limit
        (16, 2, 1000), // Max torque: 100 %
        (21, 1, 32),   // P coefficient
        (48, 2, 1000), // Torque limit, loaded from Max torque
    ];
    for (addr, len, value) in factory {
        assert_eq!(sdk.read(1, addr, len), value, "address {addr}");
    }
    // Operating modes 0–3 only: a write of 7 changes nothing (the status byte carries alarms,
    // not refusals, on Feetech).
    sdk.write(1, STS_OPERATING_MODE, 1, 7);
    assert_eq!(sdk.read(1, STS_OPERATING_MODE, 1), 0);

    // Present = Actual − Homing_Offset, the offset sign-magnitude with bit 11.
    sdk.write(1, STS_HOMING_OFFSET, 2, 300);
    assert_eq!(sts(sdk.read(1, STS_PRESENT, 2), 15), 700);
    sdk.write(1, STS_HOMING_OFFSET, 2, sts_raw(-300, 11));
    assert_eq!(sts(sdk.read(1, STS_PRESENT, 2), 15), 1300);
    // Torque_Enable 128: the present position becomes 2048 (actual 1000: offset −1048).
    sdk.write(1, STS_TORQUE, 1, 128);
    assert_eq!(sts(sdk.read(1, STS_PRESENT, 2), 15), 2048);
    assert_eq!(sts(sdk.read(1, STS_HOMING_OFFSET, 2), 11), -1048);

    // A goal past the max angle limit stops there; Goal_Speed bounds the speed on the way.
    sdk.write(2, STS_HOMING_OFFSET, 2, 0);
    sdk.write(2, STS_MAX_LIMIT, 2, 3200);
    sdk.write(2, STS_TORQUE, 1, 1);
    sdk.write(2, STS_GOAL_SPEED, 2, 100);
    sdk.write(2, STS_GOAL, 2, 4000);
    let speed = poll_until(
        "STS moving",
        || sts(sdk.read(2, STS_PRESENT_VELOCITY, 2), 15),
        |v| v != 0,
    );
    assert!(
        (1..=100).contains(&speed),
        "Present_Velocity {speed} steps/s"
    );
    poll_until(
        "STS at its max angle limit",
        || sts(sdk.read(2, STS_PRESENT, 2), 15),
        |p| (p - 3200).abs() <= 1,
    );
}

#[test]
fn lerobot_half_turn_homing_and_range_of_motion_on_feetech() {
    let (server, mut sdk) = factory_bus(
        Protocol::FeetechSts,
        &[
            (1, ServoModel::Sts3215, 600.0),
            (2, ServoModel::Sts3215, 3500.0),
        ],
    );
    // LeRobot `calibrate()`: torque off, Homing_Offset 0, read the middle pose, then
    // Homing_Offset = present − 2047 (Feetech: Present = Actual − Offset) so it reads 2047.
    let mut offsets = Vec::new();
    for id in [1u8, 2] {
        sdk.write(id, STS_TORQUE, 1, 0);
        sdk.write(id, STS_HOMING_OFFSET, 2, 0);
        let present = sts(sdk.read(id, STS_PRESENT, 2), 15);
        let offset = present - HALF_TURN;
        sdk.write(id, STS_HOMING_OFFSET, 2, sts_raw(offset, 11));
        assert_eq!(
            sts(sdk.read(id, STS_PRESENT, 2), 15),
            HALF_TURN,
            "servo {id}"
        );
        offsets.push(offset);
    }
    assert_eq!(offsets, [600 - 2047, 3500 - 2047]);

    // Recording ranges of motion: the hand moves the limp shafts; the min and max of the
    // present positions are the shafts' extremes minus the offsets.
    let shafts = [[300.0, 900.0], [3000.0, 3900.0]];
    let mut seen = [(i64::MAX, i64::MIN); 2];
    for step in 0..=2 {
        for (i, id) in [1u8, 2].into_iter().enumerate() {
            let [low, high] = shafts[i];
            let actual = [low, high, (low + high) / 2.0][step];
            server.bus().lock().servos[i].motion.push_to(actual);
            let present = sts(sdk.read(id, STS_PRESENT, 2), 15);
            seen[i] = (seen[i].0.min(present), seen[i].1.max(present));
        }
    }
    // Servo 1: 300 + 1447 = 1747, 900 + 1447 = 2347; servo 2: 3000 − 1453 = 1547, 2447.
    assert_eq!(seen, [(1747, 2347), (1547, 2447)]);
}
