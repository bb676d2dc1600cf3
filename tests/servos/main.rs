//! Servos: the protocol codecs against the vendor SDKs, the emulated bus, the player and its limiter, playback and recording through the binary, one arm or a cell.
//!
//! One test crate of several: each links the library once (tests/README.md).

#[path = "../common/mod.rs"]
mod common;

mod conformance;
mod play;
mod play_cell;
mod player;
mod player_stalls;
mod record;
mod record_cell;
mod record_virtual;
mod sdk_bridge;
mod servo_profile;
mod virtual_registers;
