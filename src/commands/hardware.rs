//! The commands that talk to servos or ports without a sequence: `read`, `torque`, `scan`,
//! `ports`, `doctor`, `virtual-bus`.

use super::{option_values, write_output, CommandError, Verdict};
use crate::bus::{self, Driver};
use crate::robot::{Protocol, Robot};
use serde_json::json;
use std::io::BufRead;
use std::path::PathBuf;

/// Where the servos are.
#[derive(Debug, Clone, clap::Args)]
pub struct BusArgs {
    /// Serial port (e.g. /dev/ttyUSB0, /dev/ttyACM0), or "virtual" for emulated servos on a
    /// pseudo-terminal. `play` without a port plays in MuJoCo.
    #[arg(long, value_name = "PATH|virtual")]
    pub port: Option<String>,
    /// Our own protocol code (native) or the vendor's Python SDK (sdk).
    #[arg(long, value_enum, default_value_t = Driver::Native)]
    pub driver: Driver,
    /// Baud rate [default: the robot's].
    #[arg(long, value_name = "BPS", value_parser = option_values::parse_baud, allow_negative_numbers = true)]
    pub baud: Option<u32>,
    /// Dynamixel: read with Fast Sync Read (one combined answer; not every model and firmware
    /// supports it).
    #[arg(long)]
    pub fast_sync_read: bool,
}

impl BusArgs {
    /// Opens the bus on `port` for `robot`.
    pub fn connect(&self, robot: &Robot, port: &str) -> Result<bus::Connection, CommandError> {
        let options = bus::BusOptions {
            driver: self.driver,
            baud: self.baud,
            fast_sync_read: self.fast_sync_read,
        };
        Ok(bus::connect_with(robot, port, &options)?)
    }
}

/// A robot for commands without a sequence.
#[derive(Debug, Clone, clap::Args)]
pub struct RobotArgs {
    /// A built-in robot (so101, koch, omx) or a robot file.
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: String,
    /// LeRobot calibration file to apply.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
}

impl RobotArgs {
    pub fn load(&self) -> Result<Robot, CommandError> {
        super::load_robot(&self.robot, self.calibration.as_deref())
    }
}

fn required_port(args: &BusArgs) -> Result<&str, CommandError> {
    args.port.as_deref().ok_or_else(|| {
        CommandError::Usage(
            "--port is required: a serial port (see `keypose ports`) or \"virtual\"".into(),
        )
    })
}

#[derive(Debug, Clone, clap::Args)]
pub struct ReadArgs {
    #[command(flatten)]
    pub robot: RobotArgs,
    #[command(flatten)]
    pub bus: BusArgs,
}

/// `keypose read`: the present pose as JSON, in degrees (metres for prismatic joints).
pub fn read(args: &ReadArgs) -> Result<Verdict, CommandError> {
    let robot = args.robot.load()?;
    let mut connection = args.bus.connect(&robot, required_port(&args.bus)?)?;
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    let ticks = connection.bus.read_positions(&ids)?;
    let mut joints = serde_json::Map::new();
    for (joint, tick) in robot.joints.iter().zip(&ticks) {
        joints.insert(joint.name.clone(), json!(joint.servo.value(*tick)));
    }
    let out = json!({ "robot": robot.name, "joints": joints, "ticks": ticks });
    write_output(None, &format!("{out}\n"))?;
    Ok(Verdict::Pass)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Debug, Clone, clap::Args)]
pub struct TorqueArgs {
    /// on: hold position; off: limp, the joints can be moved by hand (they will fall under
    /// gravity: support the arm).
    #[arg(value_enum)]
    pub state: OnOff,
    #[command(flatten)]
    pub robot: RobotArgs,
    #[command(flatten)]
    pub bus: BusArgs,
    /// Only these joints (comma-separated) [default: all].
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub joints: Vec<String>,
}

