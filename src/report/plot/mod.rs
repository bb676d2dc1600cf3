//! Hand-written SVG rendering of a sampled joint trajectory.
//!
//! The output is meant to be opened in a browser next to a sequence file: one row per joint with a
//! position panel and a velocity panel, limit violations shown as red-shaded zones, keys as dots and
//! an optional measured trace overlaid dashed. No plotting crate is used so the report has no
//! extra dependencies and the SVG stays small and diff-able.
//!
//! This module only assembles the document; `axis` (ranges, pixel maps, ticks), `text`
//! (widths, fitting, short numbers), `svg` (pixel numbers, escaping), `layout` and
//! `style` (where and how), `header` (legend, key labels), `panel` (a panel's parts) and
//! `joint_row` (a joint's two panels) do the rest.

use std::fmt::Write;

/// One joint's curves, already sampled at `PlotData::times`.
#[derive(Debug, Clone, Default)]
pub struct PlotJoint {
    /// Joint name as written in the robot file; shown in panel titles and the y axis label.
    pub name: String,
    /// Unit label for positions, e.g. "deg" or "m"; velocity axis uses `"<unit>/s"`.
    pub unit: String,
    /// Position limits (same unit). A non-finite limit leaves that side unlimited (no shading);
    /// a swapped pair is drawn as if given in order.
    pub min: f64,
    /// Upper position limit, see `min`.
    pub max: f64,
    /// Velocity limit magnitude (unit/s); the band is ±velocity_limit.
    pub velocity_limit: f64,
    /// Same length as PlotData::times.
    pub positions: Vec<f64>,
    /// Commanded velocity at each sample (unit/s), same length as `positions`.
    pub velocities: Vec<f64>,
    /// (time, value) of this joint's own keys, marked with dots on the position curve.
    pub keys: Vec<(f64, f64)>,
    /// Optional measured trace (time, position) to overlay, e.g. from a playback log; drawn dashed
    /// in a contrasting colour so the tracking error against the commanded curve is visible.
    pub measured: Option<Vec<(f64, f64)>>,
}

/// One joint's servo telemetry from a playback log, against sequence time: a row of its own
/// under the joints' rows.
#[derive(Debug, Clone, Default)]
pub struct TelemetryRow {
    /// The joint's name.
    pub name: String,
    /// Its load, percent of full output, in the joint's direction.
    pub load: Vec<(f64, f64)>,
    /// What the push guard judged the motion needed, percent.
    pub need: Vec<(f64, f64)>,
    /// Its temperature, °C.
    pub temperature: Vec<(f64, f64)>,
    /// The temperature at which its heat protection trips, °C.
    pub temperature_limit: Option<f64>,
    /// The push guard's line, percent: the servo's continuous rating (`None`: not rated).
    pub push_line: Option<f64>,
}

/// Everything one SVG plot shows: commanded curves of every joint, keys, and measured traces.
#[derive(Debug, Clone, Default)]
pub struct PlotData {
    /// Shown at the top and as the document `<title>`.
    pub title: String,
    /// Sample times in seconds, shared by every joint's `positions` and `velocities`.
    pub times: Vec<f64>,
    /// One plot row per joint, in this order.
    pub joints: Vec<PlotJoint>,
    /// Keyframe times with their labels (key name or "#index"), drawn as thin vertical guide lines
    /// across every panel, labelled once at the top.
    pub key_marks: Vec<(f64, String)>,
    /// Servo telemetry rows (from a playback log), drawn after the joints' rows.
    pub telemetry: Vec<TelemetryRow>,
}

/// Writing into a `String` cannot fail, so the `fmt::Result` is deliberately dropped.
macro_rules! w {
    ($out:expr, $($arg:tt)*) => {{
        let _ = write!($out, $($arg)*);
    }};
}

mod axis;
mod header;
mod joint_row;
mod layout;
mod panel;
mod style;
mod svg;
mod telemetry_row;
mod text;

