//! LeRobot's normalised motor values and raw ticks, both ways, exactly as LeRobot's motor bus
//! turns them (docs/interop.md §1.4; LeRobot's `motors_bus.py::_normalize` and `_unnormalize`).
//!
//! keypose drives a LeRobot robot object through its own `send_action` and `get_observation`,
//! which take and give normalised values. The player's goals are ticks (its position guard makes
//! them), so each goal tick is handed to LeRobot as the value LeRobot turns back into that very
//! tick: LeRobot's `_unnormalize` truncates towards zero (`int(...)`), so the value sent is the
//! middle of the tick's interval, where float noise cannot move it to a neighbour.

/// How LeRobot normalises one motor (`MotorNormMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormMode {
    /// `DEGREES`: `(raw − mid) · 360 / (resolution − 1)`, `mid` the middle of the recorded range.
    Degrees,
    /// `RANGE_M100_100`: the recorded range onto −100 … 100.
    Range,
    /// `RANGE_0_100`: the recorded range onto 0 … 100 (the SO and Koch grippers).
    Percent,
}

impl NormMode {
    /// The mode by LeRobot's name of it (`MotorNormMode.value`): `degrees`, `range_m100_100`,
    /// `range_0_100`.
    pub fn from_lerobot(name: &str) -> Option<NormMode> {
        match name {
            "degrees" => Some(NormMode::Degrees),
            "range_m100_100" => Some(NormMode::Range),
            "range_0_100" => Some(NormMode::Percent),
            _ => None,
        }
    }
}

/// One motor as LeRobot's bus normalises it: its mode and its calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorNorm {
    /// How its values are normalised.
    pub mode: NormMode,
    /// The lowest raw tick recorded at calibration.
    pub range_min: i64,
    /// The highest raw tick recorded at calibration.
    pub range_max: i64,
    /// Whether the range modes are mirrored: `drive_mode` 1 on a bus that applies it (Feetech;
    /// LeRobot's Dynamixel bus does not).
    pub mirrored: bool,
    /// Ticks per turn of the model (4096 for the STS3215 and the X series).
    pub resolution: i64,
}

impl MotorNorm {
    /// LeRobot's value for raw tick `raw`, exact: `_normalize`, which bounds the range modes to
    /// the recorded range.
    pub fn normalize(&self, raw: f64) -> f64 {
        let (min, max) = (self.range_min as f64, self.range_max as f64);
        let bounded = raw.clamp(min, max);
        let share = (bounded - min) / (max - min);
        match self.mode {
            NormMode::Range => {
                let norm = share * 200.0 - 100.0;
                if self.mirrored {
                    -norm
                } else {
                    norm
                }
            }
            NormMode::Percent => {
                let norm = share * 100.0;
                if self.mirrored {
                    100.0 - norm
                } else {
                    norm
                }
            }
            NormMode::Degrees => (raw - self.mid()) * 360.0 / self.max_res(),
        }
    }

    /// The raw tick LeRobot's `_unnormalize` makes of `value` (bounded, then truncated towards
    /// zero).
    pub fn unnormalize(&self, value: f64) -> i64 {
        let (min, max) = (self.range_min as f64, self.range_max as f64);
        let raw = match self.mode {
            NormMode::Range => {
                let v = if self.mirrored { -value } else { value };
                (v.clamp(-100.0, 100.0) + 100.0) / 200.0 * (max - min) + min
            }
            NormMode::Percent => {
                let v = if self.mirrored { 100.0 - value } else { value };
                v.clamp(0.0, 100.0) / 100.0 * (max - min) + min
            }
            NormMode::Degrees => value * self.max_res() / 360.0 + self.mid(),
        };
        raw.trunc() as i64
    }

    /// The value to hand LeRobot for goal tick `tick`: the middle of the interval that
    /// `unnormalize` truncates to `tick` (a tick at the range's top end, where the range modes
    /// bound, is the top end itself).
    pub fn value_for_tick(&self, tick: i64) -> f64 {
        let middle = if tick >= 0 {
            tick as f64 + 0.5
        } else {
            tick as f64 - 0.5
        };
        let raw = match self.mode {
            NormMode::Degrees => middle,
            _ => middle.clamp(self.range_min as f64, self.range_max as f64),
        };
        self.normalize(raw)
    }

    /// The raw tick a value read from LeRobot (`get_observation`, normalised from a whole
    /// tick) came from: the nearest tick to the inverse of `_normalize`. The range modes bound
    /// it to the recorded range, as LeRobot's value already is.
    pub fn tick_of_value(&self, value: f64) -> i64 {
        let (min, max) = (self.range_min as f64, self.range_max as f64);
        let raw = match self.mode {
            NormMode::Range => {
                let v = if self.mirrored { -value } else { value };
                (v + 100.0) / 200.0 * (max - min) + min
            }
            NormMode::Percent => {
                let v = if self.mirrored { 100.0 - value } else { value };
                v / 100.0 * (max - min) + min
            }
            NormMode::Degrees => value * self.max_res() / 360.0 + self.mid(),
        };
        raw.round() as i64
    }

    fn mid(&self) -> f64 {
        (self.range_min + self.range_max) as f64 / 2.0
    }

    fn max_res(&self) -> f64 {
        (self.resolution - 1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn so101_pan(mode: NormMode, mirrored: bool) -> MotorNorm {
        MotorNorm {
            mode,
            range_min: 758,
            range_max: 3292,
            mirrored,
            resolution: 4096,
        }
    }

    /// Hand-derived from LeRobot's formulas: mid = 2025, 2025 + 409.5 → 36°·4095/360 … and
    /// the range modes' ends.
    #[test]
    fn lerobot_formulas_by_hand() {
        let deg = so101_pan(NormMode::Degrees, false);
        assert_eq!(deg.normalize(2025.0), 0.0);
        assert!((deg.normalize(2434.5) - 36.0).abs() < 1e-12);
        assert_eq!(deg.unnormalize(36.0), 2434);
        let range = so101_pan(NormMode::Range, false);
        assert_eq!(range.normalize(758.0), -100.0);
        assert_eq!(range.normalize(3292.0), 100.0);
        assert_eq!(range.normalize(5000.0), 100.0);
        assert_eq!(range.unnormalize(0.0), 2025);
        let mirrored = so101_pan(NormMode::Percent, true);
        assert_eq!(mirrored.normalize(758.0), 100.0);
        assert_eq!(mirrored.unnormalize(100.0), 758);
    }

    /// Every tick of the range, in every mode, mirrored or not, comes back as itself from
    /// LeRobot's `_unnormalize` of the value sent for it, and from the value read for it.
    #[test]
    fn every_tick_round_trips_through_lerobot() {
        for mode in [NormMode::Degrees, NormMode::Range, NormMode::Percent] {
            for mirrored in [false, true] {
                let motor = so101_pan(mode, mirrored);
                for tick in motor.range_min..=motor.range_max {
                    assert_eq!(
                        motor.unnormalize(motor.value_for_tick(tick)),
                        tick,
                        "{motor:?}"
                    );
                    assert_eq!(motor.tick_of_value(motor.normalize(tick as f64)), tick);
                }
            }
        }
        let deg = so101_pan(NormMode::Degrees, false);
        for tick in [-40, -1, 0, 5000] {
            assert_eq!(deg.unnormalize(deg.value_for_tick(tick)), tick);
        }
    }
}
