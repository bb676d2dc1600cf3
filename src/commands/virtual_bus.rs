//! `keypose virtual-bus`: emulated servos on a pseudo-terminal, with injected faults, homing
//! offsets and a hand that moves the arm.

use super::{option_values, CommandError, Verdict};
use keypose::bus;
use keypose::robot::Robot;
use std::io::BufRead;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct VirtualBusArgs {
    /// The robot whose servos to emulate (a built-in name or a robot file).
    #[arg(long, value_name = "NAME|FILE")]
    pub robot: String,
    /// Inject a fault: ID:no-answer, ID:corrupt, ID:late=MS, ID:overload, ID:overheating,
    /// ID:voltage, ID:encoder, ID:electrical; or "gone" (the port disappears). Repeatable.
    #[arg(long, value_name = "FAULT", value_parser = parse_fault)]
    pub fault: Vec<FaultSpec>,
    /// Set a servo's Homing_Offset register (as a calibration tool would): ID:TICKS.
    /// Repeatable.
    #[arg(long, value_name = "ID:TICKS", value_parser = parse_homing_offset)]
    pub homing_offset: Vec<(u8, i64)>,
    /// Seconds after start at which the faults take effect.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = option_values::parse_fault_after, allow_negative_numbers = true)]
    pub fault_after: f64,
    /// A hand that moves the arm along this sequence (for the emulated robot) once a servo is
    /// told to go limp, as a user would for `keypose record`; servos with torque on resist it.
    /// With --physics the hand pulls the arm's links towards the path, a firm grip of bounded
    /// force, instead of setting the shafts.
    #[arg(long, value_name = "SEQ")]
    pub hand: Option<PathBuf>,
    /// The baud rate whose wire time to take [default: the robot's].
    #[arg(long, value_name = "BPS", value_parser = option_values::parse_baud, allow_negative_numbers = true)]
    pub baud: Option<u32>,
    #[command(flatten)]
    pub wire: super::WireArgs,
    #[command(flatten)]
    pub physics: super::PhysicsArgs,
}

/// A fault for the virtual bus, from the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultSpec {
    Servo(u8, keypose::testing::ServoFault),
    PortGone,
}

fn parse_fault(s: &str) -> Result<FaultSpec, String> {
    use keypose::testing::ServoFault;
    if s == "gone" {
        return Ok(FaultSpec::PortGone);
    }
    let expected = || {
        format!(
            "expected ID:KIND (KIND: no-answer, corrupt, late=MS, overload, overheating, voltage, encoder, electrical) or \"gone\", found {s:?}"
        )
    };
    let (id, kind) = s.split_once(':').ok_or_else(expected)?;
    let id: u8 = id.parse().map_err(|_| expected())?;
    let alarm = |set: fn(&mut bus::Alarms)| {
        let mut alarms = bus::Alarms::default();
        set(&mut alarms);
        ServoFault::Alarm(alarms)
    };
    let fault = match kind {
        "no-answer" => ServoFault::NoAnswer,
        "corrupt" => ServoFault::CorruptChecksum,
        "overload" => alarm(|a| a.overload = true),
        "overheating" => alarm(|a| a.overheating = true),
        "voltage" => alarm(|a| a.input_voltage = true),
        "encoder" => alarm(|a| a.encoder = true),
        "electrical" => alarm(|a| a.electrical = true),
        late => {
            let ms = late.strip_prefix("late=").ok_or_else(expected)?;
            let ms = option_values::integer_in(
                ms,
                0..=option_values::MAX_LATE_MS,
                "late=MS: milliseconds",
            )?;
            ServoFault::Late(std::time::Duration::from_millis(ms))
        }
    };
    Ok(FaultSpec::Servo(id, fault))
}

fn parse_homing_offset(s: &str) -> Result<(u8, i64), String> {
    let expected = || format!("expected ID:TICKS (e.g. 3:-1024), found {s:?}");
    let (id, ticks) = s.split_once(':').ok_or_else(expected)?;
    Ok((
        id.parse().map_err(|_| expected())?,
        ticks.parse().map_err(|_| expected())?,
    ))
}

/// A hand moving every servo of `robot` along `trajectory` (from its start, in sequence time).
fn start_hand(
    bus: &keypose::testing::VirtualBus,
    robot: &Robot,
    trajectory: keypose::plan::Trajectory,
) -> keypose::testing::Hand {
    let ids = robot.joints.iter().map(|j| j.servo.id).collect();
    let servos: Vec<_> = robot.joints.iter().map(|j| j.servo.clone()).collect();
    let start = trajectory.start();
    let duration = trajectory.duration();
    let mut values = vec![0.0; servos.len()];
    let path = move |t: f64, ticks: &mut [f64]| {
        trajectory.sample_into(start + t, &mut values);
        for ((tick, servo), &value) in ticks.iter_mut().zip(&servos).zip(&values) {
            *tick = servo.tick_exact(value);
        }
    };
    keypose::testing::Hand::start(bus.clone(), ids, duration, Box::new(path))
}

