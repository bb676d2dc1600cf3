//! What a register is (name, address, size, encoding) and how its value is encoded in a byte
//! order. Signed positions reuse [`PositionEncoding`], the tick representation the robot's
//! servo mapping uses too, so a register and the joint mapping cannot disagree about a negative
//! tick.

use super::PositionEncoding;

/// The order of a register value's bytes in memory and on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ByteOrder {
    /// Low byte at the lower address: Dynamixel, Feetech STS/SMS.
    Little,
    /// High byte at the lower address: Feetech SCS.
    Big,
}

impl ByteOrder {
    /// The low `size` bytes of `raw` (at most 4).
    pub fn to_bytes(self, raw: u32, size: u8) -> Vec<u8> {
        let mut bytes = vec![0; usize::from(size.min(4))];
        self.put_bytes(raw, &mut bytes);
        bytes
    }

    /// The low `out.len()` bytes of `raw` (at most 4) into `out`, without allocating.
    pub fn put_bytes(self, raw: u32, out: &mut [u8]) {
        let size = out.len().min(4);
        match self {
            ByteOrder::Little => out[..size].copy_from_slice(&raw.to_le_bytes()[..size]),
            ByteOrder::Big => out[..size].copy_from_slice(&raw.to_be_bytes()[4 - size..]),
        }
    }

    /// The value of up to 4 bytes; `None` for more.
    pub fn from_bytes(self, bytes: &[u8]) -> Option<u32> {
        if bytes.len() > 4 {
            return None;
        }
        let fold = |acc: u32, &b: &u8| (acc << 8) | u32::from(b);
        Some(match self {
            ByteOrder::Little => bytes.iter().rev().fold(0, fold),
            ByteOrder::Big => bytes.iter().fold(0, fold),
        })
    }
}

/// How a register represents a signed or unsigned value in its bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// Plain binary, 0 up.
    Unsigned,
    /// Two's complement over the register's whole width (Dynamixel).
    TwosComplement,
    /// Magnitude in the bits below `sign_bit`, `sign_bit` set for negative values (Feetech
    /// STS/SMS). Always a 2-byte register.
    SignMagnitude {
        /// The bit that marks a negative value.
        sign_bit: u8,
    },
}

/// One control-table entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Register {
    /// Its name in the vendor's control table (`Goal_Position`).
    pub name: &'static str,
    /// Its first address in the control table.
    pub address: u16,
    /// In bytes: 1, 2 or 4.
    pub size: u8,
    /// How its bits hold a value.
    pub encoding: Encoding,
}

/// A value or bytes that do not fit a register.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegisterError {
    /// A value outside what the register can hold.
    #[error("{register}: value {value} does not fit the register ({min} to {max})")]
    OutOfRange {
        /// The register's name.
        register: &'static str,
        /// The value.
        value: i64,
        /// The least it holds.
        min: i64,
        /// The most it holds.
        max: i64,
    },
    /// Another number of bytes than the register has.
    #[error("{register}: {found} bytes where the register has {expected}")]
    Size {
        /// The register's name.
        register: &'static str,
        /// Its size, bytes.
        expected: u8,
        /// The bytes given.
        found: usize,
    },
    /// A register outside the block of bytes read.
    #[error("{register} (address {address}, {size} bytes) is not inside the {len} bytes read from address {start}")]
    OutsideBlock {
        /// The register's name.
        register: &'static str,
        /// Its address.
        address: u16,
        /// Its size, bytes.
        size: u8,
        /// The block's first address.
        start: u16,
        /// The block's length, bytes.
        len: usize,
    },
    /// An address a one-byte address field cannot carry.
    #[error("{register}: address {address} does not fit a one-byte (Feetech) address")]
    Address {
        /// The register's name.
        register: &'static str,
        /// Its address.
        address: u16,
    },
}

impl Register {
    /// A register called `name` of `size` bytes at `address`.
    pub const fn new(name: &'static str, address: u16, size: u8, encoding: Encoding) -> Register {
        Register {
            name,
            address,
            size,
            encoding,
        }
    }

    /// One past the last address.
    pub fn end(&self) -> u16 {
        self.address.saturating_add(u16::from(self.size))
    }

