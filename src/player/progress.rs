//! The progress line of a playback, on servos or in simulation: phase, sequence time, key,
//! loop. One wording for both, so that a simulated playback reads like a real one.

use crate::plan::Trajectory;
use std::io::Write;

/// Redraws the line on stderr: `phase` and the loop as the timeline names them, at sequence
/// time `t`.
pub fn print_progress_line(phase: &str, t: f64, loop_label: &str, trajectory: &Trajectory) {
    let key = trajectory.key_reached(t);
    let label = crate::terminal_text::escape_field(&trajectory.key_labels[key]);
    let mut err = std::io::stderr().lock();
    let _ = write!(
        err,
        "\r{:<9} {:>7.2} / {:.2} s  key {}/{} {:<16} loop {}   ",
        phase,
        t,
        trajectory.end,
        key + 1,
        trajectory.key_times.len(),
        label,
        loop_label,
    );
    let _ = err.flush();
}
