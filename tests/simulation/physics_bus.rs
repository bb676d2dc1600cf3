//! Emulated servos that carry the arm (`virtual-bus --physics`): the servos' registers and
//! firmware in keypose, the arm in MuJoCo. Each test judges what the servos report against
//! physics worked out apart from the emulator: a free pendulum's fall, a spring's droop under
//! the link's weight, the vendor's protection time, the table's height.
//!
//! The physics keeps the bus's clock, so however late a busy machine lets the test read, each
//! reading is the arm at the moment the physics reached (`physics_time`), and the oracles are
//! evaluated at those moments.

use keypose::dynamics::Dynamics;
use keypose::robot::Robot;
use keypose::sim::MujocoArm;
use keypose::testing::{VirtualServo, VirtualServos};
use std::path::Path;
use std::time::Duration;

fn so101_at(home: &[f64]) -> Robot {
    let mut robot = Robot::builtin("so101").unwrap();
    robot.home = home.to_vec();
    robot
}

fn physical(robot: &Robot, scene: Option<&Path>) -> VirtualServos {
    let arm = MujocoArm::start(robot, scene).expect("MuJoCo starts with the robot's model");
    VirtualServos::with_physics(robot, Box::new(arm)).expect("every SO-101 servo is rated")
}

fn index(robot: &Robot, joint: &str) -> usize {
    robot.joints.iter().position(|j| j.name == joint).unwrap()
}

/// Joint values the servos report now, and the physics' time of them.
fn pose(robot: &Robot, servos: &mut VirtualServos) -> (f64, Vec<f64>) {
    servos.advance_physics();
    values_now(robot, servos)
}

/// Joint values the servos report at `t` seconds of the physics' clock: waits until then,
/// however late this thread runs.
fn pose_at(robot: &Robot, servos: &mut VirtualServos, t: f64) -> Vec<f64> {
    while servos.physics_time().unwrap() < t - 1e-9 {
        std::thread::sleep(Duration::from_millis(5));
        servos.advance_physics_to(t);
    }
    values_now(robot, servos).1
}

fn values_now(robot: &Robot, servos: &mut VirtualServos) -> (f64, Vec<f64>) {
    let time = servos.physics_time().unwrap();
    let values = robot
        .joints
        .iter()
        .zip(servos.servos.iter_mut())
        .map(|(joint, servo)| joint.servo.value_exact(servo.present_position()))
        .collect();
    (time, values)
}

/// Torque on, holding `goal` (joint value); an STS3215 with LeRobot's P coefficient of 16, for
/// which its stiffness is rated (an X series servo keeps its factory gain, its rating's).
fn hold(robot: &Robot, servo: &mut VirtualServo, joint: usize, goal: f64) {
    if servo.model.spec().item("P_Coefficient").is_some() {
        servo.set("P_Coefficient", 16).unwrap();
    }
    let tick = robot.joints[joint].servo.tick(goal).unwrap();
    // Torque on holds where the shaft is; the goal after.
    servo.set("Torque_Enable", 1).unwrap();
    servo.set("Goal_Position", tick).unwrap();
}

/// The limp joint's angle (degrees) `times` seconds after it was let go at rest at `start`,
/// the rest of the arm held still: M(q)·q̈ = −G(q) − f·sign(q̇), with M and G from keypose's
/// inverse dynamics (itself checked against MuJoCo's mj_inverse, tests/simulation/dynamics.rs)
/// and f the servo's rated gear friction, integrated with RK4 at 0.1 ms.
fn free_fall(robot: &Robot, start: &[f64], joint: usize, times: &[f64]) -> Vec<f64> {
    let dynamics = Dynamics::for_robot(robot).unwrap();
    let friction = robot.joints[joint].servo.drive().unwrap().friction.value;
    let rest = vec![0.0; start.len()];
    let acceleration = |q: f64, qd: f64| -> f64 {
        let mut values = start.to_vec();
        values[joint] = q;
        let gravity = dynamics.joint_forces(&values, &rest, &rest)[joint];
        let mut unit = rest.clone();
        unit[joint] = 1.0;
        // N·m per degree/s² of this joint alone.
        let inertia = dynamics.joint_forces(&values, &rest, &unit)[joint] - gravity;
        let resisting = if qd.abs() > 1e-9 {
            friction * qd.signum()
        } else if gravity.abs() > friction {
            -friction * gravity.signum()
        } else {
            -gravity
        };
        -(gravity + resisting) / inertia
    };
    let (mut q, mut qd, mut t) = (start[joint], 0.0, 0.0);
    let h = 1e-4;
    times
        .iter()
        .map(|&until| {
            while t < until {
                let k1 = (qd, acceleration(q, qd));
                let k2 = (
                    qd + 0.5 * h * k1.1,
                    acceleration(q + 0.5 * h * k1.0, qd + 0.5 * h * k1.1),
                );
                let k3 = (
                    qd + 0.5 * h * k2.1,
                    acceleration(q + 0.5 * h * k2.0, qd + 0.5 * h * k2.1),
                );
                let k4 = (qd + h * k3.1, acceleration(q + h * k3.0, qd + h * k3.1));
                q += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
                qd += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
                t += h;
            }
            q
        })
        .collect()
}

