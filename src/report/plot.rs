//! Hand-written SVG rendering of a sampled joint trajectory.
//!
//! The output is meant to be opened in a browser next to a sequence file: one row per joint with a
//! position panel and a velocity panel, limit violations shown as red-shaded zones, keys as dots and
//! an optional measured trace overlaid dashed. No plotting crate is used so the report has no
//! extra dependencies and the SVG stays small and diff-able.

use std::fmt::{self, Write};

/// One joint's curves, already sampled at `PlotData::times`.
#[derive(Debug, Clone, Default)]
pub struct PlotJoint {
    /// Joint name as written in the robot file; shown in panel titles and the y axis label.
    pub name: String,
    /// Unit label for positions, e.g. "deg" or "m"; velocity axis uses "<unit>/s".
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
}

// ---------------------------------------------------------------------------------------------
// Layout (all in px). Kept as named constants so the tests can recompute pixel positions by hand.
// ---------------------------------------------------------------------------------------------

const WIDTH: f64 = 1100.0;
/// Room for y tick labels plus the rotated y axis label of the left column.
const MARGIN_LEFT: f64 = 72.0;
const MARGIN_RIGHT: f64 = 16.0;
/// The velocity panel needs the same room for its own y labels as the left margin provides.
const PANEL_GAP: f64 = 84.0;
const PANEL_W: f64 = (WIDTH - MARGIN_LEFT - MARGIN_RIGHT - PANEL_GAP) / 2.0;
/// Title, legend and the strip of key-mark labels.
const HEADER_H: f64 = 92.0;
const ROW_H: f64 = 170.0;
/// Strip above each panel holding the panel title.
const ROW_TITLE_H: f64 = 20.0;
const PLOT_H: f64 = 112.0;
const BOTTOM_PAD: f64 = 4.0;
/// Fraction of the data span added on each side so extremes never sit on the frame.
const PAD_FRAC: f64 = 0.05;

// Compile-time guards so a tweak to one constant cannot silently make rows overlap.
const _: () = {
    // Panel title strip + plot + x tick labels + "time (s)" must fit in one row.
    assert!(ROW_TITLE_H + PLOT_H + 34.0 <= ROW_H);
    // Key-mark labels live in the header, above the first row's panel titles.
    assert!(KEY_LABEL_Y[1] < HEADER_H);
    assert!(PANEL_W > 0.0);
};

const TITLE_Y: f64 = 24.0;
const LEGEND_Y: f64 = 48.0;
/// Two baselines for key-mark labels so neighbouring labels can be staggered instead of overlapping.
const KEY_LABEL_Y: [f64; 2] = [70.0, 83.0];
const KEY_LABEL_MAX_W: f64 = 90.0;

const FONT: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
/// Okabe–Ito colours minus yellow (unreadable on white), vermillion (too close to the limit red)
/// and black (reserved for the measured overlay).
const PALETTE: [&str; 5] = ["#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9"];
const MEASURED_COLOR: &str = "#1a1a1a";
const LIMIT_FILL: &str = "#fbe3e3";
const LIMIT_LINE: &str = "#d62728";
const GRID: &str = "#e5e5e5";
const ZERO_LINE: &str = "#bdbdbd";
const FRAME: &str = "#8c8c8c";
const KEY_MARK: &str = "#9e9e9e";
const WHITE: &str = "#ffffff";
const TEXT: &str = "#222222";
const SUBTLE_TEXT: &str = "#666666";

/// Data beyond this magnitude is treated as this magnitude when choosing the axis range, so the
/// span (hi - lo) and the padding can never overflow to infinity.
const RANGE_LIMIT: f64 = 1e150;
/// Pixel coordinates are clamped here: wild outliers are clipped anyway, and this keeps the
/// numbers short and finite.
const PX_LIMIT: f64 = 1e5;

/// Writing into a `String` cannot fail, so the `fmt::Result` is deliberately dropped.
macro_rules! w {
    ($out:expr, $($arg:tt)*) => {{
        let _ = write!($out, $($arg)*);
    }};
}

