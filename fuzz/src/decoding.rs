//! The properties of a packet framing both decoder targets check.

use keypose::bus::protocol::packet::{
    Decoded, Direction, Framing, Packet, PacketError, PacketKind,
};

/// Decodes all of `bytes`, asserting that every step that does not ask for more bytes consumes
/// at least one (the driver's receive loop relies on it to terminate) and that asking for more
/// never grows the buffer.
pub fn decode_all(
    framing: &dyn Framing,
    bytes: &mut Vec<u8>,
    direction: Direction,
) -> Vec<Result<Packet, PacketError>> {
    let mut out = Vec::new();
    loop {
        let before = bytes.len();
        let result = framing.decode(bytes, direction);
        assert!(bytes.len() <= before, "decoding grew the buffer");
        match result {
            Ok(Decoded::NeedMore) => return out,
            Ok(Decoded::Packet(packet)) => out.push(Ok(packet)),
            Err(e) => out.push(Err(e)),
        }
        assert!(
            bytes.len() < before,
            "a decoding step consumed nothing: {:?}",
            out.last()
        );
    }
}

/// The bytes `framing` sends for `packet`.
pub fn encode(framing: &dyn Framing, packet: &Packet) -> Result<Vec<u8>, PacketError> {
    match packet.kind {
        PacketKind::Instruction(code) => {
            framing.try_encode_instruction(packet.id, code, &packet.params)
        }
        PacketKind::Status { error } => framing.try_encode_status(packet.id, error, &packet.params),
    }
}

/// A fuzz input for a framing: the first byte says where to split the rest in two (as a
/// fraction of 256), and the rest is checked as both directions read it ([`check_framing`]).
pub fn fuzz_framing(framing: &dyn Framing, data: &[u8]) {
    let Some((&split, bytes)) = data.split_first() else {
        return;
    };
    let split = usize::from(split) * bytes.len() / 256;
    for direction in [Direction::FromServo, Direction::ToServo] {
        check_framing(framing, bytes, split, direction);
    }
}

/// Every property of one decoder on one input:
/// - progress: each step consumes a byte or asks for more;
/// - incremental: the input fed in two pieces (split where `split` says) decodes to the same
///   results as fed whole, as a serial line delivers it in arbitrary chunks;
/// - round trip: every decoded packet re-encodes to bytes that decode, whole, to the same
///   packet; the only packets that may not re-encode are those too long for what we transmit
///   (the receive limit is the SDK's receive buffer, wider than its transmit buffer).
pub fn check_framing(framing: &dyn Framing, data: &[u8], split: usize, direction: Direction) {
    let mut whole = data.to_vec();
    let results = decode_all(framing, &mut whole, direction);

    let split = split.min(data.len());
    let mut pieces = data[..split].to_vec();
    let mut in_pieces = decode_all(framing, &mut pieces, direction);
    pieces.extend_from_slice(&data[split..]);
    in_pieces.extend(decode_all(framing, &mut pieces, direction));
    assert_eq!(
        packets(&results),
        packets(&in_pieces),
        "split at {split} changes what decodes"
    );
    assert_eq!(whole, pieces, "split at {split} changes what is left");

    for packet in packets(&results) {
        round_trip(framing, packet, direction);
    }
}

fn packets(results: &[Result<Packet, PacketError>]) -> Vec<&Packet> {
    results.iter().filter_map(|r| r.as_ref().ok()).collect()
}

fn round_trip(framing: &dyn Framing, packet: &Packet, direction: Direction) {
    let mut bytes = match encode(framing, packet) {
        Ok(bytes) => bytes,
        Err(PacketError::TooLong { .. }) => return,
        Err(e) => panic!("decoded {packet:?} does not re-encode: {e}"),
    };
    let encoded = bytes.clone();
    match framing.decode(&mut bytes, direction) {
        Ok(Decoded::Packet(again)) => {
            assert_eq!(&again, packet, "re-encoded as {encoded:02x?}");
            assert!(bytes.is_empty(), "{:02x?} left after the packet", bytes);
        }
        other => panic!("re-encoded {packet:?} as {encoded:02x?}, decodes as {other:?}"),
    }
}
