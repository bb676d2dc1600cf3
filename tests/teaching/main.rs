//! Teaching: the terminal pendant in a pseudo-terminal, the session state machine, and the studio (its engine, its server, and its page in headless Chromium).
//!
//! One test crate of several: each links the library once (tests/README.md).

#[path = "../common/mod.rs"]
mod common;
#[path = "../common/harness_starts.rs"]
mod harness_starts;

mod direction;
mod session;
mod studio;
mod studio_edit;
mod studio_engine;
mod studio_keyboard;
mod studio_server;
mod studio_truth;
mod terminal;