/// Render the trajectory as a standalone SVG document.
pub fn render_svg(data: &PlotData) -> String {
    let n = data.joints.len();
    let height = if n == 0 {
        HEADER_H + 40.0
    } else {
        HEADER_H + n as f64 * ROW_H + BOTTOM_PAD
    };

    let time_axis = time_range(data);
    let mut out = String::with_capacity(16 * 1024 + n * 32 * data.times.len().max(1));

    w!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="{FONT}" font-size="12" fill="{TEXT}">"#,
        w = Px(WIDTH),
        h = Px(height),
    );
    out.push('\n');
    w!(out, "<title>{}</title>\n", Esc(&data.title));

    w!(out, "<defs>\n");
    for row in 0..n {
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

    let any_measured = data.joints.iter().any(|j| j.measured.is_some());
    draw_legend(&mut out, any_measured);

    if n == 0 {
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

    draw_key_mark_labels(&mut out, data, time_axis);

    for (row, joint) in data.joints.iter().enumerate() {
        draw_joint_row(&mut out, data, joint, row, time_axis, row + 1 == n);
    }

    out.push_str("</svg>\n");
    out
}

// ---------------------------------------------------------------------------------------------
// Axes and ranges
// ---------------------------------------------------------------------------------------------

/// Running min/max over finite values only, so a single NaN sample cannot poison the axis.
struct Extent {
    lo: f64,
    hi: f64,
}

impl Extent {
    fn new() -> Self {
        Extent {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, v: f64) {
        if v.is_finite() {
            let v = v.clamp(-RANGE_LIMIT, RANGE_LIMIT);
            self.lo = self.lo.min(v);
            self.hi = self.hi.max(v);
        }
    }

    /// Final (lo, hi) with padding; degenerate or empty extents are widened so that every axis
    /// has a strictly positive, finite span and the pixel mapping never divides by zero.
    fn finish(self, pad_frac: f64, fallback: (f64, f64)) -> (f64, f64) {
        if self.lo > self.hi {
            return fallback;
        }
        let (lo, hi) = (self.lo, self.hi);
        let span = hi - lo;
        let scale = lo.abs().max(hi.abs());
        // Relative threshold: a span of 1e-12 around 1e6 would round away in f64 and produce
        // duplicate ticks, so treat it like a flat line.
        if span <= scale * 1e-9 {
            let mid = 0.5 * (lo + hi);
            let half = (mid.abs() * 0.1).max(1.0);
            (mid - half, mid + half)
        } else {
            let pad = span * pad_frac;
            (lo - pad, hi + pad)
        }
    }
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

/// Linear map from a value range to a pixel range (`px0` is where `lo` lands).
#[derive(Debug, Clone, Copy)]
struct Axis {
    lo: f64,
    hi: f64,
    px0: f64,
    px1: f64,
}

impl Axis {
    fn px(&self, v: f64) -> f64 {
        let p = self.px0 + (v - self.lo) / (self.hi - self.lo) * (self.px1 - self.px0);
        // NaN cannot reach here (callers filter), but an overflowing ratio can be ±inf.
        p.clamp(-PX_LIMIT, PX_LIMIT)
    }
}

/// Geometry of one panel: its frame plus both axes.
struct Panel {
    left: f64,
    top: f64,
    x: Axis,
    y: Axis,
}

impl Panel {
    fn new(row: usize, col: usize, t: (f64, f64), y: (f64, f64)) -> Self {
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

    fn right(&self) -> f64 {
        self.left + PANEL_W
    }

    fn bottom(&self) -> f64 {
        self.top + PLOT_H
    }
}

/// A 1/2/5 × 10^k tick step: `mant` × 10^`exp`. Kept in integer form so labels are printed exactly
/// (no `0.30000000000000004`) and so every label on one axis gets the same number of decimals.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Step {
    mant: i64,
    exp: i32,
}

impl Step {
    fn value(self) -> f64 {
        self.mant as f64 * 10f64.powi(self.exp)
    }
}

fn nice_step(span: f64, target: f64) -> Step {
    let raw = span / target;
    let mut exp = raw.log10().floor() as i32;
    let f = raw / 10f64.powi(exp);
    let mant = if f <= 1.0 {
        1
    } else if f <= 2.0 {
        2
    } else if f <= 5.0 {
        5
    } else {
        exp += 1;
        1
    };
    Step { mant, exp }
}

/// Ticks inside [lo, hi] with their labels; about `target` of them.
fn nice_ticks(lo: f64, hi: f64, target: f64) -> Vec<(f64, String)> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let step = nice_step(span, target);
    let s = step.value();
    // The epsilon keeps a tick that lands exactly on a bound despite rounding in lo / s.
    let first = (lo / s - 1e-9).ceil();
    let last = (hi / s + 1e-9).floor();
    if !(first.is_finite() && last.is_finite()) || last < first || last - first > 50.0 {
        return Vec::new();
    }
    let sci = step.exp >= 6 || step.exp <= -5 || lo.abs().max(hi.abs()) >= 1e7;
    let count = (last - first) as i64;
    (0..=count)
        .map(|k| {
            let i = first as i64 + k;
            let n = i as i128 * step.mant as i128;
            (i as f64 * s, tick_label(n, step.exp, sci))
        })
        .collect()
}

/// Label for the value `n` × 10^`exp`.
fn tick_label(n: i128, exp: i32, sci: bool) -> String {
    if n == 0 {
        return if sci || exp >= 0 {
            "0".to_string()
        } else {
            format!("0.{}", "0".repeat((-exp) as usize))
        };
    }
    let sign = if n < 0 { "-" } else { "" };
    if sci {
        let mut m = n.unsigned_abs();
        let mut e = exp;
        // Move trailing zeros into the exponent so 1500 × 10^4 prints as 1.5e7, not 1.500e7.
        while m != 0 && m / 10 * 10 == m {
            m /= 10;
            e += 1;
        }
        let digits = m.to_string();
        let magnitude = e + digits.len() as i32 - 1;
        let (a, b) = digits.split_at(1);
        return if b.is_empty() {
            format!("{sign}{a}e{magnitude}")
        } else {
            format!("{sign}{a}.{b}e{magnitude}")
        };
    }
    let digits = n.unsigned_abs().to_string();
    if exp >= 0 {
        return format!("{sign}{digits}{}", "0".repeat(exp as usize));
    }
    let frac = (-exp) as usize;
    if digits.len() > frac {
        let (a, b) = digits.split_at(digits.len() - frac);
        format!("{sign}{a}.{b}")
    } else {
        format!("{sign}0.{}{digits}", "0".repeat(frac - digits.len()))
    }
}

// ---------------------------------------------------------------------------------------------
// Drawing
// ---------------------------------------------------------------------------------------------

/// Rough advance width of `s` at `size` px in a DejaVu-like sans; only used to space labels.
/// Estimated advance width of `s` at `size` px, from rough DejaVu Sans glyph widths (the widest
/// of the fonts we ask for, so Helvetica/Arial only come out narrower). Used to space and
/// truncate labels, since SVG has no layout engine and `textLength` is not honoured everywhere.
fn text_width(s: &str, size: f64) -> f64 {
    let em: f64 = s
        .chars()
        .map(|c| match c {
            'i' | 'j' | 'l' | '.' | ',' | ':' | ';' | '\'' | '|' | '!' => 0.28,
            'f' | 't' | 'r' | ' ' | '(' | ')' | '[' | ']' | '-' | '/' | '#' => 0.4,
            'm' | 'w' | 'M' | 'W' | '…' | '%' => 0.95,
            'A'..='Z' => 0.72,
            _ => 0.63,
        })
        .sum();
    em * size
}

/// `s` cut with an ellipsis so it fits in `max_w` px at `size` px (user-chosen joint and key
/// names can be arbitrarily long and would otherwise run into neighbouring labels).
fn fit_text(s: &str, max_w: f64, size: f64) -> String {
    if text_width(s, size) <= max_w {
        return s.to_string();
    }
    let budget = max_w - text_width("…", size);
    let mut out = String::new();
    let mut used = 0.0;
    for c in s.chars() {
        let cw = text_width(c.encode_utf8(&mut [0; 4]), size);
        if used + cw > budget {
            break;
        }
        used += cw;
        out.push(c);
    }
    out.push('…');
    out
}

fn draw_legend(out: &mut String, any_measured: bool) {
    let y = LEGEND_Y;
    let mut x = MARGIN_LEFT;
    let label = |out: &mut String, x: &mut f64, text: &str| {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="12">{}</text>"#,
            Px(*x + 30.0),
            Px(y + 4.0),
            Esc(text)
        );
        out.push('\n');
        *x += 30.0 + text_width(text, 12.0) + 24.0;
    };

    // `<line>` rather than `<polyline>` so the legend never counts as a curve.
    w!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="2"/>"#,
        Px(x),
        Px(y),
        Px(x + 24.0),
        Px(y),
        PALETTE[0]
    );
    label(out, &mut x, "commanded position");

    // A fully rounded rect instead of `<circle>` keeps circle elements reserved for real keys.
    w!(
        out,
        r#"<rect x="{}" y="{}" width="7" height="7" rx="3.5" ry="3.5" fill="{}" stroke="{WHITE}" stroke-width="1"/>"#,
        Px(x + 8.5),
        Px(y - 3.5),
        PALETTE[0]
    );
    label(out, &mut x, "keys");

    w!(
        out,
        r#"<rect x="{}" y="{}" width="24" height="10" fill="{LIMIT_FILL}"/>"#,
        Px(x),
        Px(y - 10.0)
    );
    w!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{LIMIT_LINE}" stroke-width="1"/>"#,
        Px(x),
        Px(y),
        Px(x + 24.0),
        Px(y)
    );
    label(out, &mut x, "limit (shaded = outside)");

    if any_measured {
        w!(
            out,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{MEASURED_COLOR}" stroke-width="1.4" stroke-dasharray="5 3"/>"#,
            Px(x),
            Px(y),
            Px(x + 24.0),
            Px(y)
        );
        label(out, &mut x, "measured");
    }
}

