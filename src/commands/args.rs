//! The arguments several verbs share: where the servos are ([`BusArgs`]), which robot
//! ([`RobotArgs`]), which sequence on which robot ([`SequenceInput`]).

use super::{option_values, CalibrationArgs, CommandError};
use keypose::bus::{self, Driver};
use keypose::curve::Interp;
use keypose::robot::Robot;
use keypose::sequence::Sequence;
use std::path::{Path, PathBuf};

/// Where the servos are.
#[derive(Debug, Clone, clap::Args)]
pub struct BusArgs {
    /// Serial port (e.g. /dev/ttyUSB0, /dev/ttyACM0), or "virtual" for emulated servos on a
    /// pseudo-terminal. A sequence of several arms: ARM=PATH once per arm, or "virtual" for
    /// emulated servos on a bus of their own per arm.
    #[arg(long, value_name = "[ARM=]PATH|virtual")]
    pub port: Vec<String>,
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
    #[command(flatten)]
    pub wire: WireArgs,
    #[command(flatten)]
    pub physics: PhysicsArgs,
}

/// Emulated servos that carry the arm's weight (port "virtual", `keypose virtual-bus`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct PhysicsArgs {
    /// Virtual bus: the servos carry the arm in MuJoCo (gravity, the table, load, each
    /// servo's torque-speed line, its firmware's gains, limits and protection) instead of
    /// moving in empty space.
    #[arg(long)]
    pub physics: bool,
    /// With --physics: what stands beside the arm: "table" (the table top the arm stands on,
    /// always there) or an MJCF file of objects added to it (a block to pick, a fixture).
    #[arg(long, value_name = "table|FILE.xml", requires = "physics")]
    pub scene: Option<String>,
}

/// The `--scene` that is only the table the arm stands on.
const TABLE_SCENE: &str = "table";

impl PhysicsArgs {
    /// What makes the arm's physics, when `--physics` asks for it; a scene file that is not
    /// there is refused before anything starts.
    pub fn source(&self) -> Result<Option<bus::PhysicsSource>, CommandError> {
        if !self.physics {
            return Ok(None);
        }
        let scene = match self.scene.as_deref() {
            None | Some(TABLE_SCENE) => None,
            Some(path) => {
                let path = PathBuf::from(path);
                if !path.is_file() {
                    return Err(CommandError::Usage(format!(
                        "--scene {}: no such file; expected \"{TABLE_SCENE}\" or an MJCF file of objects",
                        path.display()
                    )));
                }
                Some(path)
            }
        };
        let make = move |robot: &Robot| -> Result<
            Box<dyn keypose::testing::Physics>,
            keypose::testing::PhysicsError,
        > {
            keypose::sim::MujocoArm::start_at_rest(robot, scene.as_deref())
                .map(|arm| Box::new(arm) as Box<dyn keypose::testing::Physics>)
                .map_err(|e| keypose::testing::PhysicsError {
                    bad_input: e.kind() == keypose::error::ErrorKind::BadInput,
                    message: e.to_string(),
                })
        };
        Ok(Some(bus::PhysicsSource(std::sync::Arc::new(make))))
    }
}

/// `--realtime` for the commands that run a control loop.
#[derive(Debug, Clone, clap::Args)]
pub struct RealtimeArgs {
    /// Run the control loop under SCHED_FIFO with memory locked, where permitted (otherwise a
    /// one-line notice, and the ordinary scheduler); see `keypose doctor`.
    #[arg(long)]
    pub realtime: bool,
}

impl RealtimeArgs {
    /// Enters real-time scheduling for the calling thread when asked; threads started before
    /// (the virtual bus's server, the signal handler) keep the ordinary scheduler.
    pub fn enter(&self) {
        if self.realtime {
            for notice in keypose::pacing::realtime::enter().notices() {
                eprintln!("{notice}");
            }
        }
    }
}

/// How emulated servos (port "virtual", `keypose virtual-bus`) time their wire.
#[derive(Debug, Clone, clap::Args)]
pub struct WireArgs {
    /// Virtual bus: answer at once instead of taking the real wire's time (bytes at the baud
    /// rate, return delays).
    #[arg(long)]
    pub no_wire_timing: bool,
    /// Virtual bus: emulate a USB adapter's latency, milliseconds (FTDI's default 16, 1 when
    /// tuned).
    #[arg(long, value_name = "MS", default_value = "0", value_parser = option_values::parse_usb_latency, allow_negative_numbers = true)]
    pub usb_latency: std::time::Duration,
}

impl WireArgs {
    /// The wire timing at `baud`, or `None` for answers at once.
    pub fn timing(&self, baud: u32) -> Option<keypose::testing::WireTiming> {
        (!self.no_wire_timing).then_some(keypose::testing::WireTiming {
            baud,
            usb_latency: self.usb_latency,
        })
    }
}

