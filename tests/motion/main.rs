//! The motion library, through its API and the binary: keyframe lists and their editing, interpolation, kinematics, the built-in robots, cells of arms, the exact limit check, loaders under random input, and keys fitted to recordings.
//!
//! One test crate of several: each links the library once (tests/README.md).

#[path = "../common/mod.rs"]
mod common;
/// The oracle scripts' runner, shared by the TOPP-RA (`retime`) and Ruckig (`jerk`) tests.
#[path = "../../benches/common/oracle.rs"]
mod oracle;
/// Ruckig's moves and the bench's jerk limits, shared by the `jerk` and `retime` tests.
#[path = "../../benches/common/ruckig.rs"]
mod ruckig;

mod cell_sequences;
mod check_exact;
mod clearance;
mod editing;
mod fuzz_loader;
mod interpolation;
mod jerk;
mod kinematics;
mod record_extract;
mod record_keyframes;
mod retime;
mod robots;
mod tool_keys;
mod torque;
