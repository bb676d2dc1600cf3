//! The load on each servo along a trajectory, against what its drive can give: the check's
//! torque part.
//!
//! Each joint's torque at its servo's output comes from the inverse dynamics of the arm
//! (`dynamics`: gravity, inertia, Coriolis, the rotor's reflected inertia, the payload)
//! at the exact state of motion (`plan::States`), every [`STEP`] seconds of the servos' time and
//! on both sides of every instant where an acceleration jumps. Three findings come of it:
//!
//! - **over the line** (fails the check): more torque than the servo's torque-speed line gives
//!   at that speed ([`crate::servo::Drive::available`]), the servo then falls behind its goal,
//!   or stalls, and its overload protection may cut its torque;
//! - **duty** (a warning): the root mean square of the torque over the motion above the
//!   continuous rating: played in a loop, it heats the servo towards its protection;
//! - **droop** (a warning): at a key, the weight the servo holds over its position loop's
//!   stiffness, more than `sim`'s settling tolerance: the arm rests that far from the key.

use super::states::{Side, State, States};
use super::Trajectory;
use crate::dynamics::{Dynamics, DynamicsError};
use crate::robot::{JointKind, Robot};

/// The longest interval between two evaluated instants, seconds of the servos' time: the
/// built-in arms' control period, at which the player asks for each goal. Torque is smooth
/// between the instants where an acceleration jumps, which are all read, both sides.
pub const STEP: f64 = 0.01;

/// How far from its key an arm may rest before `sim` judges it unsettled, degrees (prismatic:
/// [`SETTLED_TOLERANCE_M`]): what droop is measured against.
pub const SETTLED_TOLERANCE_DEG: f64 = 3.0;
/// The same for a prismatic joint, metres.
pub const SETTLED_TOLERANCE_M: f64 = 0.002;

/// How far over its line a servo may be asked, as a share of its stall torque, before it is a
/// finding: far below what any datasheet knows its line to, and enough that a motion riding the
/// line (the fastest timing does, where it is the binding limit) is not failed by rounding, as
/// where gravity speeds a joint past its no-load speed and the servo must ask for no torque
/// at all.
pub const LINE_TOLERANCE: f64 = 0.005;

/// Over-line instants closer than this (seconds of sequence time) make one finding.
const JOIN: f64 = 0.05;

/// A stretch of time where a servo is asked for more torque than its line gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Overload {
    /// The joint.
    pub joint: String,
    /// The keyframe segment of the worst instant.
    pub segment: usize,
    /// Its keys' names.
    pub segment_label: String,
    /// First and last instant over the line, sequence time.
    pub from: f64,
    /// Last.
    pub to: f64,
    /// The worst instant.
    pub peak_time: f64,
    /// The torque asked there, N·m at the servo's output (signed).
    pub torque: f64,
    /// What the line gives there in that direction, N·m.
    pub available: f64,
    /// The servo's output speed there, rad/s.
    pub speed: f64,
    /// What the torque would be holding the same pose still: when it alone is over the line,
    /// no timing helps.
    pub holding: f64,
    /// What to do about it.
    pub advice: String,
}

impl Overload {
    /// In one line: "elbow_flex asks 0.64 N·m at 1.95 rad/s where the line gives 0.60 N·m, at
    /// 0.350 s (from 0.326 to 0.358 s), segment 0 (home → raise)".
    pub fn describe(&self) -> String {
        format!(
            "{} asks {:.2} N·m at {:.2} rad/s where the line gives {:.2} N·m, at {:.3} s (from \
             {:.3} to {:.3} s), segment {} ({})",
            self.joint,
            self.torque.abs(),
            self.speed.abs(),
            self.available,
            self.peak_time,
            self.from,
            self.to,
            self.segment,
            self.segment_label
        )
    }
}

/// A key where a servo gives under its load by more than the settling tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct Droop {
    /// The joint.
    pub joint: String,
    /// The key's index and name.
    pub key: usize,
    /// Its name (or `#N`).
    pub key_label: String,
    /// The weight held there, N·m at the servo's output.
    pub torque: f64,
    /// How far the joint gives, joint units (degrees, metres).
    pub droop: f64,
    /// The tolerance, joint units.
    pub tolerance: f64,
    /// What to do about it.
    pub advice: String,
}

