//! Opening the servos of a robot: a serial port or a virtual bus, our driver or the vendor SDK.

use super::driver::NativeBus;
use super::transport::SerialTransport;
use super::virtual_bus::{Physics, PhysicsError, PtyServer, VirtualBus, VirtualServos, WireTiming};
use super::{BusError, PingInfo, ServoBus};
use crate::robot::{Protocol, Robot};
use std::sync::Arc;
use std::time::Duration;

/// Which code speaks the protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Driver {
    /// keypose's own protocol code.
    Native,
    /// The vendor's Python SDK (dynamixel-sdk, feetech-servo-sdk) through the bridge.
    Sdk,
}

/// An open bus, with the virtual servos behind it when the port is "virtual".
pub struct Connection {
    /// The bus, probed, its homing offsets checked.
    pub bus: Box<dyn ServoBus>,
    /// Kept alive for as long as the connection: dropping it stops the emulated servos.
    pub virtual_bus: Option<PtyServer>,
}

/// The port name that starts emulated servos instead of opening a device.
pub const VIRTUAL_PORT: &str = "virtual";

/// How to open a bus, beyond the port.
#[derive(Debug, Clone)]
pub struct BusOptions {
    /// Whose code speaks the protocol.
    pub driver: Driver,
    /// None: the robot's baud rate.
    pub baud: Option<u32>,
    /// Dynamixel, native driver: read with Fast Sync Read.
    pub fast_sync_read: bool,
    /// Port "virtual": the emulated bus takes the real wire's time (at the baud rate, with
    /// return delays) instead of answering at once.
    pub wire_timing: bool,
    /// Port "virtual", with wire timing: the USB adapter latency to emulate.
    pub usb_latency: Duration,
    /// Port "virtual": the arm's physics the emulated servos carry (`--physics`); `None`: they
    /// move in empty space, as the kinematic emulation says.
    pub physics: Option<PhysicsSource>,
}

/// Makes the physics of a robot's arm for its emulated servos (`sim::MujocoArm` behind
/// `--physics`): the bus cannot make it itself, MuJoCo being the simulation's.
#[derive(Clone)]
pub struct PhysicsSource(pub Arc<PhysicsMaker>);

/// What a [`PhysicsSource`] calls.
pub type PhysicsMaker = dyn Fn(&Robot) -> Result<Box<dyn Physics>, PhysicsError> + Send + Sync;

impl std::fmt::Debug for PhysicsSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PhysicsSource")
    }
}

impl PhysicsSource {
    /// Emulated servos of `robot` carrying the arm's physics, served on a pseudo-terminal
    /// with the wire timed as `wire` says.
    pub fn serve(&self, robot: &Robot, wire: Option<WireTiming>) -> Result<PtyServer, BusError> {
        // A robot whose servos cannot carry the arm is refused before MuJoCo starts.
        super::virtual_bus::ratings(robot)?;
        let servos = VirtualServos::with_physics(robot, (self.0)(robot)?)?;
        let bus = VirtualBus::new(servos);
        bus.keep_physics_running();
        PtyServer::serve(bus, wire)
    }
}

impl Default for BusOptions {
    /// The native driver at the robot's baud rate, on a wire-timed virtual bus without
    /// adapter latency.
    fn default() -> Self {
        BusOptions {
            driver: Driver::Native,
            baud: None,
            fast_sync_read: false,
            wire_timing: true,
            usb_latency: Duration::ZERO,
            physics: None,
        }
    }
}

impl BusOptions {
    /// How a virtual bus opened with these options times its wire at `baud`.
    pub fn virtual_wire(&self, baud: u32) -> Option<WireTiming> {
        self.wire_timing.then_some(WireTiming {
            baud,
            usb_latency: self.usb_latency,
        })
    }
}

/// Opens `robot`'s bus on `port` ("virtual" serves emulated servos on a pseudo-terminal and
/// connects to it through the same serial code as a real adapter).
pub fn connect(
    robot: &Robot,
    port: &str,
    driver: Driver,
    baud: Option<u32>,
) -> Result<Connection, BusError> {
    connect_with(
        robot,
        port,
        &BusOptions {
            driver,
            baud,
            ..BusOptions::default()
        },
    )
}

