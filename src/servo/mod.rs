//! The servo catalogue: what a servo model is, as data. A leaf: it reads nothing else of the
//! crate, and everything that needs a fact about a servo (the robot's tick mapping, the
//! drivers, the emulated servos, the planner's and the simulation's speed limits) reads it
//! here.
//!
//! - [`Protocol`], [`Vendor`] and [`PositionEncoding`] (`protocol`): the bus protocols, whose
//!   servos each addresses, how each puts a signed tick on the wire.
//! - [`ServoModel`] and its [`ModelSpec`] (`model`): one static description per model, with its
//!   behaviour as data (resolution, position modes, homing sign, return-delay unit, recalibrate
//!   value, profile units, drive-mode bits, speeds), in one file per family (`dynamixel_x`,
//!   `sts3215`).
//! - The control table: [`Register`] and its encodings (`register`), the registers with a role
//!   ([`RegisterTable`], `table`), the full table as the manual lists it (`item`), the alarm
//!   bits ([`AlarmBits`], `alarms`), the motion-profile registers ([`ProfileRegister`],
//!   `profile`), where its firmware counts an overload ([`OverloadRule`], `overload`).
//! - What it drives ([`Drive`], `drive`): per variant and supply, the torque-speed line, the
//!   continuous rating, stiffness and rotor inertia, each with how it is known.
//!
//! A new model of an existing family is one more description here and its variant in
//! [`ServoModel`]. What the vendor's firmware does with these numbers (how the homing offset
//! and direction make the present position, how the profile registers bound a move) is the
//! vendor's, beside its codec in `bus::protocol`.

mod alarms;
pub mod drive;
pub mod dynamixel_x;
pub mod item;
mod model;
mod overload;
mod profile;
mod protocol;
mod register;
pub mod sts3215;
mod table;

pub use alarms::{AlarmBits, Alarms};
pub use drive::{Basis, Drive, Rated, Variant, CONTINUOUS_FRACTION};
pub use model::{model_from_number, ExtendedMode, ModelSpec, Modes, ServoModel};
pub use overload::OverloadRule;
pub use profile::{DriveModeBits, Limit, ProfileRegister, Setting};
pub use protocol::{PositionEncoding, Protocol, TickError, Vendor};
pub use register::{span, ByteOrder, Encoding, Register, RegisterError};
pub use table::{LoadUnit, RegisterTable};
