//! Tool keys solved as a person would (`Solver::solve_key`) on random reachable targets, on every
//! built-in: success rate, solve time (median and 90th percentile), and what the chosen poses
//! are like (comfortable, clear), against the nearest solution (`Solver::solve`, what a jog
//! takes) on the same targets in the same run. Gripper-down keys too. The machine's load is
//! printed: times on a shared machine are read as the ratio to the peer measured beside them.
//!
//! `cargo bench --bench tool_keys` (no criterion: each target is solved once per solver, timed,
//! and the answers checked before anything is printed).

use glam::DVec3;
use keypose::collision::CollisionModel;
use keypose::kinematics::{
    lowest_below_floor, smallest_margin, tool_joints, Approach, KeyOrientation, KeyTarget,
    Preference, Solver, ToolTarget, COMFORT,
};
use keypose::robot::Robot;
use std::hint::black_box;
use std::time::{Duration, Instant};

const TARGETS: usize = 300;
const ROBOTS: [&str; 4] = ["so101", "so100", "koch", "omx"];

/// A linear congruential sequence: the same targets on every run.
struct Lcg(u64);

impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Reachable targets: tool positions of random poses inside 90 % of each tool joint's range,
/// above the floor (skeleton and tool 2 cm up) and touching nothing in the collision model.
fn targets(robot: &Robot, model: Option<&CollisionModel>, rng: &mut Lcg) -> Vec<DVec3> {
    let tool = tool_joints(robot);
    let mut out = Vec::with_capacity(TARGETS);
    while out.len() < TARGETS {
        let values: Vec<f64> = robot
            .joints
            .iter()
            .zip(&tool)
            .map(|(j, &t)| {
                let (lo, hi) = (j.limits.min, j.limits.max);
                if t {
                    0.5 * (lo + hi) + (rng.unit() - 0.5) * 0.9 * (hi - lo)
                } else {
                    0f64.clamp(lo, hi)
                }
            })
            .collect();
        let clear = model.is_none_or(|m| m.touches(&values, 0.0).is_empty());
        if clear
            && lowest_below_floor(robot, &values).is_none()
            && robot.tcp_position(&values).z > 0.02
        {
            out.push(robot.tcp_position(&values));
        }
    }
    out
}

/// Median and 90th percentile, microseconds.
fn percentiles(mut times: Vec<Duration>) -> (f64, f64) {
    if times.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    times.sort();
    let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize].as_secs_f64() * 1e6;
    (at(0.5), at(0.9))
}

/// What one solver did on one robot's targets.
#[derive(Default)]
struct Tally {
    solved: usize,
    /// On target (0.1 mm) and inside the limits, by the forward kinematics.
    correct: usize,
    comfortable: usize,
    clear: usize,
    times: Vec<Duration>,
}

impl Tally {
    fn add(
        &mut self,
        robot: &Robot,
        model: Option<&CollisionModel>,
        target: DVec3,
        answer: Option<Vec<f64>>,
        took: Duration,
    ) {
        self.times.push(took);
        let Some(values) = answer else {
            return;
        };
        self.solved += 1;
        let inside = robot
            .joints
            .iter()
            .zip(&values)
            .all(|(j, &v)| j.limits.contains(v));
        if inside && robot.tcp_position(&values).distance(target) < 1e-4 {
            self.correct += 1;
        }
        let tool = tool_joints(robot);
        if smallest_margin(robot, &values, &tool).is_some_and(|m| m.share >= COMFORT - 1e-9) {
            self.comfortable += 1;
        }
        if model.is_none_or(|m| m.touches(&values, 0.0).is_empty()) {
            self.clear += 1;
        }
    }

    fn row(&self, robot: &str, what: &str, targets: usize, peer_median: f64) -> String {
        let (median, p90) = percentiles(self.times.clone());
        let share = |n: usize| 100.0 * n as f64 / targets as f64;
        format!(
            "| {robot} | {what} | {:.1} % ({}/{targets}) | {:.1} % | {:.1} % | {:.1} % | {median:.1} µs | {p90:.1} µs | {:.1}× |",
            share(self.solved),
            self.solved,
            share(self.correct),
            share(self.comfortable),
            share(self.clear),
            median / peer_median
        )
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn main() {
    // `cargo bench` passes --bench; a filter argument is not used.
    println!(
        "tool keys on {TARGETS} random reachable targets per robot, seed = home; load average {} on {} CPUs",
        load_average(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    println!("| robot | solver | solved | on target, in limits | comfortable (≥ 25 %) | clear | median | 90th pct. | median vs nearest |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut rng = Lcg(0x7475_6e65);
    for name in ROBOTS {
        let robot = Robot::builtin(name).expect("built-in");
        let model = CollisionModel::for_robot(&robot);
        let solver = Solver::for_robot(&robot);
        let held = vec![false; robot.joints.len()];
        let targets = targets(&robot, model.as_ref(), &mut rng);
        let preference = Preference {
            seed: &robot.home,
            held: &held,
            collision: model.as_ref(),
        };
        let mut nearest = Tally::default();
        let mut key = Tally::default();
        for &target in &targets {
            let start = Instant::now();
            let answer = solver.solve(&robot, &ToolTarget::position(target), &robot.home, &held);
            let took = start.elapsed();
            let answer = black_box(answer).ok().map(|s| s.values);
            nearest.add(&robot, model.as_ref(), target, answer, took);

            let asked = KeyTarget {
                position: target,
                orientation: KeyOrientation::Free,
            };
            let start = Instant::now();
            let answer = solver.solve_key(&robot, &asked, &preference);
            let took = start.elapsed();
            let answer = black_box(answer).ok().map(|c| c.solution.values);
            key.add(&robot, model.as_ref(), target, answer, took);
        }
        let peer = percentiles(nearest.times.clone()).0;
        println!("{}", nearest.row(name, "nearest (solve)", TARGETS, peer));
        println!("{}", key.row(name, "key (solve_key)", TARGETS, peer));

        // Gripper down, tilted where it must be, at the same targets.
        let mut down = Tally::default();
        let mut straight = 0;
        for &target in &targets {
            let asked = KeyTarget {
                position: target,
                orientation: KeyOrientation::Approach(Approach::down(true)),
            };
            let start = Instant::now();
            let answer = solver.solve_key(&robot, &asked, &preference);
            let took = start.elapsed();
            let answer = black_box(answer).ok();
            if answer
                .as_ref()
                .is_some_and(|c| c.tilt_deg.is_some_and(|t| t < 0.05))
            {
                straight += 1;
            }
            down.add(
                &robot,
                model.as_ref(),
                target,
                answer.map(|c| c.solution.values),
                took,
            );
        }
        println!(
            "{} (straight down: {straight})",
            down.row(name, "key, down-or-tilted", TARGETS, peer)
        );
    }
}
