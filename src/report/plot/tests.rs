use super::axis::{nice_step, nice_ticks};
use super::layout::{PANEL_GAP, ROW_TITLE_H};
use super::style::{KEY_MARK, LIMIT_FILL, LIMIT_LINE};
use super::text::short;
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
        telemetry: Vec::new(),
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
        telemetry: Vec::new(),
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
        telemetry: Vec::new(),
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
            telemetry: Vec::new(),
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
    let labels =
        |lo, hi, n| -> Vec<String> { nice_ticks(lo, hi, n).into_iter().map(|(_, s)| s).collect() };
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

#[test]
fn a_log_with_telemetry_gets_a_load_and_a_temperature_panel_per_joint() {
    let mut data = sample();
    data.joints.truncate(1);
    data.telemetry = vec![TelemetryRow {
        name: "shoulder".into(),
        load: vec![(0.0, 10.0), (1.0, 40.0), (2.5, -20.0)],
        need: vec![(0.0, 10.0), (2.5, 10.0)],
        temperature: vec![(0.0, 25.0), (2.5, 31.0)],
        temperature_limit: Some(70.0),
        push_line: Some(20.0),
    }];
    let svg = render_svg(&data);
    assert_clean(&svg);
    // The joint's two curves and its measured none; then load, need and temperature.
    assert_eq!(count(&svg, "<polyline"), 2 + 3);
    assert_eq!(count(&svg, "<clipPath"), 2 * 2);
    assert_eq!(count(&svg, " · load<"), 1);
    assert_eq!(count(&svg, " · temperature<"), 1);
    assert!(svg.contains("peak 40 %, need dashed"));
    assert!(svg.contains("hottest 31 °C, protection 70 °C"));
    // By hand: the load panel spans -20 … 40 (the ±20 % lines and the data), padded by 5 % of
    // 60 → -23 … 43, span 66. Row 1: top = HEADER_H + ROW_H + ROW_TITLE_H = 92 + 170 + 20 =
    // 282; the +20 % line at 282 + (43 − 20)/66 · 112 = 321.03; the time axis 0 … 2.5 over
    // 72 … 536, so the point (1.0, 40) is at x = 72 + 464 · 0.4 = 257.6, y = 282 + 3/66 · 112
    // = 287.09.
    assert!(svg.contains(&format!(
        "<line x1=\"72\" y1=\"321.03\" x2=\"536\" y2=\"321.03\" stroke=\"{LIMIT_LINE}\""
    )));
    assert!(svg.contains("257.6,287.09"), "{svg}");
    // Two rows in all.
    assert!(svg.contains(&format!(
        "height=\"{}\"",
        Px(HEADER_H + 2.0 * ROW_H + BOTTOM_PAD)
    )));
}
