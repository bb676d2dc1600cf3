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
    // A timeout, or on a loaded machine the same told with the starvation seen.
    let error = bus.ping(9).unwrap_err();
    assert!(error.is_no_answer() && error.servo() == Some(9), "{error}");
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

/// The SO-101's driver over an in-memory line that delivers each answer when it is due, as a
/// shared line does (a servo's late answer comes after other servos' answers to later
/// requests), with servo `late_id`'s answers `late` late.
fn so101_with_a_late_servo(late_id: u8, late: Duration) -> (NativeBus, VirtualBus, Vec<u8>) {
    use crate::bus::virtual_bus::ServoFault;
    let (robot, servos, ids) = builtin("so101");
    let virtual_bus = VirtualBus::new(VirtualServos::for_robot(&robot));
    virtual_bus
        .lock()
        .set_fault(late_id, Some(ServoFault::Late(late)));
    let transport = MemoryTransport::as_due(virtual_bus.clone());
    let bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
    (bus, virtual_bus, ids)
}

#[test]
fn a_servo_answering_later_than_the_timeout_is_never_read_as_present() {
    // Servo 4 answers 300 ms late, beyond the 200 ms timeout outside a control loop: every
    // answer it gives belongs
    // to a request at least 300 ms old. Without telling answers apart, the late answer to an
    // earlier read lands while a later read waits for servo 4, and is taken for the present.
    // Servo 4 is moved by hand before every read, so an answer says which read it belongs to.
    // Its own answer may still come in as the present one: when this thread does not run for
    // the 300 ms (a loaded machine), the answer to the present read is due by the time it
    // looks. What must never happen is an older read's answer taken for the present.
    let (mut bus, servos, ids) = so101_with_a_late_servo(4, Duration::from_millis(300));
    let at = ids.iter().position(|&id| id == 4).unwrap();
    let mut stale = 0;
    for read in 0..12 {
        let present = 1000 + 10 * read;
        servos.lock().servo_mut(4).unwrap().push_to(present as f64);
        match bus.read_positions(&ids) {
            Ok(ticks) => assert_eq!(
                ticks[at], present,
                "read {read} took a late answer for the present: {ticks:?}"
            ),
            Err(BusError::Stale { id, late_ms, .. }) => {
                // Servos 5 and 6 answer after servo 4 on the line: late with it.
                assert!((4..=6).contains(&id), "servo {id}");
                assert!(late_ms >= 40, "{late_ms} ms");
                stale += 1;
            }
            Err(BusError::Timeout { id, .. } | BusError::Starved { id, .. }) => assert_eq!(id, 4),
            Err(other) => panic!("read {read}: {other}"),
        }
    }
    assert!(stale > 0, "the lateness was never named");
}

#[test]
fn a_servo_that_answers_in_time_again_is_read_again() {
    let late = Duration::from_millis(300);
    let (mut bus, virtual_bus, ids) = so101_with_a_late_servo(4, late);
    // In a control loop's 40 ms timeout: three attempts are over long before the first late
    // answer comes, even when this thread is starved for a while on a loaded machine.
    bus.pace(Some(Duration::from_millis(10)));
    assert!(bus.read_positions(&ids).is_err());
    virtual_bus.lock().set_fault(4, None);
    // Its late answers arrive meanwhile, in order; each is known for what it is, and the next
    // read, answered in time, is read.
    std::thread::sleep(2 * late);
    let home = home_ticks(&Robot::builtin("so101").unwrap());
    assert_eq!(bus.read_positions(&ids).unwrap(), home);
}

/// A transport whose next wait ends `by` after its deadline: the thread was not scheduled (as on
/// an overloaded machine), whatever the line did meanwhile.
struct Starving<T: crate::bus::transport::Transport> {
    inner: T,
    by: Option<Duration>,
}

impl<T: crate::bus::transport::Transport> crate::bus::transport::Transport for Starving<T> {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.inner.write_all(bytes)
    }
    fn read_until(&mut self, buf: &mut [u8], deadline: Instant) -> std::io::Result<usize> {
        if let Some(by) = self.by.take() {
            let wake = deadline + by;
            while Instant::now() < wake {
                std::thread::sleep(wake - Instant::now());
            }
        }
        self.inner.read_until(buf, deadline)
    }
    fn discard_input(&mut self) -> std::io::Result<()> {
        self.inner.discard_input()
    }
}

