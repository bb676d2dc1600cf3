//! keypose: teach a robot arm poses key by key and play them back smoothly, on real servos or
//! in MuJoCo.
//!
//! The pipeline is at the root: a [`Sequence`] of keyframes and a [`Robot`] become a
//! [`Trajectory`]; [`check`] judges it exactly against the joints' limits and [`retime`] makes
//! it keep them; [`play`] streams it to a [`ServoBus`] at the control rate, starting from the
//! measured pose and stoppable at any moment; a [`Simulation`] runs it in MuJoCo. Every error
//! says what kind of failure it is ([`ErrorKind`]).
//!
//! ```
//! use keypose::player::{play_with_clock, StopSignal};
//! use keypose::testing::{VirtualBus, VirtualClock};
//! use keypose::{check, PlayOptions, Robot, Sequence, Trajectory};
//! use std::path::Path;
//!
//! let sequence = Sequence::load(Path::new("sequences/so101_wave.json"))?;
//! let robot = Robot::builtin("so101").expect("a built-in robot");
//! let trajectory = Trajectory::build(&sequence, &robot)?;
//! assert!(check(&trajectory, &robot, robot.control_hz).passed());
//!
//! // Emulated servos in memory, and a clock that does not wait: the same bytes a real arm
//! // would get, as fast as they can be computed.
//! let (mut bus, _servos) = VirtualBus::in_process(&robot);
//! let stop = StopSignal::default();
//! let options = PlayOptions::new(robot.control_hz);
//! let (outcome, stats) =
//!     play_with_clock(&mut bus, &robot, &trajectory, &options, &stop, &VirtualClock::new())?;
//! println!("{outcome:?} after {} cycles", stats.cycles);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The modules, in the order data flows through them (docs/architecture.md has the whole map):
//!
//! - [`sequence`] and [`robot`] read the files: keyframe lists, arm descriptions, LeRobot
//!   calibrations; [`pose`] is the rigid-transform math under them; [`servo`] is the catalogue
//!   of servo models (control tables, units, resolution) that the robot and the bus read;
//! - [`curve`] interpolates one degree of freedom over key times ([`curve::Track`]);
//! - [`kinematics`] solves tool poses into joint values; [`mirror`] reflects motion across an
//!   arm's plane;
//! - [`plan`] turns a sequence into a [`Trajectory`] for a robot, checks it against the joint
//!   limits, retimes it, and says what the arm should do at each moment of playback
//!   ([`plan::Timeline`]);
//! - [`bus`] talks to servos: the [`ServoBus`] trait, the Dynamixel 2.0 and Feetech codecs, our
//!   driver, the vendors' SDKs through Python; [`testing`] has emulated servos;
//! - [`player`] streams a trajectory to a bus at the control rate, paced by [`pacing`],
//!   stoppable through [`stop`], never past a joint's limits;
//! - [`sim`] plays the same command stream in MuJoCo and judges it; [`record`] turns a motion
//!   made by hand into keys; [`teach`] is the teach pendant's state and session, [`studio`] its
//!   browser front end; [`interop`] reads LeRobot datasets and writes ROS 2 and C; [`report`]
//!   writes text, JSON and SVG.
//!
//! The command-line verbs and the terminal UI belong to the binary (`src/commands/`), which uses
//! this library as any other client would.

#![warn(missing_docs)]

pub mod atomic_file;
pub mod bus;
pub mod collision;
pub mod csv;
pub mod curve;
pub mod dynamics;
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
pub mod testing;

pub use bus::{connect, BusError, ServoBus};
pub use curve::Interp;
pub use error::ErrorKind;
pub use plan::{check, retime, CheckReport, Timeline, Trajectory};
pub use player::{play, PlayError, PlayOptions};
pub use pose::RigidTransform;
pub use robot::Robot;
pub use sequence::{KeyValue, Keyframe, Sequence};
pub use servo::ServoModel;
pub use sim::Simulation;