impl BusArgs {
    /// Opens the servos of `robot`: its bus on the one `--port`, or for a cell of several arms
    /// one bus per arm (`--port ARM=PATH` each, or `--port virtual`).
    pub fn open(&self, robot: &Robot) -> Result<bus::Connection, CommandError> {
        let options = bus::BusOptions {
            driver: self.driver,
            baud: self.baud,
            fast_sync_read: self.fast_sync_read,
            wire_timing: !self.wire.no_wire_timing,
            usb_latency: self.wire.usb_latency,
            physics: self.physics.source()?,
        };
        if robot.is_cell() {
            let ports = self.arm_ports(robot)?;
            return Ok(bus::connect_cell(robot, &ports, &options)?);
        }
        Ok(bus::connect_with(robot, self.required_port()?, &options)?)
    }

    /// Refuses ports that do not fit `robot` (one plain port, or one per arm of a cell) before
    /// anything is opened.
    pub fn check_ports(&self, robot: &Robot) -> Result<(), CommandError> {
        if robot.is_cell() {
            self.arm_ports(robot).map(|_| ())
        } else {
            self.required_port().map(|_| ())
        }
    }

    /// Whether any `--port` was given.
    pub fn given(&self) -> bool {
        !self.port.is_empty()
    }

    /// The one port of a robot of one arm.
    pub fn required_port(&self) -> Result<&str, CommandError> {
        match self.port.as_slice() {
            [] => Err(CommandError::Usage(
                "--port is required: a serial port (see `keypose ports`) or \"virtual\"".into(),
            )),
            [port] => match arm_port(port) {
                None => Ok(port),
                Some((arm, _)) => Err(CommandError::Usage(format!(
                    "--port {port:?} names an arm ({arm:?}), but the robot has one arm; expected --port PATH"
                ))),
            },
            ports => Err(CommandError::Usage(format!(
                "--port is given {} times, but the robot has one arm; expected one --port PATH (ARM=PATH once per arm is for a sequence of several arms)",
                ports.len()
            ))),
        }
    }

    /// Each arm's port, in the cell's arm order.
    fn arm_ports(&self, cell: &Robot) -> Result<Vec<&str>, CommandError> {
        let names: Vec<&str> = cell.arms.iter().map(|a| a.name.as_str()).collect();
        let expected = || {
            format!(
                "expected --port ARM=PATH once for each of {}, or --port {}",
                names.join(", "),
                bus::VIRTUAL_PORT
            )
        };
        match self.port.as_slice() {
            [] => {
                return Err(CommandError::Usage(format!(
                    "--port is required: {}",
                    expected()
                )))
            }
            [one] if one == bus::VIRTUAL_PORT => return Ok(vec![bus::VIRTUAL_PORT; names.len()]),
            _ => {}
        }
        let mut ports: Vec<Option<&str>> = vec![None; names.len()];
        for value in &self.port {
            let (arm, path) = arm_port(value).ok_or_else(|| {
                CommandError::Usage(format!(
                    "--port {value:?}: the sequence has several arms; {}",
                    expected()
                ))
            })?;
            let index = names.iter().position(|n| *n == arm).ok_or_else(|| {
                CommandError::Usage(format!(
                    "--port {value:?}: the sequence has no arm {arm:?}; {}",
                    expected()
                ))
            })?;
            if ports[index].replace(path).is_some() {
                return Err(CommandError::Usage(format!(
                    "--port: arm {arm} is given twice; {}",
                    expected()
                )));
            }
        }
        let mut found = Vec::with_capacity(names.len());
        for (name, port) in names.iter().zip(&ports) {
            let port = port.ok_or_else(|| {
                CommandError::Usage(format!("--port: no port for arm {name}; {}", expected()))
            })?;
            // One adapter cannot be two arms' bus: the second open would fail, or worse,
            // two arms' goals would reach the same servos.
            if port != bus::VIRTUAL_PORT && found.contains(&port) {
                return Err(CommandError::Usage(format!(
                    "--port: {port} is given to two arms; expected a port of its own for each arm"
                )));
            }
            found.push(port);
        }
        Ok(found)
    }
}

/// `("left", "/dev/ttyACM0")` for `left=/dev/ttyACM0`. An arm's name has no `/` (joints are
/// `ARM/JOINT`), so a path that holds a `=` further on is still a path.
fn arm_port(value: &str) -> Option<(&str, &str)> {
    value
        .split_once('=')
        .filter(|(arm, _)| !arm.is_empty() && !arm.contains('/'))
}

/// A robot for commands without a sequence.
#[derive(Debug, Clone, clap::Args)]
pub struct RobotArgs {
    /// A built-in robot (so101, so100, koch, omx), a LeRobot robot type (so101_follower,
    /// so100_follower, koch_follower and their leaders) or a robot file.
    #[arg(long, value_name = "NAME|FILE", default_value = super::DEFAULT_ROBOT)]
    pub robot: String,
    #[command(flatten)]
    pub calibration: CalibrationArgs,
}

impl RobotArgs {
    pub fn load(&self) -> Result<Robot, CommandError> {
        super::load_robot(&self.robot, &self.calibration)
    }
}

