//! What the bus adds to the servo catalogue's registers ([`crate::servo`]): a servo's answer
//! read into a register's value, or a corrupt answer.

use super::BusError;
use crate::servo::{Register, RegisterTable};

/// Reading a register's value out of a servo's answer.
pub trait DecodeAnswer {
    /// The value of `register` in servo `id`'s answer `bytes`: bytes that do not fit are a
    /// corrupt answer.
    fn decode_answer(&self, id: u8, register: &Register, bytes: &[u8]) -> Result<i64, BusError>;
}

impl DecodeAnswer for RegisterTable {
    fn decode_answer(&self, id: u8, register: &Register, bytes: &[u8]) -> Result<i64, BusError> {
        self.decode(register, bytes)
            .map_err(|e| BusError::corrupt(id, e))
    }
}
