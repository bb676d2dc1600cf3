//! Clearance along a whole motion, certified: no contact can hide between two evaluated
//! instants.
//!
//! A motion is a pose for each parameter value (a time, or a fraction of a straight move) and,
//! for any interval, how far each joint strays from its value at the interval's middle. With
//! the model's reach (`reach`: how far a body's points move per unit of each joint's change),
//! the distance of every pair at the middle, less both bodies' reach over the interval, bounds
//! the pair's distance everywhere in it from below. Where that bound clears, the interval is
//! clear for that pair; where it does not, the interval is halved and only the pairs not yet
//! cleared are looked at again. An interval whose middle is closer than the clearance is a
//! contact, refined to `resolution`; one that can neither be cleared nor found in contact down
//! to `finest` is reported as a contact at the bound (it cannot be ruled out).

use super::CollisionModel;

/// A motion the sweep follows.
pub(crate) trait Motion {
    /// How many joints a pose has (the robot's).
    fn joints(&self) -> usize;
    /// The pose at `s` (robot order, joint units).
    fn pose(&self, s: f64, out: &mut [f64]);
    /// For each joint, the most it differs anywhere on [a, b] from its value at `middle`, into
    /// `out` (joint units; an upper bound is enough).
    fn deviation(&self, a: f64, b: f64, middle: f64, out: &mut [f64]);
}

/// How closely the sweep looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Resolution {
    /// A pair closer than this, metres, is a contact.
    pub clearance: f64,
    /// Intervals of a contact are refined down to this width (parameter units): how exactly
    /// its start and end are reported.
    pub contact: f64,
    /// The narrowest interval the sweep halves to certify a clear pair; narrower than this,
    /// what it cannot clear is reported as a contact at the bound.
    pub finest: f64,
}

/// One interval of a pair closer than the clearance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Near {
    /// The pair (`CollisionModel::pairs`).
    pub pair: usize,
    /// The interval, parameter units.
    pub from: f64,
    pub to: f64,
    /// Where in it the distance was found.
    pub at: f64,
    /// The pair's signed distance there, metres; or, where `certain` is false, the lower bound
    /// that could not be cleared.
    pub distance: f64,
    /// Whether `distance` was measured (a contact) rather than a bound not cleared.
    pub certain: bool,
}

/// Every interval of `[from, to]` where a pair of `model` may be closer than
/// `resolution.clearance` along `motion`, in order of the parameter; empty when the motion is
/// certified clear.
pub(crate) fn sweep(
    model: &CollisionModel,
    motion: &dyn Motion,
    from: f64,
    to: f64,
    resolution: Resolution,
) -> Vec<Near> {
    let n = motion.joints();
    let mut pose = vec![0.0; n];
    let mut deviation = vec![0.0; n];
    let mut found = Vec::new();
    let all: Vec<usize> = (0..model.pairs().len()).collect();
    // Depth first, the earlier half on top, so that what is found comes out in order.
    let mut stack: Vec<(f64, f64, Vec<usize>)> = vec![(from, to, all)];
    while let Some((a, b, active)) = stack.pop() {
        let middle = 0.5 * (a + b);
        motion.pose(middle, &mut pose);
        motion.deviation(a, b, middle, &mut deviation);
        let placed = model.placed(&pose);
        let width = b - a;
        let mut open = Vec::new();
        for p in active {
            let d = model.pair_distance(&placed, p);
            if d < resolution.clearance && width <= resolution.contact {
                found.push(Near {
                    pair: p,
                    from: a,
                    to: b,
                    at: middle,
                    distance: d,
                    certain: true,
                });
                continue;
            }
            let bound = d - model.pair_reach(p, &deviation);
            if bound >= resolution.clearance {
                continue;
            }
            if width <= resolution.finest {
                found.push(Near {
                    pair: p,
                    from: a,
                    to: b,
                    at: middle,
                    distance: bound,
                    certain: false,
                });
                continue;
            }
            open.push(p);
        }
        if !open.is_empty() {
            stack.push((middle, b, open.clone()));
            stack.push((a, middle, open));
        }
    }
    found
}

/// A straight move in joint space from one pose to another, over [0, 1].
pub(crate) struct Line<'a> {
    pub from: &'a [f64],
    pub to: &'a [f64],
}

