//! Verdicts on a simulated run. Python measures; Rust decides (DESIGN.md): every threshold is
//! here, applied to a [`Trace`] in joint units (degrees, metres, seconds).

use crate::robot::{JointKind, Robot};

/// One simulated run, in joint units, one row per control cycle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    /// Seconds since the start of the run.
    pub time: Vec<f64>,
    /// The sequence time each row belongs to, or `None` during the approach ramp.
    pub sequence_time: Vec<Option<f64>>,
    /// commanded[row][joint]
    pub commanded: Vec<Vec<f64>>,
    pub position: Vec<Vec<f64>>,
    /// Joint units per second.
    pub velocity: Vec<Vec<f64>>,
    /// Actuator force or torque (N·m, N).
    pub force: Vec<Vec<f64>>,
    /// A joint-limit constraint was active.
    pub at_limit: Vec<Vec<bool>>,
    pub contacts: Vec<Contact>,
    pub divergence: Vec<(f64, String)>,
    /// Actuator force limits per joint (None: unlimited).
    pub force_limits: Vec<Option<f64>>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    pub time: f64,
    pub body1: String,
    pub body2: String,
    pub kind: ContactKind,
    /// Penetration, metres (positive).
    pub depth: f64,
    /// Normal force, newtons.
    pub force: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactKind {
    Floor,
    SelfCollision,
    Environment,
}

impl ContactKind {
    pub fn name(self) -> &'static str {
        match self {
            ContactKind::Floor => "floor",
            ContactKind::SelfCollision => "self",
            ContactKind::Environment => "environment",
        }
    }
}

/// The thresholds of a verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// Largest tracking error, degrees (revolute) during motion.
    pub max_error_deg: f64,
    /// Largest tracking error, metres (prismatic).
    pub max_error_m: f64,
    /// Error allowed once the arm has settled at a key, degrees / metres.
    pub settled_error_deg: f64,
    pub settled_error_m: f64,
    /// How long after a key (or the end of its hold) the arm has to settle, seconds.
    pub settle_time: f64,
    /// Saturation shorter than this is normal during fast moves, seconds.
    pub saturation_time: f64,
    /// Share of the force limit that counts as saturated.
    pub saturation_share: f64,
    /// Contacts shallower than this are resting touches, not collisions, metres.
    pub contact_depth: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            max_error_deg: 15.0,
            max_error_m: 0.005,
            settled_error_deg: 3.0,
            settled_error_m: 0.002,
            settle_time: 0.5,
            saturation_time: 0.25,
            saturation_share: 0.98,
            contact_depth: 0.0005,
        }
    }
}

/// Per-joint tracking figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracking {
    pub joint: String,
    pub unit: &'static str,
    pub max_error: f64,
    pub max_error_time: f64,
    pub rms_error: f64,
    /// (key label, sequence time, error) after settling at each key.
    pub settled: Vec<(String, f64, f64)>,
    pub peak_speed_servo_deg_s: f64,
    pub servo_speed_limit_deg_s: f64,
}

/// Something the simulation caught.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub kind: &'static str,
    pub joint: Option<String>,
    pub time: f64,
    pub message: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    pub tracking: Vec<Tracking>,
    pub findings: Vec<Finding>,
}

impl Verdict {
    pub fn passed(&self) -> bool {
        self.findings.is_empty()
    }
}

/// Key times and labels in sequence time, for settling checks.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyMark {
    pub label: String,
    /// When the arm should be at the key and still: the key time plus its hold.
    pub settle_from: f64,
}

