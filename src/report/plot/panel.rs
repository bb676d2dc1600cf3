//! The parts of one panel: frame and labels, limit bands and lines, grid, key guides, curves
//! and border.
//!
//! Knows nothing about joints: a panel gets its geometry and its texts.

use super::axis::nice_ticks;
use super::layout::{Panel, PANEL_W, PLOT_H};
use super::style::{FRAME, GRID, KEY_MARK, LIMIT_FILL, LIMIT_LINE, SUBTLE_TEXT, WHITE};
use super::svg::{Esc, Px};
use super::text::{fit_text, text_width};
use super::PlotData;
use std::fmt::Write;

/// About how many ticks an axis gets: the grid and the tick labels must agree.
const Y_TICKS: f64 = 5.0;
const X_TICKS: f64 = 8.0;

/// The texts of a panel: its title (`name · kind`, `info` on the right) and its y axis label
/// (`y_head (y_unit)`).
pub(super) struct PanelText<'a> {
    pub name: &'a str,
    pub kind: &'a str,
    pub info: &'a str,
    pub y_head: &'a str,
    pub y_unit: &'a str,
}

/// Panel title, axis labels, tick labels and the white plotting area.
pub(super) fn draw_panel_frame(
    out: &mut String,
    p: &Panel,
    row: usize,
    col: usize,
    text: &PanelText,
    bottom_row: bool,
) {
    w!(out, "<g id=\"panel-{row}-{col}\">\n");
    draw_title(out, p, text);
    w!(
        out,
        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{WHITE}"/>"#,
        Px(p.left),
        Px(p.top),
        Px(PANEL_W),
        Px(PLOT_H)
    );
    out.push('\n');
    draw_tick_labels(out, p);
    draw_y_label(out, p, text.y_head, text.y_unit);
    if bottom_row {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="12" text-anchor="middle">time (s)</text>"#,
            Px(p.left + PANEL_W / 2.0),
            Px(p.bottom() + 32.0)
        );
        out.push('\n');
    }
    w!(out, "</g>\n");
}

/// The bold name and kind on the left, the info text on the right.
fn draw_title(out: &mut String, p: &Panel, text: &PanelText) {
    let title_y = p.top - 6.0;
    let kind = format!(" · {}", text.kind);
    // Bold glyphs are ~10% wider; the right-aligned info text has priority over a long name.
    let name_room = PANEL_W - text_width(text.info, 11.0) - text_width(&kind, 13.0) - 16.0;
    let name = fit_text(text.name, (name_room / 1.1).max(40.0), 13.0);
    w!(
        out,
        r#"<text x="{}" y="{}" font-size="13"><tspan font-weight="bold">{}</tspan>{}</text>"#,
        Px(p.left),
        Px(title_y),
        Esc(&name),
        Esc(&kind)
    );
    out.push('\n');
    w!(
        out,
        r#"<text x="{}" y="{}" font-size="11" text-anchor="end" fill="{SUBTLE_TEXT}">{}</text>"#,
        Px(p.right()),
        Px(title_y),
        Esc(text.info)
    );
    out.push('\n');
}

fn draw_tick_labels(out: &mut String, p: &Panel) {
    for (v, label) in nice_ticks(p.y.lo, p.y.hi, Y_TICKS) {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="11" text-anchor="end">{}</text>"#,
            Px(p.left - 6.0),
            Px(p.y.px(v) + 4.0),
            Esc(&label)
        );
        out.push('\n');
    }
    for (v, label) in nice_ticks(p.x.lo, p.x.hi, X_TICKS) {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="11" text-anchor="middle">{}</text>"#,
            Px(p.x.px(v)),
            Px(p.bottom() + 14.0),
            Esc(&label)
        );
        out.push('\n');
    }
}

/// The rotated y axis label left of the panel.
fn draw_y_label(out: &mut String, p: &Panel, y_head: &str, y_unit: &str) {
    let cx = p.left - 56.0;
    let cy = p.top + PLOT_H / 2.0;
    // Rotated, the label must fit the panel height or it runs into the next row: step down one
    // font size, then shorten the name but never drop the unit.
    let unit = format!(" ({y_unit})");
    let full = format!("{y_head}{unit}");
    let (size, label) = if text_width(&full, 12.0) <= PLOT_H {
        (12.0, full)
    } else if text_width(&full, 11.0) <= PLOT_H {
        (11.0, full)
    } else {
        let head = fit_text(y_head, PLOT_H - text_width(&unit, 11.0), 11.0);
        (11.0, format!("{head}{unit}"))
    };
    w!(
        out,
        r#"<text x="{x}" y="{y}" font-size="{}" text-anchor="middle" transform="rotate(-90 {x} {y})">{}</text>"#,
        Px(size),
        Esc(&label),
        x = Px(cx),
        y = Px(cy),
    );
    out.push('\n');
}