/// One joint's load over the motion.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLoad {
    /// The joint.
    pub joint: String,
    /// Its servo's variant and supply, as "sts3215 c001 @ 5 V".
    pub drive: String,
    /// The servo's stall torque and no-load speed (N·m, rad/s); `None` without drive data.
    pub line: Option<(f64, f64)>,
    /// The largest torque asked (signed, N·m) and when.
    pub peak_torque: f64,
    /// Sequence time of the peak.
    pub peak_time: f64,
    /// The largest share of the line's torque asked, at any instant (1 is on the line).
    pub peak_share: f64,
    /// Root mean square of the torque over the motion, N·m.
    pub rms_torque: f64,
    /// The continuous rating, N·m.
    pub continuous: Option<f64>,
    /// The share of the motion's time above the continuous rating.
    pub time_above_continuous: f64,
    /// The largest droop at a key, joint units.
    pub max_droop: f64,
    /// The joint's unit ("deg", "m").
    pub unit: &'static str,
    /// The duty warning, when the RMS is above the continuous rating.
    pub duty_advice: Option<String>,
}

/// The load part of a check.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadScope {
    /// The loads were computed.
    Checked(LoadReport),
    /// They could not be: why.
    Unchecked(String),
}

/// What the load check found.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadReport {
    /// The build judged: each distinct servo variant and supply, and the payload.
    pub build: String,
    /// One per joint, robot order.
    pub joints: Vec<JointLoad>,
    /// Every stretch over a torque-speed line: each fails the check.
    pub overloads: Vec<Overload>,
    /// Every key that droops past the tolerance: warnings.
    pub droops: Vec<Droop>,
    /// Joints whose servo has no drive data: not judged.
    pub unrated: Vec<String>,
}

/// Each joint's servo torque along a trajectory, at the instants the check reads: one flat
/// buffer of `[time, values…, torques…, speeds…]` rows (a long sequence has millions of
/// instants; one row each, not a vector each).
#[derive(Debug, Clone)]
pub struct Samples {
    joints: usize,
    rows: Vec<f64>,
}

/// One instant of [`Samples`].
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Sequence time, seconds.
    pub time: f64,
    /// Joint values (degrees, metres).
    pub values: &'a [f64],
    /// Each servo's torque at its output, N·m.
    pub torques: &'a [f64],
    /// Each servo's output speed, rad/s.
    pub speeds: &'a [f64],
}

impl Samples {
    fn width(&self) -> usize {
        1 + 3 * self.joints
    }

    /// How many instants.
    pub fn len(&self) -> usize {
        self.rows.len() / self.width()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Instant `k`.
    pub fn get(&self, k: usize) -> Sample<'_> {
        let n = self.joints;
        let row = &self.rows[k * self.width()..(k + 1) * self.width()];
        Sample {
            time: row[0],
            values: &row[1..1 + n],
            torques: &row[1 + n..1 + 2 * n],
            speeds: &row[1 + 2 * n..],
        }
    }

    /// Every instant in order.
    pub fn iter(&self) -> impl Iterator<Item = Sample<'_>> {
        (0..self.len()).map(|k| self.get(k))
    }
}

/// Each joint's servo torque along `trajectory` at playback `speed`, at the instants the
/// check reads.
pub fn torques(trajectory: &Trajectory, dynamics: &Dynamics, speed: f64) -> Samples {
    let states = States::of(trajectory);
    let joints = trajectory.tracks().len();
    let instants = instants(&states, STEP * speed);
    let mut rows = Vec::with_capacity(instants.len() * (1 + 3 * joints));
    let mut s = State::default();
    for (t, side) in instants {
        states.fill(t, side, &mut s);
        for v in &mut s.velocities {
            *v *= speed;
        }
        for a in &mut s.accelerations {
            *a *= speed * speed;
        }
        rows.push(t);
        rows.extend_from_slice(&s.values);
        rows.extend(dynamics.servo_torques(&s.values, &s.velocities, &s.accelerations));
        rows.extend(dynamics.servo_speeds(&s.velocities));
    }
    Samples { joints, rows }
}

