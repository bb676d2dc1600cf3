//! `--servo-profile`: the joints' limits written into the servos' own motion profile for the
//! playback, and the values found there put back afterwards, however the playback ends.
//!
//! [`ProfileGuard`] reads and remembers the profile registers, writes the limits
//! ([`crate::robot::profile::settings_for`]), and lends the bus to the playback; it restores the
//! remembered values when told to ([`ProfileGuard::restore`], which reports a failure) or,
//! failing that, when dropped: after an error return or a panic too.

use crate::bus::{BusError, ServoBus};
use crate::robot::profile::{settings_for, ProfileError};
use crate::robot::Robot;
use crate::servo::Setting;

/// One profile register's values, (id, value) per servo: the values found before playback, or
/// the ones to write.
type Values = (Setting, Vec<(u8, i64)>);

/// The servos' profile registers as found before the playback, put back when told to or
/// dropped.
pub struct ProfileGuard<'a> {
    bus: &'a mut dyn ServoBus,
    /// What to write back, in the order it was written; empty once restored.
    saved: Vec<Values>,
}

/// Why the profile could not be set up or put back.
#[derive(Debug, thiserror::Error)]
pub enum ServoProfileError {
    /// A joint limit the servo's register cannot express (nothing was written).
    #[error(transparent)]
    Units(#[from] ProfileError),
    /// A Dynamixel servo set to the time-based profile (nothing was written).
    #[error(
        "--servo-profile: servo {servo} (joint {joint}) runs the time-based profile (Drive_Mode \
         {drive_mode}, bit 2 set), where the profile registers hold milliseconds, not the \
         joint's limits; clear the bit or play without --servo-profile; nothing was written"
    )]
    TimeBased {
        /// The joint's name.
        joint: String,
        /// Its servo's id.
        servo: u8,
        /// The Drive_Mode register's value.
        drive_mode: i64,
    },
    /// The bus failed while reading or writing the profile (what was written is put back).
    #[error("--servo-profile")]
    Setup(#[from] BusError),
    /// The bus failed while putting the previous profile back after the playback.
    #[error("--servo-profile: the servos' previous profile could not be restored")]
    Restore(#[source] BusError),
}

impl<'a> ProfileGuard<'a> {
    /// Converts every joint's limits first (nothing is written when one cannot be expressed),
    /// then reads the present values, then writes the new ones; a failure part-way restores
    /// what was already written.
    pub fn apply(
        bus: &'a mut dyn ServoBus,
        robot: &Robot,
    ) -> Result<ProfileGuard<'a>, ServoProfileError> {
        let wanted = wanted_settings(robot)?;
        refuse_time_based(bus, robot)?;
        let mut guard = ProfileGuard {
            bus,
            saved: Vec::new(),
        };
        for (setting, values) in wanted {
            let ids: Vec<u8> = values.iter().map(|(id, _)| *id).collect();
            let before = guard.bus.read_setting(&ids, setting)?;
            guard
                .saved
                .push((setting, ids.into_iter().zip(before).collect()));
            // On an error here the guard is dropped, which restores what was saved so far.
            guard.bus.write_setting(&values, setting)?;
        }
        Ok(guard)
    }

    /// The bus, for the playback.
    pub fn bus(&mut self) -> &mut dyn ServoBus {
        &mut *self.bus
    }

    /// Writes the remembered values back (the last written first).
    pub fn restore(&mut self) -> Result<(), BusError> {
        let mut first_error = None;
        while let Some((setting, values)) = self.saved.pop() {
            if let Err(e) = self.bus.write_setting(&values, setting) {
                first_error.get_or_insert(e);
            }
        }
        first_error.map_or(Ok(()), Err)
    }
}

impl Drop for ProfileGuard<'_> {
    fn drop(&mut self) {
        if !self.saved.is_empty() {
            if let Err(e) = self.restore() {
                let error = ServoProfileError::Restore(e);
                eprintln!("warning: {}", crate::error::Report(&error));
            }
        }
    }
}

/// Refuses a servo whose Drive_Mode selects the time-based profile (a Dynamixel set up as
/// ROBOTIS's OpenMANIPULATOR-X is): the limits, in velocity-based units, would be taken as move
/// times there. Models without a Drive_Mode register are not asked.
fn refuse_time_based(bus: &mut dyn ServoBus, robot: &Robot) -> Result<(), ServoProfileError> {
    let joints: Vec<_> = robot
        .joints
        .iter()
        .filter_map(|j| j.servo.model.spec().drive_mode.map(|bits| (j, bits)))
        .collect();
    if joints.is_empty() {
        return Ok(());
    }
    let ids: Vec<u8> = joints.iter().map(|(j, _)| j.servo.id).collect();
    let modes = bus.read_setting(&ids, Setting::DriveMode)?;
    let time_based = joints
        .iter()
        .zip(modes)
        .find(|((_, bits), mode)| bits.time_based(*mode));
    match time_based {
        Some(((joint, _), drive_mode)) => Err(ServoProfileError::TimeBased {
            joint: joint.name.clone(),
            servo: joint.servo.id,
            drive_mode,
        }),
        None => Ok(()),
    }
}

/// Each setting with the value every servo gets, grouped by setting (one sync write each), in
/// joint order.
fn wanted_settings(robot: &Robot) -> Result<Vec<Values>, ProfileError> {
    let mut grouped: Vec<Values> = Vec::new();
    for joint in &robot.joints {
        for (setting, value) in settings_for(joint)? {
            match grouped.iter_mut().find(|(s, _)| *s == setting) {
                Some((_, values)) => values.push((joint.servo.id, value)),
                None => grouped.push((setting, vec![(joint.servo.id, value)])),
            }
        }
    }
    Ok(grouped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Report;

    #[test]
    fn a_bus_failure_is_said_once_as_the_cause_of_its_layer() {
        let bus = || BusError::Timeout {
            id: 3,
            timeout_ms: 40,
        };
        let said = bus().to_string();
        for (error, own) in [
            (ServoProfileError::Setup(bus()), "--servo-profile"),
            (
                ServoProfileError::Restore(bus()),
                "--servo-profile: the servos' previous profile could not be restored",
            ),
        ] {
            assert_eq!(error.to_string(), own);
            let source = std::error::Error::source(&error).map(|s| s.to_string());
            assert_eq!(source.as_deref(), Some(said.as_str()));
            assert_eq!(Report(&error).to_string(), format!("{own}: {said}"));
        }
    }
}
