//! The Protocol 2.0 packet CRC (ROBOTIS e-Manual, Protocol 2.0, "CRC"; the SDK's `updateCRC`).

/// CRC-16 with polynomial 0x8005, MSB first, initial value 0, no final XOR (CRC-16/UMTS), one
/// table entry per value of the top byte.
pub(super) const CRC_TABLE: [u16; 256] = {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x8005
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
};

/// Continues a CRC over more bytes.
pub fn crc16_update(mut crc: u16, data: &[u8]) -> u16 {
    for &byte in data {
        let index = ((crc >> 8) as u8 ^ byte) as usize;
        crc = (crc << 8) ^ CRC_TABLE[index];
    }
    crc
}

/// The packet CRC of `data` (everything from the header to the last parameter, as sent).
pub fn crc16(data: &[u8]) -> u16 {
    crc16_update(0, data)
}
