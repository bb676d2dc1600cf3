//! Where everything goes, in px: the page, the rows, the panels and the header strips, and
//! the geometry of one panel. Kept as named constants so the tests can recompute pixel
//! positions by hand.
//!
//! Knows nothing about the data plotted or how SVG is written.

use super::axis::Axis;

pub(super) const WIDTH: f64 = 1100.0;
/// Room for y tick labels plus the rotated y axis label of the left column.
pub(super) const MARGIN_LEFT: f64 = 72.0;
pub(super) const MARGIN_RIGHT: f64 = 16.0;
/// The velocity panel needs the same room for its own y labels as the left margin provides.
pub(super) const PANEL_GAP: f64 = 84.0;
pub(super) const PANEL_W: f64 = (WIDTH - MARGIN_LEFT - MARGIN_RIGHT - PANEL_GAP) / 2.0;
/// Title, legend and the strip of key-mark labels.
pub(super) const HEADER_H: f64 = 92.0;
pub(super) const ROW_H: f64 = 170.0;
/// Strip above each panel holding the panel title.
pub(super) const ROW_TITLE_H: f64 = 20.0;
pub(super) const PLOT_H: f64 = 112.0;
pub(super) const BOTTOM_PAD: f64 = 4.0;
/// Fraction of the data span added on each side so extremes never sit on the frame.
pub(super) const PAD_FRAC: f64 = 0.05;

// Compile-time guards so a tweak to one constant cannot silently make rows overlap.
const _: () = {
    // Panel title strip + plot + x tick labels + "time (s)" must fit in one row.
    assert!(ROW_TITLE_H + PLOT_H + 34.0 <= ROW_H);
    // Key-mark labels live in the header, above the first row's panel titles.
    assert!(KEY_LABEL_Y[1] < HEADER_H);
    assert!(PANEL_W > 0.0);
};

pub(super) const TITLE_Y: f64 = 24.0;
pub(super) const LEGEND_Y: f64 = 48.0;
/// Two baselines for key-mark labels so neighbouring labels can be staggered instead of overlapping.
pub(super) const KEY_LABEL_Y: [f64; 2] = [70.0, 83.0];
pub(super) const KEY_LABEL_MAX_W: f64 = 90.0;

/// Geometry of one panel: its frame plus both axes.
pub(super) struct Panel {
    pub left: f64,
    pub top: f64,
    pub x: Axis,
    pub y: Axis,
}

impl Panel {
    pub fn new(row: usize, col: usize, t: (f64, f64), y: (f64, f64)) -> Self {
        let left = MARGIN_LEFT + col as f64 * (PANEL_W + PANEL_GAP);
        let top = HEADER_H + row as f64 * ROW_H + ROW_TITLE_H;
        Panel {
            left,
            top,
            x: Axis {
                lo: t.0,
                hi: t.1,
                px0: left,
                px1: left + PANEL_W,
            },
            y: Axis {
                lo: y.0,
                hi: y.1,
                px0: top + PLOT_H,
                px1: top,
            },
        }
    }

    pub fn right(&self) -> f64 {
        self.left + PANEL_W
    }

    pub fn bottom(&self) -> f64 {
        self.top + PLOT_H
    }
}