pub fn judge(robot: &Robot, trace: &Trace, keys: &[KeyMark], t: &Thresholds) -> Verdict {
    let mut findings = Vec::new();
    let mut tracking = Vec::new();
    let rows = trace.time.len();
    for (j, joint) in robot.joints.iter().enumerate() {
        let revolute = joint.kind == JointKind::Revolute;
        let (max_allowed, settled_allowed) = if revolute {
            (t.max_error_deg, t.settled_error_deg)
        } else {
            (t.max_error_m, t.settled_error_m)
        };
        let error = |row: usize| (trace.position[row][j] - trace.commanded[row][j]).abs();
        let (max_error, max_time) = peak(trace, error);
        let sum_sq: f64 = (0..rows).map(|row| error(row).powi(2)).sum();
        if max_error > max_allowed {
            findings.push(Finding {
                kind: "tracking",
                joint: Some(joint.name.clone()),
                time: max_time,
                message: format!(
                    "tracking error {max_error:.3} {} exceeds {max_allowed} {}",
                    joint.kind.unit(),
                    joint.kind.unit()
                ),
            });
        }
        let mut settled = Vec::new();
        for key in keys {
            let at = key.settle_from + t.settle_time;
            let Some(row) = trace
                .sequence_time
                .iter()
                .position(|s| s.is_some_and(|s| s >= at - 1e-9))
            else {
                continue;
            };
            let e = error(row);
            if e > settled_allowed {
                findings.push(Finding {
                    kind: "settling",
                    joint: Some(joint.name.clone()),
                    time: trace.time[row],
                    message: format!(
                        "{e:.3} {} off key {} {:.2} s after it (allowed {settled_allowed})",
                        joint.kind.unit(),
                        key.label,
                        t.settle_time
                    ),
                });
            }
            settled.push((key.label.clone(), key.settle_from, e));
        }

        // Speed of the servo's output shaft: joint speed through the servo's tick mapping.
        let deg_per_tick = crate::robot::servo::DEGREES_PER_TICK;
        let servo_speed = |v: f64| (v / joint.servo.units_per_tick).abs() * deg_per_tick;
        let limit = joint.servo.model.no_load_speed_deg_s();
        let (top_speed, top_speed_time) = peak(trace, |row| servo_speed(trace.velocity[row][j]));
        if top_speed > limit {
            findings.push(Finding {
                kind: "speed",
                joint: Some(joint.name.clone()),
                time: top_speed_time,
                message: format!(
                    "servo speed {top_speed:.0} °/s beyond the {} no-load speed {limit:.0} °/s",
                    joint.servo.model.name()
                ),
            });
        }
        // The command itself asking for more than the servo can do: the physics then lags and
        // saturates, but this names the cause.
        let dt = |row: usize| trace.time[row] - trace.time[row - 1];
        if let Some(row) = (1..rows).find(|&r| {
            dt(r) > 0.0
                && servo_speed((trace.commanded[r][j] - trace.commanded[r - 1][j]) / dt(r)) > limit
        }) {
            let asked =
                servo_speed((trace.commanded[row][j] - trace.commanded[row - 1][j]) / dt(row));
            findings.push(Finding {
                kind: "speed",
                joint: Some(joint.name.clone()),
                time: trace.time[row],
                message: format!(
                    "commanded {asked:.0} °/s at the servo, beyond the {} no-load speed {limit:.0} °/s",
                    joint.servo.model.name()
                ),
            });
        }

        if let Some(row) = (0..rows).find(|&r| trace.at_limit[r][j]) {
            findings.push(Finding {
                kind: "joint limit",
                joint: Some(joint.name.clone()),
                time: trace.time[row],
                message: "the joint ran into its stop".into(),
            });
        }

        if let Some(limit) = trace.force_limits.get(j).copied().flatten() {
            if let Some((start, end)) = longest_run(rows, |r| {
                trace.force[r][j].abs() >= t.saturation_share * limit
            }) {
                let seconds = trace.time[end] - trace.time[start];
                if seconds >= t.saturation_time {
                    findings.push(Finding {
                        kind: "saturation",
                        joint: Some(joint.name.clone()),
                        time: trace.time[start],
                        message: format!(
                            "actuator at its force limit ({limit}) for {seconds:.2} s"
                        ),
                    });
                }
            }
        }

        tracking.push(Tracking {
            joint: joint.name.clone(),
            unit: joint.kind.unit(),
            max_error,
            max_error_time: max_time,
            rms_error: if rows > 0 {
                (sum_sq / rows as f64).sqrt()
            } else {
                0.0
            },
            settled,
            peak_speed_servo_deg_s: top_speed,
            servo_speed_limit_deg_s: limit,
        });
    }

    // One finding per colliding pair and kind: the deepest.
    let mut worst: Vec<&Contact> = Vec::new();
    for c in trace.contacts.iter().filter(|c| c.depth >= t.contact_depth) {
        match worst
            .iter_mut()
            .find(|w| w.kind == c.kind && w.body1 == c.body1 && w.body2 == c.body2)
        {
            Some(w) if w.depth < c.depth => *w = c,
            Some(_) => {}
            None => worst.push(c),
        }
    }
    for c in worst {
        findings.push(Finding {
            kind: match c.kind {
                ContactKind::Floor => "floor collision",
                ContactKind::SelfCollision => "self collision",
                ContactKind::Environment => "collision",
            },
            joint: None,
            time: c.time,
            message: format!(
                "{} touches {}: {:.1} mm deep, {:.1} N",
                c.body1,
                c.body2,
                c.depth * 1000.0,
                c.force
            ),
        });
    }
    for (time, message) in &trace.divergence {
        findings.push(Finding {
            kind: "divergence",
            joint: None,
            time: *time,
            message: message.clone(),
        });
    }
    findings.sort_by(|a, b| a.time.total_cmp(&b.time));
    Verdict { tracking, findings }
}