/// The instants read: both sides of every break, and every `step` (sequence time) between.
fn instants(states: &States, step: f64) -> Vec<(f64, Side)> {
    let breaks = states.breaks();
    let mut out = Vec::new();
    for w in breaks.windows(2) {
        let (a, b) = (w[0], w[1]);
        let n = ((b - a) / step).ceil().max(1.0) as usize;
        out.push((a, Side::After));
        for k in 1..n {
            out.push((a + (b - a) * k as f64 / n as f64, Side::After));
        }
        out.push((b, Side::Before));
    }
    if breaks.len() == 1 {
        out.push((breaks[0], Side::After));
    }
    out
}

/// The load check of `trajectory` on `robot` at playback `speed`.
pub fn check_loads(trajectory: &Trajectory, robot: &Robot, speed: f64) -> LoadScope {
    let dynamics = match Dynamics::for_robot(robot) {
        Ok(d) => d,
        Err(e) => return LoadScope::Unchecked(unchecked_reason(&e)),
    };
    let mut samples = torques(trajectory, &dynamics, speed);
    add_grasps(&mut samples, trajectory, robot);
    let mut joints = Vec::with_capacity(robot.joints.len());
    let mut overloads = Vec::new();
    let mut unrated = Vec::new();
    for (j, joint) in robot.joints.iter().enumerate() {
        let drive = joint.servo.drive();
        if drive.is_none() {
            unrated.push(joint.name.clone());
        }
        let summary = summarise(j, joint, &samples);
        if let Some(d) = drive {
            overloads.extend(over_line(trajectory, robot, &dynamics, j, d, &samples));
        }
        joints.push(summary);
    }
    let droops = droops(trajectory, robot, &dynamics, &mut joints);
    LoadScope::Checked(LoadReport {
        build: build_name(robot),
        joints,
        overloads,
        droops,
        unrated,
    })
}

/// A joint held still below full effort (a key's `"effort"`: a grasp) is taken to squeeze what
/// it holds at that effort, however little its motion needs: what heats its servo while it
/// holds. Moving, it is closing on nothing yet, and only its motion counts.
fn add_grasps(samples: &mut Samples, trajectory: &Trajectory, robot: &Robot) {
    if trajectory.efforts.is_empty() {
        return;
    }
    let (n, width) = (samples.joints, samples.width());
    for row in samples.rows.chunks_mut(width) {
        let efforts = super::efforts_at(&trajectory.efforts, n, row[0]);
        for (j, (joint, &effort)) in robot.joints.iter().zip(&efforts).enumerate() {
            let (Some(drive), true) = (joint.servo.drive(), effort < super::FULL_EFFORT) else {
                continue;
            };
            if row[1 + 2 * n + j].abs() > STILL_RAD_S {
                continue;
            }
            let squeeze = effort / 100.0 * drive.stall_torque.value;
            let torque = &mut row[1 + n + j];
            if torque.abs() < squeeze {
                *torque = squeeze.copysign(*torque);
            }
        }
    }
}

/// A servo output slower than this, rad/s, is held still (a grasp's closing has ended).
const STILL_RAD_S: f64 = 1e-3;

fn unchecked_reason(e: &DynamicsError) -> String {
    match e {
        DynamicsError::NoModel { hint, .. } if hint.is_empty() => {
            format!("{e} (the built-in arms have one; a robot file named like one uses its masses)")
        }
        _ => e.to_string(),
    }
}

/// "sts3215 c001 @ 5 V", every distinct one of the robot's servos, and the payload.
pub fn build_name(robot: &Robot) -> String {
    let mut builds: Vec<String> = Vec::new();
    for joint in &robot.joints {
        let s = drive_name(&joint.servo);
        if !builds.contains(&s) {
            builds.push(s);
        }
    }
    let arms = robot
        .arms
        .iter()
        .filter_map(|a| a.robot.payload.map(|p| (a.name.clone(), p)));
    let payloads: Vec<String> = robot
        .payload
        .map(|p| (String::new(), p))
        .into_iter()
        .chain(arms)
        .map(|(arm, p)| {
            let at = if arm.is_empty() {
                String::new()
            } else {
                format!(" on {arm}")
            };
            format!("{:.3} kg payload{at}", p.mass)
        })
        .collect();
    let mut name = builds.join(", ");
    if !payloads.is_empty() {
        name += &format!("; {}", payloads.join(", "));
    }
    name
}