impl Motion for Line<'_> {
    fn joints(&self) -> usize {
        self.from.len()
    }

    fn pose(&self, s: f64, out: &mut [f64]) {
        for ((slot, a), b) in out.iter_mut().zip(self.from).zip(self.to) {
            *slot = a + (b - a) * s;
        }
    }

    fn deviation(&self, a: f64, b: f64, middle: f64, out: &mut [f64]) {
        let reach = (middle - a).max(b - middle);
        for ((slot, x), y) in out.iter_mut().zip(self.from).zip(self.to) {
            *slot = (y - x).abs() * reach;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    const RESOLUTION: Resolution = Resolution {
        clearance: 0.0,
        contact: 1e-3,
        finest: 1e-7,
    };

    /// The SO-101's wrist swung from −85.5° to +85.5° with the elbow at 30° points the gripper
    /// at the desk on the way (from about 38°, tests in `collision`): the sweep finds it, on
    /// the floor, and certifies the part that stops short of the desk.
    #[test]
    fn a_swing_through_the_desk_is_found_and_a_clear_one_certified() {
        let robot = Robot::builtin("so101").unwrap();
        let model = CollisionModel::for_robot(&robot).unwrap();
        let pose = |wrist: f64| vec![0.0, 0.0, 30.0, wrist, 0.0, 0.0];
        let (from, to) = (pose(-85.5), pose(85.5));
        let through = sweep(
            &model,
            &Line {
                from: &from,
                to: &to,
            },
            0.0,
            1.0,
            RESOLUTION,
        );
        assert!(!through.is_empty());
        assert!(through.iter().all(|n| model.pairs()[n.pair].b.is_none()));
        // What is found is below the clearance: measured inside the contact, a bound that does
        // not clear at its edges.
        assert!(through.iter().any(|n| n.certain));
        assert!(through.iter().all(|n| n.distance < 0.0));
        let wrist_at = |s: f64| -85.5 + 171.0 * s;
        let seen: Vec<f64> = through.iter().map(|n| wrist_at(n.at)).collect();
        // The gripper reaches the desk at about 38° and leaves it before the clear end.
        let first = seen.iter().copied().fold(f64::INFINITY, f64::min);
        assert!((35.0..40.0).contains(&first), "{seen:?}");
        assert!(seen.iter().all(|&w| w < 85.0), "{seen:?}");
        let short = pose(20.0);
        assert_eq!(
            sweep(
                &model,
                &Line {
                    from: &from,
                    to: &short
                },
                0.0,
                1.0,
                RESOLUTION
            ),
            vec![]
        );
    }

    /// A dip shorter than any sampling grid: the wrist goes into the desk and out again
    /// within 1/1000 of the move, and the sweep still finds it.
    #[test]
    fn a_dip_of_a_thousandth_of_the_move_is_found() {
        struct Dip;
        impl Motion for Dip {
            fn joints(&self) -> usize {
                6
            }
            fn pose(&self, s: f64, out: &mut [f64]) {
                out.copy_from_slice(&[0.0, 0.0, 30.0, wrist(s), 0.0, 0.0]);
            }
            fn deviation(&self, a: f64, b: f64, middle: f64, out: &mut [f64]) {
                // The tent is monotone on each side of its peak: its extremes are at the ends
                // and the peak.
                let centre = wrist(middle);
                let mut most = (wrist(a) - centre).abs().max((wrist(b) - centre).abs());
                if a < PEAK && PEAK < b {
                    most = most.max((wrist(PEAK) - centre).abs());
                }
                out.fill(0.0);
                out[3] = most;
            }
        }
        const PEAK: f64 = 0.61803;
        // −60° everywhere but a tent up to +38° within ±0.0005 of PEAK.
        fn wrist(s: f64) -> f64 {
            let x = 1.0 - (s - PEAK).abs() / 0.0005;
            -60.0 + 98.0 * x.max(0.0)
        }
        let robot = Robot::builtin("so101").unwrap();
        let model = CollisionModel::for_robot(&robot).unwrap();
        let found = sweep(&model, &Dip, 0.0, 1.0, RESOLUTION);
        assert!(!found.is_empty(), "a one-in-a-thousand dip went unseen");
        assert!(found
            .iter()
            .all(|n| (n.at - PEAK).abs() < 0.0005 && n.distance < 0.0));
        // 100 evenly spaced samples, as a sampled check would take, all miss it.
        let mut values = vec![0.0; 6];
        for k in 0..=100 {
            Dip.pose(k as f64 / 100.0, &mut values);
            assert_eq!(model.touches(&values, 0.0), vec![]);
        }
    }
}