#[test]
fn a_limp_shoulder_falls_as_the_free_link_does() {
    // The arm stretched out and raised a little, clear of the table: let go, the shoulder
    // swings down with the whole arm's weight on it.
    let start = [0.0, -10.0, 0.0, 0.0, 0.0, 10.0];
    let robot = so101_at(&start);
    let mut servos = physical(&robot, None);
    let lift = index(&robot, "shoulder_lift");
    for (j, servo) in servos.servos.iter_mut().enumerate() {
        if j != lift {
            hold(&robot, servo, j, start[j]);
        }
    }
    // Every 25 ms of the physics' clock to 0.35 s, each sample of its moment however late
    // this thread runs.
    let times: Vec<f64> = (1..=14).map(|k| k as f64 * 0.025).collect();
    let samples: Vec<(f64, f64)> = times
        .iter()
        .map(|&t| (t, pose_at(&robot, &mut servos, t)[lift]))
        .collect();
    let expected = free_fall(&robot, &start, lift, &times);
    let mut worst: f64 = 0.0;
    for ((t, measured), expected) in samples.iter().zip(&expected) {
        let fallen = expected - start[lift];
        println!(
            "t {t:.3} s: fell {:.2} deg, free fall {fallen:.2} deg",
            measured - start[lift]
        );
        // The first degrees are the held joints' springs settling under the swing.
        if fallen.abs() > 5.0 {
            worst = worst.max(((measured - start[lift]) / fallen - 1.0).abs());
        }
    }
    let last_fallen = expected.last().unwrap() - start[lift];
    assert!(
        last_fallen.abs() > 5.0,
        "the link should have fallen by now: {samples:?}"
    );
    // The held joints give a little under the swing (their servos are springs, the gear's
    // friction MuJoCo's soft constraint), which the rigid oracle does not: 10 %.
    assert!(
        worst < 0.10,
        "fall differs from the free link's by {:.1} %",
        worst * 100.0
    );
}

/// Holds every joint at `start` (ticks rounded as the goal is written) for `seconds`; the
/// goals held, in joint values.
fn hold_all(robot: &Robot, servos: &mut VirtualServos, start: &[f64], seconds: f64) -> Vec<f64> {
    for (j, servo) in servos.servos.iter_mut().enumerate() {
        hold(robot, servo, j, start[j]);
    }
    settle(robot, servos, seconds);
    robot
        .joints
        .iter()
        .zip(start)
        .map(|(joint, &v)| joint.servo.value(joint.servo.tick(v).unwrap()))
        .collect()
}