/// The inputs every sequence command takes: the file, and how to read it.
#[derive(Debug, Clone, clap::Args)]
pub struct SequenceInput {
    /// Sequence file (keypose-sequence/1 JSON).
    pub sequence: PathBuf,
    #[command(flatten)]
    pub options: SequenceOptions,
}

/// How to read a sequence: on which robot, with which calibration, in which mode. `play` takes
/// these without [`SequenceInput`], since a dataset episode may stand in for its file.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SequenceOptions {
    /// Robot to use instead of the one the sequence names: a built-in name (so101, so100, koch, omx),
    /// a LeRobot robot type (so101_follower, koch_leader, …) or a robot file.
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: Option<String>,
    #[command(flatten)]
    pub calibration: CalibrationArgs,
    /// Interpolation for segments without their own "interp", instead of the file's: try the same
    /// keys in another mode.
    #[arg(long, value_name = "MODE", value_parser = parse_interp)]
    pub interpolation: Option<Interp>,
    /// How close the arm may come to the floor, itself or another arm before the check
    /// reports it, millimetres [default: the robot file's clearance_mm, 3 mm for the
    /// built-ins].
    #[arg(long, value_name = "MM", value_parser = parse_clearance, allow_negative_numbers = true)]
    pub clearance: Option<f64>,
    /// A load the tool carries, kilograms, at the TCP: its weight and inertia in the torque
    /// check, the fastest timing and the simulation [default: the robot file's payload].
    #[arg(long, value_name = "KG", value_parser = parse_payload, allow_negative_numbers = true)]
    pub payload: Option<f64>,
    /// The servos' build: 5v (7.4 V STS3215 on 5 V, the standard SO-101 and SO-100), 7.4v,
    /// 12v (12 V STS3215 on 12 V) [default: what the robot file says, 5v for the built-ins].
    #[arg(long, value_name = "NAME")]
    pub robot_variant: Option<String>,
}

fn parse_payload(s: &str) -> Result<f64, String> {
    from_zero_to(s, keypose::robot::MAX_PAYLOAD_KG, "a payload", "kg")
}

fn parse_clearance(s: &str) -> Result<f64, String> {
    from_zero_to(s, keypose::robot::MAX_CLEARANCE_MM, "a clearance", "mm")
}

/// A number from 0 to `max` (`what`, in `unit`).
fn from_zero_to(s: &str, max: f64, what: &str, unit: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| (0.0..=max).contains(x))
        .ok_or_else(|| format!("expected {what} from 0 to {max} {unit}, found {s:?}"))
}

fn parse_interp(s: &str) -> Result<Interp, String> {
    Interp::parse(s).ok_or_else(|| format!("expected one of {}, found {s:?}", Interp::names()))
}

impl SequenceInput {
    /// Loads the sequence and its robot (with any calibration applied).
    pub fn load(&self) -> Result<(Sequence, Robot), CommandError> {
        self.options.load(&self.sequence)
    }
}

impl SequenceOptions {
    /// Loads the sequence at `path` and its robot (with any calibration applied).
    pub fn load(&self, path: &Path) -> Result<(Sequence, Robot), CommandError> {
        let mut sequence = Sequence::load(path)?;
        if let Some(mode) = self.interpolation {
            sequence.interpolation = mode;
        }
        if sequence.is_cell() {
            if self.robot.is_some() {
                return Err(CommandError::Usage(format!(
                    "--robot: {} names several arms (\"robots\"); expected no --robot (name each arm's robot in the file)",
                    sequence.file
                )));
            }
            let mut cell = super::load_cell(&sequence, path, &self.calibration)?;
            self.apply_to(&mut cell)?;
            return Ok((sequence, cell));
        }
        let robot = match &self.robot {
            Some(spec) => super::resolve_option_robot(spec)?,
            None => super::resolve_sequence_robot(&sequence, path)?,
        };
        let mut robot = super::finish_robot(robot, &self.calibration)?;
        self.apply_to(&mut robot)?;
        Ok((sequence, robot))
    }

    /// `--clearance`, `--payload` and `--robot-variant`, over what the robot file says (on
    /// every arm of a cell).
    pub fn apply_to(&self, robot: &mut Robot) -> Result<(), CommandError> {
        if let Some(mm) = self.clearance {
            robot.clearance = mm / 1000.0;
        }
        if let Some(mass) = self.payload {
            let payload = keypose::robot::Payload {
                mass,
                com: glam::DVec3::ZERO,
            };
            if robot.is_cell() {
                for arm in &mut robot.arms {
                    arm.robot.payload = Some(payload);
                }
            } else {
                robot.payload = Some(payload);
            }
        }
        if let Some(name) = &self.robot_variant {
            let usage = |e: keypose::robot::BuildError| {
                CommandError::Usage(format!("--robot-variant: {e}"))
            };
            let build = keypose::robot::Build::named(name).map_err(usage)?;
            robot.with_build(build).map_err(usage)?;
        }
        Ok(())
    }
}
