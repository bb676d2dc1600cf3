//! A cell's servos: one [`ServoBus`] over one bus per arm.
//!
//! The cell robot ([`Robot::cell`]) numbers its joints' servos 1 … N; each arm's own bus knows
//! them by the arm's ids, which repeat from arm to arm. [`CellBus`] maps each cell id to its arm
//! and that arm's id, and runs a transaction on every arm it touches at once, each arm's bus on
//! a thread of its own ([`worker`]): the player keeps one loop, one timeline, one limiter and
//! one guard for the whole cell, and only the I/O is spread over the buses. A goal write starts
//! on every arm together, once every arm's thread is at the start gate ([`gate`]), and how far
//! apart the writes really started is measured ([`WriteOffsets`]).
//!
//! No arm's silent bus holds the others: while the player drives the cell it gives the control
//! period ([`ServoBus::pace`]), and in a read of positions or health where one arm's answers
//! came in promptly (within an answer timeout), the arms whose answers have not come by
//! [`READ_SHARE`] of the period after the cycle's goal write began, and at least
//! [`STRAGGLER_SHARE`] of it after that arm's, are cut short ([`ReadCutoff`], set ahead of
//! time): their reads fail as timeouts (lost answers, counted like any other) and their threads
//! are free for their next goals, which go out in their period with the others'. When no arm's
//! answers come promptly the machine is slow for all of them, and every arm is waited for.
//!
//! Errors come back naming the arm ([`BusError::Arm`]) with the servo's cell id, so a fault
//! names `right/wrist_flex`. On a fault the player isolates that arm
//! ([`ServoBus::isolate`]): nothing more is sent to its bus while the others brake to rest.

mod gate;
mod offsets;
mod worker;

pub use offsets::WriteOffsets;

use super::cutoff::ReadCutoff;
use super::driver::DEFAULT_TIMEOUT;
use super::virtual_bus::PtyServer;
use super::{
    connect_with, BusError, BusOptions, Connection, Health, PingInfo, PositionLoad, ServoBus,
};
use crate::robot::{Arm, Robot, ServoModel};
use crate::servo::Setting;
use gate::Gate;
use offsets::OffsetRecord;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant};
use worker::{Done, Worker};

/// The longest one arm's transaction may take before its bus counts as hung: beyond any
/// transaction's retries outside a control loop (a health check's two reads, three attempts
/// each at [`super::driver::DEFAULT_SETUP_TIMEOUT`]), well short of a user's patience.
pub const HUNG_AFTER: Duration = Duration::from_millis(1500);
/// The share of the control period, from the start of the cycle's goal write, that an arm's
/// read may take while another arm's is done: the rest is the loop's own work before the next
/// cycle's goals are due.
pub const READ_SHARE: f64 = 0.9;
/// The share of the control period an arm's read still gets once another arm's has come in,
/// however late in the cycle: arms on alike buses answer close together.
pub const STRAGGLER_SHARE: f64 = 0.25;

/// One arm's bus in the cell.
struct ArmBus {
    name: String,
    description: String,
    /// (cell id, the servo's id on this arm's bus), in joint order.
    ids: Vec<(u8, u8)>,
    isolated: bool,
    /// Cuts its reads short when it would hold the other arms.
    cutoff: Arc<ReadCutoff>,
    /// Declared before the emulated servos: the bus closes before they stop.
    worker: Worker,
    _virtual_bus: Option<PtyServer>,
}

/// The servos of a cell, one bus per arm.
pub struct CellBus {
    arms: Vec<ArmBus>,
    /// By cell id − 1: the arm and the servo's id on its bus.
    route: Vec<(usize, u8)>,
    offsets: OffsetRecord,
    /// The control period, while a player drives the cell ([`ServoBus::pace`]).
    period: Option<Duration>,
    /// When the last goal write began: the start of the cycle its reads belong to.
    last_write: Option<Instant>,
}

/// The share of a transaction that goes to one arm.
struct Part {
    arm: usize,
    /// The servos' ids on the arm's bus.
    ids: Vec<u8>,
    /// Where each of them stands in the transaction.
    places: Vec<usize>,
}