#[test]
fn a_wait_keypose_overslept_is_given_again_and_told_as_starvation() {
    use crate::bus::virtual_bus::ServoFault;
    let (robot, servos, _) = builtin("so101");
    let starved = |fault: ServoFault| {
        let virtual_bus = VirtualBus::new(VirtualServos::for_robot(&robot));
        virtual_bus.lock().set_fault(4, Some(fault));
        let transport = Starving {
            inner: MemoryTransport::as_due(virtual_bus),
            by: Some(Duration::from_millis(30)),
        };
        let mut bus = NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
        bus.read_retries = 0;
        bus
    };
    // The wait for servo 4 ends 30 ms past its deadline; its answer (the emulated bus starved
    // with the process) comes 100 ms after the request, within the wait given again.
    let mut bus = starved(ServoFault::Late(Duration::from_millis(100)));
    assert_eq!(
        bus.read_positions(&[4]).unwrap(),
        vec![home_ticks(&robot)[3]],
        "an overslept wait was taken for silence"
    );
    // Nothing comes at all: a timeout, said with the starvation seen.
    let mut bus = starved(ServoFault::NoAnswer);
    match bus.read_positions(&[4]) {
        Err(BusError::Starved {
            id: 4, starved_ms, ..
        }) => assert!(starved_ms >= 30, "{starved_ms} ms"),
        other => panic!("expected starvation to be told, got {other:?}"),
    }
}

/// A line that loses the status answers to WRITE instructions, once each servo has taken the
/// write (`taken`) or before it reaches the servo (not `taken`); every other answer comes.
struct LosesWriteAnswers {
    bus: VirtualBus,
    codec: &'static dyn Codec,
    taken: bool,
}

impl Responder for LosesWriteAnswers {
    fn respond(&mut self, written: &[u8]) -> Vec<(Duration, Vec<u8>)> {
        let mut bytes = written.to_vec();
        let instruction = match self.codec.framing().decode(&mut bytes, Direction::ToServo) {
            Ok(Decoded::Packet(packet)) => packet.instruction_code(),
            _ => None,
        };
        if instruction != Some(self.codec.instructions().write) {
            return self.bus.lock().handle(written);
        }
        if self.taken {
            self.bus.lock().handle(written);
        }
        Vec::new()
    }
}

#[test]
fn a_torque_write_whose_answer_is_lost_is_confirmed_by_reading_it_back() {
    for name in ["so101", "koch"] {
        let (robot, servos, ids) = builtin(name);
        let connect = |taken: bool| {
            let bus = VirtualBus::new(VirtualServos::for_robot(&robot));
            let responder = LosesWriteAnswers {
                bus: bus.clone(),
                codec: codec(robot.bus.protocol),
                taken,
            };
            let transport = MemoryTransport::new(responder);
            let driver = NativeBus::new(Box::new(transport), robot.bus.protocol, &servos);
            (driver, bus)
        };
        let torque = |bus: &VirtualBus| -> Vec<bool> {
            let mut servos = bus.lock();
            ids.iter()
                .map(|&id| servos.servo_mut(id).unwrap().motion.torque)
                .collect()
        };
        // Every servo took the write; no answer said so, the registers do.
        let (mut driver, bus) = connect(true);
        driver.set_torque(&ids, true).unwrap();
        assert_eq!(torque(&bus), vec![true; ids.len()], "{name}");
        // The writes were lost: the read-back shows torque still off, and the write's own
        // missing answer is the error, naming the first servo (a timeout; on a machine so
        // busy that the wait itself was starved of CPU, the starvation that says so).
        let (mut driver, bus) = connect(false);
        match driver.set_torque(&ids, true) {
            Err(e @ (BusError::Timeout { .. } | BusError::Starved { .. })) => {
                assert_eq!(e.servo(), Some(ids[0]), "{name}")
            }
            other => panic!("{name}: expected the write's timeout, got {other:?}"),
        }
        assert_eq!(torque(&bus), vec![false; ids.len()], "{name}");
    }
}

#[test]
fn outside_a_control_loop_an_answer_is_waited_for_longer_than_inside_one() {
    // Servo 4 answers 100 ms late: more than a control loop's 40 ms, less than the 200 ms a
    // one-off exchange waits.
    let (mut bus, servos, ids) = so101_with_a_late_servo(4, Duration::from_millis(100));
    servos.lock().servo_mut(4).unwrap().push_to(1234.0);
    let at = ids.iter().position(|&id| id == 4).unwrap();
    assert_eq!(bus.read_positions(&ids).unwrap()[at], 1234);
    bus.pace(Some(Duration::from_millis(10)));
    let error = bus.read_positions(&ids).unwrap_err();
    assert!(error.is_no_answer(), "{error}");
    bus.pace(None);
    // The late answers of the paced read are skipped by their length; this one is waited for.
    servos.lock().servo_mut(4).unwrap().push_to(1300.0);
    assert_eq!(bus.read_positions(&ids).unwrap()[at], 1300);
}
