//! Arbitrary bytes into the dynamixel framing decoder, as the driver (status packets) and the
//! emulated servos (instruction packets) read them. Property (keypose_fuzz::decoding): every
//! step consumes a byte or asks for more; chunking does not change what decodes; every decoded
//! packet re-encodes to bytes that decode to the same packet.
#![no_main]

use keypose::bus::protocol::dynamixel::Dynamixel2;
use keypose_fuzz::decoding::fuzz_framing;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| fuzz_framing(&Dynamixel2, data));
