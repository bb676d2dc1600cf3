//! Arbitrary instruction bytes, in arbitrary chunks, into the emulated servos of a built-in
//! robot (the first byte picks it), as a driver or a stray program on the port would send them.
//! Property: no panic; every answer is exactly one well-formed status packet from one of the
//! robot's servos (or, for a Dynamixel Fast Sync Read, the broadcast id).
#![no_main]

use keypose::bus::protocol::codec;
use keypose::bus::protocol::packet::{Decoded, Direction};
use keypose::testing::VirtualServos;
use keypose_fuzz::{builtin_robot, Choices};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut choices = Choices::new(data);
    let robot = builtin_robot(choices.byte());
    let framing = codec(robot.bus.protocol).framing();
    let mut servos = VirtualServos::for_robot(robot);
    let ids: Vec<u8> = robot.joints.iter().map(|j| j.servo.id).collect();
    // The rest in chunks: a length byte, then that many bytes.
    while !choices.is_empty() {
        let length = usize::from(choices.byte());
        for (_, answer) in servos.handle(choices.take(length)) {
            let mut bytes = answer.clone();
            match framing.decode(&mut bytes, Direction::FromServo) {
                Ok(Decoded::Packet(packet)) => {
                    assert!(
                        ids.contains(&packet.id) || packet.id == framing.broadcast_id(),
                        "answer from id {} ({answer:02x?})",
                        packet.id
                    );
                    assert!(bytes.is_empty(), "{answer:02x?} is more than one packet");
                }
                other => panic!("answer {answer:02x?} decodes as {other:?}"),
            }
        }
    }
});