/// Shade everything outside [lo, hi]; a missing bound means that side is unlimited.
pub(super) fn draw_band(out: &mut String, p: &Panel, lo: Option<f64>, hi: Option<f64>) {
    let mut shade = |y0: f64, y1: f64| {
        let (a, b) = (y0.clamp(p.top, p.bottom()), y1.clamp(p.top, p.bottom()));
        if b > a {
            w!(
                out,
                r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{LIMIT_FILL}"/>"#,
                Px(p.left),
                Px(a),
                Px(PANEL_W),
                Px(b - a)
            );
            out.push('\n');
        }
    };
    if let Some(hi) = hi {
        shade(p.top, p.y.px(hi));
    }
    if let Some(lo) = lo {
        shade(p.y.px(lo), p.bottom());
    }
}

/// A full-width line across a panel at pixel height `y`.
pub(super) fn horizontal_line(out: &mut String, p: &Panel, y: f64, colour: &str) {
    w!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{colour}" stroke-width="1"/>"#,
        Px(p.left),
        Px(y),
        Px(p.right()),
        Px(y)
    );
    out.push('\n');
}

pub(super) fn draw_limit_lines(out: &mut String, p: &Panel, lo: Option<f64>, hi: Option<f64>) {
    for v in lo.into_iter().chain(hi) {
        let y = p.y.px(v);
        horizontal_line(out, p, y, LIMIT_LINE);
    }
}

pub(super) fn draw_grid(out: &mut String, p: &Panel) {
    for (v, _) in nice_ticks(p.y.lo, p.y.hi, Y_TICKS) {
        let y = p.y.px(v);
        horizontal_line(out, p, y, GRID);
    }
    for (v, _) in nice_ticks(p.x.lo, p.x.hi, X_TICKS) {
        let x = p.x.px(v);
        w!(
            out,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{GRID}" stroke-width="1"/>"#,
            Px(x),
            Px(p.top),
            Px(x),
            Px(p.bottom())
        );
        out.push('\n');
    }
}

pub(super) fn draw_key_guides(out: &mut String, data: &PlotData, p: &Panel) {
    for &(t, _) in &data.key_marks {
        if !t.is_finite() {
            continue;
        }
        let x = p.x.px(t);
        w!(
            out,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{KEY_MARK}" stroke-width="0.8" stroke-dasharray="3 3"/>"#,
            Px(x),
            Px(p.top),
            Px(x),
            Px(p.bottom())
        );
        out.push('\n');
    }
}

/// Always emits exactly one `<polyline>` per curve (possibly with no points) so the document
/// structure does not depend on the data. Non-finite samples are skipped; the line simply joins
/// their finite neighbours.
pub(super) fn draw_polyline(
    out: &mut String,
    p: &Panel,
    points: impl Iterator<Item = (f64, f64)>,
    color: &str,
    width: f64,
    dash: Option<&str>,
) {
    w!(
        out,
        r#"<polyline fill="none" stroke="{color}" stroke-width="{}" stroke-linejoin="round" stroke-linecap="round""#,
        Px(width)
    );
    if let Some(d) = dash {
        w!(out, r#" stroke-dasharray="{d}""#);
    }
    out.push_str(r#" points=""#);
    let mut first = true;
    for (t, v) in points {
        if !(t.is_finite() && v.is_finite()) {
            continue;
        }
        if !first {
            out.push(' ');
        }
        first = false;
        w!(out, "{},{}", Px(p.x.px(t)), Px(p.y.px(v)));
    }
    out.push_str("\"/>\n");
}

pub(super) fn draw_border(out: &mut String, p: &Panel) {
    w!(
        out,
        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="{FRAME}" stroke-width="1"/>"#,
        Px(p.left),
        Px(p.top),
        Px(PANEL_W),
        Px(PLOT_H)
    );
    out.push('\n');
}
