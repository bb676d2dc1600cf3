//! The driver against emulated servos behind echoing, late and stale adapters.

use super::*;
use crate::bus::transport::{MemoryTransport, Responder};
use crate::bus::virtual_bus::{VirtualBus, VirtualServos};
use crate::robot::Robot;

/// A half-duplex line that hears its own transmission: every packet comes back first.
struct Echoing(VirtualBus);

impl Responder for Echoing {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let mut out = vec![(Duration::ZERO, written.to_vec())];
        out.extend(self.0.lock().handle(written));
        out
    }
}

/// Before every answer, a late answer of servo `id` to an earlier request: a status packet
/// with 3 data bytes, a length no position read asks for. With `answer` false, only that.
struct LateAnswerFirst {
    bus: VirtualBus,
    codec: &'static dyn Codec,
    id: u8,
    answer: bool,
}

impl Responder for LateAnswerFirst {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let stale = self.codec.framing().encode_status(self.id, 0, &[0x11; 3]);
        let mut out = vec![(Duration::ZERO, stale)];
        let answers = self.bus.lock().handle(written);
        if self.answer {
            out.extend(answers);
        }
        out
    }
}

/// An echoing adapter whose echo arrives late: the echo of a packet that gets no answer (a
/// sync write) reaches the host only after the driver has flushed its input for the next
/// packet, so it arrives right before that packet's own echo and answer.
struct LateEcho {
    bus: VirtualBus,
    late: Option<Vec<u8>>,
}

impl Responder for LateEcho {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let mut out: Vec<(Duration, Vec<u8>)> = self
            .late
            .take()
            .map(|echo| (Duration::ZERO, echo))
            .into_iter()
            .collect();
        let answers = self.bus.lock().handle(written);
        if answers.is_empty() {
            self.late = Some(written.to_vec());
        } else {
            out.push((Duration::ZERO, written.to_vec()));
            out.extend(answers);
        }
        out
    }
}

/// A built-in robot, its servos and their ids.
fn builtin(name: &str) -> (Robot, Vec<(u8, ServoModel)>, Vec<u8>) {
    let robot = Robot::builtin(name).unwrap();
    let servos = robot.servos();
    let ids = servos.iter().map(|(id, _)| *id).collect();
    (robot, servos, ids)
}

/// The ticks of the robot's home pose, where the emulated servos rest.
fn home_ticks(robot: &Robot) -> Vec<i64> {
    robot
        .joints
        .iter()
        .zip(&robot.home)
        .map(|(j, h)| j.servo.tick(*h).unwrap())
        .collect()
}

#[test]
fn a_late_echo_of_a_sync_write_is_not_taken_for_a_status() {
    for name in ["so101", "koch"] {
        let (robot, servos, ids) = builtin(name);
        let responder = LateEcho {
            bus: VirtualBus::new(VirtualServos::for_robot(&robot)),
            late: None,
        };
        let mut bus = NativeBus::new(
            Box::new(MemoryTransport::new(responder)),
            robot.bus.protocol,
            &servos,
        );
        // What `torque on` does: read, hold where the arm is, then one WRITE per servo.
        // Without matching, the STS WRITE echo (FF FF 01 04 03 28 01 CE) behind the late
        // sync-write echo reads as a status with error byte 0x03: voltage + angle sensor.
        let ticks = bus.read_positions(&ids).unwrap();
        let goals: Vec<(u8, i64)> = ids.iter().copied().zip(ticks).collect();
        bus.write_goals(&goals).unwrap();
        bus.set_torque(&ids, true).unwrap();
        bus.write_goals(&goals).unwrap();
        assert_eq!(
            bus.read_positions(&ids).unwrap(),
            goals.iter().map(|g| g.1).collect::<Vec<_>>(),
            "{name}"
        );
        bus.write_goals(&goals).unwrap();
        assert!(bus.ping(ids[0]).is_ok(), "{name}");
    }
}

#[test]
fn a_ping_answer_equal_to_the_ping_is_an_answer_not_an_echo() {
    let robot = Robot::builtin("so101").unwrap();
    let (mut bus, virtual_bus) = VirtualBus::in_process(&robot);
    let voltage = Alarms {
        input_voltage: true,
        ..Alarms::default()
    };
    virtual_bus
        .lock()
        .set_fault(1, Some(crate::bus::virtual_bus::ServoFault::Alarm(voltage)));
    // STS PING to id 1: FF FF 01 02 01 FB. A status from id 1 with error byte 0x01 (input
    // voltage, Feetech protocol manual) and no data is the same six bytes.
    let ping = [0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB];
    assert_eq!(
        virtual_bus.lock().handle(&ping),
        vec![(Duration::ZERO, ping.to_vec())]
    );
    let info = bus.ping(1).unwrap();
    assert_eq!((info.id, info.model_number), (1, 777));
    assert_eq!(info.alarms, voltage);
}

