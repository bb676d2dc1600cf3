//! One joint's row: its position panel (limits shaded, keys, measured overlay) and its
//! velocity panel (the ± limit band around zero).
//!
//! Knows nothing about the page header or how the panels' parts are drawn.

use super::axis::Extent;
use super::layout::{Panel, PAD_FRAC};
use super::panel::{
    draw_band, draw_border, draw_grid, draw_key_guides, draw_limit_lines, draw_panel_frame,
    draw_polyline, horizontal_line, PanelText,
};
use super::style::{MEASURED_COLOR, PALETTE, WHITE, ZERO_LINE};
use super::svg::Px;
use super::text::short;
use super::{PlotData, PlotJoint};
use std::fmt::Write;

/// What a row's panels share: the data, the joint, where the row is and its colour.
struct Row<'a> {
    data: &'a PlotData,
    joint: &'a PlotJoint,
    row: usize,
    t: (f64, f64),
    bottom_row: bool,
    color: &'static str,
}

pub(super) fn draw_joint_row(
    out: &mut String,
    data: &PlotData,
    joint: &PlotJoint,
    row: usize,
    t: (f64, f64),
    bottom_row: bool,
) {
    let r = Row {
        data,
        joint,
        row,
        t,
        bottom_row,
        color: PALETTE[row % PALETTE.len()],
    };
    draw_position_panel(out, &r);
    draw_velocity_panel(out, &r);
}

