//! A trajectory as a play_motion2 motion (PAL Robotics' `play_motion2` README): a parameter
//! file with, under `motions.<name>`, the `joints`, every point's positions one after the other
//! in one flat `positions` list, their `times_from_start` and a `meta` block (docs/interop.md
//! §3). play_motion2 carries positions only, so the curve is sampled at a rate the user sets.

use super::yaml;
use crate::plan::Trajectory;
use crate::robot::{JointKind, Robot};

/// The motion file for `trajectory` sampled at `rate` Hz (the first sample at the played start,
/// the last at its end), under the motion name `name`.
pub fn motion_yaml(
    trajectory: &Trajectory,
    robot: &Robot,
    rate: f64,
    name: &str,
    description: &str,
) -> String {
    let mut times: Vec<f64> = trajectory.grid(rate).collect();
    if times.last().is_some_and(|&t| trajectory.end - t > 1e-9) {
        times.push(trajectory.end);
    }
    let mut pose = vec![0.0; robot.joints.len()];
    let mut positions = Vec::with_capacity(times.len() * pose.len());
    let mut sampler = trajectory.sampler();
    for &t in &times {
        sampler.sample_into(t, &mut pose);
        for (joint, value) in robot.joints.iter().zip(&pose) {
            positions.push(match joint.kind {
                JointKind::Revolute => value.to_radians(),
                JointKind::Prismatic => *value,
            });
        }
    }
    let mut out = String::new();
    yaml::open(&mut out, 0, "/play_motion2");
    yaml::open(&mut out, 2, "ros__parameters");
    yaml::open(&mut out, 4, "motions");
    yaml::open_named(&mut out, 6, name);
    let names = super::ros2::joint_names(robot);
    yaml::line(
        &mut out,
        8,
        "joints",
        &yaml::name_list(names.iter().map(String::as_str)),
    );
    yaml::line(&mut out, 8, "positions", &yaml::float_list(positions));
    yaml::line(
        &mut out,
        8,
        "times_from_start",
        &yaml::float_list(times.iter().map(|t| t - trajectory.start)),
    );
    yaml::open(&mut out, 8, "meta");
    yaml::line(&mut out, 10, "name", &yaml::quoted(name));
    yaml::line(&mut out, 10, "usage", "'keypose'");
    yaml::line(&mut out, 10, "description", &yaml::quoted(description));
    out
}
