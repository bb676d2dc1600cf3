//! The vendors' protocols, one folder each: `dynamixel` (Protocol 2.0) and `feetech` (SCS/STS),
//! over the framing vocabulary both share (`packet`).
pub mod dynamixel;
pub mod feetech;
pub mod packet;
