//! The control-table vocabulary the bus uses, from the servo catalogue ([`crate::servo`]),
//! and what only the bus adds to it: a servo's answer read into a register's value.

use super::BusError;
pub use crate::servo::{
    model_from_number, span, ByteOrder, Encoding, LoadUnit, Register, RegisterError, RegisterTable,
};

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
