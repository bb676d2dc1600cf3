//! One static description per supported servo model: name, model number, control table and
//! its units, no-load speed, and the ranges of its position modes. Everything else (the
//! drivers, the emulated servos, the planner's speed limits) reads the facts from here through
//! [`ServoModel::spec`]. A new model is one more file here and one arm in [`spec`].

mod dynamixel_x;
pub mod item;
mod sts3215;
#[cfg(test)]
mod tests;

use super::registers::{Encoding, Register, RegisterTable};
use super::BusError;
use crate::robot::{Protocol, ServoModel};
use std::collections::HashMap;

/// The goal-position ranges of a model's position modes, in ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Modes {
    /// Position control within one turn.
    pub position: (i64, i64),
    /// Multi-turn position control, where the model has it.
    pub extended_position: Option<(i64, i64)>,
}

/// Everything keypose knows about one servo model.
#[derive(Debug, PartialEq)]
pub struct ModelSpec {
    pub model: ServoModel,
    /// What the model number register (and a Dynamixel ping) reports.
    pub model_number: u16,
    pub table: &'static RegisterTable,
    /// At the supply voltage the supported arms use, degrees per second.
    pub no_load_speed_deg_s: f64,
    pub modes: Modes,
    /// The full control table (what the manual lists), in address order, with
    /// [`Self::extra_items`] the items only some models of a family have.
    pub items: &'static [item::Item],
    pub extra_items: &'static [item::Item],
    /// The values of the operating mode register the model has.
    pub operating_modes: &'static [i64],
}

/// The description of `model`.
pub fn spec(model: ServoModel) -> &'static ModelSpec {
    match model {
        ServoModel::Sts3215 => &sts3215::STS3215,
        ServoModel::Xl330M288 => &dynamixel_x::XL330_M288,
        ServoModel::Xl330M077 => &dynamixel_x::XL330_M077,
        ServoModel::Xl430W250 => &dynamixel_x::XL430_W250_SPEC,
        ServoModel::Xm430W350 => &dynamixel_x::XM430_W350_SPEC,
    }
}

impl ServoModel {
    /// Everything the bus knows about the model: model number, control table, speeds.
    pub fn spec(self) -> &'static ModelSpec {
        spec(self)
    }
}

impl ModelSpec {
    pub fn name(&self) -> &'static str {
        self.model.name()
    }

    /// Every item of the model's control table.
    pub fn all_items(&self) -> impl Iterator<Item = &'static item::Item> {
        self.items.iter().chain(self.extra_items)
    }

    /// The control-table item called `name`.
    pub fn item(&self, name: &str) -> Option<&'static item::Item> {
        item::find(self.items, name).or_else(|| item::find(self.extra_items, name))
    }
}

pub use dynamixel_x::FIRMWARE_VERSION as DYNAMIXEL_FIRMWARE_VERSION;
pub use sts3215::{FIRMWARE as STS3215_FIRMWARE, TORQUE_RECALIBRATE};

/// The supported model of a bus protocol with this model number. Model numbers are only
/// unique within a vendor, so the protocol says which vendor's numbers to look in.
pub fn model_from_number(protocol: Protocol, number: u16) -> Option<ServoModel> {
    ServoModel::ALL
        .into_iter()
        .find(|&m| m.speaks(protocol) && m.spec().model_number == number)
}

/// The servos of one bus by id: which table each one's registers are in.
#[derive(Debug, Clone, Default)]
pub struct Servos(HashMap<u8, ServoModel>);

impl Servos {
    pub fn new(servos: &[(u8, ServoModel)]) -> Servos {
        Servos(servos.iter().copied().collect())
    }

    pub fn model(&self, id: u8) -> Result<ServoModel, BusError> {
        self.0
            .get(&id)
            .copied()
            .ok_or_else(|| BusError::Protocol(format!("servo {id} is not part of this robot")))
    }

    pub fn table(&self, id: u8) -> Result<&'static RegisterTable, BusError> {
        self.model(id).map(|m| m.spec().table)
    }

    /// The register of the servos `ids` picked by `pick`, and the first one's table: a sync
    /// transfer needs it at the same address and size on all of them, which is checked.
    pub fn common_register(
        &self,
        ids: &[u8],
        pick: fn(&RegisterTable) -> Register,
    ) -> Result<(Register, &'static RegisterTable), BusError> {
        let first = *ids
            .first()
            .ok_or_else(|| BusError::Protocol("no servos given".into()))?;
        let table = self.table(first)?;
        let register = pick(table);
        for &id in &ids[1..] {
            let other = pick(self.table(id)?);
            if other.address != register.address || other.size != register.size {
                return Err(BusError::Protocol(format!(
                    "servos {first} and {id} keep {} at different addresses; they cannot share a sync transfer",
                    register.name
                )));
            }
        }
        Ok((register, table))
    }
}

const fn unsigned(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::Unsigned)
}

const fn signed(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::TwosComplement)
}

const fn sign_magnitude(name: &'static str, address: u16, sign_bit: u8) -> Register {
    Register::new(name, address, 2, Encoding::SignMagnitude { sign_bit })
}
