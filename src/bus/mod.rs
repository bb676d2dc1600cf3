//! Servo buses: the [`ServoBus`] trait that the player and the teaching session use without
//! knowing the vendor, and its implementations — our own Dynamixel 2.0 and Feetech STS/SCS
//! drivers over a serial port ([`NativeBus`]), the vendor SDKs through the Python bridge
//! ([`sdk::SdkBus`]), a cell's buses as one ([`CellBus`]), and emulated servos
//! (`crate::testing`).
//!
//! Layers, bottom up: the servo catalogue ([`crate::servo`]: one static description per model,
//! its control table, units and speeds) beneath the bus; [`protocol`] (one folder per vendor
//! protocol behind the [`protocol::Codec`] trait: framing, instruction codes, parameter
//! layouts, status bytes, and the vendor's firmware rules); `registers` (a servo's answer read
//! into a register's value, [`DecodeAnswer`]); `models` (which model each servo of a bus is);
//! [`transport`] (a serial port with deadlines and resynchronisation); `driver` ([`NativeBus`]
//! over a transport); `virtual_bus` (emulated servos that answer the real protocols byte for
//! byte); [`sdk`] (the vendor SDKs through the Python bridge); `connect` ([`connect`]: a robot's
//! bus opened, probed and its homing offsets checked, `homing`); `cell` and `cutoff` (several
//! arms' buses as one); `faults` (the read streak, which joint a fault names); `ports` (the
//! serial ports of this machine). Neither the driver nor the emulated servos ask which vendor
//! they talk to: the codec, its firmware and the model description answer for them.

mod cell;
mod connect;
mod cutoff;
mod driver;
mod echo;
mod faults;
mod homing;
mod models;
mod ports;
pub mod protocol;
mod registers;
pub mod sdk;
pub mod transport;
pub(crate) mod virtual_bus;

/// The alarms are the catalogue's vocabulary (a model's alarm register has their bits); the
/// bus reports them.
pub use crate::servo::{AlarmBits, Alarms};
pub use cell::{connect_cell, CellBus, WriteOffsets};
pub use connect::{
    connect, connect_with, scan, BusOptions, Connection, Driver, PhysicsMaker, PhysicsSource,
    VIRTUAL_PORT,
};
pub use cutoff::ReadCutoff;
pub use driver::NativeBus;
pub use faults::{
    alarm_error, faulty_joint, joint_prefix, ReadStreak, MAX_READ_FAILURES, SILENT_FOR,
};
pub use homing::{HomingMismatch, NoHomingRegister, OffsetMismatch};
pub use ports::{latency_timers, list_ports, PortInfo};
pub use registers::DecodeAnswer;

use crate::error::ErrorKind;
use std::sync::Arc;
use std::time::Duration;

/// What a servo says about itself when pinged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PingInfo {
    /// The servo's id on the bus.
    pub id: u8,
    /// Its model number (from the ping answer, or Feetech's model register).
    pub model_number: u16,
    /// Dynamixel reports its firmware version in the ping answer; Feetech does not.
    pub firmware: Option<u8>,
    /// The alarms the servo reported while answering: a servo in alarm still says what it is.
    pub alarms: Alarms,
}

/// One servo's position and load, read together: what the player's push guard watches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionLoad {
    /// Present position, ticks.
    pub position: i64,
    /// Load as in [`Health::load_percent`]; `None` where the bus reads no load.
    pub load_percent: Option<f64>,
}

impl PositionLoad {
    /// Each of `positions` with the same `load_percent`.
    pub fn each(positions: Vec<i64>, load_percent: Option<f64>) -> Vec<PositionLoad> {
        positions
            .into_iter()
            .map(|position| PositionLoad {
                position,
                load_percent,
            })
            .collect()
    }
}

/// One servo's condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Health {
    /// The servo's id on the bus.
    pub id: u8,
    /// Its internal temperature, °C.
    pub temperature_c: f64,
    /// Its supply voltage, volts.
    pub voltage_v: f64,
    /// Load as a signed percentage of the maximum (Feetech, XL430) or derived from current.
    pub load_percent: f64,
    /// The current it draws, amperes; `None` where the model measures none (the XL430).
    pub current_a: Option<f64>,
    /// The alarms its alarm register holds.
    pub alarms: Alarms,
}

