//! The parameter layouts of READ, WRITE, SYNC READ and SYNC WRITE, which both vendors share
//! except for the width of the address and length fields: two bytes, little-endian, on
//! Dynamixel 2.0, one byte on Feetech (docs/protocols.md).

use super::packet::PacketError;

/// How wide the address and length fields of a protocol's instructions are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fields {
    /// Bytes per field: 1 or 2.
    width: usize,
}

impl Fields {
    /// Two-byte little-endian fields (Dynamixel 2.0).
    pub const WIDE: Fields = Fields { width: 2 };
    /// One-byte fields (Feetech).
    pub const NARROW: Fields = Fields { width: 1 };

    /// Bytes per field.
    pub fn width(self) -> usize {
        self.width
    }

    fn push(self, out: &mut Vec<u8>, value: u16) -> Result<(), PacketError> {
        if self.width == 2 {
            out.extend_from_slice(&value.to_le_bytes());
            return Ok(());
        }
        let byte = u8::try_from(value).map_err(|_| PacketError::FieldWidth { value })?;
        out.push(byte);
        Ok(())
    }

    /// READ parameters: address and length.
    pub fn read(self, address: u16, length: u16) -> Result<Vec<u8>, PacketError> {
        self.address_length(address, length, 0)
    }

    /// Address and length, in a buffer with room for `more` bytes after them.
    fn address_length(
        self,
        address: u16,
        length: u16,
        more: usize,
    ) -> Result<Vec<u8>, PacketError> {
        let mut params = Vec::with_capacity(2 * self.width + more);
        self.push(&mut params, address)?;
        self.push(&mut params, length)?;
        Ok(params)
    }

    /// WRITE parameters: address, then the data (already in the register's byte order).
    pub fn write(self, address: u16, data: &[u8]) -> Result<Vec<u8>, PacketError> {
        let mut params = Vec::with_capacity(self.width + data.len());
        self.push(&mut params, address)?;
        params.extend_from_slice(data);
        Ok(params)
    }

    /// SYNC READ (and Dynamixel FAST SYNC READ) parameters: address, length, ids. Sent to the
    /// broadcast id.
    pub fn sync_read(self, address: u16, length: u16, ids: &[u8]) -> Result<Vec<u8>, PacketError> {
        let mut params = self.address_length(address, length, ids.len())?;
        params.extend_from_slice(ids);
        Ok(params)
    }

    /// SYNC WRITE parameters: address, length, then each id with exactly `length` bytes of
    /// data. Sent to the broadcast id.
    pub fn sync_write(
        self,
        address: u16,
        length: u16,
        entries: &[(u8, Vec<u8>)],
    ) -> Result<Vec<u8>, PacketError> {
        let each = 1 + usize::from(length);
        let mut params = self.address_length(address, length, entries.len() * each)?;
        for (id, data) in entries {
            if data.len() != usize::from(length) {
                return Err(PacketError::DataLength {
                    id: *id,
                    expected: usize::from(length),
                    found: data.len(),
                });
            }
            params.push(*id);
            params.extend_from_slice(data);
        }
        Ok(params)
    }

    /// The field at the front of `params` and what follows it (the servo's side of the
    /// layouts above); `None` when the field is cut short.
    pub fn split(self, params: &[u8]) -> Option<(u16, &[u8])> {
        let field = params.get(..self.width)?;
        let value = match *field {
            [lo, hi] => u16::from_le_bytes([lo, hi]),
            [byte] => u16::from(byte),
            _ => return None,
        };
        Some((value, &params[self.width..]))
    }

    /// Address, length and the rest (ids, or sync-write entries) of READ-shaped parameters.
    pub fn split_read(self, params: &[u8]) -> Option<(u16, u16, &[u8])> {
        let (address, rest) = self.split(params)?;
        let (length, rest) = self.split(rest)?;
        Some((address, length, rest))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_round_trip_and_narrow_ones_refuse_wide_values() {
        let wide = Fields::WIDE.sync_read(132, 4, &[1, 2]).unwrap();
        assert_eq!(wide, [0x84, 0x00, 0x04, 0x00, 1, 2]);
        assert_eq!(
            Fields::WIDE.split_read(&wide),
            Some((132, 4, &[1u8, 2][..]))
        );
        let narrow = Fields::NARROW.sync_read(56, 2, &[3]).unwrap();
        assert_eq!(narrow, [56, 2, 3]);
        assert_eq!(
            Fields::NARROW.split_read(&narrow),
            Some((56, 2, &[3u8][..]))
        );
        assert_eq!(
            Fields::NARROW.read(300, 1),
            Err(PacketError::FieldWidth { value: 300 })
        );
        assert_eq!(Fields::WIDE.split(&[1]), None);
    }
}