    /// The address as the one byte Feetech packets carry.
    pub fn short_address(&self) -> Result<u8, RegisterError> {
        u8::try_from(self.address).map_err(|_| RegisterError::Address {
            register: self.name,
            address: self.address,
        })
    }

    /// The tick representation this register shares with the robot's servo mapping, when its
    /// encoding and width are one of those.
    pub fn position_encoding(&self) -> Option<PositionEncoding> {
        match (self.encoding, self.size) {
            (Encoding::TwosComplement, 4) => Some(PositionEncoding::TwosComplement32),
            (Encoding::SignMagnitude { sign_bit }, 2) if sign_bit < 16 => {
                Some(PositionEncoding::SignMagnitude16 { sign_bit })
            }
            (Encoding::Unsigned, 2) => Some(PositionEncoding::Unsigned16),
            _ => None,
        }
    }

    /// The width in bits, with nonsensical sizes clamped so that no shift overflows.
    fn bits(&self) -> u32 {
        8 * u32::from(self.size.clamp(1, 4))
    }

    /// The values the register can hold.
    pub fn range(&self) -> (i64, i64) {
        if let Some(encoding) = self.position_encoding() {
            return encoding.range();
        }
        let bits = self.bits();
        match self.encoding {
            Encoding::Unsigned => (0, (1i64 << bits) - 1),
            Encoding::TwosComplement => (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1),
            // A sign bit outside the register's width cannot be set: nothing negative fits.
            Encoding::SignMagnitude { sign_bit } if u32::from(sign_bit) >= bits => {
                (0, (1i64 << bits) - 1)
            }
            Encoding::SignMagnitude { sign_bit } => {
                let magnitude = (1i64 << sign_bit) - 1;
                (-magnitude, magnitude)
            }
        }
    }

    /// The register's raw bits for `value`.
    pub fn to_raw(&self, value: i64) -> Result<u32, RegisterError> {
        let (min, max) = self.range();
        let out_of_range = RegisterError::OutOfRange {
            register: self.name,
            value,
            min,
            max,
        };
        if value < min || value > max {
            return Err(out_of_range);
        }
        if let Some(encoding) = self.position_encoding() {
            return encoding.encode(value).map_err(|_| out_of_range);
        }
        let mask = if self.bits() >= 32 {
            u32::MAX
        } else {
            (1u32 << self.bits()) - 1
        };
        Ok(match self.encoding {
            Encoding::SignMagnitude { sign_bit } if value < 0 => {
                value.unsigned_abs() as u32 | (1u32 << sign_bit)
            }
            // Truncating a two's complement i64 to the width keeps its representation.
            _ => value as u32 & mask,
        })
    }

    /// The value in the register's raw bits (bits above the width are ignored).
    pub fn from_raw(&self, raw: u32) -> i64 {
        if let Some(encoding) = self.position_encoding() {
            return encoding.decode(raw);
        }
        match (self.encoding, self.size) {
            (Encoding::TwosComplement, 1) => i64::from(raw as u8 as i8),
            (Encoding::TwosComplement, 2) => i64::from(raw as u16 as i16),
            (Encoding::TwosComplement, _) => i64::from(raw as i32),
            (Encoding::SignMagnitude { sign_bit }, _) => {
                let sign = 1u32.checked_shl(u32::from(sign_bit)).unwrap_or(0);
                let magnitude = i64::from(raw & sign.wrapping_sub(1));
                if sign != 0 && raw & sign != 0 {
                    -magnitude
                } else {
                    magnitude
                }
            }
            (Encoding::Unsigned, 1) => i64::from(raw & 0xFF),
            (Encoding::Unsigned, 2) => i64::from(raw & 0xFFFF),
            (Encoding::Unsigned, _) => i64::from(raw),
        }
    }

    /// The bytes to write for `value`.
    pub fn encode(&self, value: i64, order: ByteOrder) -> Result<Vec<u8>, RegisterError> {
        Ok(order.to_bytes(self.to_raw(value)?, self.size))
    }

    /// The value in exactly `size` bytes read from the register.
    pub fn decode(&self, bytes: &[u8], order: ByteOrder) -> Result<i64, RegisterError> {
        if bytes.len() != usize::from(self.size) {
            return Err(RegisterError::Size {
                register: self.name,
                expected: self.size,
                found: bytes.len(),
            });
        }
        let raw = order.from_bytes(bytes).ok_or(RegisterError::Size {
            register: self.name,
            expected: self.size,
            found: bytes.len(),
        })?;
        Ok(self.from_raw(raw))
    }