/// The longest run of consecutive rows where `hit` holds: (first row, last row).
/// The largest `value(row)` over the trace (at least 0) and the time of its first row.
fn peak(trace: &Trace, value: impl Fn(usize) -> f64) -> (f64, f64) {
    (0..trace.time.len()).fold((0.0, 0.0), |(best, at), row| {
        let v = value(row);
        if v > best {
            (v, trace.time[row])
        } else {
            (best, at)
        }
    })
}

fn longest_run(rows: usize, hit: impl Fn(usize) -> bool) -> Option<(usize, usize)> {
    let mut best: Option<(usize, usize)> = None;
    let mut start = None;
    for r in 0..rows {
        match (hit(r), start) {
            (true, None) => start = Some(r),
            (false, Some(s)) => {
                if best.is_none_or(|(a, b)| r - 1 - s > b - a) {
                    best = Some((s, r - 1));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        if best.is_none_or(|(a, b)| rows - 1 - s > b - a) {
            best = Some((s, rows - 1));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic 2 s run at 100 Hz of the so101: every joint tracks perfectly unless a test
    /// changes it.
    fn perfect(robot: &Robot) -> Trace {
        let rows = 200;
        let n = robot.joints.len();
        Trace {
            time: (0..rows).map(|r| r as f64 / 100.0).collect(),
            sequence_time: (0..rows).map(|r| Some(r as f64 / 100.0)).collect(),
            commanded: vec![vec![0.0; n]; rows],
            position: vec![vec![0.0; n]; rows],
            velocity: vec![vec![0.0; n]; rows],
            force: vec![vec![0.0; n]; rows],
            at_limit: vec![vec![false; n]; rows],
            contacts: Vec::new(),
            divergence: Vec::new(),
            force_limits: vec![Some(3.35); n],
        }
    }

    fn kinds(v: &Verdict) -> Vec<&'static str> {
        v.findings.iter().map(|f| f.kind).collect()
    }

    #[test]
    fn a_perfect_run_passes_with_zero_error() {
        let robot = Robot::builtin("so101").unwrap();
        let v = judge(&robot, &perfect(&robot), &[], &Thresholds::default());
        assert!(v.passed(), "{:?}", v.findings);
        assert!(v
            .tracking
            .iter()
            .all(|t| t.max_error == 0.0 && t.rms_error == 0.0));
    }

    #[test]
    fn tracking_error_max_and_rms_are_computed_by_hand() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // Elbow lags 4° for the first half (100 rows) and 0 after: RMS = √(100·16/200) = √8.
        for row in 0..100 {
            trace.position[row][2] = 4.0;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(v.tracking[2].max_error, 4.0);
        assert!((v.tracking[2].rms_error - 8f64.sqrt()).abs() < 1e-12);
        assert!(v.passed(), "4° is within the 15° allowed in motion");
        trace.position[150][2] = 16.0;
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["tracking"]);
        assert_eq!(v.findings[0].time, 1.5);
    }

    #[test]
    fn an_arm_that_has_not_settled_half_a_second_after_a_key_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // 5° off from t = 1.0 on; the key at 0.4 s settles by 0.9 s, so it is judged at 0.9 s
        // (fine) and the key at 0.6 s at 1.1 s (5° off: fails).
        for row in 100..200 {
            trace.position[row][1] = 5.0;
        }
        let keys = [
            KeyMark {
                label: "a".into(),
                settle_from: 0.4,
            },
            KeyMark {
                label: "b".into(),
                settle_from: 0.6,
            },
        ];
        let v = judge(&robot, &trace, &keys, &Thresholds::default());
        assert_eq!(kinds(&v), ["settling"]);
        assert!(v.findings[0].message.contains("key b"));
        assert_eq!(v.tracking[1].settled[0].2, 0.0);
        assert_eq!(v.tracking[1].settled[1].2, 5.0);
    }

    #[test]
    fn momentary_saturation_passes_sustained_saturation_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // 20 rows = 0.19 s at the limit: momentary.
        for row in 10..30 {
            trace.force[row][1] = -3.35;
        }
        assert!(judge(&robot, &trace, &[], &Thresholds::default()).passed());
        // 40 rows = 0.39 s: sustained.
        for row in 50..90 {
            trace.force[row][1] = 3.34;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["saturation"]);
        assert_eq!(v.findings[0].time, 0.5);
    }

    #[test]
    fn speeds_beyond_the_servo_limits_fail() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // STS3215 on 5 V: 200 °/s no-load; 199 passes, 201 fails.
        trace.velocity[50][0] = 199.0;
        assert!(judge(&robot, &trace, &[], &Thresholds::default()).passed());
        trace.velocity[60][0] = -201.0;
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["speed"]);
        assert!((v.tracking[0].peak_speed_servo_deg_s - 201.0).abs() < 1e-9);
    }

    #[test]
    fn a_command_faster_than_the_servo_fails() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        // 2.5° in one 10 ms cycle is 250 °/s, beyond the STS3215's 200 °/s on 5 V.
        for row in 100..200 {
            trace.commanded[row][4] = 2.5;
            trace.position[row][4] = 2.5;
        }
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(kinds(&v), ["speed"]);
        assert!(
            v.findings[0].message.contains("commanded 250 °/s"),
            "{}",
            v.findings[0].message
        );
        assert_eq!(v.findings[0].time, 1.0);
    }

    #[test]
    fn limits_contacts_and_divergence_are_reported_once_each() {
        let robot = Robot::builtin("so101").unwrap();
        let mut trace = perfect(&robot);
        trace.at_limit[70][3] = true;
        trace.at_limit[71][3] = true;
        let contact = |time, depth, kind| Contact {
            time,
            body1: "gripper".into(),
            body2: "floor".into(),
            kind,
            depth,
            force: 2.0,
        };
        trace.contacts = vec![
            contact(0.8, 0.0001, ContactKind::Floor), // a resting touch: ignored
            contact(0.9, 0.003, ContactKind::Floor),
            contact(1.0, 0.004, ContactKind::Floor),
            contact(1.1, 0.002, ContactKind::SelfCollision),
        ];
        trace.divergence = vec![(1.5, "mjWARN_BADQACC".into())];
        let v = judge(&robot, &trace, &[], &Thresholds::default());
        assert_eq!(
            kinds(&v),
            [
                "joint limit",
                "floor collision",
                "self collision",
                "divergence"
            ]
        );
        assert!(v.findings[1].message.contains("4.0 mm deep"));
    }
}
