//! MuJoCo simulation: the harness, the official models, the joint maps, `keypose sim` on one arm and on a cell.
//!
//! One test crate of several: each links the library once (tests/README.md).

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/harness_starts.rs"]
mod harness_starts;

mod cell;
mod cli;
mod collision;
mod dynamics;
mod grasp;
mod harness;
mod joint_map;
mod models;
mod physics_bus;
mod push_guard;
mod tool_keys;
