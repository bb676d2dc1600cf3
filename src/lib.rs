//! keypose: teach a robot arm poses key by key and play them back smoothly.
//!
//! Data flows one way, from files to bytes: [`sequence`] and [`robot`] files become a
//! [`plan::Trajectory`] of per-joint [`curve::Track`]s built on the [`pose`] math; [`report`]
//! turns trajectories and checks into text, JSON and SVG. The command-line verbs belong to the
//! binary (`src/commands/`), which uses this library as any other client would.

pub mod atomic_file;
pub mod bus;
pub mod curve;
pub mod input_file;
pub mod json;
pub mod plan;
pub mod player;
pub mod pose;
pub mod pyenv;
pub mod record;
pub mod report;
pub mod robot;
pub mod sequence;
pub mod sim;
pub mod teach;
pub mod terminal_text;