/// Why a bus transaction failed. Variants with an `id` name the servo (the arm's own id; in a
/// cell, [`BusError::Arm`] wraps them with the cell's id).
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// The arm's physics behind emulated servos (`--physics`) could not be made or failed.
    #[error("--physics: {0}")]
    Physics(#[from] virtual_bus::PhysicsError),
    /// The robot's servos cannot carry an arm's physics.
    #[error("--physics: {0}")]
    PhysicalArm(#[from] virtual_bus::PhysicalArmError),
    /// No answer from servo `id` within `timeout_ms` milliseconds.
    #[error("servo {id}: no answer within {timeout_ms} ms")]
    Timeout {
        /// The servo asked.
        id: u8,
        /// How long the answer was waited for.
        timeout_ms: u64,
    },
    /// No answer to the present request, but the servo answered earlier ones late: its answers
    /// are too old to be its present state, and are not taken for it.
    #[error("servo {id}: no answer within {timeout_ms} ms; it answers {late_ms} ms late (or later), too late to be its present state")]
    Stale {
        /// The servo asked.
        id: u8,
        /// How long the answer was waited for.
        timeout_ms: u64,
        /// How late its late answers came, at least.
        late_ms: u64,
    },
    /// No answer, while keypose itself was not running for a good part of the wait: the machine
    /// is overloaded, which the servo's silence may owe nothing to.
    #[error("servo {id}: no answer within {timeout_ms} ms, but keypose itself did not run for {starved_ms} ms of that wait (CPU starvation: the machine is overloaded, not necessarily the servo)")]
    Starved {
        /// The servo asked.
        id: u8,
        /// How long the answer was waited for.
        timeout_ms: u64,
        /// How much of that wait keypose did not run.
        starved_ms: u64,
    },
    /// No answer in the part of a cycle a cell left the read: it was cut short so that the
    /// other arms are served on time (see [`CellBus`]), not waited out, so on a busy machine a
    /// healthy servo's answer may simply not have been read yet.
    #[error("servo {id}: no answer in the {waited_ms} ms its cycle left the read (cut short so that the cell's other arms are served on time)")]
    CutShort {
        /// The servo asked.
        id: u8,
        /// How long the answer was waited for.
        waited_ms: u64,
    },
    /// An answer that arrived damaged.
    #[error("servo {id}: corrupt answer ({source})")]
    Corrupt {
        /// The servo whose answer it was.
        id: u8,
        /// What was wrong with it.
        #[source]
        source: CorruptAnswer,
    },
    /// The servo reports alarms (overload, overheating, voltage, …).
    #[error("servo {id}: alarm: {alarms}")]
    Alarm {
        /// The servo in alarm.
        id: u8,
        /// Which alarms.
        alarms: Alarms,
    },
    /// The servo answered that it did not carry out the instruction.
    #[error("servo {id}: refused the instruction: {reason}")]
    Refused {
        /// The servo that refused.
        id: u8,
        /// Its status, in words (access, range, unknown instruction, …).
        reason: String,
    },
    /// The serial port failed (open, read, write).
    #[error("serial port {port}: {source}")]
    Port {
        /// The port's path.
        port: String,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The first servo did not answer when the bus was opened: nothing on the bus is talking,
    /// which is a set-up problem far more often than a servo fault.
    #[error("no answer from servo {id} at {baud} baud: is the arm powered, is the id right? try `keypose scan`")]
    Silent {
        /// The servo pinged first.
        id: u8,
        /// The baud rate tried.
        baud: u32,
    },
    /// A servo id the robot (and so the bus) does not have.
    #[error("servo {id} is not part of this robot")]
    UnknownServo {
        /// The id asked for.
        id: u8,
    },
    /// A servo id outside a cell's numbering (1 … `servos`).
    #[error("servo {id} is not in the cell (ids 1 … {servos})")]
    NotInCell {
        /// The id asked for.
        id: u8,
        /// How many servos the cell has.
        servos: usize,
    },
    /// A transaction over several servos was given none.
    #[error("no servos given")]
    NoServos,
    /// Two servos of one sync transfer keep the register at different addresses or sizes.
    #[error("servos {first} and {other} keep {register} at different addresses; they cannot share a sync transfer")]
    SplitRegister {
        /// The first servo of the transfer.
        first: u8,
        /// A servo whose table differs from the first's.
        other: u8,
        /// The register's name.
        register: &'static str,
    },
    /// The servo's model has no such register (a profile setting of the other vendor, a
    /// Homing_Offset on a model without one).
    #[error("servo {id} has no {register} register")]
    MissingRegister {
        /// The servo.
        id: u8,
        /// The register's name.
        register: &'static str,
    },
    /// A value that does not fit the servo's register: nothing was sent.
    #[error("servo {id}: {error}")]
    Unencodable {
        /// The servo the value was for.
        id: u8,
        /// Why it does not fit.
        error: crate::servo::RegisterError,
    },
    /// A goal tick the servo's position register cannot hold: nothing was sent.
    #[error("servo {id}: goal not sent: {error}")]
    GoalUnencodable {
        /// The servo the goal was for.
        id: u8,
        /// Why the tick does not fit.
        error: crate::robot::TickError,
    },
    /// A packet the protocol cannot frame (too long, an id it cannot address): nothing was
    /// sent.
    #[error("{protocol}: {error}")]
    Unframable {
        /// The protocol's name.
        protocol: &'static str,
        /// Why the packet cannot be framed.
        error: protocol::packet::PacketError,
    },
    /// An instruction the protocol does not have.
    #[error("{protocol}: {instruction}")]
    NoInstruction {
        /// The protocol's name.
        protocol: &'static str,
        /// Which instruction, and whose it is.
        instruction: &'static str,
    },
    /// A register written and read back with another value.
    #[error("servo {id}: {register} reads {found} after writing {expected}")]
    RegisterMismatch {
        /// The servo.
        id: u8,
        /// The register's name.
        register: &'static str,
        /// The value written.
        expected: i64,
        /// The value read back.
        found: i64,
    },
    /// A profile register this driver cannot reach.
    #[error("{bus}: this driver does not reach the {register} register (use --driver native)")]
    Unreachable {
        /// The bus, as [`ServoBus::describe`] gives it.
        bus: String,
        /// The register's name.
        register: &'static str,
    },
    /// The thread that drives one arm's bus in a cell has ended.
    #[error("the bus's thread has ended")]
    ThreadEnded,
    /// The vendor SDK bridge process failed (it did not start, exited, or did not answer).
    #[error("vendor SDK bridge: {error}")]
    Bridge {
        /// What went wrong with the process; its own cause (the system's reason) follows it in
        /// the chain.
        #[source]
        error: Box<crate::python::HarnessError>,
    },
    /// The vendor SDK (or the bridge) refused a request for a reason no other variant
    /// names: `by` is the SDK's module name, or "vendor SDK bridge".
    #[error("{by}: {message}")]
    Sdk {
        /// Who refused.
        by: &'static str,
        /// Its reason, as it gave it.
        message: String,
    },
    /// A reply of the SDK bridge without what it should carry.
    #[error("{}the SDK bridge's {what}: {reply}", servo.map_or(String::new(), |id| format!("servo {id}: ")))]
    BridgeReply {
        /// The servo the request was about, if one.
        servo: Option<u8>,
        /// What the reply should have carried.
        what: String,
        /// The reply as it came.
        reply: String,
    },
    /// The servos hold other homing offsets than the description: not a fault of the bus but
    /// of the input (a calibration made on another arm), found by reading the servos.
    #[error(transparent)]
    HomingOffset(#[from] homing::HomingMismatch),
    /// The description gives a homing offset other than 0 to a servo whose model has no
    /// Homing_Offset register: bad input, found before anything is read or moved.
    #[error(transparent)]
    NoHomingRegister(#[from] homing::NoHomingRegister),
    /// An error of one arm's bus in a cell ([`CellBus`]): `servo` is the servo's id in the
    /// cell (so the joint it names is `ARM/JOINT`); the source keeps the arm's own ids.
    #[error("{arm} bus: {source}")]
    Arm {
        /// The arm's name in the cell.
        arm: String,
        /// The servo's id in the cell, when the error names one.
        servo: Option<u8>,
        /// The arm's bus's own error.
        #[source]
        source: Box<BusError>,
    },
    /// A transaction that took longer than the cell allows one bus: the bus hangs.
    #[error("no answer from the bus within {waited_ms} ms")]
    Hung {
        /// How long the cell waited.
        waited_ms: u64,
    },
    /// A transaction addressed an arm whose bus was isolated after a fault.
    #[error("isolated after a fault (arm {arm}): nothing more is sent to it")]
    Isolated {
        /// The arm's name in the cell.
        arm: String,
    },
}

impl BusError {
    /// A damaged answer from servo `id`.
    pub fn corrupt(id: u8, source: impl Into<CorruptAnswer>) -> BusError {
        BusError::Corrupt {
            id,
            source: source.into(),
        }
    }

    /// The servo the error is about, when there is one.
    pub fn servo(&self) -> Option<u8> {
        match self {
            BusError::Timeout { id, .. }
            | BusError::CutShort { id, .. }
            | BusError::Stale { id, .. }
            | BusError::Starved { id, .. }
            | BusError::Corrupt { id, .. }
            | BusError::Alarm { id, .. }
            | BusError::Refused { id, .. }
            | BusError::Silent { id, .. } => Some(*id),
            BusError::HomingOffset(m) => m.mismatches.first().map(|m| m.servo),
            BusError::NoHomingRegister(e) => Some(e.servo),
            BusError::Arm { servo, .. } => *servo,
            BusError::UnknownServo { id }
            | BusError::NotInCell { id, .. }
            | BusError::MissingRegister { id, .. }
            | BusError::Unencodable { id, .. }
            | BusError::GoalUnencodable { id, .. }
            | BusError::RegisterMismatch { id, .. } => Some(*id),
            BusError::BridgeReply { servo, .. } => *servo,
            BusError::Port { .. }
            | BusError::NoServos
            | BusError::SplitRegister { .. }
            | BusError::Unframable { .. }
            | BusError::NoInstruction { .. }
            | BusError::Unreachable { .. }
            | BusError::ThreadEnded
            | BusError::Bridge { .. }
            | BusError::Sdk { .. }
            | BusError::Hung { .. }
            | BusError::Physics(_)
            | BusError::PhysicalArm(_)
            | BusError::Isolated { .. } => None,
        }
    }

    /// What kind of failure this is: the servos hold another calibration than the input's, or
    /// cannot hold the input's at all (in a cell, one arm's), is bad input; anything else is
    /// the hardware's.
    pub fn kind(&self) -> ErrorKind {
        match self.root() {
            BusError::HomingOffset(_)
            | BusError::NoHomingRegister(_)
            | BusError::PhysicalArm(_) => ErrorKind::BadInput,
            BusError::Physics(e) if e.bad_input => ErrorKind::BadInput,
            _ => ErrorKind::Hardware,
        }
    }

    /// No usable answer came in time (silent, late, or keypose starved): a read may be tried
    /// again, and a scan goes on.
    pub fn is_no_answer(&self) -> bool {
        matches!(
            self.root(),
            BusError::Timeout { .. }
                | BusError::CutShort { .. }
                | BusError::Stale { .. }
                | BusError::Starved { .. }
        )
    }

    /// The error itself, out of the arm that wraps it in a cell.
    pub fn root(&self) -> &BusError {
        match self {
            BusError::Arm { source, .. } => source.root(),
            other => other,
        }
    }
}

/// What was wrong with a damaged answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CorruptAnswer {
    /// The packet itself: checksum, length, layout.
    #[error(transparent)]
    Packet(#[from] protocol::packet::PacketError),
    /// Its data does not decode as the register asked for.
    #[error(transparent)]
    Register(#[from] crate::servo::RegisterError),
    /// A well-formed answer with another amount of data than asked for: a late answer to an
    /// earlier request, when nothing better came.
    #[error("{found} data bytes where {expected} were asked")]
    DataLength {
        /// Data bytes asked for.
        expected: usize,
        /// Data bytes in the answer.
        found: usize,
    },
    /// A combined (fast sync read) answer for other servos than asked.
    #[error("fast sync read answered for ids {found:?} where {expected:?} were asked")]
    Ids {
        /// The ids asked, in order.
        expected: Vec<u8>,
        /// The ids the answer carries.
        found: Vec<u8>,
    },
    /// The vendor SDK's own account of a corrupt packet.
    #[error("{0}")]
    Sdk(String),
}

/// A bus of servos, addressed by id, positions in ticks.
///
/// Reads may be retried (a bounded number of times) by implementations; writes are never
/// repeated, because a repeated goal is not harmless when the first one did arrive.
pub trait ServoBus: Send {
    /// A short description for messages ("dynamixel-2 on /dev/ttyUSB0 at 1000000").
    fn describe(&self) -> String;
    /// Pings servo `id`: what it is, and its alarms.
    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError>;
    /// Present positions in ticks, in the order of `ids`.
    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError>;
    /// Present positions and loads, in the order of `ids`, in one read where the bus can (the
    /// two registers are a few bytes apart on every model). A bus that reads no load gives
    /// positions only.
    fn read_positions_loads(&mut self, ids: &[u8]) -> Result<Vec<PositionLoad>, BusError> {
        Ok(PositionLoad::each(self.read_positions(ids)?, None))
    }
    /// Goal positions in ticks, all in one sync write.
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError>;
    /// Switches the torque of the servos `ids` on (holding) or off (limp), each servo
    /// confirming its write.
    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError>;
    /// Temperature, voltage, load and alarms of the servos `ids`, in order.
    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError>;
    /// The Homing_Offset register of each servo (id, model), in ticks, in order; a model
    /// without one is [`BusError::MissingRegister`].
    fn read_homing_offsets(
        &mut self,
        servos: &[(u8, crate::robot::ServoModel)],
    ) -> Result<Vec<i64>, BusError>;
    /// One profile register of each servo in `ids`, raw register values, in order. Drivers
    /// that cannot read it say so (the vendor-SDK bridge does not carry these registers).
    fn read_setting(
        &mut self,
        ids: &[u8],
        setting: crate::servo::Setting,
    ) -> Result<Vec<i64>, BusError> {
        let _ = ids;
        Err(setting_unsupported(&self.describe(), setting))
    }
    /// Writes one profile register of each servo, (id, raw value), and reads it back to
    /// confirm: a profile setting that silently did not arrive would go unnoticed otherwise.
    fn write_setting(
        &mut self,
        values: &[(u8, i64)],
        setting: crate::servo::Setting,
    ) -> Result<(), BusError> {
        let _ = values;
        Err(setting_unsupported(&self.describe(), setting))
    }
    /// A bus made of several arms' buses (a cell): stops serving the arm that `error` came
    /// from, so that the other arms can still be braked to rest, and returns the servo ids it
    /// no longer serves. `None` (one bus, or no healthy arm left): the fault ends everything.
    fn isolate(&mut self, error: &BusError) -> Option<Vec<u8>> {
        let _ = error;
        None
    }
    /// Reads stop waiting for answers once `cutoff` has passed (it is set from another
    /// thread: a cell cuts short the read of an arm whose answers are late, see [`CellBus`]). An
    /// answer not in by then is a timeout, and a cut read is not retried. A bus that cannot cut
    /// a read short ignores it.
    fn set_read_cutoff(&mut self, cutoff: Arc<ReadCutoff>) {
        let _ = cutoff;
    }
    /// A bus made of several arms' buses (a cell): the control period of the loop that drives
    /// it, from which it judges when an arm's read would hold the others (see [`CellBus`]).
    /// `None`: every arm's read is waited for as long as its own bus waits.
    fn pace(&mut self, period: Option<Duration>) {
        let _ = period;
    }
    /// How far apart the arms' buses started each goal write (a cell); `None` on one bus.
    fn write_offsets(&self) -> Option<WriteOffsets> {
        None
    }
}

fn setting_unsupported(bus: &str, setting: crate::servo::Setting) -> BusError {
    BusError::Unreachable {
        bus: bus.to_string(),
        register: setting.name(),
    }
}
