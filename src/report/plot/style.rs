//! The look: the font and the colours.
//!
//! Knows nothing about where things go.

pub(super) const FONT: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
/// Okabe–Ito colours minus yellow (unreadable on white), vermillion (too close to the limit red)
/// and black (reserved for the measured overlay).
pub(super) const PALETTE: [&str; 5] = ["#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9"];
pub(super) const MEASURED_COLOR: &str = "#1a1a1a";
pub(super) const LIMIT_FILL: &str = "#fbe3e3";
pub(super) const LIMIT_LINE: &str = "#d62728";
pub(super) const GRID: &str = "#e5e5e5";
pub(super) const ZERO_LINE: &str = "#bdbdbd";
pub(super) const FRAME: &str = "#8c8c8c";
pub(super) const KEY_MARK: &str = "#9e9e9e";
pub(super) const WHITE: &str = "#ffffff";
pub(super) const TEXT: &str = "#222222";
pub(super) const SUBTLE_TEXT: &str = "#666666";