#[test]
fn an_echoing_adapter_without_a_servo_times_out() {
    let robot = Robot::builtin("so101").unwrap();
    let servos: Vec<_> = robot.servos();
    let virtual_bus = VirtualBus::new(VirtualServos::for_robot(&robot));
    let transport = MemoryTransport::new(Echoing(virtual_bus));
    let mut bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
    // Id 9 is not on the bus: only the ping's own echo comes back.
    assert!(matches!(bus.ping(9), Err(BusError::Timeout { id: 9, .. })));
}

#[test]
fn a_late_answer_to_an_earlier_request_is_skipped_by_its_length() {
    for name in ["so101", "koch"] {
        let (robot, servos, ids) = builtin(name);
        let connect = |answer: bool| {
            let responder = LateAnswerFirst {
                bus: VirtualBus::new(VirtualServos::for_robot(&robot)),
                codec: codec(robot.bus.protocol),
                id: ids[0],
                answer,
            };
            let transport = MemoryTransport::new(responder);
            NativeBus::new(Box::new(transport), robot.bus.protocol, &servos)
        };
        let home = home_ticks(&robot);
        assert_eq!(connect(true).read_positions(&ids).unwrap(), home, "{name}");
        // Nothing but the late answer: reported as what it is, not as a silent timeout.
        match connect(false).read_positions(&ids) {
            Err(BusError::Corrupt { id, source }) => {
                let detail = source.to_string();
                assert_eq!(id, ids[0], "{name}");
                assert!(detail.contains("3 data bytes"), "{name}: {detail}");
            }
            other => panic!("{name}: expected a corrupt answer, got {other:?}"),
        }
    }
}

fn koch_in_process() -> (NativeBus, VirtualBus, Vec<u8>) {
    let robot = Robot::builtin("koch").unwrap();
    let (bus, virtual_bus) = VirtualBus::in_process(&robot);
    let ids = robot.joints.iter().map(|j| j.servo.id).collect();
    (bus, virtual_bus, ids)
}

#[test]
fn fast_sync_read_reads_what_sync_read_reads() {
    let (mut bus, virtual_bus, ids) = koch_in_process();
    virtual_bus
        .lock()
        .servo_mut(4)
        .unwrap()
        .motion
        .push_to(1000.0);
    let slow = bus.read_positions(&ids).unwrap();
    bus.fast_sync_read = true;
    let fast = bus.read_positions(&ids).unwrap();
    assert_eq!(slow, fast);
    assert_eq!(fast[3], 1000);
    let last = virtual_bus.lock().received.last().cloned().unwrap();
    assert_eq!(
        last.instruction_code(),
        Some(crate::bus::protocol::dynamixel::FAST_SYNC_READ)
    );
}

#[test]
fn reboot_clears_a_shutdown() {
    use crate::bus::virtual_bus::ServoFault;
    let (mut bus, virtual_bus, ids) = koch_in_process();
    let overheating = Alarms {
        overheating: true,
        ..Alarms::default()
    };
    virtual_bus
        .lock()
        .set_fault(3, Some(ServoFault::Alarm(overheating)));
    match bus.read_positions(&ids) {
        Err(BusError::Alarm { id: 3, alarms }) => assert!(alarms.overheating),
        other => panic!("expected the alarm, got {other:?}"),
    }
    bus.reboot(3).unwrap();
    assert!(bus.read_positions(&ids).is_ok());
}

#[test]
fn an_echoing_adapter_is_heard_through() {
    for name in ["so101", "koch"] {
        let (robot, servos, ids) = builtin(name);
        let virtual_bus = VirtualBus::new(VirtualServos::for_robot(&robot));
        let transport = MemoryTransport::new(Echoing(virtual_bus));
        let mut bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
        // Without echo handling the STS READ echo would read as an angle-sensor alarm.
        let info = bus.ping(ids[0]).unwrap();
        assert_eq!(info.id, ids[0]);
        let positions = bus.read_positions(&ids).unwrap();
        let home = home_ticks(&robot);
        assert_eq!(positions, home, "{name}");
        bus.set_torque(&ids, true).unwrap();
        assert!(bus
            .read_health(&ids)
            .unwrap()
            .iter()
            .all(|h| !h.alarms.any()));
    }
}