use axis::Extent;
use layout::{Panel, BOTTOM_PAD, HEADER_H, MARGIN_LEFT, PANEL_W, PLOT_H, ROW_H, TITLE_Y, WIDTH};
use style::{FONT, SUBTLE_TEXT, TEXT, WHITE};
use svg::{Esc, Px};

/// Render the trajectory as a standalone SVG document.
pub fn render_svg(data: &PlotData) -> String {
    let joints = data.joints.len();
    let n = joints + data.telemetry.len();
    let height = if n == 0 {
        HEADER_H + 40.0
    } else {
        HEADER_H + n as f64 * ROW_H + BOTTOM_PAD
    };
    let time_axis = time_range(data);
    let mut out = String::with_capacity(16 * 1024 + joints * 32 * data.times.len().max(1));
    open_document(&mut out, data, height);
    draw_clip_paths(&mut out, n, time_axis);
    draw_background_and_title(&mut out, data, height);
    let any_measured = data.joints.iter().any(|j| j.measured.is_some());
    header::draw_legend(&mut out, any_measured);
    if joints == 0 {
        w!(
            out,
            r#"<text x="{}" y="{}" fill="{SUBTLE_TEXT}">no joints to plot</text>"#,
            Px(MARGIN_LEFT),
            Px(HEADER_H + 20.0)
        );
        out.push('\n');
        out.push_str("</svg>\n");
        return out;
    }
    header::draw_key_mark_labels(&mut out, data, time_axis);
    for (row, joint) in data.joints.iter().enumerate() {
        joint_row::draw_joint_row(&mut out, data, joint, row, time_axis, row + 1 == n);
    }
    for (i, telemetry) in data.telemetry.iter().enumerate() {
        let row = joints + i;
        let last = row + 1 == n;
        telemetry_row::draw_telemetry_row(&mut out, data, telemetry, row, time_axis, last);
    }
    out.push_str("</svg>\n");
    out
}

fn open_document(out: &mut String, data: &PlotData, height: f64) {
    w!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="{FONT}" font-size="12" fill="{TEXT}">"#,
        w = Px(WIDTH),
        h = Px(height),
    );
    out.push('\n');
    w!(out, "<title>{}</title>\n", Esc(&data.title));
}

/// One clip path per panel, so curves beyond the axis range stay inside their frame.
fn draw_clip_paths(out: &mut String, rows: usize, time_axis: (f64, f64)) {
    w!(out, "<defs>\n");
    for row in 0..rows {
        for col in 0..2 {
            let p = Panel::new(row, col, time_axis, (0.0, 1.0));
            w!(
                out,
                r#"<clipPath id="clip-{row}-{col}"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath>"#,
                Px(p.left),
                Px(p.top),
                Px(PANEL_W),
                Px(PLOT_H),
            );
            out.push('\n');
        }
    }
    w!(out, "</defs>\n");
}

fn draw_background_and_title(out: &mut String, data: &PlotData, height: f64) {
    // Explicit background: viewers in dark mode would otherwise show the white bands as holes.
    w!(
        out,
        r#"<rect x="0" y="0" width="{}" height="{}" fill="{WHITE}"/>"#,
        Px(WIDTH),
        Px(height)
    );
    out.push('\n');
    w!(
        out,
        r#"<text x="{}" y="{}" font-size="16" font-weight="bold">{}</text>"#,
        Px(MARGIN_LEFT),
        Px(TITLE_Y),
        Esc(&data.title)
    );
    out.push('\n');
}

/// Shared time axis: covers the samples, the key marks and the joints' keys. Measured traces are
/// deliberately left out so a long playback log does not squash the commanded trajectory.
fn time_range(data: &PlotData) -> (f64, f64) {
    let mut e = Extent::new();
    for &t in &data.times {
        e.add(t);
    }
    for (t, _) in &data.key_marks {
        e.add(*t);
    }
    for j in &data.joints {
        for &(t, _) in &j.keys {
            e.add(t);
        }
    }
    e.finish(0.0, (0.0, 1.0))
}

#[cfg(test)]
mod tests;
