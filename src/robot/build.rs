//! Named builds: the same arm with other servos or another supply, as people buy it. A build
//! sets every servo of one model to a variant at a supply (`--robot-variant`); a robot file can
//! say the same servo by servo (`"variant"`, `"supply_v"`).

use super::Robot;
use crate::servo::ServoModel;

/// One build.
#[derive(Debug, PartialEq)]
pub struct Build {
    /// The name `--robot-variant` takes.
    pub name: &'static str,
    /// What it is, for people.
    pub description: &'static str,
    /// The servo model it changes.
    pub model: ServoModel,
    /// The variant its servos become.
    pub variant: &'static str,
    /// Their supply, volts.
    pub supply_v: f64,
}

/// Every build keypose knows.
pub const BUILDS: &[Build] = &[
    Build {
        name: "5v",
        description:
            "7.4 V STS3215 (C001) on a 5 V supply: the standard SO-101 and SO-100 follower",
        model: ServoModel::Sts3215,
        variant: "c001",
        supply_v: 5.0,
    },
    Build {
        name: "7.4v",
        description: "7.4 V STS3215 (C001) on a 7.4 V supply",
        model: ServoModel::Sts3215,
        variant: "c001",
        supply_v: 7.4,
    },
    Build {
        name: "12v",
        description: "12 V STS3215 (C047, 30 kg·cm) on a 12 V supply: the SO-101's 12 V option",
        model: ServoModel::Sts3215,
        variant: "c047",
        supply_v: 12.0,
    },
];

/// Why a build does not apply.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// Not a build keypose knows.
    #[error("unknown robot variant {found:?}; expected one of {known}")]
    Unknown {
        /// What was asked.
        found: String,
        /// The names known.
        known: String,
    },
    /// The robot has none of the servos the build changes.
    #[error("robot variant {build:?} changes {model} servos, and robot {robot:?} has none")]
    NoSuchServos {
        /// The build.
        build: String,
        /// Its servo model.
        model: &'static str,
        /// The robot.
        robot: String,
    },
}

impl Build {
    /// The build called `name`.
    pub fn named(name: &str) -> Result<&'static Build, BuildError> {
        BUILDS
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| BuildError::Unknown {
                found: name.to_string(),
                known: BUILDS.iter().map(|b| b.name).collect::<Vec<_>>().join(", "),
            })
    }
}

impl Robot {
    /// The robot with every servo of `build`'s model made its variant at its supply (each
    /// arm's too, on a cell).
    pub fn with_build(&mut self, build: &Build) -> Result<(), BuildError> {
        let variant = build
            .model
            .variant(build.variant)
            .expect("a build names a variant of its model");
        let mut changed = false;
        let joints = self
            .joints
            .iter_mut()
            .chain(self.arms.iter_mut().flat_map(|a| a.robot.joints.iter_mut()));
        for joint in joints.filter(|j| j.servo.model == build.model) {
            joint.servo.variant = variant;
            joint.servo.supply_v = build.supply_v;
            changed = true;
        }
        if !changed {
            return Err(BuildError::NoSuchServos {
                build: build.name.to_string(),
                model: build.model.name(),
                robot: self.name.clone(),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_12_v_build_makes_every_sts3215_a_c047_on_12_v_and_a_koch_has_none() {
        let mut robot = Robot::builtin("so101").unwrap();
        assert_eq!(
            robot.joints[1].servo.drive().unwrap().stall_torque.value,
            1.35
        );
        robot.with_build(Build::named("12v").unwrap()).unwrap();
        for j in &robot.joints {
            assert_eq!((j.servo.variant.name, j.servo.supply_v), ("c047", 12.0));
        }
        assert_eq!(
            robot.joints[1].servo.drive().unwrap().stall_torque.value,
            2.94
        );
        let mut koch = Robot::builtin("koch").unwrap();
        let error = koch.with_build(Build::named("12v").unwrap()).unwrap_err();
        assert!(error.to_string().contains("has none"), "{error}");
        assert!(Build::named("24v")
            .unwrap_err()
            .to_string()
            .contains("5v, 7.4v, 12v"));
    }
}