/// `keypose virtual-bus`: emulated servos on a pseudo-terminal; the device path is the first
/// line printed; serves until standard input closes or the process is terminated.
pub fn run(args: &VirtualBusArgs) -> Result<Verdict, CommandError> {
    let robot = super::load_robot(&args.robot, &super::CalibrationArgs::default())?;
    check_fault_ids(&robot, &args.fault)?;
    let wire = args.wire.timing(args.baud.unwrap_or(robot.bus.baud));
    let hand_trajectory = match &args.hand {
        Some(path) => {
            let sequence = keypose::sequence::Sequence::load(path)?;
            Some(keypose::plan::Trajectory::build(&sequence, &robot)?)
        }
        None => None,
    };
    let server = match args.physics.source()? {
        Some(physics) => physics.serve(&robot, wire)?,
        None => keypose::testing::PtyServer::start_timed(&robot, wire)?,
    };
    set_homing_offsets(&server, &robot, &args.homing_offset)?;
    let hand = hand_trajectory.map(|trajectory| start_hand(server.bus(), &robot, trajectory));
    println!("{}", server.path());
    // Flush now: the parent reads the path to connect while this process keeps running.
    let _ = std::io::Write::flush(&mut std::io::stdout());
    if !args.fault.is_empty() {
        inject_faults_after(&server, args.fault.clone(), args.fault_after);
    }
    let ended = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|scope| {
        if let Some(hand) = &hand {
            scope.spawn(|| say_when_the_hand_starts(hand, &ended));
        }
        wait_for_the_end();
        ended.store(true, std::sync::atomic::Ordering::SeqCst);
    });
    drop(hand);
    if let Some(cost) = server.bus().lock().physics_cost() {
        eprintln!(
            "virtual-bus: the physics took {:.1} ms of processor time per simulated second",
            cost * 1000.0
        );
    }
    drop(server);
    Ok(Verdict::Pass)
}

/// Says on standard error when the hand began to move, in milliseconds since 1970 (the wall
/// clock other programs share): a test times what a browser shows of the motion against it.
fn say_when_the_hand_starts(hand: &keypose::testing::Hand, ended: &std::sync::atomic::AtomicBool) {
    while !ended.load(std::sync::atomic::Ordering::SeqCst) {
        if let Some(at) = hand.started_at() {
            let ms = at.duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
            eprintln!(
                "virtual-bus: the hand moves from {} ms (since 1970)",
                ms.as_millis()
            );
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// Refuses a fault for a servo the robot does not have, before anything starts.
fn check_fault_ids(robot: &Robot, faults: &[FaultSpec]) -> Result<(), CommandError> {
    for fault in faults {
        if let FaultSpec::Servo(id, _) = fault {
            if !robot.joints.iter().any(|j| j.servo.id == *id) {
                return Err(CommandError::Usage(format!(
                    "--fault: {} has no servo {id}",
                    robot.name
                )));
            }
        }
    }
    Ok(())
}

fn set_homing_offsets(
    server: &keypose::testing::PtyServer,
    robot: &Robot,
    offsets: &[(u8, i64)],
) -> Result<(), CommandError> {
    for &(id, ticks) in offsets {
        let set = match server.bus().lock().servo_mut(id) {
            Some(servo) => servo.set_homing_offset(ticks),
            None => {
                return Err(CommandError::Usage(format!(
                    "--homing-offset: {} has no servo {id}",
                    robot.name
                )))
            }
        };
        if set.is_err() {
            return Err(CommandError::Usage(format!(
                "--homing-offset: servo {id} of {} has no Homing_Offset register",
                robot.name
            )));
        }
    }
    Ok(())
}

/// Sets the faults `seconds` from now, on a thread of their own so that serving goes on.
fn inject_faults_after(server: &keypose::testing::PtyServer, faults: Vec<FaultSpec>, seconds: f64) {
    let virtual_bus = server.bus().clone();
    let delay = std::time::Duration::from_secs_f64(seconds);
    std::thread::spawn(move || {
        std::thread::sleep(delay);
        let mut servos = virtual_bus.lock();
        for fault in faults {
            match fault {
                FaultSpec::Servo(id, f) => servos.set_fault(id, Some(f)),
                FaultSpec::PortGone => servos.connected = false,
            }
        }
    });
}

/// Blocks until standard input closes (the parent went away) or a signal arrives: both are a
/// stop request, which wakes this thread (it does not look on a timer, which would cost the
/// emulator's process a wake-up every few milliseconds).
fn wait_for_the_end() {
    let stop = keypose::stop::stop_on_signal();
    let closed = stop.clone();
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        for line in stdin.lock().lines() {
            if line.is_err() {
                break;
            }
        }
        closed.request();
    });
    while stop.wait_for(std::time::Duration::from_secs(3600), 0) == 0 {}
}