fn drive_name(servo: &crate::robot::Servo) -> String {
    let variant = servo.variant.name;
    let model = servo.model.name();
    let head = if variant == model {
        model.to_string()
    } else {
        format!("{model} {variant}")
    };
    format!("{head} @ {} V", servo.supply_v)
}

/// Joint `j`'s peak, share of the line, RMS and time above its continuous rating.
fn summarise(j: usize, joint: &crate::robot::Joint, samples: &Samples) -> JointLoad {
    let drive = joint.servo.drive();
    let (mut peak, mut peak_time, mut share) = (0.0f64, 0.0, 0.0f64);
    let (mut square, mut above, mut total) = (0.0, 0.0, 0.0);
    for k in 0..samples.len() {
        let sample = samples.get(k);
        let t = sample.torques[j];
        if t.abs() > peak.abs() {
            peak = t;
            peak_time = sample.time;
        }
        if let Some(d) = drive {
            let available = d.available(sample.speeds[j], t);
            share = share.max(t.abs() / available.max(f64::MIN_POSITIVE));
        }
        // Trapezoid weights: each instant stands for half the time to its neighbours.
        let before = k
            .checked_sub(1)
            .map_or(0.0, |p| sample.time - samples.get(p).time);
        let after = if k + 1 < samples.len() {
            samples.get(k + 1).time - sample.time
        } else {
            0.0
        };
        let dt = 0.5 * (before + after);
        square += t * t * dt;
        total += dt;
        if drive.is_some_and(|d| t.abs() > d.continuous_torque()) {
            above += dt;
        }
    }
    let rms = if total > 0.0 {
        (square / total).sqrt()
    } else {
        peak.abs()
    };
    let continuous = drive.map(|d| d.continuous_torque());
    let duty_advice = continuous.filter(|&c| rms > c).map(|c| {
        format!(
            "{} carries {rms:.2} N·m RMS, above its continuous rating {c:.2} N·m (a fifth of \
             stall): in a loop it heats towards its overload protection; rest between loops, keep \
             the arm lower or closer in, carry less, or use stronger servos",
            joint.name
        )
    });
    JointLoad {
        joint: joint.name.clone(),
        drive: drive_name(&joint.servo),
        line: drive.map(|d| (d.stall_torque.value, d.no_load_speed.value)),
        peak_torque: peak,
        peak_time,
        peak_share: share,
        rms_torque: rms,
        continuous,
        time_above_continuous: if total > 0.0 { above / total } else { 0.0 },
        max_droop: 0.0,
        unit: joint.kind.unit(),
        duty_advice,
    }
}

/// Joint `j`'s stretches over its line.
fn over_line(
    trajectory: &Trajectory,
    robot: &Robot,
    dynamics: &Dynamics,
    j: usize,
    drive: &crate::servo::Drive,
    samples: &Samples,
) -> Vec<Overload> {
    let mut out: Vec<Overload> = Vec::new();
    for sample in samples.iter() {
        let (t, w) = (sample.torques[j], sample.speeds[j]);
        let available = drive.available(w, t);
        if t.abs() <= available + LINE_TOLERANCE * drive.stall_torque.value {
            continue;
        }
        let excess = t.abs() - available;
        match out.last_mut() {
            Some(last) if sample.time - last.to <= JOIN => {
                last.to = sample.time;
                if excess > last.torque.abs() - last.available {
                    last.peak_time = sample.time;
                    last.torque = t;
                    last.available = available;
                    last.speed = w;
                    last.holding = dynamics.holding_torques(sample.values)[j];
                }
            }
            _ => out.push(Overload {
                joint: robot.joints[j].name.clone(),
                segment: 0,
                segment_label: String::new(),
                from: sample.time,
                to: sample.time,
                peak_time: sample.time,
                torque: t,
                available,
                speed: w,
                holding: dynamics.holding_torques(sample.values)[j],
                advice: String::new(),
            }),
        }
    }
    for o in &mut out {
        o.segment = trajectory.segment_at(o.peak_time);
        o.segment_label = trajectory.segment_label(o.segment);
        o.advice = overload_advice(o, drive);
    }
    out
}

