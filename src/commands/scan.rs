//! `keypose scan`: which servos answer on a port.

use super::{option_values, write_output, CommandError, Verdict};
use keypose::bus::{self, Driver};
use keypose::robot::Protocol;
use serde_json::json;

#[derive(Debug, Clone, clap::Args)]
pub struct ScanArgs {
    /// Serial port to scan.
    #[arg(long, value_name = "PATH|virtual")]
    pub port: String,
    /// Protocol to scan with [default: both Dynamixel 2.0 and Feetech STS].
    #[arg(long, value_parser = parse_protocol)]
    pub protocol: Option<Protocol>,
    /// Baud rate (Feetech servos ship at 1000000, Dynamixel X-series at 57600).
    #[arg(long, value_name = "BPS", default_value_t = 1_000_000, value_parser = option_values::parse_baud, allow_negative_numbers = true)]
    pub baud: u32,
    /// With --port virtual: the robot whose servos to emulate.
    #[arg(long, value_name = "NAME|FILE", default_value = super::DEFAULT_ROBOT)]
    pub robot: String,
    /// Our own protocol code (native) or the vendor's Python SDK (sdk).
    #[arg(long, value_enum, default_value_t = Driver::Native)]
    pub driver: Driver,
}

fn parse_protocol(s: &str) -> Result<Protocol, String> {
    Protocol::ALL
        .into_iter()
        .find(|p| p.name() == s)
        .ok_or_else(|| format!("expected dynamixel-2, feetech-sts or feetech-scs, found {s:?}"))
}

/// `keypose scan`: ping every id and report the servos that answer, with their alarms. Exit 0
/// when every servo found answered cleanly, 1 when some are in alarm or none answered.
pub fn run(args: &ScanArgs) -> Result<Verdict, CommandError> {
    let protocols: Vec<Protocol> = match args.protocol {
        Some(p) => vec![p],
        None => vec![Protocol::Dynamixel2, Protocol::FeetechSts],
    };
    let robot = super::load_robot(&args.robot, &super::CalibrationArgs::default())?;
    let found = bus::scan(&args.port, &robot, &protocols, args.baud, args.driver)?;
    let rows = servo_rows(&found);
    write_output(
        None,
        &format!(
            "{}\n",
            json!({ "port": args.port, "baud": args.baud, "servos": rows })
        ),
    )?;
    if found.is_empty() {
        explain_silence(args, &protocols);
        return Ok(Verdict::Fail);
    }
    let in_alarm: Vec<_> = found.iter().filter(|(_, info)| info.alarms.any()).collect();
    for (_, info) in &in_alarm {
        eprintln!("servo {}: alarm: {}", info.id, info.alarms);
    }
    Ok(if in_alarm.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fail
    })
}

/// One JSON row per servo found.
fn servo_rows(found: &[(Protocol, bus::PingInfo)]) -> Vec<serde_json::Value> {
    found
        .iter()
        .map(|(protocol, info)| {
            json!({
                "protocol": protocol.name(),
                "id": info.id,
                "model_number": info.model_number,
                "model": keypose::servo::model_from_number(*protocol, info.model_number).map(|m| m.name()),
                "firmware": info.firmware,
                "alarms": info.alarms.names(),
            })
        })
        .collect()
}

/// What to check when no servo answered: the usual causes, most common first.
fn explain_silence(args: &ScanArgs, protocols: &[Protocol]) {
    let protocols: Vec<&str> = protocols.iter().map(|p| p.name()).collect();
    eprintln!(
        "no servo answered on {} at {} baud ({}). Check that the servos are powered (the \
         adapter's USB alone does not power them), the baud rate (--baud: Feetech ships at \
         1000000, Dynamixel X-series at 57600), the protocol (--protocol), that every servo \
         has its own id, and that the adapter is the bus adapter and is wired to the servos",
        args.port,
        args.baud,
        protocols.join(", ")
    );
}
