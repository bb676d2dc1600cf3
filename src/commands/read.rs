//! `keypose read`: the present pose as JSON.

use super::{write_output, BusArgs, CommandError, RobotArgs, Verdict};
use serde_json::json;

#[derive(Debug, Clone, clap::Args)]
pub struct ReadArgs {
    #[command(flatten)]
    pub robot: RobotArgs,
    #[command(flatten)]
    pub bus: BusArgs,
}

/// `keypose read`: the present pose as JSON, in degrees (metres for prismatic joints), and in
/// percent of the calibrated range for joints a LeRobot calibration recorded one for; then each
/// servo's health: its load (signed percent of its maximum, or of its stall current), its
/// temperature, its supply and the alarms it raises.
pub fn run(args: &ReadArgs) -> Result<Verdict, CommandError> {
    let robot = args.robot.load()?;
    super::announce_robot(&robot);
    let mut connection = args.bus.open(&robot)?;
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let ticks = connection.bus.read_positions(&ids)?;
    let mut joints = serde_json::Map::new();
    // Joints whose calibration recorded a range, also as LeRobot's 0…100 of it.
    let mut percent = serde_json::Map::new();
    for (joint, tick) in robot.joints.iter().zip(&ticks) {
        let value = joint.servo.value(*tick);
        joints.insert(joint.name.clone(), json!(value));
        if let Some(range) = joint.calibrated_range {
            percent.insert(joint.name.clone(), json!(range.percent(value)));
        }
    }
    let mut out = json!({ "robot": robot.name, "joints": joints, "ticks": ticks });
    if !percent.is_empty() {
        out["percent"] = serde_json::Value::Object(percent);
    }
    out["health"] = health(&robot, connection.bus.read_health(&ids)?);
    write_output(None, &format!("{out}\n"))?;
    Ok(Verdict::Pass)
}

/// Per joint: load in percent, current in amperes (null where not measured), temperature in °C, supply in volts, the alarms raised (named).
fn health(robot: &keypose::robot::Robot, health: Vec<keypose::bus::Health>) -> serde_json::Value {
    let mut out = serde_json::Map::new();
    for (joint, h) in robot.joints.iter().zip(health) {
        out.insert(
            joint.name.clone(),
            json!({
                "load_percent": (h.load_percent * 10.0).round() / 10.0,
                "current_a": h.current_a.map(|a| (a * 1000.0).round() / 1000.0),
                "temperature_c": h.temperature_c,
                "voltage_v": h.voltage_v,
                "alarms": h.alarms.names(),
            }),
        );
    }
    serde_json::Value::Object(out)
}