fn overload_advice(o: &Overload, drive: &crate::servo::Drive) -> String {
    if o.holding.abs() > drive.stall_torque.value {
        format!(
            "even held still this pose needs {:.2} N·m, above the servo's {:.2} N·m stall torque: \
             no timing helps; move the key lower or closer in, carry less, or use stronger servos",
            o.holding.abs(),
            drive.stall_torque.value
        )
    } else {
        format!(
            "slow the segment down ({:.2} N·m asked at {:.2} rad/s, the line gives {:.2}): \
             `keypose retime --fastest` keeps every joint under its line",
            o.torque.abs(),
            o.speed.abs(),
            o.available
        )
    }
}

/// The droop at each key (the pose held still), recorded per joint in `joints`; the keys past
/// the tolerance.
fn droops(
    trajectory: &Trajectory,
    robot: &Robot,
    dynamics: &Dynamics,
    joints: &mut [JointLoad],
) -> Vec<Droop> {
    let mut out = Vec::new();
    for (k, &time) in trajectory.key_times.iter().enumerate() {
        if time < trajectory.start - 1e-9 || time > trajectory.end + 1e-9 {
            continue;
        }
        let values = trajectory.sample(time);
        let holding = dynamics.holding_torques(&values);
        for (j, joint) in robot.joints.iter().enumerate() {
            let Some(drive) = joint.servo.drive() else {
                continue;
            };
            let shaft = drive.droop(holding[j].abs());
            let n = joint.servo.transmission(joint.kind);
            let droop = crate::dynamics::from_si(joint.kind, shaft * n);
            let tolerance = match joint.kind {
                JointKind::Revolute => SETTLED_TOLERANCE_DEG,
                JointKind::Prismatic => SETTLED_TOLERANCE_M,
            };
            joints[j].max_droop = joints[j].max_droop.max(droop);
            if droop <= tolerance {
                continue;
            }
            let (gain, value) = drive.gain;
            out.push(Droop {
                joint: joint.name.clone(),
                key: k,
                key_label: trajectory.key_labels[k].clone(),
                torque: holding[j],
                droop,
                tolerance,
                advice: format!(
                    "{} rests {droop:.1} {unit} off the key, past sim's settling tolerance of \
                     {tolerance} {unit}: {:.2} N·m of weight on a stiffness of {:.1} N·m/rad \
                     ({gain} {value}); play it with --compensate-droop, add a key lower, carry \
                     less, or use stiffer servos (the 12 V build)",
                    joint.name,
                    holding[j].abs(),
                    drive.stiffness.value,
                    unit = joint.kind.unit()
                ),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::Sequence;

    fn so101(text: &str) -> (Trajectory, Robot) {
        let robot = Robot::builtin("so101").unwrap();
        let sequence = Sequence::from_json("t.json", text).unwrap();
        (Trajectory::build(&sequence, &robot).unwrap(), robot)
    }

    #[test]
    fn a_payload_at_the_tcp_adds_its_weight_times_its_reach_at_the_shoulder() {
        // Held still with the arm stretched forward, 0.2 kg at the TCP loads shoulder_lift by
        // m·g times the TCP's horizontal distance from the lift axis (from the robot file's own
        // forward kinematics, not the model's tree).
        let mut robot = Robot::builtin("so101").unwrap();
        let values = vec![0.0, 60.0, -60.0, 0.0, 0.0, 0.0];
        let bare = Dynamics::for_robot(&robot)
            .unwrap()
            .holding_torques(&values);
        robot.payload = Some(crate::robot::Payload {
            mass: 0.2,
            com: glam::DVec3::ZERO,
        });
        let loaded = Dynamics::for_robot(&robot)
            .unwrap()
            .holding_torques(&values);
        let lift = 1;
        let (anchor, axis) = robot.joint_axes(&values)[lift];
        let tcp = robot.tcp_position(&values);
        let lever = (tcp - anchor)
            .cross(glam::DVec3::new(0.0, 0.0, -0.2 * 9.81))
            .dot(axis);
        let added = loaded[lift] - bare[lift];
        assert!(
            (added.abs() - lever.abs()).abs() < 1e-9,
            "{added} vs {lever}"
        );
        assert!(lever.abs() > 0.3, "a real lever: {lever}");
    }

    #[test]
    fn a_fast_swing_of_the_5_v_shoulder_is_over_its_line_and_a_slow_one_is_not() {
        // 1.35 N·m stall, 3.5 rad/s no load: 90° of shoulder_lift in 0.6 s asks ~2 rad/s and
        // more torque than the line gives there; in 3 s it does not.
        let fast = r#"{"format": "keypose-sequence/1", "robot": "so101", "interpolation": "cubic",
            "keyframes": [{"time": 0, "joints": {"shoulder_lift": -45, "elbow_flex": 0}},
                          {"time": 0.6, "joints": {"shoulder_lift": 45, "elbow_flex": 0}}]}"#;
        let (trajectory, robot) = so101(fast);
        let LoadScope::Checked(report) = check_loads(&trajectory, &robot, 1.0) else {
            panic!("the SO-101 has masses")
        };
        assert_eq!(report.build, "sts3215 c001 @ 5 V");
        let o = report
            .overloads
            .iter()
            .find(|o| o.joint == "shoulder_lift")
            .expect("over the line");
        assert!(o.torque.abs() > o.available);
        assert!(o.advice.contains("retime --fastest"), "{}", o.advice);
        let slow = fast.replace("\"time\": 0.6", "\"time\": 3.0");
        let (trajectory, robot) = so101(&slow);
        let LoadScope::Checked(report) = check_loads(&trajectory, &robot, 1.0) else {
            panic!()
        };
        assert!(report.overloads.is_empty(), "{:?}", report.overloads);
    }

    #[test]
    fn the_arm_stretched_out_droops_past_the_tolerance_and_home_does_not() {
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"name": "home", "time": 0, "joints": {"shoulder_lift": 0}},
                          {"name": "out", "time": 3, "joints": {"shoulder_lift": 80, "elbow_flex": -80}}]}"#;
        let (trajectory, robot) = so101(text);
        let LoadScope::Checked(report) = check_loads(&trajectory, &robot, 1.0) else {
            panic!()
        };
        let d = report
            .droops
            .iter()
            .find(|d| d.joint == "shoulder_lift")
            .expect("the stretched arm droops");
        assert_eq!(d.key_label, "out");
        // Weight over 6 N·m/rad, in degrees.
        assert!((d.droop - (d.torque.abs() / 6.0).to_degrees()).abs() < 1e-9);
        assert!(report
            .droops
            .iter()
            .all(|d| d.key != 0 || d.joint != "shoulder_lift"));
    }

    #[test]
    fn a_grasp_held_at_an_effort_carries_that_share_of_stall_while_it_holds() {
        // Closed in 1 s, then held 9 s at 30 %: the motion itself needs next to nothing of the
        // gripper, so its RMS is the squeeze over nine tenths of the time.
        let (trajectory, robot) = so101(
            r#"{"format":"keypose-sequence/1","robot":"so101","interpolation":"monotone","keyframes":[
            {"time":0,"joints":{"gripper":40}},
            {"time":1,"hold":9,"joints":{"gripper":0},"effort":{"gripper":30}}]}"#,
        );
        let LoadScope::Checked(report) = check_loads(&trajectory, &robot, 1.0) else {
            panic!("the SO-101 is modelled");
        };
        let gripper = report.joints.iter().find(|j| j.joint == "gripper").unwrap();
        let stall = robot.joints[5].servo.drive().unwrap().stall_torque.value;
        let expected = 0.3 * stall * 0.9f64.sqrt();
        assert!(
            (gripper.rms_torque - expected).abs() < 0.03 * expected,
            "RMS {} N·m, expected {expected} N·m",
            gripper.rms_torque
        );
        // 30 % of stall is above the continuous rating (a fifth): held that long, it heats.
        assert!(gripper.duty_advice.is_some());
    }

    #[test]
    fn a_robot_file_without_a_model_is_not_checked_and_says_why() {
        let mut robot = Robot::builtin("so101").unwrap();
        robot.name = "my-arm".into();
        let text = r#"{"format": "keypose-sequence/1", "robot": "so101",
            "keyframes": [{"time": 0, "joints": {"shoulder_lift": 0}}, {"time": 1, "joints": {"shoulder_lift": 10}}]}"#;
        let (trajectory, _) = so101(text);
        let LoadScope::Unchecked(why) = check_loads(&trajectory, &robot, 1.0) else {
            panic!()
        };
        assert!(why.contains("my-arm"), "{why}");
    }
}
