//! A servo model and its description: everything keypose knows about it, as data.

use super::item::{self, Item};
use super::profile::{DriveModeBits, ProfileRegister};
use super::protocol::{Protocol, Vendor};
use super::table::RegisterTable;
use super::{dynamixel_x, sts3215};
use std::time::Duration;

/// A servo model as a robot file names it. What it is and how it behaves is its
/// [`ModelSpec`], reached through [`ServoModel::spec`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoModel {
    /// Feetech STS3215 (SO-100/SO-101 arms).
    Sts3215,
    /// ROBOTIS XL330-M288-T.
    Xl330M288,
    /// ROBOTIS XL330-M077-T.
    Xl330M077,
    /// ROBOTIS XL430-W250-T.
    Xl430W250,
    /// ROBOTIS XM430-W350-T.
    Xm430W350,
}

impl ServoModel {
    /// Every model keypose knows.
    pub const ALL: [ServoModel; 5] = [
        ServoModel::Sts3215,
        ServoModel::Xl330M288,
        ServoModel::Xl330M077,
        ServoModel::Xl430W250,
        ServoModel::Xm430W350,
    ];

    /// The model's description: the one place a model is matched on.
    pub fn spec(self) -> &'static ModelSpec {
        match self {
            ServoModel::Sts3215 => &sts3215::STS3215,
            ServoModel::Xl330M288 => &dynamixel_x::XL330_M288,
            ServoModel::Xl330M077 => &dynamixel_x::XL330_M077,
            ServoModel::Xl430W250 => &dynamixel_x::XL430_W250,
            ServoModel::Xm430W350 => &dynamixel_x::XM430_W350,
        }
    }

    /// The name robot files use.
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// The model robot files call `s`.
    pub fn parse(s: &str) -> Option<ServoModel> {
        ServoModel::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Who made it.
    pub fn vendor(self) -> Vendor {
        self.spec().protocol.vendor()
    }

    /// Whether a bus of `protocol` can address this model.
    pub fn speaks(self, protocol: Protocol) -> bool {
        self.vendor() == protocol.vendor()
    }
}

/// The supported model of a bus protocol with this model number. Model numbers are only
/// unique within a vendor, so the protocol says which vendor's numbers to look in.
pub fn model_from_number(protocol: Protocol, number: u16) -> Option<ServoModel> {
    ServoModel::ALL
        .into_iter()
        .find(|&m| m.speaks(protocol) && m.spec().model_number == number)
}

/// Multi-turn position control: its Operating_Mode value and goal range in ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExtendedMode {
    /// Its Operating_Mode value.
    pub mode: i64,
    /// Its goal range, ticks.
    pub range: (i64, i64),
}

/// A model's position modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Modes {
    /// The Operating_Mode value of position control within one turn (the factory mode);
    /// unused where the table has no Operating_Mode (the model is always in that mode).
    pub position_mode: i64,
    /// Its goal range, in ticks.
    pub position: (i64, i64),
    /// Multi-turn position control, where the model has it (only a model with an
    /// Operating_Mode register can be switched to it).
    pub extended_position: Option<ExtendedMode>,
    /// In position mode a homing offset beyond ± this is ignored, where the firmware does so
    /// (Dynamixel X: 1024, e-Manual `control_table_homingoffset.md`).
    pub position_mode_offset_limit: Option<i64>,
}

/// Everything keypose knows about one servo model: identity, resolution, control table and
/// its units, speeds, modes, and the values that change what the firmware does. The rules
/// the firmware follows with these numbers are the vendor's (`bus::protocol::VENDOR::firmware`).
#[derive(Debug, PartialEq)]
pub struct ModelSpec {
    /// The model described.
    pub model: ServoModel,
    /// The name robot files use.
    pub name: &'static str,
    /// The protocol the model speaks from the factory: its vendor, and whose firmware rules
    /// it follows.
    pub protocol: Protocol,
    /// What the model number register (and a Dynamixel ping) reports.
    pub model_number: u16,
    /// Position ticks per revolution of the shaft: 4096 on every supported model (an AX-12's
    /// 1024 ticks span 300°, 1228.8 a revolution).
    pub ticks_per_revolution: f64,
    /// The registers with a role, their units and firmware behaviours.
    pub table: &'static RegisterTable,
    /// At the supply voltage the supported arms use, degrees per second.
    pub no_load_speed_deg_s: f64,
    /// Its position modes.
    pub modes: Modes,
    /// The full control table (what the manual lists), in address order, with
    /// [`Self::extra_items`] the items only some models of a family have.
    pub items: &'static [Item],
    /// The items only this model of its family has.
    pub extra_items: &'static [Item],
    /// The values of the operating mode register the model has; empty where it has none.
    pub operating_modes: &'static [i64],
    /// Present_Velocity's unit, ticks per second.
    pub velocity_unit: f64,
    /// Return_Delay_Time's unit; zero where the register has no function.
    pub return_delay_unit: Duration,
    /// The Torque_Enable value that recalibrates: the present position becomes half a turn,
    /// by the homing offset that makes it so; the torque stays as it was.
    pub recalibrate: Option<i64>,
    /// The motion-profile registers `--servo-profile` writes, in the order it writes them.
    pub profile: &'static [ProfileRegister],
    /// The Drive_Mode register's bits, where the model has one.
    pub drive_mode: Option<DriveModeBits>,
}

impl ModelSpec {
    /// The name robot files use.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// Joint degrees per position tick.
    pub fn degrees_per_tick(&self) -> f64 {
        360.0 / self.ticks_per_revolution
    }

    /// Ticks per second at the no-load speed.
    pub fn no_load_speed_ticks_s(&self) -> f64 {
        self.no_load_speed_deg_s * self.ticks_per_revolution / 360.0
    }

    /// Every item of the model's control table.
    pub fn all_items(&self) -> impl Iterator<Item = &'static Item> {
        self.items.iter().chain(self.extra_items)
    }

    /// The temperature at which its heat protection trips from the factory, °C.
    pub fn factory_temperature_limit_c(&self) -> Option<f64> {
        match self.item(self.table.temperature_limit.name)?.default {
            super::item::Default::Value(v) => Some(v as f64),
            super::item::Default::Live => None,
        }
    }

    /// The control-table item called `name`.
    pub fn item(&self, name: &str) -> Option<&'static Item> {
        item::find(self.items, name).or_else(|| item::find(self.extra_items, name))
    }

    /// The profile register of `setting`, if `--servo-profile` writes one.
    pub fn profile_register(&self, setting: super::Setting) -> Option<&'static ProfileRegister> {
        self.profile.iter().find(|p| p.setting == setting)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_has_its_own_description_and_name() {
        for model in ServoModel::ALL {
            assert_eq!(model.spec().model, model);
            assert_eq!(ServoModel::parse(model.name()), Some(model));
        }
        assert_eq!(ServoModel::parse("sts3215"), Some(ServoModel::Sts3215));
        assert_eq!(ServoModel::parse("xl330-m077"), Some(ServoModel::Xl330M077));
        assert_eq!(ServoModel::Sts3215.vendor(), Vendor::Feetech);
        assert_eq!(ServoModel::Xm430W350.vendor(), Vendor::Dynamixel);
        // 4096 ticks a turn: 360/4096 degrees each.
        assert_eq!(ServoModel::Xl430W250.spec().degrees_per_tick(), 0.087890625);
    }
}