impl Part {
    /// This part's entries of `entries` (cell id, value), with the arm's own ids.
    fn own<T: Copy>(&self, entries: &[(u8, T)]) -> Vec<(u8, T)> {
        self.ids
            .iter()
            .zip(&self.places)
            .map(|(&id, &place)| (id, entries[place].1))
            .collect()
    }
}

/// Opens the bus of every arm of `cell`, arm `k` on `ports[k]` ("virtual": emulated servos on a
/// pseudo-terminal of its own), each probed and its homing offsets checked as a one-arm bus is
/// ([`connect_with`]).
pub fn connect_cell(
    cell: &Robot,
    ports: &[&str],
    options: &BusOptions,
) -> Result<Connection, BusError> {
    let mut connections = Vec::with_capacity(cell.arms.len());
    for (arm, port) in cell.arms.iter().zip(ports) {
        let connection = connect_with(&arm.robot, port, options)
            .map_err(|error| in_arm(&arm.name, &cell_ids(arm), error))?;
        connections.push(connection);
    }
    Ok(Connection {
        bus: Box::new(CellBus::new(cell, connections)),
        virtual_bus: None,
    })
}

/// (cell id, the arm's own id) of each of `arm`'s servos.
fn cell_ids(arm: &Arm) -> Vec<(u8, u8)> {
    arm.robot
        .joints
        .iter()
        .enumerate()
        .map(|(k, joint)| ((arm.joints.start + k + 1) as u8, joint.servo.id))
        .collect()
}

/// `error` of `arm`'s bus as the cell's: the servo it names by its cell id.
fn in_arm(arm: &str, ids: &[(u8, u8)], error: BusError) -> BusError {
    let servo = error.servo().and_then(|id| {
        ids.iter()
            .find(|(_, own)| *own == id)
            .map(|(cell, _)| *cell)
    });
    BusError::Arm {
        arm: arm.to_string(),
        servo,
        source: Box::new(error),
    }
}

/// When a paced read of the cell cuts short the arms whose answers are late.
#[derive(Debug, Clone, Copy)]
struct CutPlan {
    /// The earliest cut: [`READ_SHARE`] of the period into the cycle, and a straggler's grace
    /// into the read.
    from: Instant,
    /// The first arm's read must be in by then (within one answer timeout,
    /// [`DEFAULT_TIMEOUT`]), or the machine is slow for every arm (a starved scheduler, an
    /// adapter's latency): then no arm holds another, every arm is waited for, and one read cut
    /// short after another would take a slow bus for a dead one.
    prompt_by: Instant,
    /// How long the others are still waited for once an arm's read is in.
    grace: Duration,
}

impl CellBus {
    /// The cell over `connections`, one per arm of `cell` in its order (arms without one are
    /// not served: their servos' transactions fail).
    pub fn new(cell: &Robot, connections: Vec<Connection>) -> CellBus {
        let mut route = vec![(usize::MAX, 0); cell.joints.len()];
        let arms = cell
            .arms
            .iter()
            .zip(connections)
            .enumerate()
            .map(|(index, (arm, connection))| {
                let ids = cell_ids(arm);
                for &(cell_id, own) in &ids {
                    route[usize::from(cell_id) - 1] = (index, own);
                }
                let mut bus = connection.bus;
                let cutoff = Arc::new(ReadCutoff::default());
                bus.set_read_cutoff(Arc::clone(&cutoff));
                ArmBus {
                    name: arm.name.clone(),
                    description: bus.describe(),
                    ids,
                    isolated: false,
                    cutoff,
                    worker: Worker::new(&arm.name, bus),
                    _virtual_bus: connection.virtual_bus,
                }
            })
            .collect();
        CellBus {
            arms,
            route,
            offsets: OffsetRecord::default(),
            period: None,
            last_write: None,
        }
    }

    /// The emulated servos behind arm `arm`, when its port is "virtual".
    pub fn virtual_bus(&self, arm: &str) -> Option<&PtyServer> {
        self.arms
            .iter()
            .find(|a| a.name == arm)
            .and_then(|a| a._virtual_bus.as_ref())
    }

