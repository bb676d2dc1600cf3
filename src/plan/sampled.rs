//! The trajectory sampled on an even grid, for plots and tables (the limit check is exact and
//! samples nothing).

use super::Trajectory;

/// Every joint sampled on an even grid that spans the played window exactly.
#[derive(Debug, Clone)]
pub struct Sampled {
    /// Sequence time of each sample, seconds, from the played window's start to its end.
    pub times: Vec<f64>,
    /// Grid spacing, at most 1/rate.
    pub dt: f64,
    /// `positions[joint][k]`
    pub positions: Vec<Vec<f64>>,
}

impl Sampled {
    /// Samples `trajectory` at `rate` Hz or a little faster, so that the grid ends on the
    /// window's end.
    pub fn new(trajectory: &Trajectory, rate: f64) -> Sampled {
        let span = trajectory.duration();
        let steps = ((span * rate).ceil() as usize).max(1);
        let dt = if span > 0.0 {
            span / steps as f64
        } else {
            1.0 / rate
        };
        let times: Vec<f64> = (0..=steps)
            .map(|k| trajectory.start + k as f64 * dt)
            .collect();
        let joints = trajectory.joint_names.len();
        let mut positions = vec![vec![0.0; times.len()]; joints];
        let mut sampler = trajectory.sampler();
        let mut pose = vec![0.0; joints];
        for (k, &t) in times.iter().enumerate() {
            sampler.sample_into(t, &mut pose);
            for (series, &value) in positions.iter_mut().zip(&pose) {
                series[k] = value;
            }
        }
        Sampled {
            times,
            dt,
            positions,
        }
    }

    /// Velocity of a joint at each grid time (central differences, one-sided at the ends).
    pub fn velocity_at_samples(&self, joint: usize) -> Vec<f64> {
        let p = &self.positions[joint];
        let n = p.len();
        (0..n)
            .map(|k| {
                let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
                if b == a {
                    0.0
                } else {
                    (p[b] - p[a]) / ((b - a) as f64 * self.dt)
                }
            })
            .collect()
    }
}