/// `keypose torque on|off`.
pub fn torque(args: &TorqueArgs) -> Result<Verdict, CommandError> {
    let robot = args.robot.load()?;
    let joints = super::joint_indices(&robot, &args.joints)?;
    let ids: Vec<u8> = joints.iter().map(|&j| robot.joints[j].servo.id).collect();
    let mut connection = args.bus.connect(&robot, required_port(&args.bus)?)?;
    let on = args.state == OnOff::On;
    if on {
        // Torque on must hold where the arm is: set the goals to the present positions first,
        // and only where a goal may go.
        let ticks = connection.bus.read_positions(&ids)?;
        let mut goals = Vec::with_capacity(ids.len());
        for ((&j, &id), &tick) in joints.iter().zip(&ids).zip(&ticks) {
            let joint = &robot.joints[j];
            let goal = joint.hold_tick(tick).ok_or_else(|| {
                CommandError::Usage(format!(
                    "{} is at {:.2} {}, past its limits {} … {}: move it inside by hand first (nothing was sent)",
                    joint.name,
                    joint.servo.value(tick),
                    joint.kind.unit(),
                    joint.limits.min,
                    joint.limits.max
                ))
            })?;
            goals.push((id, goal));
        }
        connection.bus.write_goals(&goals)?;
    }
    connection.bus.set_torque(&ids, on)?;
    eprintln!(
        "torque {} on servo(s) {ids:?}",
        if on { "on" } else { "off" }
    );
    Ok(Verdict::Pass)
}

