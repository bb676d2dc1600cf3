//! Fast Sync Read (0x8A): one status packet from the broadcast id that several servos
//! assemble, each appending its block (ROBOTIS e-Manual, Protocol 2.0, "Fast Sync Read").

use super::crc::crc16;
use super::{BROADCAST_ID, HEADER, MAX_DEVICE_ID, MAX_PACKET, PREFIX, STATUS};
use crate::bus::protocol::packet::{Packet, PacketError};

/// One servo's part of a Fast Sync Read answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FastSyncReadEntry {
    /// The servo.
    pub id: u8,
    /// The servo's status error byte.
    pub error: u8,
    /// The bytes read from it.
    pub data: Vec<u8>,
}

/// Splits a Fast Sync Read answer (one status packet from [`BROADCAST_ID`]) into its servos'
/// blocks. On the wire each block is `ERR ID DATA(length) CRC(2)`; in the decoded packet the
/// first ERR is the status error byte and the last CRC is the packet CRC, so the parameters are
/// `ID DATA CRC | ERR ID DATA CRC | … | ERR ID DATA`.
///
/// The per-block CRCs are skipped unchecked, as the ROBOTIS SDK does: the packet CRC already
/// covers every byte.
pub fn parse_fast_sync_read(
    packet: &Packet,
    length: u16,
) -> Result<Vec<FastSyncReadEntry>, PacketError> {
    let id = packet.id;
    let Some(first_error) = packet.error() else {
        return Err(PacketError::Malformed {
            id,
            detail: "an instruction packet where a fast sync read answer was expected".into(),
        });
    };
    let data_len = length as usize;
    let block = data_len + 4;
    // The decoded packet lacks the first ERR and the last CRC of the wire blocks.
    let wire_len = packet.params.len() + 3;
    if wire_len % block != 0 {
        return Err(PacketError::Malformed {
            id,
            detail: format!(
                "{} parameter bytes do not split into blocks of {} data bytes",
                packet.params.len(),
                data_len
            ),
        });
    }
    let count = wire_len / block;
    let mut entries = Vec::with_capacity(count);
    for k in 0..count {
        let truncated = || PacketError::Malformed {
            id,
            detail: format!("fast sync read block {k} is truncated"),
        };
        // Block k ≥ 1 starts (ERR) at k·block on the wire, one less in the parameters.
        let (error, id_at) = if k == 0 {
            (first_error, 0)
        } else {
            let error_at = k * block - 1;
            let error = *packet.params.get(error_at).ok_or_else(truncated)?;
            (error, error_at + 1)
        };
        let servo = *packet.params.get(id_at).ok_or_else(truncated)?;
        let data = packet
            .params
            .get(id_at + 1..id_at + 1 + data_len)
            .ok_or_else(truncated)?;
        entries.push(FastSyncReadEntry {
            id: servo,
            error,
            data: data.to_vec(),
        });
    }
    Ok(entries)
}

/// The whole Fast Sync Read answer packet for `entries` (what an emulated bus sends). Each
/// block's CRC is the running CRC of every byte before it, so the last one is the packet CRC,
/// as the layout requires. Not stuffed, like the real answer (see [`parse_fast_sync_read`]).
pub fn encode_fast_sync_read(entries: &[FastSyncReadEntry]) -> Result<Vec<u8>, PacketError> {
    let Some(first) = entries.first() else {
        return Err(PacketError::Malformed {
            id: BROADCAST_ID,
            detail: "a fast sync read answer needs at least one servo".into(),
        });
    };
    let data_len = first.data.len();
    for entry in entries {
        if entry.id > MAX_DEVICE_ID {
            return Err(PacketError::Id { id: entry.id });
        }
        if entry.data.len() != data_len {
            return Err(PacketError::DataLength {
                id: entry.id,
                expected: data_len,
                found: entry.data.len(),
            });
        }
    }
    let region_len = 1 + entries.len() * (data_len + 4);
    if PREFIX + region_len > MAX_PACKET {
        return Err(PacketError::TooLong {
            id: BROADCAST_ID,
            length: region_len - 2,
            max: MAX_PACKET - PREFIX - 2,
        });
    }
    let mut out = Vec::with_capacity(PREFIX + region_len);
    out.extend_from_slice(&HEADER);
    out.push(BROADCAST_ID);
    out.extend_from_slice(&(region_len as u16).to_le_bytes());
    out.push(STATUS);
    for entry in entries {
        out.push(entry.error);
        out.push(entry.id);
        out.extend_from_slice(&entry.data);
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_le_bytes());
    }
    Ok(out)
}
