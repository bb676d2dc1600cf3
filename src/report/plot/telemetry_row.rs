//! One joint's servo telemetry from a playback log (`plot --log` of a log that has it): its
//! load panel (the load read, in the joint's direction, what the motion needed dashed, a fifth
//! of stall either way as lines: the push guard's) and its temperature panel (the heat
//! protection's limit as a line).
//!
//! Knows nothing about the page header or how the panels' parts are drawn.

use super::axis::Extent;
use super::layout::{Panel, PAD_FRAC};
use super::panel::{
    draw_border, draw_grid, draw_key_guides, draw_limit_lines, draw_panel_frame, draw_polyline,
    horizontal_line, PanelText,
};
use super::style::{MEASURED_COLOR, PALETTE, ZERO_LINE};
use super::{PlotData, TelemetryRow};
use std::fmt::Write;

/// What a telemetry row's panels share: the data, the joint's telemetry, where the row is and
/// its colour.
struct Row<'a> {
    data: &'a PlotData,
    telemetry: &'a TelemetryRow,
    row: usize,
    t: (f64, f64),
    bottom_row: bool,
    color: &'static str,
}

pub(super) fn draw_telemetry_row(
    out: &mut String,
    data: &PlotData,
    telemetry: &TelemetryRow,
    row: usize,
    t: (f64, f64),
    bottom_row: bool,
) {
    // The joint's own colour, as its position row has it.
    let index = data.joints.iter().position(|j| j.name == telemetry.name);
    let r = Row {
        data,
        telemetry,
        row,
        t,
        bottom_row,
        color: PALETTE[index.unwrap_or(row) % PALETTE.len()],
    };
    draw_load_panel(out, &r);
    draw_temperature_panel(out, &r);
}

fn draw_load_panel(out: &mut String, r: &Row) {
    let telemetry = r.telemetry;
    let mut e = Extent::new();
    let line = telemetry.push_line;
    line.iter().for_each(|&l| {
        e.add(l);
        e.add(-l);
    });
    telemetry.load.iter().for_each(|&(_, v)| e.add(v));
    telemetry.need.iter().for_each(|&(_, v)| e.add(v));
    let p = Panel::new(r.row, 0, r.t, e.finish(PAD_FRAC, (-100.0, 100.0)));
    let peak = telemetry
        .load
        .iter()
        .map(|&(_, v)| v.abs())
        .fold(0.0, f64::max);
    let info = format!("peak {peak:.0} %, need dashed");
    let text = PanelText {
        name: &telemetry.name,
        kind: "load",
        info: &info,
        y_head: "load",
        y_unit: "%",
    };
    draw_panel_frame(out, &p, r.row, 0, &text, r.bottom_row);
    draw_grid(out, &p);
    horizontal_line(out, &p, p.y.px(0.0), ZERO_LINE);
    draw_key_guides(out, r.data, &p);
    draw_limit_lines(out, &p, line.map(|l| -l), line);
    w!(out, r#"<g clip-path="url(#clip-{}-0)">"#, r.row);
    out.push('\n');
    draw_polyline(out, &p, telemetry.load.iter().copied(), r.color, 1.5, None);
    let need = telemetry.need.iter().copied();
    draw_polyline(out, &p, need, MEASURED_COLOR, 1.2, Some("5 3"));
    w!(out, "</g>\n");
    draw_border(out, &p);
}

fn draw_temperature_panel(out: &mut String, r: &Row) {
    let telemetry = r.telemetry;
    let mut e = Extent::new();
    telemetry.temperature.iter().for_each(|&(_, v)| e.add(v));
    telemetry.temperature_limit.iter().for_each(|&v| e.add(v));
    let p = Panel::new(r.row, 1, r.t, e.finish(PAD_FRAC, (20.0, 80.0)));
    let hottest = telemetry
        .temperature
        .iter()
        .map(|&(_, v)| v)
        .fold(f64::NAN, f64::max);
    let info = match (hottest.is_finite(), telemetry.temperature_limit) {
        (true, Some(limit)) => format!("hottest {hottest:.0} °C, protection {limit:.0} °C"),
        (true, None) => format!("hottest {hottest:.0} °C"),
        (false, _) => "not read".to_string(),
    };
    let text = PanelText {
        name: &telemetry.name,
        kind: "temperature",
        info: &info,
        y_head: "temperature",
        y_unit: "°C",
    };
    draw_panel_frame(out, &p, r.row, 1, &text, r.bottom_row);
    draw_grid(out, &p);
    draw_key_guides(out, r.data, &p);
    draw_limit_lines(out, &p, None, telemetry.temperature_limit);
    w!(out, r#"<g clip-path="url(#clip-{}-1)">"#, r.row);
    out.push('\n');
    draw_polyline(
        out,
        &p,
        telemetry.temperature.iter().copied(),
        r.color,
        1.5,
        None,
    );
    w!(out, "</g>\n");
    draw_border(out, &p);
}