    /// The transaction on `ids` split by arm, in arm order.
    fn split(&self, ids: impl IntoIterator<Item = u8>) -> Result<Vec<Part>, BusError> {
        let mut parts: Vec<Part> = Vec::new();
        for (place, id) in ids.into_iter().enumerate() {
            let &(arm, own) = usize::from(id)
                .checked_sub(1)
                .and_then(|i| self.route.get(i))
                .filter(|(arm, _)| *arm < self.arms.len())
                .ok_or(BusError::NotInCell {
                    id,
                    servos: self.route.len(),
                })?;
            let part = match parts.iter().position(|p| p.arm == arm) {
                Some(i) => &mut parts[i],
                None => {
                    parts.push(Part {
                        arm,
                        ids: Vec::new(),
                        places: Vec::new(),
                    });
                    parts.last_mut().expect("just pushed")
                }
            };
            part.ids.push(own);
            part.places.push(place);
        }
        parts.sort_by_key(|p| p.arm);
        Ok(parts)
    }

    /// Runs `job` of each part on its arm's thread, all at once, and waits for every one (so no
    /// answer is left behind), up to [`HUNG_AFTER`]; the first error in arm order is the
    /// result. The part of an isolated arm is not sent: it fails, after the other arms' parts
    /// are done (restoring the servos' profile after a fault still reaches the healthy arms).
    /// `cuttable`: a read of the control loop, whose stragglers are cut short ([`CutPlan`]).
    fn each<T, F>(
        &mut self,
        parts: &[Part],
        cuttable: bool,
        job: impl Fn(&Part) -> F,
    ) -> Result<Vec<T>, BusError>
    where
        T: Send + 'static,
        F: FnOnce(&mut dyn ServoBus) -> Result<T, BusError> + Send + 'static,
    {
        let began = Instant::now();
        let hung_at = began + HUNG_AFTER;
        let (results, done) = mpsc::channel::<Done<T>>();
        let mut outcomes: Vec<Option<Result<T, BusError>>> = parts.iter().map(|_| None).collect();
        let served = parts.iter().filter(|p| !self.arms[p.arm].isolated).count();
        // One arm alone holds no other: nothing to cut.
        let plan = self.cut_plan(began).filter(|_| cuttable && served >= 2);
        let mut waiting = 0;
        for (place, part) in parts.iter().enumerate() {
            let arm = &mut self.arms[part.arm];
            if arm.isolated {
                let arm = arm.name.clone();
                outcomes[place] = Some(Err(BusError::Isolated { arm }));
                continue;
            }
            if let Some(plan) = &plan {
                arm.cutoff.watch(plan.from, plan.grace);
            }
            arm.worker.start(job(part), &results, place);
            waiting += 1;
        }
        drop(results);
        // Watching until the first arm's read is in, or the machine is found slow for all.
        let mut watching = plan;
        while waiting > 0 {
            let until = watching.map_or(hung_at, |plan| plan.prompt_by.min(hung_at));
            match done.recv_timeout(until.saturating_duration_since(Instant::now())) {
                Ok((place, result)) => {
                    outcomes[place] = Some(result);
                    waiting -= 1;
                    if let Some(plan) = watching.take() {
                        let now = Instant::now();
                        if now <= plan.prompt_by {
                            self.cut_short(parts, &outcomes, plan.from.max(now + plan.grace));
                        } else {
                            self.uncut(parts);
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) if watching.is_some() => {
                    watching = None;
                    self.uncut(parts);
                }
                Err(_) => break,
            }
        }
        if plan.is_some() {
            self.uncut(parts);
        }
        let mut values = Vec::with_capacity(parts.len());
        let mut first_error = None;
        for (part, outcome) in parts.iter().zip(outcomes) {
            let outcome = outcome.unwrap_or(Err(BusError::Hung {
                waited_ms: HUNG_AFTER.as_millis() as u64,
            }));
            match outcome {
                Ok(value) => values.push(value),
                Err(error) => {
                    let arm = &self.arms[part.arm];
                    first_error.get_or_insert_with(|| in_arm(&arm.name, &arm.ids, error));
                }
            }
        }
        match first_error {
            Some(error) => Err(error),
            None => Ok(values),
        }
    }

    /// Cuts short at `at` the reads of the parts not done yet.
    fn cut_short<T>(&self, parts: &[Part], outcomes: &[Option<T>], at: Instant) {
        for (part, outcome) in parts.iter().zip(outcomes) {
            if outcome.is_none() {
                self.arms[part.arm].cutoff.cut(at);
            }
        }
    }

    /// Every part's read waits as long as its bus does.
    fn uncut(&self, parts: &[Part]) {
        for part in parts {
            self.arms[part.arm].cutoff.clear();
        }
    }

    /// When a read begun at `began` may cut its stragglers short; `None` unless a player paces
    /// the cell.
    fn cut_plan(&self, began: Instant) -> Option<CutPlan> {
        let period = self.period?;
        let grace = period.mul_f64(STRAGGLER_SHARE);
        let in_cycle = self.last_write.unwrap_or(began) + period.mul_f64(READ_SHARE);
        Some(CutPlan {
            from: in_cycle.max(began + grace),
            prompt_by: began + DEFAULT_TIMEOUT,
            grace,
        })
    }

    /// Each part's values put back in the places of the transaction.
    fn merge<T: Clone>(parts: &[Part], values: Vec<Vec<T>>, len: usize) -> Vec<T> {
        let mut merged: Vec<Option<T>> = vec![None; len];
        for (part, values) in parts.iter().zip(values) {
            for (&place, value) in part.places.iter().zip(values) {
                merged[place] = Some(value);
            }
        }
        merged.into_iter().flatten().collect()
    }

    /// The cell id of servo `own` of arm `arm`.
    fn cell_id(&self, arm: usize, own: u8) -> u8 {
        self.arms[arm]
            .ids
            .iter()
            .find(|(_, id)| *id == own)
            .map_or(own, |(cell, _)| *cell)
    }
}

impl ServoBus for CellBus {
    fn describe(&self) -> String {
        self.arms
            .iter()
            .map(|a| format!("{}: {}", a.name, a.description))
            .collect::<Vec<_>>()
            .join("; ")
    }

    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        let parts = self.split([id])?;
        let mut info = self.each(&parts, false, |part| {
            let own = part.ids[0];
            move |bus: &mut dyn ServoBus| bus.ping(own)
        })?;
        let mut info = info.pop().expect("one part");
        info.id = id;
        Ok(info)
    }

    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        let parts = self.split(ids.iter().copied())?;
        let values = self.each(&parts, true, |part| {
            let ids = part.ids.clone();
            move |bus: &mut dyn ServoBus| bus.read_positions(&ids)
        })?;
        Ok(Self::merge(&parts, values, ids.len()))
    }

