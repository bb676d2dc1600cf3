//! The header: the legend and the key-mark labels above the first row.
//!
//! Knows nothing about the joints' curves.

use super::layout::{Panel, KEY_LABEL_MAX_W, KEY_LABEL_Y, LEGEND_Y, MARGIN_LEFT, WIDTH};
use super::style::{LIMIT_FILL, LIMIT_LINE, MEASURED_COLOR, PALETTE, SUBTLE_TEXT, WHITE};
use super::svg::{Esc, Px};
use super::text::{fit_text, text_width};
use super::PlotData;
use std::fmt::Write;

/// The legend: one sample of each kind of mark, each followed by its label, left to right.
pub(super) fn draw_legend(out: &mut String, any_measured: bool) {
    let mut x = MARGIN_LEFT;
    legend_line(out, x, PALETTE[0], 2.0, None);
    legend_label(out, &mut x, "commanded position");
    // A fully rounded rect instead of `<circle>` keeps circle elements reserved for real keys.
    w!(
        out,
        r#"<rect x="{}" y="{}" width="7" height="7" rx="3.5" ry="3.5" fill="{}" stroke="{WHITE}" stroke-width="1"/>"#,
        Px(x + 8.5),
        Px(LEGEND_Y - 3.5),
        PALETTE[0]
    );
    legend_label(out, &mut x, "keys");
    w!(
        out,
        r#"<rect x="{}" y="{}" width="24" height="10" fill="{LIMIT_FILL}"/>"#,
        Px(x),
        Px(LEGEND_Y - 10.0)
    );
    legend_line(out, x, LIMIT_LINE, 1.0, None);
    legend_label(out, &mut x, "limit (shaded = outside)");
    if any_measured {
        legend_line(out, x, MEASURED_COLOR, 1.4, Some("5 3"));
        legend_label(out, &mut x, "measured");
    }
}

/// A 24 px sample line at `x`. `<line>` rather than `<polyline>` so the legend never counts
/// as a curve.
fn legend_line(out: &mut String, x: f64, stroke: &str, width: f64, dash: Option<&str>) {
    let y = LEGEND_Y;
    w!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{stroke}" stroke-width="{}""#,
        Px(x),
        Px(y),
        Px(x + 24.0),
        Px(y),
        Px(width)
    );
    if let Some(dash) = dash {
        w!(out, r#" stroke-dasharray="{dash}""#);
    }
    out.push_str("/>");
}

/// The label after the sample at `x`; moves `x` past it to the next sample.
fn legend_label(out: &mut String, x: &mut f64, text: &str) {
    w!(
        out,
        r#"<text x="{}" y="{}" font-size="12">{}</text>"#,
        Px(*x + 30.0),
        Px(LEGEND_Y + 4.0),
        Esc(text)
    );
    out.push('\n');
    *x += 30.0 + text_width(text, 12.0) + 24.0;
}

/// Key-mark labels go in the header, once per column, staggered on two baselines when they
/// would collide (keys are often only a fraction of a second apart).
pub(super) fn draw_key_mark_labels(out: &mut String, data: &PlotData, t: (f64, f64)) {
    let mut marks: Vec<(f64, &str)> = data
        .key_marks
        .iter()
        .filter(|(time, _)| time.is_finite())
        .map(|(time, label)| (*time, label.as_str()))
        .collect();
    marks.sort_by(|a, b| a.0.total_cmp(&b.0));

    for col in 0..2 {
        let p = Panel::new(0, col, t, (0.0, 1.0));
        // Right edge of the last label placed on each baseline.
        let mut right_edge = [f64::NEG_INFINITY; 2];
        for &(time, label) in &marks {
            let x = p.x.px(time);
            let label = fit_text(label, KEY_LABEL_MAX_W, 11.0);
            let half = 0.5 * text_width(&label, 11.0);
            let cx = x.clamp(half, WIDTH - half);
            let level = if cx - half >= right_edge[0] + 4.0 {
                0
            } else if cx - half >= right_edge[1] + 4.0 {
                1
            } else if right_edge[0] <= right_edge[1] {
                0
            } else {
                1
            };
            right_edge[level] = cx + half;
            w!(
                out,
                r#"<text x="{}" y="{}" font-size="11" text-anchor="middle" fill="{SUBTLE_TEXT}">{}</text>"#,
                Px(cx),
                Px(KEY_LABEL_Y[level]),
                Esc(&label)
            );
            out.push('\n');
        }
    }
}
