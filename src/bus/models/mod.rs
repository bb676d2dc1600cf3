//! The servos of one bus: which model, and so which control table, each id has. What a model
//! is lives in the servo catalogue ([`crate::servo`]); its unit tests, which check the
//! catalogue's tables against the codecs and the published values, are here, beside the bus.

#[cfg(test)]
mod tests;

use super::BusError;
use crate::servo::{Register, RegisterTable, ServoModel};

/// The servos of one bus by id: which table each one's registers are in. Indexed by the id
/// itself (one byte): every transaction looks up each of its servos, so no hashing.
#[derive(Debug, Clone, Default)]
pub struct Servos(Vec<Option<ServoModel>>);

impl Servos {
    pub fn new(servos: &[(u8, ServoModel)]) -> Servos {
        let mut by_id = vec![None; usize::from(u8::MAX) + 1];
        for &(id, model) in servos {
            by_id[usize::from(id)] = Some(model);
        }
        Servos(by_id)
    }

    pub fn model(&self, id: u8) -> Result<ServoModel, BusError> {
        self.0
            .get(usize::from(id))
            .copied()
            .flatten()
            .ok_or_else(|| BusError::UnknownServo { id })
    }

    pub fn table(&self, id: u8) -> Result<&'static RegisterTable, BusError> {
        self.model(id).map(|m| m.spec().table)
    }

    /// The register `pick` gives in the table of every servo in `ids`, and the first one's
    /// table: a sync transfer needs it at the same address and size on all of them, which is
    /// checked. `pick` gives the register, or the name of the one a model does not have.
    pub fn common_register(
        &self,
        ids: &[u8],
        pick: impl Fn(&RegisterTable) -> Result<Register, &'static str>,
    ) -> Result<(Register, &'static RegisterTable), BusError> {
        let first = *ids.first().ok_or(BusError::NoServos)?;
        let register_of = |id: u8| {
            let table = self.table(id)?;
            pick(table)
                .map(|register| (register, table))
                .map_err(|register| BusError::MissingRegister { id, register })
        };
        let (register, table) = register_of(first)?;
        for &id in &ids[1..] {
            let (other, _) = register_of(id)?;
            if other.address != register.address || other.size != register.size {
                return Err(BusError::SplitRegister {
                    first,
                    other: id,
                    register: register.name,
                });
            }
        }
        Ok((register, table))
    }
}