    fn read_positions_loads(&mut self, ids: &[u8]) -> Result<Vec<PositionLoad>, BusError> {
        let parts = self.split(ids.iter().copied())?;
        let values = self.each(&parts, true, |part| {
            let ids = part.ids.clone();
            move |bus: &mut dyn ServoBus| bus.read_positions_loads(&ids)
        })?;
        Ok(Self::merge(&parts, values, ids.len()))
    }

    /// Every arm's sync write starts once every arm's thread is ready for it (`Gate`); the
    /// spread of the instants they really started at is recorded.
    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        let parts = self.split(goals.iter().map(|(id, _)| *id))?;
        let served = parts.iter().filter(|p| !self.arms[p.arm].isolated).count();
        let gate = Arc::new(Gate::new(served));
        self.last_write = Some(Instant::now());
        let starts = self.each(&parts, false, |part| {
            let own = part.own(goals);
            let gate = Arc::clone(&gate);
            move |bus: &mut dyn ServoBus| {
                gate.pass();
                let started = Instant::now();
                bus.write_goals(&own).map(|()| started)
            }
        })?;
        self.offsets.add(&starts);
        Ok(())
    }

    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        let parts = self.split(ids.iter().copied())?;
        self.each(&parts, false, |part| {
            let ids = part.ids.clone();
            move |bus: &mut dyn ServoBus| bus.set_torque(&ids, on)
        })?;
        Ok(())
    }

    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        let parts = self.split(ids.iter().copied())?;
        let mut health = self.each(&parts, true, |part| {
            let ids = part.ids.clone();
            move |bus: &mut dyn ServoBus| bus.read_health(&ids)
        })?;
        for (part, health) in parts.iter().zip(&mut health) {
            for h in health {
                h.id = self.cell_id(part.arm, h.id);
            }
        }
        Ok(Self::merge(&parts, health, ids.len()))
    }

    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        let parts = self.split(servos.iter().map(|(id, _)| *id))?;
        let values = self.each(&parts, false, |part| {
            let own = part.own(servos);
            move |bus: &mut dyn ServoBus| bus.read_homing_offsets(&own)
        })?;
        Ok(Self::merge(&parts, values, servos.len()))
    }

    fn read_setting(&mut self, ids: &[u8], setting: Setting) -> Result<Vec<i64>, BusError> {
        let parts = self.split(ids.iter().copied())?;
        let values = self.each(&parts, false, |part| {
            let ids = part.ids.clone();
            move |bus: &mut dyn ServoBus| bus.read_setting(&ids, setting)
        })?;
        Ok(Self::merge(&parts, values, ids.len()))
    }

    fn write_setting(&mut self, values: &[(u8, i64)], setting: Setting) -> Result<(), BusError> {
        let parts = self.split(values.iter().map(|(id, _)| *id))?;
        self.each(&parts, false, |part| {
            let own = part.own(values);
            move |bus: &mut dyn ServoBus| bus.write_setting(&own, setting)
        })?;
        Ok(())
    }

    /// Stops serving the arm `error` names, unless it is the last one served.
    fn isolate(&mut self, error: &BusError) -> Option<Vec<u8>> {
        let BusError::Arm { arm, .. } = error else {
            return None;
        };
        let index = self.arms.iter().position(|a| &a.name == arm)?;
        let others_served = self
            .arms
            .iter()
            .enumerate()
            .any(|(i, a)| i != index && !a.isolated);
        if !others_served {
            return None;
        }
        let arm = &mut self.arms[index];
        arm.isolated = true;
        Some(arm.ids.iter().map(|(cell, _)| *cell).collect())
    }

    fn write_offsets(&self) -> Option<WriteOffsets> {
        Some(self.offsets.summary())
    }

    fn pace(&mut self, period: Option<Duration>) {
        self.period = period;
        // Each arm's own bus times its answers by whether a loop drives it, too.
        let every_servo = (1..=self.route.len()).filter_map(|id| u8::try_from(id).ok());
        if let Ok(parts) = self.split(every_servo) {
            let _ = self.each(&parts, false, |_| {
                move |bus: &mut dyn ServoBus| {
                    bus.pace(period);
                    Ok(())
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::faulty_joint;
    use crate::bus::virtual_bus::{ServoFault, VirtualBus};
    use crate::pose::RigidTransform;

    /// Two SO-101 (servo ids 1 … 6 each) as a cell, each on emulated servos behind the real
    /// driver, in memory.
    fn two_arms() -> (Robot, CellBus, VirtualBus, VirtualBus) {
        let so101 = Robot::builtin("so101").unwrap();
        let cell = Robot::cell(vec![
            ("left".into(), so101.clone(), RigidTransform::IDENTITY),
            ("right".into(), so101.clone(), RigidTransform::IDENTITY),
        ])
        .unwrap();
        let (left_bus, left) = VirtualBus::in_process(&so101);
        let (right_bus, right) = VirtualBus::in_process(&so101);
        let connections = [left_bus, right_bus]
            .into_iter()
            .map(|bus| Connection {
                bus: Box::new(bus),
                virtual_bus: None,
            })
            .collect();
        let bus = CellBus::new(&cell, connections);
        (cell, bus, left, right)
    }

    #[test]
    fn each_cell_id_reaches_its_arms_servo_by_the_arms_own_id() {
        let (_, mut bus, left, right) = two_arms();
        left.lock().servo_mut(1).unwrap().place_at(1000.0);
        right.lock().servo_mut(2).unwrap().place_at(3000.0);
        // Cell id 8 is the right arm's second servo (its id 2), cell id 1 the left's first.
        assert_eq!(bus.read_positions(&[8, 1]).unwrap(), vec![3000, 1000]);
        bus.write_goals(&[(1, 2000), (7, 2100), (12, 2200)])
            .unwrap();
        assert_eq!(left.lock().goals_received(), vec![(1, 2000)]);
        assert_eq!(right.lock().goals_received(), vec![(1, 2100), (6, 2200)]);
        let health = bus.read_health(&[12, 6]).unwrap();
        assert_eq!(health.iter().map(|h| h.id).collect::<Vec<_>>(), vec![12, 6]);
        // One write to both arms: one offset measured.
        assert_eq!(bus.write_offsets().unwrap().cycles, 1);
    }

    #[test]
    fn a_paced_read_cuts_a_silent_arm_short_instead_of_retrying_it() {
        let (_, mut bus, _, right) = two_arms();
        for id in 1..=6 {
            right.lock().set_fault(id, Some(ServoFault::NoAnswer));
        }
        let ids: Vec<u8> = (1..=12).collect();
        let asked = |since: usize| right.lock().received.len() - since;
        // Unpaced (teach, record): the silent arm's read is tried three times, each waited
        // out at the patient timeout outside a control loop, as on a bus of one arm.
        let before = right.lock().received.len();
        let error = bus.read_positions(&ids).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("right bus: servo 1: no answer within 200 ms"),
            "{error}"
        );
        assert_eq!(asked(before), 3);
        // Paced by a player at 100 Hz: once the left arm's read is in, the right one's is cut
        // short within the cycle, and not tried again.
        bus.pace(Some(Duration::from_millis(10)));
        bus.write_goals(&[(1, 2048), (7, 2048)]).unwrap();
        let before = right.lock().received.len();
        let error = bus.read_positions(&ids).unwrap_err();
        assert!(
            // Starved too: on a loaded machine this process may not run for part of the wait.
            matches!(error.root(), BusError::CutShort { id: 1, waited_ms: timeout_ms }
                | BusError::Starved { id: 1, timeout_ms, .. } if *timeout_ms < 40),
            "{error}"
        );
        assert_eq!(asked(before), 1);
        // The next goal reaches both arms, and so would every one after.
        bus.write_goals(&[(1, 2048), (7, 2049)]).unwrap();
        assert_eq!(right.lock().goals_received().last(), Some(&(1, 2049)));
    }

    #[test]
    fn a_fault_names_its_arm_and_joint_and_an_isolated_arm_is_sent_nothing() {
        let (cell, mut bus, _, right) = two_arms();
        right.lock().set_fault(4, Some(ServoFault::NoAnswer));
        let ids: Vec<u8> = (1..=12).collect();
        let error = bus.read_positions(&ids).unwrap_err();
        assert_eq!(
            faulty_joint(&cell, &error).as_deref(),
            Some("right/wrist_flex")
        );
        assert!(
            error.is_no_answer() && error.root().servo() == Some(4),
            "{error}"
        );
        assert!(
            error.to_string().starts_with("right bus: servo 4: "),
            "{error}"
        );

        assert_eq!(bus.isolate(&error), Some((7..=12).collect()));
        let sent = right.lock().received.len();
        let refused = bus.read_positions(&[1, 7]).unwrap_err();
        assert!(
            matches!(refused.root(), BusError::Isolated { arm } if arm == "right"),
            "{refused}"
        );
        assert_eq!(
            right.lock().received.len(),
            sent,
            "the isolated bus was sent to"
        );
        // The left arm is still served; it is the last one, so a fault of its own ends all.
        assert_eq!(bus.read_positions(&[1, 2]).unwrap().len(), 2);
        let left_fault = BusError::Arm {
            arm: "left".into(),
            servo: Some(1),
            source: Box::new(BusError::ThreadEnded),
        };
        assert_eq!(bus.isolate(&left_fault), None);
        // An error of no arm is the whole cell's.
        assert_eq!(bus.isolate(&BusError::ThreadEnded), None);
    }
}