/// Key-mark labels go in the header, once per column, staggered on two baselines when they
/// would collide (keys are often only a fraction of a second apart).
fn draw_key_mark_labels(out: &mut String, data: &PlotData, t: (f64, f64)) {
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

fn finite_limit(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn draw_joint_row(
    out: &mut String,
    data: &PlotData,
    joint: &PlotJoint,
    row: usize,
    t: (f64, f64),
    bottom_row: bool,
) {
    let color = PALETTE[row % PALETTE.len()];

    // --- position panel -----------------------------------------------------------------------
    let (mut pmin, mut pmax) = (finite_limit(joint.min), finite_limit(joint.max));
    if let (Some(a), Some(b)) = (pmin, pmax) {
        // A swapped pair is a config mistake; still show the band the user evidently meant.
        if a > b {
            (pmin, pmax) = (Some(b), Some(a));
        }
    }
    let mut e = Extent::new();
    pmin.into_iter().chain(pmax).for_each(|v| e.add(v));
    joint.positions.iter().for_each(|&v| e.add(v));
    joint.keys.iter().for_each(|&(_, v)| e.add(v));
    if let Some(m) = &joint.measured {
        m.iter().for_each(|&(_, v)| e.add(v));
    }
    let pos = Panel::new(row, 0, t, e.finish(PAD_FRAC, (0.0, 1.0)));

    let limits_text = match (pmin, pmax) {
        (Some(a), Some(b)) => format!("limits {} … {} {}", short(a), short(b), joint.unit),
        (Some(a), None) => format!("min {} {}", short(a), joint.unit),
        (None, Some(b)) => format!("max {} {}", short(b), joint.unit),
        (None, None) => "no limits".to_string(),
    };
    draw_panel_frame(
        out,
        &pos,
        row,
        0,
        &joint.name,
        "position",
        &limits_text,
        &joint.name,
        &joint.unit,
        bottom_row,
    );
    draw_band(out, &pos, pmin, pmax);
    draw_grid(out, &pos);
    draw_key_guides(out, data, &pos);
    draw_limit_lines(out, &pos, pmin, pmax);

    w!(out, r#"<g clip-path="url(#clip-{row}-0)">"#);
    out.push('\n');
    let commanded = data
        .times
        .iter()
        .copied()
        .zip(joint.positions.iter().copied());
    draw_polyline(out, &pos, commanded, color, 1.8, None);
    if let Some(m) = &joint.measured {
        draw_polyline(
            out,
            &pos,
            m.iter().copied(),
            MEASURED_COLOR,
            1.3,
            Some("5 3"),
        );
    }
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
    w!(out, "</g>\n");
    draw_border(out, &pos);

    // --- velocity panel -----------------------------------------------------------------------
    let vlim = finite_limit(joint.velocity_limit).map(f64::abs);
    let mut e = Extent::new();
    // Zero is always in view so the sign of the velocity is readable at a glance.
    e.add(0.0);
    if let Some(l) = vlim {
        e.add(l);
        e.add(-l);
    }
    joint.velocities.iter().for_each(|&v| e.add(v));
    let vel = Panel::new(row, 1, t, e.finish(PAD_FRAC, (-1.0, 1.0)));

    let peak = joint
        .velocities
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .map(f64::abs)
        .fold(None, |acc: Option<f64>, v| {
            Some(acc.map_or(v, |a| a.max(v)))
        });
    let vunit = format!("{}/s", joint.unit);
    let mut vel_text = match vlim {
        Some(l) => format!("limit ±{} {vunit}", short(l)),
        None => "no limit".to_string(),
    };
    if let Some(p) = peak {
        let _ = write!(vel_text, ", peak {}", short(p));
        if let Some(l) = vlim.filter(|&l| l > 0.0) {
            let _ = write!(vel_text, " ({:.0}%)", 100.0 * p / l);
        }
    }
    draw_panel_frame(
        out,
        &vel,
        row,
        1,
        &joint.name,
        "velocity",
        &vel_text,
        "velocity",
        &vunit,
        bottom_row,
    );
    draw_band(out, &vel, vlim.map(|l| -l), vlim);
    draw_grid(out, &vel);
    let y0 = vel.y.px(0.0);
    w!(
        out,
        r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{ZERO_LINE}" stroke-width="1"/>"#,
        Px(vel.left),
        Px(y0),
        Px(vel.right()),
        Px(y0)
    );
    out.push('\n');
    draw_key_guides(out, data, &vel);
    draw_limit_lines(out, &vel, vlim.map(|l| -l), vlim);

    w!(out, r#"<g clip-path="url(#clip-{row}-1)">"#);
    out.push('\n');
    let commanded = data
        .times
        .iter()
        .copied()
        .zip(joint.velocities.iter().copied());
    draw_polyline(out, &vel, commanded, color, 1.8, None);
    w!(out, "</g>\n");
    draw_border(out, &vel);
}

/// Panel title, axis labels, tick labels and the white plotting area.
#[allow(clippy::too_many_arguments)]
fn draw_panel_frame(
    out: &mut String,
    p: &Panel,
    row: usize,
    col: usize,
    name: &str,
    kind: &str,
    info: &str,
    y_head: &str,
    y_unit: &str,
    bottom_row: bool,
) {
    w!(out, "<g id=\"panel-{row}-{col}\">\n");
    let title_y = p.top - 6.0;
    let kind = format!(" · {kind}");
    // Bold glyphs are ~10% wider; the right-aligned info text has priority over a long name.
    let name_room = PANEL_W - text_width(info, 11.0) - text_width(&kind, 13.0) - 16.0;
    let name = fit_text(name, (name_room / 1.1).max(40.0), 13.0);
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
        Esc(info)
    );
    out.push('\n');

    w!(
        out,
        r#"<rect x="{}" y="{}" width="{}" height="{}" fill="{WHITE}"/>"#,
        Px(p.left),
        Px(p.top),
        Px(PANEL_W),
        Px(PLOT_H)
    );
    out.push('\n');

    for (v, label) in nice_ticks(p.y.lo, p.y.hi, 5.0) {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="11" text-anchor="end">{}</text>"#,
            Px(p.left - 6.0),
            Px(p.y.px(v) + 4.0),
            Esc(&label)
        );
        out.push('\n');
    }
    for (v, label) in nice_ticks(p.x.lo, p.x.hi, 8.0) {
        w!(
            out,
            r#"<text x="{}" y="{}" font-size="11" text-anchor="middle">{}</text>"#,
            Px(p.x.px(v)),
            Px(p.bottom() + 14.0),
            Esc(&label)
        );
        out.push('\n');
    }

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

/// Shade everything outside [lo, hi]; a missing bound means that side is unlimited.
fn draw_band(out: &mut String, p: &Panel, lo: Option<f64>, hi: Option<f64>) {
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
fn horizontal_line(out: &mut String, p: &Panel, y: f64, colour: &str) {
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

fn draw_limit_lines(out: &mut String, p: &Panel, lo: Option<f64>, hi: Option<f64>) {
    for v in lo.into_iter().chain(hi) {
        let y = p.y.px(v);
        horizontal_line(out, p, y, LIMIT_LINE);
    }
}

fn draw_grid(out: &mut String, p: &Panel) {
    for (v, _) in nice_ticks(p.y.lo, p.y.hi, 5.0) {
        let y = p.y.px(v);
        horizontal_line(out, p, y, GRID);
    }
    for (v, _) in nice_ticks(p.x.lo, p.x.hi, 8.0) {
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

fn draw_key_guides(out: &mut String, data: &PlotData, p: &Panel) {
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
fn draw_polyline(
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

fn draw_border(out: &mut String, p: &Panel) {
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

// ---------------------------------------------------------------------------------------------
// Formatting helpers
// ---------------------------------------------------------------------------------------------

/// A pixel coordinate: two decimals, trailing zeros dropped, never "-0", "NaN" or "inf".
struct Px(f64);

impl fmt::Display for Px {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_finite() { self.0 } else { 0.0 };
        let s = format!("{v:.2}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        f.write_str(if s == "-0" { "0" } else { s })
    }
}

/// A data value for human-readable annotations (limits, peaks): three significant digits, since
/// "peak 44.999" reads worse than "peak 45" and says nothing more.
fn short(v: f64) -> String {
    if !v.is_finite() {
        return "?".to_string();
    }
    let a = v.abs();
    let s = if a != 0.0 && !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        match s.split_once('e') {
            Some((m, e)) => {
                let m = m.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{e}")
            }
            None => s,
        }
    } else {
        // a is 0 or within [1e-3, 1e5) here, so the logarithm is finite or zero is special.
        let decimals = if a == 0.0 {
            0
        } else {
            (2 - a.log10().floor() as i64).clamp(0, 4) as usize
        };
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if s == "-0" {
        "0".to_string()
    } else {
        s
    }
}

/// XML-escaped text. Characters XML 1.0 forbids even when escaped (most C0 controls) are
/// dropped, and line breaks become spaces because every label is a single line.
struct Esc<'a>(&'a str);

impl fmt::Display for Esc<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            match c {
                '&' => f.write_str("&amp;")?,
                '<' => f.write_str("&lt;")?,
                '>' => f.write_str("&gt;")?,
                '"' => f.write_str("&quot;")?,
                '\'' => f.write_str("&#39;")?,
                '\n' | '\r' | '\t' => f.write_char(' ')?,
                c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => {}
                c => f.write_char(c)?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Minimal well-formedness check: tags nest and close, attribute quotes pair up, and every
    /// `&` starts an entity. Returns the first problem found.
    fn check_balanced(svg: &str) -> Result<(), String> {
        let mut stack: Vec<&str> = Vec::new();
        let mut rest = svg;
        let mut saw_root = false;
        while let Some(open) = rest.find('<') {
            check_text(&rest[..open])?;
            let after = &rest[open + 1..];
            // The tag ends at the first '>' outside an attribute value; running out of input
            // while still inside quotes means a quote was left open.
            let mut in_quotes = false;
            let close = after
                .char_indices()
                .find(|&(_, c)| {
                    if c == '"' {
                        in_quotes = !in_quotes;
                    }
                    c == '>' && !in_quotes
                })
                .map(|(i, _)| i)
                .ok_or_else(|| {
                    let near: String = after.chars().take(60).collect();
                    format!("unterminated tag or open quote near {near:?}")
                })?;
            let tag = &after[..close];
            rest = &after[close + 1..];
            if tag.starts_with('?') || tag.starts_with('!') {
                continue;
            }
            if let Some(name) = tag.strip_prefix('/') {
                let name = name.trim();
                match stack.pop() {
                    Some(top) if top == name => {}
                    other => return Err(format!("</{name}> closes {other:?}")),
                }
                continue;
            }
            let name = tag
                .split(|c: char| c.is_whitespace() || c == '/')
                .next()
                .unwrap_or("");
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric()) {
                return Err(format!("bad tag name in <{tag}>"));
            }
            if stack.is_empty() {
                if saw_root {
                    return Err(format!("second root element <{name}>"));
                }
                saw_root = true;
            }
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        check_text(rest)?;
        if !saw_root {
            return Err("no root element".into());
        }
        if !stack.is_empty() {
            return Err(format!("unclosed: {stack:?}"));
        }
        Ok(())
    }

    fn check_text(text: &str) -> Result<(), String> {
        if text.contains('>') {
            return Err(format!("raw '>' in text {text:?}"));
        }
        let mut rest = text;
        while let Some(i) = rest.find('&') {
            rest = &rest[i..];
            let ok = ["&amp;", "&lt;", "&gt;", "&quot;", "&#39;"]
                .iter()
                .any(|e| rest.starts_with(e));
            if !ok {
                return Err(format!("bare '&' in {text:?}"));
            }
            rest = &rest[1..];
        }
        Ok(())
    }

    fn assert_clean(svg: &str) {
        if let Err(e) = check_balanced(svg) {
            panic!("malformed SVG: {e}\n{svg}");
        }
        assert!(!svg.contains("NaN"), "NaN in output");
        assert!(!svg.contains("inf"), "inf in output");
        assert!(svg.starts_with("<svg "));
        assert!(svg.trim_end().ends_with("</svg>"));
    }

    fn count(svg: &str, needle: &str) -> usize {
        svg.matches(needle).count()
    }

    fn joint(name: &str, times: &[f64]) -> PlotJoint {
        let positions: Vec<f64> = times.iter().map(|t| 30.0 * (t * 1.3).sin()).collect();
        let velocities: Vec<f64> = times.iter().map(|t| 39.0 * (t * 1.3).cos()).collect();
        PlotJoint {
            name: name.to_string(),
            unit: "deg".to_string(),
            min: -45.0,
            max: 45.0,
            velocity_limit: 60.0,
            positions,
            velocities,
            keys: vec![(0.0, 0.0), (1.0, 29.0), (2.5, -3.0)],
            measured: None,
        }
    }

    fn sample() -> PlotData {
        let times: Vec<f64> = (0..=50).map(|i| i as f64 * 0.05).collect();
        let mut elbow = joint("elbow", &times);
        elbow.measured = Some(
            times
                .iter()
                .map(|&t| (t + 0.02, 30.0 * (t * 1.3).sin() + 0.5))
                .collect(),
        );
        elbow.keys.push((2.0, 15.0));
        PlotData {
            title: "pick & place".to_string(),
            joints: vec![joint("shoulder", &times), elbow, joint("wrist", &times)],
            times,
            key_marks: vec![
                (0.0, "start".into()),
                (1.0, "#1".into()),
                (2.5, "end".into()),
            ],
        }
    }

    #[test]
    fn counts_curves_keys_and_is_well_formed() {
        let data = sample();
        let svg = render_svg(&data);
        assert_clean(&svg);
        let measured = data.joints.iter().filter(|j| j.measured.is_some()).count();
        assert_eq!(count(&svg, "<polyline"), 2 * data.joints.len() + measured);
        let keys: usize = data.joints.iter().map(|j| j.keys.len()).sum();
        assert_eq!(count(&svg, "<circle"), keys);
        assert_eq!(count(&svg, "<clipPath"), 2 * data.joints.len());
        assert!(svg.contains("pick &amp; place"));
        assert!(svg.contains(">measured</text>"));
        assert!(svg.contains("time (s)"));
        assert!(svg.contains("velocity (deg/s)"));
        assert!(svg.contains("shoulder (deg)"));
        assert!(svg.contains(FONT));
        // Each key mark: one guide line per panel, one label per column.
        let guides = count(&svg, &format!("stroke=\"{KEY_MARK}\""));
        assert_eq!(guides, data.key_marks.len() * 2 * data.joints.len());
        assert_eq!(count(&svg, ">start</text>"), 2);
        // Height grows with the joint count.
        assert!(svg.contains(&format!(
            "height=\"{}\"",
            Px(HEADER_H + 3.0 * ROW_H + BOTTOM_PAD)
        )));
    }

    #[test]
    fn measured_legend_only_when_present() {
        let mut data = sample();
        for j in &mut data.joints {
            j.measured = None;
        }
        let svg = render_svg(&data);
        assert_clean(&svg);
        assert!(!svg.contains("measured"));
        assert_eq!(count(&svg, "<polyline"), 2 * data.joints.len());
    }

    #[test]
    fn text_is_escaped() {
        let mut data = sample();
        data.title = "\"quoted\" <title>".into();
        data.joints[0].name = "a<b&c".into();
        data.joints[0].unit = "m>s".into();
        data.key_marks.push((0.5, "k<1>&\"x\"\u{1}\nline".into()));
        let svg = render_svg(&data);
        assert_clean(&svg);
        assert!(svg.contains("a&lt;b&amp;c"));
        assert!(!svg.contains("a<b"));
        assert!(svg.contains("a&lt;b&amp;c (m&gt;s)"));
        assert!(svg.contains("&quot;quoted&quot; &lt;title&gt;"));
        assert!(svg.contains("k&lt;1&gt;&amp;&quot;x&quot; line"));
        assert!(!svg.contains('\u{1}'));
    }

    #[test]
    fn long_names_are_shortened_but_keep_the_unit() {
        let mut data = sample();
        data.joints[0].name = "x".repeat(200);
        data.key_marks[0].1 = "y".repeat(200);
        let svg = render_svg(&data);
        assert_clean(&svg);
        assert!(!svg.contains(&"x".repeat(60)));
        assert!(!svg.contains(&"y".repeat(60)));
        assert!(svg.contains("… (deg)</text>"));
    }

    #[test]
    fn value_above_max_lands_in_shaded_zone() {
        let data = PlotData {
            title: "overshoot".into(),
            times: vec![0.0, 1.0, 2.0],
            joints: vec![PlotJoint {
                name: "j".into(),
                unit: "rad".into(),
                min: -1.0,
                max: 1.0,
                velocity_limit: 2.0,
                positions: vec![0.0, 2.0, 0.0],
                velocities: vec![2.0, 0.0, -2.0],
                keys: vec![],
                measured: None,
            }],
            key_marks: vec![],
        };
        let svg = render_svg(&data);
        assert_clean(&svg);

        // By hand: data+limits span [-1, 2], 5% padding of 3 → y range [-1.15, 2.15], span 3.3.
        // Row 0 position panel: top = HEADER_H + ROW_TITLE_H = 92 + 20 = 112, height 112,
        // left = MARGIN_LEFT = 72, width 464, time range [0, 2].
        let top = HEADER_H + ROW_TITLE_H;
        assert_eq!(top, 112.0);
        let y_of = |v: f64| top + (2.15 - v) / 3.3 * PLOT_H;
        let y_peak = y_of(2.0); // 112 + 0.15/3.3*112 = 117.09
        let y_max = y_of(1.0); // 112 + 1.15/3.3*112 = 151.03
        let y_min = y_of(-1.0); // 112 + 3.15/3.3*112 = 218.91
        assert_eq!(format!("{}", Px(y_peak)), "117.09");
        assert_eq!(format!("{}", Px(y_max)), "151.03");
        assert_eq!(format!("{}", Px(y_min)), "218.91");
        let x_mid = MARGIN_LEFT + 0.5 * PANEL_W; // 72 + 232 = 304
        assert_eq!(x_mid, 304.0);

        // The curve passes through the overshoot at (304, 117.09), above the max line at 151.03
        // (smaller y is higher on screen) but still inside the panel. Its ends are y(0) =
        // 112 + 2.15/3.3*112 = 184.97 at x = 72 and x = 72 + 464 = 536.
        assert!(svg.contains("points=\"72,184.97 304,117.09 536,184.97\""));
        assert!(top < y_peak && y_peak < y_max);
        assert!(svg.contains(&format!(
            "<line x1=\"72\" y1=\"151.03\" x2=\"536\" y2=\"151.03\" stroke=\"{LIMIT_LINE}\""
        )));
        // The shaded zone above max spans exactly [top, y_max], which contains the peak.
        assert!(svg.contains(&format!(
            "<rect x=\"72\" y=\"112\" width=\"464\" height=\"39.03\" fill=\"{LIMIT_FILL}\"/>"
        )));
        // And the lower zone from the min line to the panel bottom (224).
        assert!(svg.contains(&format!(
            "<rect x=\"72\" y=\"218.91\" width=\"464\" height=\"5.09\" fill=\"{LIMIT_FILL}\"/>"
        )));
    }

    #[test]
    fn velocity_band_is_symmetric() {
        let data = PlotData {
            title: String::new(),
            times: vec![0.0, 1.0],
            joints: vec![PlotJoint {
                name: "j".into(),
                unit: "deg".into(),
                min: 0.0,
                max: 1.0,
                velocity_limit: -10.0, // sign is ignored: the limit is a magnitude
                positions: vec![0.0, 1.0],
                velocities: vec![0.0, 0.0],
                ..Default::default()
            }],
            key_marks: vec![],
        };
        let svg = render_svg(&data);
        assert_clean(&svg);
        // y range [-10, 10] padded to [-11, 11]; panel top 112, height 112 → ±10 at 112 ± 50.91.
        let top = HEADER_H + ROW_TITLE_H;
        let y_hi = top + 1.0 / 22.0 * PLOT_H;
        let y_lo = top + 21.0 / 22.0 * PLOT_H;
        let left = MARGIN_LEFT + PANEL_W + PANEL_GAP; // 620
        assert_eq!(left, 620.0);
        for y in [y_hi, y_lo] {
            assert!(svg.contains(&format!(
                "<line x1=\"620\" y1=\"{0}\" x2=\"1084\" y2=\"{0}\" stroke=\"{LIMIT_LINE}\"",
                Px(y)
            )));
        }
        assert!(svg.contains("limit ±10 deg/s, peak 0 (0%)"));
    }

    fn edge_joint(times_len: usize) -> PlotJoint {
        PlotJoint {
            name: "edge".into(),
            unit: "deg".into(),
            min: 0.0,
            max: 0.0,
            velocity_limit: 0.0,
            positions: vec![0.0; times_len],
            velocities: vec![0.0; times_len],
            keys: vec![],
            measured: None,
        }
    }

    #[test]
    fn edge_cases_do_not_panic_and_stay_well_formed() {
        let nan = f64::NAN;
        let inf = f64::INFINITY;
        // All values equal, min == max == data.
        let mut flat = edge_joint(4);
        flat.positions = vec![7.0; 4];
        flat.min = 7.0;
        flat.max = 7.0;
        flat.keys = vec![(0.0, 7.0)];
        // NaN / infinite everywhere.
        let mut wild = edge_joint(5);
        wild.positions = vec![0.0, nan, inf, -inf, 1.0];
        wild.velocities = vec![nan, nan, nan, nan, nan];
        wild.min = nan;
        wild.max = inf;
        wild.velocity_limit = nan;
        wild.keys = vec![(nan, 1.0), (1.0, inf)];
        wild.measured = Some(vec![(nan, 0.0), (0.5, nan), (1.0, 0.5)]);
        // Huge and tiny magnitudes, swapped limits, mismatched lengths.
        let mut huge = edge_joint(3);
        huge.positions = vec![1e300, -f64::MAX, 5.0];
        huge.velocities = vec![1e-300];
        huge.min = 10.0;
        huge.max = -10.0;
        // Near-degenerate span around a large value, unlimited joint.
        let mut big = edge_joint(2);
        big.positions = vec![1e9, 1e9 + 1e-6];
        big.min = f64::NEG_INFINITY;
        big.max = f64::INFINITY;

        let cases = vec![
            // Zero joints, nothing at all.
            PlotData::default(),
            // Zero joints but with marks and a title.
            PlotData {
                title: "empty".into(),
                key_marks: vec![(1.0, "k".into())],
                ..Default::default()
            },
            // Empty times with a joint.
            PlotData {
                joints: vec![edge_joint(0)],
                ..Default::default()
            },
            // Single time.
            PlotData {
                times: vec![3.0],
                joints: vec![edge_joint(1)],
                key_marks: vec![(3.0, "only".into())],
                ..Default::default()
            },
            PlotData {
                times: vec![0.0, 1.0, 2.0, 3.0],
                joints: vec![flat],
                ..Default::default()
            },
            PlotData {
                title: "wild".into(),
                times: vec![0.0, 1.0, nan, inf, 2.0],
                joints: vec![wild],
                key_marks: vec![(nan, "x".into()), (-inf, "y".into()), (1.0, "ok".into())],
            },
            // Only non-finite times.
            PlotData {
                times: vec![nan, inf],
                joints: vec![edge_joint(2)],
                ..Default::default()
            },
            PlotData {
                times: vec![0.0, 1e-12, 2e-12],
                joints: vec![huge],
                ..Default::default()
            },
            PlotData {
                times: vec![1e6, 1e6 + 1.0],
                joints: vec![big],
                ..Default::default()
            },
        ];

        for (i, data) in cases.iter().enumerate() {
            let svg = render_svg(data);
            if let Err(e) = check_balanced(&svg) {
                panic!("case {i}: {e}\n{svg}");
            }
            assert_clean(&svg);
            let measured = data.joints.iter().filter(|j| j.measured.is_some()).count();
            assert_eq!(
                count(&svg, "<polyline"),
                2 * data.joints.len() + measured,
                "case {i}"
            );
        }
    }

    #[test]
    fn wild_values_are_skipped_not_written() {
        let mut j = edge_joint(4);
        j.min = -1.0;
        j.max = 1.0;
        j.positions = vec![0.0, f64::NAN, 0.5, f64::INFINITY];
        j.keys = vec![(0.0, 0.0), (f64::NAN, 0.0)];
        let data = PlotData {
            times: vec![0.0, 1.0, 2.0, 3.0],
            joints: vec![j],
            ..Default::default()
        };
        let svg = render_svg(&data);
        assert_clean(&svg);
        let pos_line = svg.lines().find(|l| l.starts_with("<polyline")).unwrap();
        let pts = pos_line.split("points=\"").nth(1).unwrap();
        assert_eq!(pts.trim_end_matches("\"/>").split(' ').count(), 2);
        assert_eq!(count(&svg, "<circle"), 1);
    }

    #[test]
    fn nice_ticks_are_round_and_exact() {
        let labels = |lo, hi, n| -> Vec<String> {
            nice_ticks(lo, hi, n).into_iter().map(|(_, s)| s).collect()
        };
        assert_eq!(labels(0.0, 10.0, 5.0), ["0", "2", "4", "6", "8", "10"]);
        assert_eq!(
            labels(0.0, 1.0, 5.0),
            ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        );
        assert_eq!(labels(-1.15, 2.15, 5.0), ["-1", "0", "1", "2"]);
        assert_eq!(labels(-190.0, 190.0, 5.0), ["-100", "0", "100"]);
        assert_eq!(
            labels(0.0, 0.0025, 5.0),
            ["0.0000", "0.0005", "0.0010", "0.0015", "0.0020", "0.0025"]
        );
        assert_eq!(
            labels(0.0, 2.5e7, 5.0),
            ["0", "5e6", "1e7", "1.5e7", "2e7", "2.5e7"]
        );
        assert_eq!(labels(0.0, 2e-12, 8.0)[1..4], ["5e-13", "1e-12", "1.5e-12"]);
        let steps: Vec<i64> = [0.7, 1.3, 3.3, 7.0, 9.9]
            .iter()
            .map(|&s| nice_step(s, 1.0).mant)
            .collect();
        assert_eq!(steps, [1, 2, 5, 1, 1]);
        assert!(nice_ticks(1.0, 1.0, 5.0).is_empty());
        assert!(nice_ticks(0.0, f64::INFINITY, 5.0).is_empty());
        assert!(nice_ticks(f64::NAN, 1.0, 5.0).is_empty());
    }

    #[test]
    fn pixel_numbers_are_short() {
        assert_eq!(Px(12.0).to_string(), "12");
        assert_eq!(Px(12.5).to_string(), "12.5");
        assert_eq!(Px(1.0 / 3.0).to_string(), "0.33");
        assert_eq!(Px(-0.001).to_string(), "0");
        assert_eq!(Px(f64::NAN).to_string(), "0");
        assert_eq!(short(-45.0), "-45");
        assert_eq!(short(0.12345), "0.123");
        assert_eq!(short(2.5e6), "2.5e6");
    }
}
