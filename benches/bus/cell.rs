//! Section 4: two arms. A cell of two so101 arms, each on its own wire-timed pseudo-terminal,
//! cycled through the cell's bus (each arm's transactions on its own thread, goal writes
//! released together at a start gate), against one arm on one bus in the same run: cycles per
//! second and their ratio (1 when the buses run side by side, 0.5 when one waits for the
//! other), and how far apart the two buses' goal writes were — as the cell records it (at the
//! start gate, before the packets are encoded and written) and at the write itself (each arm's
//! transport stamps its goal writes, [`Stamped`]; the k-th goal write of one arm is paired with
//! the k-th of the other).

use super::cycles::{Contender, DriverResult, KeyposeCycler, Link, Runs, REPS};
use super::stamps::{goal_writes, Log, Stamped};
use crate::common;
use keypose::bus::{CellBus, Connection, NativeBus, WriteOffsets};
use keypose::robot::Robot;
use keypose::testing::PtyServer;
use std::sync::{Arc, Mutex};

pub struct CellResult {
    pub one: DriverResult,
    pub cell: DriverResult,
    /// As the cell records them, at the start gate.
    pub at_gate: Option<WriteOffsets>,
    /// At the write, seconds, one per cycle written to both buses.
    pub at_write: Vec<f64>,
    /// Goal writes of each arm (equal unless a write failed).
    pub writes: [usize; 2],
}

/// A cell of `cell`'s arms, each arm's emulated servos on a wire-timed pseudo-terminal of
/// their own, through [`CellBus`] and the native driver over stamped transports.
fn stamped_cell(cell: &Robot, logs: &[Log]) -> Result<Link, String> {
    let mut servers = Vec::new();
    let mut connections = Vec::new();
    for (arm, log) in cell.arms.iter().zip(logs) {
        let server = PtyServer::start(&arm.robot).map_err(|e| e.to_string())?;
        let transport = Stamped::open(&arm.robot, server.path(), Arc::clone(log))?;
        let bus = NativeBus::new(
            Box::new(transport),
            arm.robot.bus.protocol,
            &arm.robot.servos(),
        );
        connections.push(Connection {
            bus: Box::new(bus),
            virtual_bus: None,
        });
        servers.push(server);
    }
    let connection = Connection {
        bus: Box::new(CellBus::new(cell, connections)),
        virtual_bus: None,
    };
    let cycler = KeyposeCycler::on(cell, connection)?;
    Ok(Link::of(Box::new(cycler), servers))
}

pub fn cell_cycles() -> CellResult {
    let so101 = Robot::builtin("so101").expect("a built-in robot");
    let arm = |name: &str, y: f64| {
        let base = keypose::pose::RigidTransform::new(
            glam::DVec3::new(0.0, y, 0.0),
            glam::DQuat::IDENTITY,
        );
        (name.to_string(), so101.clone(), base)
    };
    let cell = Robot::cell(vec![arm("left", 0.25), arm("right", -0.25)]).expect("two arms");
    let logs: [Log; 2] = [
        Arc::new(Mutex::new(Vec::new())),
        Arc::new(Mutex::new(Vec::new())),
    ];
    let mut one = Runs::of(super::cycles::open(&so101, Contender::Native));
    let mut two = Runs::of(stamped_cell(&cell, &logs));
    for _ in 0..REPS {
        one.run();
        two.run();
    }
    let at_gate = two
        .link
        .as_ref()
        .ok()
        .and_then(|l| l.cycler.write_offsets());
    let result_two = two.finish();
    let [left, right] = [goal_writes(&logs[0]), goal_writes(&logs[1])];
    let at_write = left
        .iter()
        .zip(&right)
        .map(|(&(_, a), &(_, b))| {
            let (early, late) = if a < b { (a, b) } else { (b, a) };
            (late - early).as_secs_f64()
        })
        .collect();
    CellResult {
        one: one.finish(),
        cell: result_two,
        at_gate,
        at_write,
        writes: [left.len(), right.len()],
    }
}

/// "median / p99 / max" of offsets in seconds, microseconds.
pub fn show_offsets(offsets: &[f64]) -> String {
    let mut sorted = offsets.to_vec();
    sorted.sort_by(f64::total_cmp);
    format!(
        "median {:.0} µs, p99 {:.0} µs, max {:.0} µs over {} cycles",
        common::quantile(&sorted, 0.5) * 1e6,
        common::quantile(&sorted, 0.99) * 1e6,
        sorted.last().copied().unwrap_or(f64::NAN) * 1e6,
        sorted.len()
    )
}
