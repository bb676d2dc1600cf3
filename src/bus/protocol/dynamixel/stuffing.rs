//! Byte stuffing: how Protocol 2.0 keeps the header `FF FF FD` out of a packet's body.

/// Inserts 0xFD after every `FF FF FD` so that the header cannot appear inside a packet.
/// `region` is the instruction byte and the parameters (for a status: 0x55, ERR, parameters).
pub fn stuff(region: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(region.len() + region.len() / 3);
    stuff_into(&mut out, region.iter().copied());
    out
}

/// [`stuff`] appending to `out`, so that a packet is built in one buffer: the region may come
/// in parts (the instruction byte, then the parameters), and a header spanning them is found
/// all the same.
pub fn stuff_into(out: &mut Vec<u8>, region: impl IntoIterator<Item = u8>) {
    // The two region bytes before the current one (not the stuffed output: an inserted 0xFD
    // is no part of a header).
    let (mut second_last, mut last) = (None, None);
    for byte in region {
        out.push(byte);
        if byte == 0xFD && second_last == Some(0xFF) && last == Some(0xFF) {
            out.push(0xFD);
        }
        (second_last, last) = (last, Some(byte));
    }
}

/// Reverses [`stuff`]: drops the 0xFD that follows each `FF FF FD` of the received bytes.
///
/// An `FF FF FD` not followed by 0xFD cannot come from a correct transmitter; the bytes are
/// kept as they are, as the ROBOTIS SDK does, because the CRC has already vouched for them.
pub fn unstuff(region: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(region.len());
    let mut i = 0;
    while i < region.len() {
        let byte = region[i];
        out.push(byte);
        let stuffed = byte == 0xFD
            && i >= 2
            && region[i - 1] == 0xFF
            && region[i - 2] == 0xFF
            && region.get(i + 1) == Some(&0xFD);
        i += if stuffed { 2 } else { 1 };
    }
    out
}