fn finite_limit(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Opens the group clipped to panel (`row`, `col`): curves beyond the axis range stay inside.
fn open_clip(out: &mut String, row: usize, col: usize) {
    w!(out, r#"<g clip-path="url(#clip-{row}-{col})">"#);
    out.push('\n');
}

/// The commanded curve of `values`, sampled at the data's times.
fn draw_commanded(out: &mut String, r: &Row, p: &Panel, values: &[f64]) {
    let commanded = r.data.times.iter().copied().zip(values.iter().copied());
    draw_polyline(out, p, commanded, r.color, 1.8, None);
}

// --- position panel ---------------------------------------------------------------------------

fn draw_position_panel(out: &mut String, r: &Row) {
    let joint = r.joint;
    let (pmin, pmax) = position_limits(joint);
    let pos = Panel::new(r.row, 0, r.t, position_range(joint, pmin, pmax));
    let info = position_info(pmin, pmax, &joint.unit);
    let text = PanelText {
        name: &joint.name,
        kind: "position",
        info: &info,
        y_head: &joint.name,
        y_unit: &joint.unit,
    };
    draw_panel_frame(out, &pos, r.row, 0, &text, r.bottom_row);
    draw_band(out, &pos, pmin, pmax);
    draw_grid(out, &pos);
    draw_key_guides(out, r.data, &pos);
    draw_limit_lines(out, &pos, pmin, pmax);
    draw_position_curves(out, r, &pos);
    draw_border(out, &pos);
}

/// The finite position limits, in order.
fn position_limits(joint: &PlotJoint) -> (Option<f64>, Option<f64>) {
    let (pmin, pmax) = (finite_limit(joint.min), finite_limit(joint.max));
    match (pmin, pmax) {
        // A swapped pair is a config mistake; still show the band the user evidently meant.
        (Some(a), Some(b)) if a > b => (Some(b), Some(a)),
        limits => limits,
    }
}

/// The value range of the position panel: limits, curve, keys and measured trace in view.
fn position_range(joint: &PlotJoint, pmin: Option<f64>, pmax: Option<f64>) -> (f64, f64) {
    let mut e = Extent::new();
    pmin.into_iter().chain(pmax).for_each(|v| e.add(v));
    joint.positions.iter().for_each(|&v| e.add(v));
    joint.keys.iter().for_each(|&(_, v)| e.add(v));
    if let Some(m) = &joint.measured {
        m.iter().for_each(|&(_, v)| e.add(v));
    }
    e.finish(PAD_FRAC, (0.0, 1.0))
}

fn position_info(pmin: Option<f64>, pmax: Option<f64>, unit: &str) -> String {
    match (pmin, pmax) {
        (Some(a), Some(b)) => format!("limits {} … {} {}", short(a), short(b), unit),
        (Some(a), None) => format!("min {} {}", short(a), unit),
        (None, Some(b)) => format!("max {} {}", short(b), unit),
        (None, None) => "no limits".to_string(),
    }
}

/// The commanded curve, the measured overlay and the key dots, clipped to the panel.
fn draw_position_curves(out: &mut String, r: &Row, pos: &Panel) {
    let joint = r.joint;
    open_clip(out, r.row, 0);
    draw_commanded(out, r, pos, &joint.positions);
    if let Some(m) = &joint.measured {
        draw_polyline(
            out,
            pos,
            m.iter().copied(),
            MEASURED_COLOR,
            1.3,
            Some("5 3"),
        );
    }
    draw_key_dots(out, joint, pos, r.color);
    w!(out, "</g>\n");
}

fn draw_key_dots(out: &mut String, joint: &PlotJoint, pos: &Panel, color: &str) {
    for &(kt, kv) in &joint.keys {
        if kt.is_finite() && kv.is_finite() {
            w!(
                out,
                r#"<circle cx="{}" cy="{}" r="3.5" fill="{color}" stroke="{WHITE}" stroke-width="1"/>"#,
                Px(pos.x.px(kt)),
                Px(pos.y.px(kv))
            );
            out.push('\n');
        }
    }
}

// --- velocity panel ---------------------------------------------------------------------------

fn draw_velocity_panel(out: &mut String, r: &Row) {
    let joint = r.joint;
    let vlim = finite_limit(joint.velocity_limit).map(f64::abs);
    let vel = Panel::new(r.row, 1, r.t, velocity_range(joint, vlim));
    let vunit = format!("{}/s", joint.unit);
    let info = velocity_info(joint, vlim, &vunit);
    let text = PanelText {
        name: &joint.name,
        kind: "velocity",
        info: &info,
        y_head: "velocity",
        y_unit: &vunit,
    };
    draw_panel_frame(out, &vel, r.row, 1, &text, r.bottom_row);
    draw_band(out, &vel, vlim.map(|l| -l), vlim);
    draw_grid(out, &vel);
    horizontal_line(out, &vel, vel.y.px(0.0), ZERO_LINE);
    draw_key_guides(out, r.data, &vel);
    draw_limit_lines(out, &vel, vlim.map(|l| -l), vlim);
    open_clip(out, r.row, 1);
    draw_commanded(out, r, &vel, &joint.velocities);
    w!(out, "</g>\n");
    draw_border(out, &vel);
}

/// The value range of the velocity panel: zero, the ± limit and the curve in view.
fn velocity_range(joint: &PlotJoint, vlim: Option<f64>) -> (f64, f64) {
    let mut e = Extent::new();
    // Zero is always in view so the sign of the velocity is readable at a glance.
    e.add(0.0);
    if let Some(l) = vlim {
        e.add(l);
        e.add(-l);
    }
    joint.velocities.iter().for_each(|&v| e.add(v));
    e.finish(PAD_FRAC, (-1.0, 1.0))
}

/// "limit ±L unit/s, peak P (N%)": the peak and its share of the limit when there is one.
fn velocity_info(joint: &PlotJoint, vlim: Option<f64>, vunit: &str) -> String {
    let peak = joint
        .velocities
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .map(f64::abs)
        .fold(None, |acc: Option<f64>, v| {
            Some(acc.map_or(v, |a| a.max(v)))
        });
    let mut text = match vlim {
        Some(l) => format!("limit ±{} {vunit}", short(l)),
        None => "no limit".to_string(),
    };
    if let Some(p) = peak {
        let _ = write!(text, ", peak {}", short(p));
        if let Some(l) = vlim.filter(|&l| l > 0.0) {
            let _ = write!(text, " ({:.0}%)", 100.0 * p / l);
        }
    }
    text
}
