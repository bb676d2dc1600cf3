//! The command line on files, with no servo or with the emulated one where a command needs a bus: the README's examples, exports, mirror, pose, calibration, dataset import, scan, and refusals of hostile input.
//!
//! One test crate of several: each links the library once (tests/README.md).

#[path = "../common/mod.rs"]
mod common;

mod architecture;
mod calibrated_limits;
mod calibration;
mod export;
mod export_c;
mod homing_offset;
mod hostile_input;
mod lerobot_import;
mod mirror;
mod outputs;
mod pose;
mod readme;
mod robot_names;
mod scan;
