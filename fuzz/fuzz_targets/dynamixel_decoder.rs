//! Arbitrary bytes into the dynamixel framing decoder, as the driver (status packets) and the
//! emulated servos (instruction packets) read them. Property (keypose_fuzz::decoding): every
//! step consumes a byte or asks for more; chunking does not change what decodes; every decoded
//! packet re-encodes to bytes that decode to the same packet.
#![no_main]

use keypose::bus::protocol::dynamixel::Dynamixel2;
use keypose::bus::protocol::packet::Direction;
use keypose_fuzz::decoding::check_framing;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else {
        return;
    };
    let split = usize::from(split) * bytes.len() / 256;
    for direction in [Direction::FromServo, Direction::ToServo] {
        check_framing(&Dynamixel2, bytes, split, direction);
    }
});