    /// The value inside a block of bytes read in one go starting at `start`.
    pub fn decode_in_block(
        &self,
        block: &[u8],
        start: u16,
        order: ByteOrder,
    ) -> Result<i64, RegisterError> {
        let outside = RegisterError::OutsideBlock {
            register: self.name,
            address: self.address,
            size: self.size,
            start,
            len: block.len(),
        };
        let offset = usize::from(self.address.checked_sub(start).ok_or(outside.clone())?);
        let bytes = block
            .get(offset..offset + usize::from(self.size))
            .ok_or(outside)?;
        self.decode(bytes, order)
    }
}

/// The smallest address span covering `registers`: (start, length), for reading them in one
/// READ. `None` for no registers.
pub fn span(registers: &[Register]) -> Option<(u16, u16)> {
    let start = registers.iter().map(|r| r.address).min()?;
    let end = registers.iter().map(Register::end).max()?;
    Some((start, end - start))
}

/// An unsigned register.
pub(super) const fn unsigned(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::Unsigned)
}

/// A two's complement register (Dynamixel).
pub(super) const fn signed(name: &'static str, address: u16, size: u8) -> Register {
    Register::new(name, address, size, Encoding::TwosComplement)
}

/// A two-byte sign-magnitude register with the sign at `sign_bit` (Feetech STS).
pub(super) const fn sign_magnitude(name: &'static str, address: u16, sign_bit: u8) -> Register {
    Register::new(name, address, 2, Encoding::SignMagnitude { sign_bit })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::servo::ServoModel;
    use proptest::prelude::*;

    #[test]
    fn byte_order_helpers() {
        assert_eq!(
            ByteOrder::Little.to_bytes(0x1234_5678, 4),
            [0x78, 0x56, 0x34, 0x12]
        );
        assert_eq!(ByteOrder::Big.to_bytes(0x1234_5678, 2), [0x56, 0x78]);
        assert_eq!(ByteOrder::Big.from_bytes(&[0x12, 0x34]), Some(0x1234));
        assert_eq!(ByteOrder::Little.from_bytes(&[0x12, 0x34]), Some(0x3412));
        assert_eq!(ByteOrder::Little.from_bytes(&[0; 5]), None);
    }

    fn any_register() -> impl Strategy<Value = Register> {
        let models: Vec<Register> = ServoModel::ALL
            .into_iter()
            .flat_map(|m| m.spec().table.registers())
            .chain([
                Register::new("i8", 0, 1, Encoding::TwosComplement),
                Register::new("i16", 0, 2, Encoding::TwosComplement),
                Register::new("u32", 0, 4, Encoding::Unsigned),
                Register::new("sm1", 0, 1, Encoding::SignMagnitude { sign_bit: 7 }),
            ])
            .collect();
        prop::sample::select(models)
    }

    proptest! {
        #[test]
        fn values_in_range_round_trip(register in any_register(), seed in any::<i64>(), big in any::<bool>()) {
            let (min, max) = register.range();
            let span = (max - min) as u64 + 1;
            let value = min + (seed as u64 % span) as i64;
            let order = if big { ByteOrder::Big } else { ByteOrder::Little };
            let bytes = register.encode(value, order).unwrap();
            prop_assert_eq!(bytes.len(), usize::from(register.size));
            prop_assert_eq!(register.decode(&bytes, order).unwrap(), value);
        }

        #[test]
        fn any_bytes_decode(register in any_register(), bytes in prop::collection::vec(any::<u8>(), 4)) {
            let bytes = &bytes[..usize::from(register.size)];
            let value = register.decode(bytes, ByteOrder::Little).unwrap();
            let (min, max) = register.range();
            prop_assert!(min <= value && value <= max);
        }

        #[test]
        fn values_out_of_range_are_refused(register in any_register(), excess in 1i64..1000) {
            let (min, max) = register.range();
            prop_assert!(register.to_raw(max + excess).is_err());
            prop_assert!(register.to_raw(min - excess).is_err());
        }
    }
}