/// Opens `robot`'s bus on `port` as `options` say: pings the robot's first servo (a silent
/// bus is [`BusError::Silent`]) and checks the servos' homing offsets against the robot's
/// before anything is written.
pub fn connect_with(
    robot: &Robot,
    port: &str,
    options: &BusOptions,
) -> Result<Connection, BusError> {
    let (driver, baud) = (options.driver, options.baud.unwrap_or(robot.bus.baud));
    let (path, virtual_bus) = if port == VIRTUAL_PORT {
        let wire = options.virtual_wire(baud);
        let server = match &options.physics {
            Some(physics) => physics.serve(robot, wire)?,
            None => PtyServer::start_timed(robot, wire)?,
        };
        (server.path().to_string(), Some(server))
    } else {
        (port.to_string(), None)
    };
    let bus: Box<dyn ServoBus> = match driver {
        Driver::Native => {
            let transport =
                SerialTransport::open(&path, baud).map_err(|source| BusError::Port {
                    port: path.clone(),
                    source,
                })?;
            let servos: Vec<_> = robot.servos();
            Box::new(NativeBus::new(
                Box::new(transport),
                robot.bus.protocol,
                &servos,
            ))
        }
        Driver::Sdk => {
            let servos: Vec<_> = robot.servos();
            let sdk = super::sdk::SdkBus::open(&path, baud, robot.bus.protocol, &servos);
            Box::new(sdk.map_err(BusError::from)?)
        }
    };
    // Emulated servos are always there: silence from them is their thread not yet run on a
    // loaded machine, not a missing arm, so they are asked a few times.
    let attempts = if virtual_bus.is_some() {
        VIRTUAL_PROBES
    } else {
        1
    };
    let mut connection = Connection { bus, virtual_bus };
    probe(connection.bus.as_mut(), robot, baud, attempts)?;
    // Before anything can move: the servos must hold the homing offsets the ticks assume.
    super::homing::check_homing_offsets(connection.bus.as_mut(), robot)?;
    Ok(connection)
}

/// Pings the robot's first servo once the port is open, so that a bus where nothing answers
/// (no power, another baud rate or protocol, other ids) is told as such, instead of surfacing
/// as a timeout of whatever the command reads first.
fn probe(bus: &mut dyn ServoBus, robot: &Robot, baud: u32, attempts: u32) -> Result<(), BusError> {
    let Some(first) = robot.joints.first() else {
        return Ok(());
    };
    // Any answer, even an alarm or a damaged one, shows the bus is alive: the command then
    // meets it as before.
    for _ in 0..attempts {
        match bus.ping(first.servo.id) {
            Err(e) if e.is_no_answer() => continue,
            _ => return Ok(()),
        }
    }
    Err(BusError::Silent {
        id: first.servo.id,
        baud,
    })
}

/// How many times emulated servos are pinged before they count as silent.
const VIRTUAL_PROBES: u32 = 5;

/// Pings every id with each protocol; returns who answered.
pub fn scan(
    port: &str,
    robot: &Robot,
    protocols: &[Protocol],
    baud: u32,
    driver: Driver,
) -> Result<Vec<(Protocol, PingInfo)>, BusError> {
    let server = if port == VIRTUAL_PORT {
        Some(PtyServer::start_timed(robot, Some(WireTiming::at(baud)))?)
    } else {
        None
    };
    let path = server.as_ref().map_or(port, |s| s.path());
    let mut found = Vec::new();
    for &protocol in protocols {
        let mut bus: Box<dyn ServoBus> = match driver {
            Driver::Native => {
                let transport =
                    SerialTransport::open(path, baud).map_err(|source| BusError::Port {
                        port: path.to_string(),
                        source,
                    })?;
                let mut native = NativeBus::new(Box::new(transport), protocol, &[]);
                // A present servo answers within a millisecond at 1 Mbps plus the adapter's
                // latency; 253 ids at this timeout take about 5 s.
                native.setup_timeout = std::time::Duration::from_millis(20);
                Box::new(native)
            }
            Driver::Sdk => {
                // A scan only pings: no servo needs to be known.
                Box::new(
                    super::sdk::SdkBus::open(path, baud, protocol, &[]).map_err(BusError::from)?,
                )
            }
        };
        let max_id = super::protocol::codec(protocol).max_device_id();
        for id in 0..=max_id {
            match bus.ping(id) {
                Ok(info) => found.push((protocol, info)),
                Err(e) if e.is_no_answer() => {}
                Err(BusError::Corrupt { .. }) => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(found)
}