/// Lets the physics run for `seconds` of its clock, read every 20 ms or so.
fn settle(robot: &Robot, servos: &mut VirtualServos, seconds: f64) {
    let until = servos.physics_time().unwrap() + seconds;
    while pose(robot, servos).0 < until {
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_held_pose_droops_by_its_weight_over_the_servos_stiffness() {
    // The SO-101 stretched out level (the heaviest load its shoulder and elbow hold); the Koch
    // and the OpenMANIPULATOR-X at their zero pose. Each on its own servos: STS3215 at 5 V,
    // XL430 / XL330 at 12 / 5 V, XM430 at 12 V.
    for (name, start) in [
        ("so101", vec![0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
        ("koch", vec![0.0; 6]),
        ("omx", vec![0.0; 5]),
    ] {
        let mut robot = Robot::builtin(name).unwrap();
        robot.home = start.clone();
        let mut servos = physical(&robot, None);
        let goals = hold_all(&robot, &mut servos, &start, 1.5);
        let (_, measured) = pose(&robot, &mut servos);
        let dynamics = Dynamics::for_robot(&robot).unwrap();
        let holding = dynamics.holding_torques(&measured);
        let mut loaded = 0;
        for (j, joint) in robot.joints.iter().enumerate() {
            let drive = joint.servo.drive().unwrap();
            let (k, friction) = (drive.stiffness.value, drive.friction.value);
            // The servo's spring k·(goal − q) carries the weight at q, the gear's friction
            // taking up to f of it either way.
            let droop = (measured[j] - goals[j]).to_radians();
            let predicted = -holding[j] / k;
            println!(
                "{name} {}: droops {:.3} deg, weight over stiffness {:.3} deg",
                joint.name,
                droop.to_degrees(),
                predicted.to_degrees()
            );
            assert!(
                (droop - predicted).abs() <= 0.10 * predicted.abs() + friction / k + 1e-3,
                "{name} {}: droop {:.3} deg, predicted {:.3} deg",
                joint.name,
                droop.to_degrees(),
                predicted.to_degrees()
            );
            if predicted.abs() > 2.0 * friction / k {
                loaded += 1;
            }
        }
        assert!(loaded >= 2, "{name}: at least two joints carry weight here");
    }
}

#[test]
fn an_arm_driven_into_the_table_stops_at_the_table() {
    let start = [0.0, 0.0, 0.0, 0.0, 0.0, 10.0];
    let robot = so101_at(&start);
    // Shoulder down until the tool point is 8 cm under the table top.
    let mut goal = start;
    let lift = index(&robot, "shoulder_lift");
    while keypose::kinematics::lowest_below_floor(&robot, &goal).is_none_or(|(_, d)| d < 0.08) {
        goal[lift] += 1.0;
    }
    let mut servos = physical(&robot, None);
    hold_all(&robot, &mut servos, &start, 0.3);
    hold(&robot, &mut servos.servos[lift], lift, goal[lift]);
    // Read for 1.2 s, while the servo pushes; the deepest and the hardest seen. (Its 2 s
    // protection time would unload it later: the gripper's test.)
    let until = servos.physics_time().unwrap() + 1.2;
    let (mut depth, mut load) = (0.0_f64, 0_i64);
    let measured = loop {
        std::thread::sleep(Duration::from_millis(20));
        let (t, values) = pose(&robot, &mut servos);
        let below =
            keypose::kinematics::lowest_below_floor(&robot, &values).map_or(0.0, |(_, d)| d);
        depth = depth.max(below);
        if servos.servos[lift].value("Status") == 0 {
            load = load.max(servos.servos[lift].value("Present_Load").abs());
        }
        if t >= until {
            break values;
        }
    };
    println!(
        "goal shoulder_lift {:.1} deg, stopped at {:.1} deg, {:.1} mm under the table top at most, load {load}",
        goal[lift], measured[lift], depth * 1000.0
    );
    // The tool point is a few millimetres inside the jaw's capsule: at the table, not under it.
    assert!(
        depth < 0.01,
        "the arm went {:.1} mm into the table",
        depth * 1000.0
    );
    assert!(
        goal[lift] - measured[lift] > 5.0,
        "the table stopped the shoulder short of its goal"
    );
    // Pushing on the table at full effort: the loop's output is saturated (‰ of the duty).
    assert!(
        load.abs() > 900,
        "the shoulder pushes on the table: load {load}"
    );
}

#[test]
fn the_gripper_closing_on_a_block_stops_there_and_trips_the_overload_protection() {
    let open = [0.0, -30.0, 30.0, 60.0, 0.0, 40.0];
    // Where the arm rests holding this pose, found without the block: the block is put
    // between the jaws there.
    let robot = so101_at(&open);
    let mut servos = physical(&robot, None);
    hold_all(&robot, &mut servos, &open, 1.0);
    let (_, rested) = pose(&robot, &mut servos);
    drop(servos);
    // A 2 cm block where the middle of the moving jaw's blade passes at 15° (the blade
    // runs from its hinge to its tip in the jaw's frame: sim/models/so101.xml): closing from
    // 40°, the jaw meets it a few degrees before.
    let gripper = index(&robot, "gripper");
    let mut meeting = rested.clone();
    meeting[gripper] = 15.0;
    let blade_middle = glam::DVec3::new(-0.0101, -0.0474, 0.0181);
    let block = robot.joint_frames(&meeting)[gripper].apply(blade_middle);
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("block.xml");
    std::fs::write(
        &scene,
        format!(
            r#"<mujoco><worldbody><body name="block" pos="{} {} {}"><geom type="box" size="0.01 0.01 0.01"/></body></worldbody></mujoco>"#,
            block.x, block.y, block.z
        ),
    )
    .unwrap();
    let robot = so101_at(&rested);
    let mut servos = physical(&robot, Some(&scene));
    hold_all(&robot, &mut servos, &rested, 0.2);
    let closed = robot.joints[gripper].limits.min;
    hold(&robot, &mut servos.servos[gripper], gripper, closed);
    let protection_s = servos.servos[gripper].value("Protection_Time") as f64 * 0.01;
    let overload_pct = servos.servos[gripper].value("Overload_Torque");
    let (mut overloaded_at, mut tripped_at, mut stopped_at) = (None, None, f64::NAN);
    let mut previous = servos.physics_time().unwrap();
    let mut longest_gap: f64 = 0.0;
    while tripped_at.is_none() {
        std::thread::sleep(Duration::from_millis(20));
        let (t, values) = pose(&robot, &mut servos);
        longest_gap = longest_gap.max(t - previous);
        previous = t;
        let servo = &servos.servos[gripper];
        let load = servo.value("Present_Load");
        // The firmware's clock runs while the output is past Overload_Torque, moving or not
        // (closing at full effort, then pushing on the block).
        if overloaded_at.is_none() && load.abs() > overload_pct * 10 {
            overloaded_at = Some(t);
        }
        if servo.value("Torque_Enable") == 1 && servo.value("Present_Velocity") == 0 {
            stopped_at = values[gripper];
        }
        if servo.value("Status") & 0x20 != 0 {
            tripped_at = Some(t);
            assert_eq!(
                servo.value("Torque_Enable"),
                0,
                "an overloaded STS3215 unloads"
            );
        }
        assert!(
            t < 10.0,
            "no overload protection after {t:.1} s (load {load})"
        );
    }
    let (overloaded_at, tripped_at) = (overloaded_at.unwrap(), tripped_at.unwrap());
    println!(
        "gripper stopped at {stopped_at:.1} deg (goal {closed:.1}), overloaded at {overloaded_at:.3} s, tripped at {tripped_at:.3} s (protection time {protection_s} s, readings at most {longest_gap:.3} s apart)"
    );
    assert!(
        stopped_at - closed > 10.0,
        "the block holds the jaw open: at {stopped_at:.1} deg"
    );
    let took = tripped_at - overloaded_at;
    assert!(
        (took - protection_s).abs() <= longest_gap + 1e-3,
        "tripped {took:.3} s after the overload began; the protection time is {protection_s} s"
    );
}

#[test]
fn an_openmanipulator_shoulder_jogged_into_the_table_overloads_and_stays_off_until_a_reboot() {
    use keypose::bus::protocol::dynamixel::{Dynamixel2, REBOOT};
    use keypose::bus::protocol::packet::Framing;
    // Reaching forward, then the shoulder (joint2) sent far past where the table stops it:
    // the XM430 pushes on the table at full output, as OpenMANIPULATOR users jog it.
    let start = [0.0, 40.0, -20.0, 30.0, 0.0];
    let mut robot = Robot::builtin("omx").unwrap();
    robot.home = start.to_vec();
    let mut servos = physical(&robot, None);
    hold_all(&robot, &mut servos, &start, 0.3);
    let shoulder = index(&robot, "joint2");
    let mut goal = start;
    while keypose::kinematics::lowest_below_floor(&robot, &goal).is_none_or(|(_, d)| d < 0.08) {
        goal[shoulder] += 1.0;
    }
    let goal_tick = robot.joints[shoulder].servo.tick(goal[shoulder]).unwrap();
    servos.servos[shoulder]
        .set("Goal_Position", goal_tick)
        .unwrap();
    let (mut pushing_since, mut tripped_at) = (None, None);
    let mut previous = servos.physics_time().unwrap();
    let mut longest_gap: f64 = 0.0;
    let stall_ma = 2300.0;
    while tripped_at.is_none() {
        std::thread::sleep(Duration::from_millis(20));
        let (t, _) = pose(&robot, &mut servos);
        longest_gap = longest_gap.max(t - previous);
        previous = t;
        let servo = &servos.servos[shoulder];
        // XM430-W350 Present_Current: 2.69 mA per unit (e-Manual).
        let current_ma = servo.value("Present_Current") as f64 * 2.69;
        if pushing_since.is_none() && current_ma.abs() > 0.4 * stall_ma {
            pushing_since = Some(t);
        }
        if pushing_since.is_some()
            && current_ma.abs() <= 0.3 * stall_ma
            && servo.value("Hardware_Error_Status") == 0
        {
            panic!(
                "the shoulder stopped pushing before it tripped: {current_ma:.0} mA at {t:.2} s"
            );
        }
        if servo.value("Hardware_Error_Status") & 0x20 != 0 {
            tripped_at = Some(t);
        }
        assert!(t < 15.0, "no overload after {t:.1} s ({current_ma:.0} mA)");
    }
    let took = tripped_at.unwrap() - pushing_since.unwrap();
    println!(
        "joint2 pushed on the table from {:.3} s, overloaded {took:.3} s later",
        pushing_since.unwrap()
    );
    // The 5 s of the one measurement found (docs/protocols.md §6), within the readings' gaps
    // and the time the current takes from 40 % of stall to the loop's share.
    assert!(
        (took - 5.0).abs() <= longest_gap + 0.05,
        "overloaded {took:.3} s after pushing began"
    );
    let servo = &mut servos.servos[shoulder];
    assert_eq!(
        servo.value("Torque_Enable"),
        0,
        "Shutdown has bit 5: torque off"
    );
    // Torque on is refused in shutdown: only a reboot clears it.
    servo.set("Torque_Enable", 1).unwrap();
    servos.advance_physics();
    assert_eq!(servos.servos[shoulder].value("Torque_Enable"), 0);
    let id = robot.joints[shoulder].servo.id;
    servos.handle(&Dynamixel2.encode_instruction(id, REBOOT, &[]));
    servos.advance_physics();
    let servo = &mut servos.servos[shoulder];
    assert_eq!(
        servo.value("Hardware_Error_Status"),
        0,
        "a reboot clears the error"
    );
    servo.set("Torque_Enable", 1).unwrap();
    servos.advance_physics();
    assert_eq!(servos.servos[shoulder].value("Torque_Enable"), 1);
}

#[test]
fn a_hand_moves_the_limp_arm_along_its_path_and_a_servo_with_torque_on_fights_it() {
    use keypose::testing::{Hand, VirtualBus};
    let start = [0.0, -10.0, 0.0, 0.0, 0.0, 10.0];
    let robot = so101_at(&start);
    let bus = VirtualBus::new(physical(&robot, None));
    let (pan, elbow) = (index(&robot, "shoulder_pan"), index(&robot, "elbow_flex"));
    // The hand swings the pan 40° in 2 s and holds the rest where they are.
    let servos: Vec<_> = robot.joints.iter().map(|j| j.servo.clone()).collect();
    let path = move |t: f64, ticks: &mut [f64]| {
        for (j, (tick, servo)) in ticks.iter_mut().zip(&servos).enumerate() {
            let value = if j == pan { 20.0 * t } else { start[j] };
            *tick = servo.tick_exact(value);
        }
    };
    let ids = robot.joints.iter().map(|j| j.servo.id).collect();
    let hand = Hand::start(bus.clone(), ids, 2.0, Box::new(path));
    // `record` lets the arm go limp; the elbow's servo is told to hold instead.
    hold(&robot, &mut bus.lock().servos[elbow], elbow, 30.0);
    // The hand moves once it sees a servo told to go limp after it took hold: told again
    // until it does.
    while !hand.started() {
        bus.lock().servos[pan].set("Torque_Enable", 0).unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    let mut worst_lag: f64 = 0.0;
    let mut elbow_load: i64 = 0;
    let hand_start = bus.lock().physics_time().unwrap();
    loop {
        std::thread::sleep(Duration::from_millis(20));
        let mut servos = bus.lock();
        let (t, values) = pose(&robot, &mut servos);
        let along = (t - hand_start).min(2.0);
        if along > 0.3 {
            worst_lag = worst_lag.max((values[pan] - 20.0 * along).abs());
        }
        elbow_load = elbow_load.max(servos.servos[elbow].value("Present_Load").abs());
        if t - hand_start > 2.3 {
            println!("pan at {:.1} deg, elbow at {:.1} deg (its servo holds 30, the hand 0), worst lag {worst_lag:.2} deg, elbow load {elbow_load}", values[pan], values[elbow]);
            // The hand's grip is a 40 rad/s spring: the pan ends where the hand stops. (The
            // lag along the way depends on when this thread and the hand's ran: printed only.)
            assert!(
                (values[pan] - 40.0).abs() < 1.0,
                "pan at {:.2}",
                values[pan]
            );
            // The elbow's servo fights the hand at full effort; the hand, firmer, wins
            // most of the way.
            assert!(elbow_load > 900, "elbow load {elbow_load}");
            assert!(values[elbow] < 15.0, "elbow at {:.1}", values[elbow]);
            break;
        }
    }
}
