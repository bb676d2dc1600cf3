//! Motion in and out of keypose's own formats: LeRobot dataset episodes in ([`lerobot`]);
//! ROS 2 `JointTrajectory` ([`ros2`]) and play_motion2 motions ([`play_motion2`]) out, written
//! as YAML; C headers for the stand-alone player ([`c_export`]). Knows nothing about servos: everything here is joint values over time.

pub mod c_export;
pub mod lerobot;
pub mod play_motion2;
pub mod ros2;
mod yaml;
