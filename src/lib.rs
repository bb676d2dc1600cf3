//! keypose: teach a robot arm poses key by key and play them back smoothly, on real servos or
//! in MuJoCo.
//!
//! Data flows one way, from files to bytes (docs/architecture.md has the whole map):
//!
//! - [`sequence`] and [`robot`] read the files: keyframe lists, arm descriptions, LeRobot
//!   calibrations; [`pose`] is the rigid-transform math under them; [`servo`] is the catalogue
//!   of servo models (control tables, units, resolution) that the robot and the bus read;
//! - [`curve`] interpolates one degree of freedom over key times ([`curve::Track`]);
//! - [`plan`] turns a sequence into a [`plan::Trajectory`] for a robot, checks it against the
//!   joint limits, retimes it, and says what the arm should do at each moment of playback
//!   ([`plan::Timeline`]);
//! - [`bus`] talks to servos: the [`bus::ServoBus`] trait, the Dynamixel 2.0 and Feetech codecs,
//!   our driver, the vendors' SDKs through Python, emulated servos;
//! - [`player`] streams a trajectory to a bus at the control rate ([`player::play`]), paced by
//!   [`pacing`], stoppable through [`stop`], never past a joint's limits;
//! - [`sim`] plays the same command stream in MuJoCo and judges it; [`record`] turns a motion
//!   made by hand into keys; [`teach`] is the teach pendant; [`report`] writes text, JSON and
//!   SVG.
//!
//! The command-line verbs belong to the binary (`src/commands/`), which uses this library as
//! any other client would.

pub mod atomic_file;
pub mod bus;
pub mod csv;
pub mod curve;
pub mod error;
pub mod interop;

pub mod json;
pub mod kinematics;
pub mod mirror;
pub mod pacing;
pub mod plan;
pub mod player;
pub mod pose;
pub mod python;
pub mod record;
pub mod report;
pub mod robot;
pub mod sequence;
pub mod servo;
pub mod sim;
pub mod stop;
pub mod studio;
pub mod teach;
pub mod terminal_text;
