//! Bulk Read (0x92) and Bulk Write (0x93) parameters: unlike the sync instructions, each
//! servo has its own address and length (ROBOTIS e-Manual, Protocol 2.0, "Bulk Read" and
//! "Bulk Write"; `dynamixel_sdk` `GroupBulkRead.makeParam`, `GroupBulkWrite.addParam`):
//!
//! - Bulk Read: per servo `ID ADDR_L ADDR_H LEN_L LEN_H`; each servo answers with its own
//!   status packet, in list order.
//! - Bulk Write: per servo `ID ADDR_L ADDR_H LEN_L LEN_H DATA…`; nobody answers.

/// One servo's part of a Bulk Read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BulkRead {
    /// The servo.
    pub id: u8,
    /// The first address read.
    pub address: u16,
    /// Bytes read.
    pub length: u16,
}

/// One servo's part of a Bulk Write.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BulkWrite {
    /// The servo.
    pub id: u8,
    /// The first address written.
    pub address: u16,
    /// The bytes written there.
    pub data: Vec<u8>,
}

/// ID, address and length: the head of every entry.
const ENTRY_HEAD: usize = 5;

fn head(id: u8, address: u16, length: u16) -> [u8; ENTRY_HEAD] {
    let [a0, a1] = address.to_le_bytes();
    let [l0, l1] = length.to_le_bytes();
    [id, a0, a1, l0, l1]
}

fn parse_head(bytes: &[u8]) -> (u8, u16, u16) {
    (
        bytes[0],
        u16::from_le_bytes([bytes[1], bytes[2]]),
        u16::from_le_bytes([bytes[3], bytes[4]]),
    )
}

/// The parameters of a Bulk Read of `entries`.
pub fn encode_bulk_read(entries: &[BulkRead]) -> Vec<u8> {
    entries
        .iter()
        .flat_map(|e| head(e.id, e.address, e.length))
        .collect()
}

/// `None` when the parameters are not whole entries.
pub fn parse_bulk_read(params: &[u8]) -> Option<Vec<BulkRead>> {
    if params.is_empty() || params.len() % ENTRY_HEAD != 0 {
        return None;
    }
    let entries = params.chunks(ENTRY_HEAD).map(|chunk| {
        let (id, address, length) = parse_head(chunk);
        BulkRead {
            id,
            address,
            length,
        }
    });
    Some(entries.collect())
}

/// `None` for data longer than a length field holds.
pub fn encode_bulk_write(entries: &[BulkWrite]) -> Option<Vec<u8>> {
    let mut params = Vec::new();
    for entry in entries {
        let length = u16::try_from(entry.data.len()).ok()?;
        params.extend(head(entry.id, entry.address, length));
        params.extend(&entry.data);
    }
    Some(params)
}

/// `None` when an entry is cut short.
pub fn parse_bulk_write(mut params: &[u8]) -> Option<Vec<BulkWrite>> {
    let mut entries = Vec::new();
    while !params.is_empty() {
        if params.len() < ENTRY_HEAD {
            return None;
        }
        let (id, address, length) = parse_head(params);
        let end = ENTRY_HEAD + usize::from(length);
        let data = params.get(ENTRY_HEAD..end)?.to_vec();
        entries.push(BulkWrite { id, address, data });
        params = &params[end..];
    }
    (!entries.is_empty()).then_some(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip_and_truncation_is_refused() {
        // Servo 1: 4 bytes from 132 (0x84); servo 2: 1 byte from 146 (0x92).
        let reads = [
            BulkRead {
                id: 1,
                address: 132,
                length: 4,
            },
            BulkRead {
                id: 2,
                address: 146,
                length: 1,
            },
        ];
        let params = encode_bulk_read(&reads);
        assert_eq!(params, [1, 0x84, 0, 4, 0, 2, 0x92, 0, 1, 0]);
        assert_eq!(parse_bulk_read(&params).unwrap(), reads);
        assert_eq!(parse_bulk_read(&params[..9]), None);
        let writes = [BulkWrite {
            id: 3,
            address: 116,
            data: vec![0x00, 0x08, 0, 0],
        }];
        let params = encode_bulk_write(&writes).unwrap();
        assert_eq!(params, [3, 116, 0, 4, 0, 0x00, 0x08, 0, 0]);
        assert_eq!(parse_bulk_write(&params).unwrap(), writes);
        assert_eq!(parse_bulk_write(&params[..8]), None);
    }
}