#[derive(Debug, Clone, clap::Args)]
pub struct ScanArgs {
    /// Serial port to scan.
    #[arg(long, value_name = "PATH|virtual")]
    pub port: String,
    /// Protocol to scan with [default: both Dynamixel 2.0 and Feetech STS].
    #[arg(long, value_parser = parse_protocol)]
    pub protocol: Option<Protocol>,
    /// Baud rate [default: 1000000; X-series servos ship at 57600].
    #[arg(long, value_name = "BPS", default_value_t = 1_000_000, value_parser = option_values::parse_baud, allow_negative_numbers = true)]
    pub baud: u32,
    /// With --port virtual: the robot whose servos to emulate.
    #[arg(long, value_name = "NAME|FILE", default_value = "so101")]
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
pub fn scan(args: &ScanArgs) -> Result<Verdict, CommandError> {
    let protocols: Vec<Protocol> = match args.protocol {
        Some(p) => vec![p],
        None => vec![Protocol::Dynamixel2, Protocol::FeetechSts],
    };
    let robot = super::load_robot(&args.robot, None)?;
    let found = bus::scan(&args.port, &robot, &protocols, args.baud, args.driver)?;
    let rows: Vec<_> = found
        .iter()
        .map(|(protocol, info)| {
            json!({
                "protocol": protocol.name(),
                "id": info.id,
                "model_number": info.model_number,
                "model": bus::registers::model_from_number(*protocol, info.model_number).map(|m| m.name()),
                "firmware": info.firmware,
                "alarms": info.alarms.names(),
            })
        })
        .collect();
    write_output(
        None,
        &format!(
            "{}\n",
            json!({ "port": args.port, "baud": args.baud, "servos": rows })
        ),
    )?;
    if found.is_empty() {
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

/// `keypose ports`: the serial ports of this machine, with USB adapter details.
pub fn ports() -> Result<Verdict, CommandError> {
    let ports = bus::list_ports();
    if ports.is_empty() {
        eprintln!("no serial ports found");
    }
    let text: String = ports.iter().map(|p| format!("{p}\n")).collect();
    write_output(None, &text)?;
    Ok(Verdict::Pass)
}

/// `keypose doctor`: what keypose finds on this machine, and what to fix.
pub fn doctor() -> Result<Verdict, CommandError> {
    let mut out = String::new();
    out.push_str("serial ports:\n");
    let ports = bus::list_ports();
    if ports.is_empty() {
        out.push_str("  none found\n");
    }
    for p in &ports {
        out.push_str(&format!("  {p}\n"));
    }
    out.push_str("USB latency timers:\n");
    let timers = bus::latency_timers();
    if timers.is_empty() {
        out.push_str("  no FTDI USB-serial adapters\n");
    }
    for (device, ms) in timers {
        if ms >= 16 {
            out.push_str(&format!(
                "  WARNING {device}: latency_timer is {ms} ms, which adds up to {ms} ms to every read.\n    \
                 Lower it: echo 1 | sudo tee /sys/bus/usb-serial/devices/{device}/latency_timer\n    \
                 (permanently: a udev rule, ACTION==\"add\", SUBSYSTEM==\"usb-serial\", DRIVER==\"ftdi_sio\", ATTR{{latency_timer}}=\"1\")\n"
            ));
        } else {
            out.push_str(&format!("  {device}: latency_timer {ms} ms (ok)\n"));
        }
    }
    out.push_str("python (vendor SDK bridge, simulation):\n");
    out.push_str(&crate::python::doctor_report());
    out.push_str(&simulation_report());
    write_output(None, &out)?;
    Ok(Verdict::Pass)
}

/// What the simulation harness reports when it starts: MuJoCo's version and the GL backend.
/// Never builds the environment (that is for the first `sim`).
fn simulation_report() -> String {
    use crate::python::{Harness, HarnessOptions, PyConfig};
    let config = match PyConfig::from_env() {
        Ok(c) => c,
        Err(e) => return format!("  simulation: {e}\n"),
    };
    let python = match config.find_python() {
        Ok(Some(env)) => env.python,
        Ok(None) => {
            return "  simulation: the environment is built on the first `keypose sim`\n".into()
        }
        Err(e) => return format!("  simulation: {e}\n"),
    };
    let started = config
        .script_path(crate::sim::HARNESS_SCRIPT)
        .map_err(|e| e.to_string())
        .and_then(|script| {
            Harness::spawn(&python, &script, HarnessOptions::default()).map_err(|e| e.to_string())
        });
    match started {
        Ok(harness) => {
            let ready = harness.ready();
            let field = |name: &str| ready[name].as_str().unwrap_or("?").to_string();
            format!(
                "  {}: ready: mujoco {}, numpy {}, MUJOCO_GL {}\n",
                crate::sim::HARNESS_SCRIPT,
                field("mujoco"),
                field("numpy"),
                ready["gl"]
                    .as_str()
                    .unwrap_or("not set (egl is tried first, then osmesa)")
            )
        }
        Err(e) => format!("  {}: does not start: {e}\n", crate::sim::HARNESS_SCRIPT),
    }
}

#[derive(Debug, Clone, clap::Args)]
pub struct VirtualBusArgs {
    /// The robot whose servos to emulate (a built-in name or a robot file).
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: String,
    /// Inject a fault: ID:no-answer, ID:corrupt, ID:late=MS, ID:overload, ID:overheating,
    /// ID:voltage, ID:encoder, ID:electrical; or "gone" (the port disappears). Repeatable.
    #[arg(long, value_name = "FAULT", value_parser = parse_fault)]
    pub fault: Vec<FaultSpec>,
    /// Set a servo's Homing_Offset register (as a calibration tool would): ID:TICKS.
    /// Repeatable.
    #[arg(long, value_name = "ID:TICKS", value_parser = parse_homing_offset)]
    pub homing_offset: Vec<(u8, i64)>,
    /// Seconds after start at which the faults take effect.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = option_values::parse_fault_after, allow_negative_numbers = true)]
    pub fault_after: f64,
    /// A hand that moves the arm along this sequence (for the emulated robot) once a servo is
    /// told to go limp, as a user would for `keypose record`; servos with torque on resist it.
    #[arg(long, value_name = "SEQ")]
    pub hand: Option<PathBuf>,
}

/// A fault for the virtual bus, from the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultSpec {
    Servo(u8, bus::virtual_bus::ServoFault),
    PortGone,
}

fn parse_fault(s: &str) -> Result<FaultSpec, String> {
    use bus::virtual_bus::ServoFault;
    if s == "gone" {
        return Ok(FaultSpec::PortGone);
    }
    let expected = || {
        format!(
            "expected ID:KIND (KIND: no-answer, corrupt, late=MS, overload, overheating, voltage, encoder, electrical) or \"gone\", found {s:?}"
        )
    };
    let (id, kind) = s.split_once(':').ok_or_else(expected)?;
    let id: u8 = id.parse().map_err(|_| expected())?;
    let alarm = |set: fn(&mut bus::Alarms)| {
        let mut alarms = bus::Alarms::default();
        set(&mut alarms);
        ServoFault::Alarm(alarms)
    };
    let fault = match kind {
        "no-answer" => ServoFault::NoAnswer,
        "corrupt" => ServoFault::CorruptChecksum,
        "overload" => alarm(|a| a.overload = true),
        "overheating" => alarm(|a| a.overheating = true),
        "voltage" => alarm(|a| a.input_voltage = true),
        "encoder" => alarm(|a| a.encoder = true),
        "electrical" => alarm(|a| a.electrical = true),
        late => {
            let ms = late.strip_prefix("late=").ok_or_else(expected)?;
            let ms = option_values::integer_in(
                ms,
                0..=option_values::MAX_LATE_MS,
                "late=MS: milliseconds",
            )?;
            ServoFault::Late(std::time::Duration::from_millis(ms))
        }
    };
    Ok(FaultSpec::Servo(id, fault))
}

fn parse_homing_offset(s: &str) -> Result<(u8, i64), String> {
    let expected = || format!("expected ID:TICKS (e.g. 3:-1024), found {s:?}");
    let (id, ticks) = s.split_once(':').ok_or_else(expected)?;
    Ok((
        id.parse().map_err(|_| expected())?,
        ticks.parse().map_err(|_| expected())?,
    ))
}

/// A hand moving every servo of `robot` along `trajectory` (from its start, in sequence time).
fn start_hand(
    bus: &bus::virtual_bus::VirtualBus,
    robot: &Robot,
    trajectory: crate::plan::Trajectory,
) -> bus::virtual_bus::Hand {
    let ids = robot.joints.iter().map(|j| j.servo.id).collect();
    let servos: Vec<_> = robot.joints.iter().map(|j| j.servo.clone()).collect();
    let start = trajectory.start();
    let duration = trajectory.duration();
    let mut values = vec![0.0; servos.len()];
    let path = move |t: f64, ticks: &mut [f64]| {
        trajectory.sample_into(start + t, &mut values);
        for ((tick, servo), &value) in ticks.iter_mut().zip(&servos).zip(&values) {
            *tick = servo.tick_exact(value);
        }
    };
    bus::virtual_bus::Hand::start(bus.clone(), ids, duration, Box::new(path))
}

/// `keypose virtual-bus`: emulated servos on a pseudo-terminal; the device path is the first
/// line printed; serves until standard input closes or the process is terminated.
pub fn virtual_bus(args: &VirtualBusArgs) -> Result<Verdict, CommandError> {
    let robot = super::load_robot(&args.robot, None)?;
    for fault in &args.fault {
        if let FaultSpec::Servo(id, _) = fault {
            if !robot.joints.iter().any(|j| j.servo.id == *id) {
                return Err(CommandError::Usage(format!(
                    "--fault: {} has no servo {id}",
                    robot.name
                )));
            }
        }
    }
    let hand_trajectory = match &args.hand {
        Some(path) => {
            let sequence = crate::sequence::Sequence::load(path)?;
            Some(crate::plan::Trajectory::build(&sequence, &robot)?)
        }
        None => None,
    };
    let server = bus::virtual_bus::PtyServer::start(&robot)?;
    for &(id, ticks) in &args.homing_offset {
        match server.bus().lock().servo_mut(id) {
            Some(servo) => servo.set_homing_offset(ticks),
            None => {
                return Err(CommandError::Usage(format!(
                    "--homing-offset: {} has no servo {id}",
                    robot.name
                )))
            }
        }
    }
    let _hand = hand_trajectory.map(|trajectory| start_hand(server.bus(), &robot, trajectory));
    println!("{}", server.path());
    // Flush now: the parent reads the path to connect while this process keeps running.
    let _ = std::io::Write::flush(&mut std::io::stdout());
    if !args.fault.is_empty() {
        let virtual_bus = server.bus().clone();
        let faults = args.fault.clone();
        let delay = std::time::Duration::from_secs_f64(args.fault_after);
        std::thread::spawn(move || {
            std::thread::sleep(delay);
            let mut servos = virtual_bus.lock();
            for fault in faults {
                match fault {
                    FaultSpec::Servo(id, f) => servos.set_fault(id, Some(f)),
                    FaultSpec::PortGone => servos.connected = false,
                }
            }
        });
    }
    let stop = crate::stop::stop_on_signal();
    // Standard input closing (the parent went away) ends the server, as does a signal.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        for line in stdin.lock().lines() {
            if line.is_err() {
                break;
            }
        }
        let _ = tx.send(());
    });
    loop {
        if stop.count() > 0
            || rx
                .recv_timeout(std::time::Duration::from_millis(20))
                .is_ok()
        {
            break;
        }
    }
    drop(server);
    Ok(Verdict::Pass)
}
