//! keypose without an arm: emulated servos and a clock that only moves by waiting, for trying
//! keypose on a desk (`keypose virtual-bus`, `--port virtual`) and for testing code that drives
//! an arm.
//!
//! The emulated servos are not a mock of keypose's driver: they speak the same bytes as the
//! real ones (Dynamixel Protocol 2.0, Feetech STS/SCS), answer after the wire time the real bus
//! would take ([`WireTiming`]), keep each model's control table from the servo catalogue, and
//! move toward their goals the way the firmware's profile does. Behind a pseudo-terminal
//! ([`PtyServer`]) they are a serial port like any other, so the real serial code is what talks
//! to them; in memory ([`MemoryTransport`]) they answer a driver directly.

pub use crate::bus::transport::{MemoryTransport, Responder};
pub use crate::bus::virtual_bus::{
    Hand, MotorCommand, PhysicalArmError, Physics, PhysicsError, PtyServer, ServoFault, Shaft,
    VirtualBus, VirtualServo, VirtualServos, WireTiming,
};
pub use crate::pacing::clock::VirtualClock;
