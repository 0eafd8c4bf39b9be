//! Time-series plots as self-contained SVG, for the HTML report.

use std::fmt::Write as _;

use tether_svg::xml_escape;

/// One line of a plot.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// CSS colour.
    pub color: String,
    /// Dashed line.
    pub dashed: bool,
    /// Points `(x, y)`; `None` breaks the line (no data).
    pub points: Vec<(f64, Option<f64>)>,
}

/// A plot of several series against time.
#[derive(Debug, Clone, Default)]
pub struct Plot {
    /// Title above the plot.
    pub title: String,
    /// Label of the y axis (with unit).
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
    /// Shaded horizontal bands `(y0, y1, colour, label)`.
    pub bands: Vec<(f64, f64, String, String)>,
    /// Horizontal reference lines `(y, colour, label)`.
    pub hlines: Vec<(f64, String, String)>,
    /// Shaded vertical spans `(x0, x1, colour, label)` (e.g. when the target was lost).
    pub spans: Vec<(f64, f64, String, String)>,
}

const W: f64 = 760.0;
const H: f64 = 220.0;
const LEFT: f64 = 56.0;
const RIGHT: f64 = 12.0;
const TOP: f64 = 28.0;
const BOTTOM: f64 = 34.0;

/// Width of a character of the plots' 11 px text, px: DejaVu Sans' digits are 0.64 em
/// (7.0 px), wider than most other fonts' (Arial's are 0.56 em), so estimates err on
/// the wide side.
pub const CHAR_PX: f64 = 7.0;
/// Height of the plots' 11 px text, px.
pub const TEXT_H_PX: f64 = 11.0;
/// Least gap between two neighbouring tick labels side by side (the time axis), px.
pub const TICK_GAP_PX: f64 = 8.0;
/// Least gap between two tick labels one above the other (the y axis), px.
pub const TICK_GAP_Y_PX: f64 = 4.0;

/// "Nice" tick spacing for a range.
pub(crate) fn tick_step(span: f64) -> f64 {
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let raw = span / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let nice = if norm < 1.5 {
        1.0
    } else if norm < 3.5 {
        2.0
    } else if norm < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * mag
}

/// The round step (1, 2 or 5 times a power of ten) after `step`.
fn next_step(step: f64) -> f64 {
    let mag = 10f64.powf(step.log10().floor());
    let norm = step / mag;
    if norm < 1.5 {
        2.0 * mag
    } else if norm < 3.5 {
        5.0 * mag
    } else {
        10.0 * mag
    }
}

/// A tick's label: as many decimals as the step needs, no trailing zeros.
pub fn tick_label(v: f64, step: f64) -> String {
    let decimals = if step.is_finite() && step > 0.0 {
        (-step.log10() + 1e-9).ceil().clamp(0.0, 6.0) as usize
    } else {
        2
    };
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        &s
    };
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// The ticks of an axis from `lo` to `hi` drawn `len_px` long: the multiples of a
/// round step (1, 2 or 5 times a power of ten), about six of them, or fewer when their
/// labels would come closer than `gap_px`. `extent_px(label)` is how far a label
/// reaches along the axis (its width on a horizontal axis, its height on a vertical
/// one). Returns the step and the ticks with their labels.
pub fn axis_ticks(
    lo: f64,
    hi: f64,
    len_px: f64,
    extent_px: impl Fn(&str) -> f64,
    gap_px: f64,
) -> (f64, Vec<(f64, String)>) {
    let span = hi - lo;
    if !(lo.is_finite() && span.is_finite() && span > 0.0 && len_px > 0.0) {
        return (1.0, Vec::new());
    }
    let mut step = tick_step(span);
    for _ in 0..64 {
        let (first, last) = ((lo / step - 1e-9).ceil(), (hi / step + 1e-9).floor());
        let ticks: Vec<(f64, String)> = if last >= first && last - first < 1e4 {
            (first as i64..=last as i64)
                .map(|i| {
                    let v = i as f64 * step;
                    (v, tick_label(v, step))
                })
                .collect()
        } else {
            Vec::new()
        };
        let apart_px = step / span * len_px;
        let widest = ticks.iter().map(|(_, t)| extent_px(t)).fold(0.0, f64::max);
        if ticks.len() <= 1 || apart_px >= widest + gap_px {
            return (step, ticks);
        }
        step = next_step(step);
    }
    (step, Vec::new())
}

/// The estimated width of a line of the plots' 11 px text, px.
pub fn text_width_px(text: &str) -> f64 {
    CHAR_PX * text.chars().count() as f64
}

/// The legend's entries that have a label (entries without text are left out, and
/// an entry repeated with the same label, colour and mark is shown once), laid out in
/// rows that wrap at the plot's width: (label, colour, mark, x, row).
fn legend_layout(
    entries: Vec<(String, String, &'static str)>,
) -> Vec<(String, String, &'static str, f64, usize)> {
    let mut out: Vec<(String, String, &'static str, f64, usize)> = Vec::new();
    let (mut x, mut row) = (LEFT, 0);
    for (label, color, kind) in entries {
        if label.trim().is_empty()
            || out
                .iter()
                .any(|(l, c, k, _, _)| *l == label && *c == color && *k == kind)
        {
            continue;
        }
        let w = 28.0 + text_width_px(&label) + 24.0;
        if x + w > W - RIGHT && x > LEFT {
            x = LEFT;
            row += 1;
        }
        out.push((label, color, kind, x, row));
        x += w;
    }
    out
}

/// How a plot is drawn, beyond its data.
#[derive(Debug, Clone, Copy, Default)]
pub struct View {
    /// Only this time window, s: the x axis spans it and the y axis fits what lies in
    /// it.
    pub window: Option<(f64, f64)>,
    /// A long run's overview: the first series is drawn last (on top), the others
    /// solid, thinner and translucent beneath it, so that a noisy estimate does not
    /// hide the truth (a dashed line cannot be read once a series is thinned to its
    /// least and greatest value per pixel column).
    pub first_on_top: bool,
}

/// Baseline of the legend's first row below the plot's frame (`H`), px: below the
/// time axis's title.
const LEGEND_TOP: f64 = 18.0;
/// Height of a legend row, px.
const LEGEND_ROW: f64 = 18.0;
/// A series with more than this many points per pixel column of the plot is thinned
/// ([`thin`]).
pub const POINTS_PER_PX: f64 = 2.0;

/// The points of `points` to draw across `columns` pixel columns from `x0` to `x1`:
/// all of them when there are at most [`POINTS_PER_PX`] a column, else, in each
/// column, the point of least and the point of greatest value, in time order (every
/// peak and dip stays, the line's pixels are the same). `None` (a break in the line)
/// is kept.
pub fn thin(
    points: &[(f64, Option<f64>)],
    x0: f64,
    x1: f64,
    columns: f64,
) -> Vec<(f64, Option<f64>)> {
    if (points.len() as f64) <= POINTS_PER_PX * columns || !(x1 > x0) {
        return points.to_vec();
    }
    let column = |x: f64| ((x - x0) / (x1 - x0) * columns).floor() as i64;
    let mut out = Vec::new();
    // The current column and the indices of its least and greatest point.
    let mut bucket: Option<(i64, usize, usize)> = None;
    let flush = |bucket: &mut Option<(i64, usize, usize)>, out: &mut Vec<(f64, Option<f64>)>| {
        if let Some((_, lo, hi)) = bucket.take() {
            out.push(points[lo.min(hi)]);
            if lo != hi {
                out.push(points[lo.max(hi)]);
            }
        }
    };
    for (i, &(x, y)) in points.iter().enumerate() {
        let Some(v) = y.filter(|v| v.is_finite() && x.is_finite()) else {
            flush(&mut bucket, &mut out);
            out.push((x, None));
            continue;
        };
        let c = column(x);
        match &mut bucket {
            Some((bc, lo, hi)) if *bc == c => {
                let value = |j: usize| points[j].1.unwrap_or(v);
                if v < value(*lo) {
                    *lo = i;
                }
                if v > value(*hi) {
                    *hi = i;
                }
            }
            _ => {
                flush(&mut bucket, &mut out);
                bucket = Some((c, i, i));
            }
        }
    }
    flush(&mut bucket, &mut out);
    out
}

/// The points of `points` within `[a, b]`, with the one just before and the one just
/// after, so that the line runs to the window's edges.
fn windowed(points: &[(f64, Option<f64>)], (a, b): (f64, f64)) -> &[(f64, Option<f64>)] {
    let first = points.iter().position(|p| p.0 >= a).unwrap_or(points.len());
    let end = points.iter().rposition(|p| p.0 <= b).map_or(0, |i| i + 1);
    if first >= end {
        return &[];
    }
    &points[first.saturating_sub(1)..(end + 1).min(points.len())]
}

/// The plot's ranges and its mapping from data to pixels.
#[derive(Debug, Clone, Copy)]
struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Frame {
    const PW: f64 = W - LEFT - RIGHT;
    const PH: f64 = H - TOP - BOTTOM;

    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x0) / (self.x1 - self.x0) * Self::PW
    }

    fn py(&self, y: f64) -> f64 {
        TOP + (self.y1 - y) / (self.y1 - self.y0) * Self::PH
    }
}

impl Plot {
    /// Every legend entry the plot's parts ask for, in order: (label, colour, mark),
    /// some maybe without a label (which [`Plot::svg`] leaves out).
    fn legend_entries(&self, view: &View) -> Vec<(String, String, &'static str)> {
        self.series
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let mark = if view.first_on_top && k > 0 {
                    "faint"
                } else if s.dashed {
                    "dash"
                } else {
                    "line"
                };
                (s.label.clone(), s.color.clone(), mark)
            })
            .chain(self.bands.iter().map(|b| (b.3.clone(), b.2.clone(), "box")))
            .chain(
                self.hlines
                    .iter()
                    .map(|h| (h.2.clone(), h.1.clone(), "dash")),
            )
            .chain(
                self.spans
                    .iter()
                    .map(|sp| (sp.3.clone(), sp.2.clone(), "box")),
            )
            .collect()
    }

    /// The series' points as drawn: within the view's window, thinned to the plot's
    /// pixel columns.
    fn drawn_points(&self, view: &View, frame: &Frame) -> Vec<Vec<(f64, Option<f64>)>> {
        self.series
            .iter()
            .map(|s| {
                let points = match view.window {
                    Some(w) => windowed(&s.points, w),
                    None => &s.points,
                };
                thin(points, frame.x0, frame.x1, Frame::PW)
            })
            .collect()
    }

    /// The ranges: the data's (or the window's) in x, the values within it (and the
    /// bands and lines) in y, padded by 5 %.
    fn frame(&self, view: &View) -> Frame {
        let inside = |x: f64| view.window.is_none_or(|(a, b)| x >= a && x <= b);
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for s in &self.series {
            for &(x, y) in s.points.iter().filter(|p| inside(p.0)) {
                if x.is_finite() {
                    xs.push(x);
                }
                if let Some(y) = y.filter(|y| y.is_finite()) {
                    ys.push(y);
                }
            }
        }
        for b in &self.bands {
            ys.extend([b.0, b.1]);
        }
        for h in &self.hlines {
            ys.push(h.0);
        }
        let fold = |v: &[f64], f: fn(f64, f64) -> f64, init: f64| v.iter().copied().fold(init, f);
        let (mut x0, mut x1) = match view.window {
            Some((a, b)) => (a, b),
            None => (
                fold(&xs, f64::min, f64::INFINITY),
                fold(&xs, f64::max, f64::NEG_INFINITY),
            ),
        };
        let (mut y0, mut y1) = (
            fold(&ys, f64::min, f64::INFINITY),
            fold(&ys, f64::max, f64::NEG_INFINITY),
        );
        if !(x0.is_finite() && x1 > x0) {
            (x0, x1) = (0.0, 1.0);
        }
        if !(y0.is_finite() && y1 > y0) {
            let base = if y0.is_finite() {
                y0.clamp(-1.0, 0.0)
            } else {
                0.0
            };
            (y0, y1) = (base, base + 1.0);
        }
        let pad = 0.05 * (y1 - y0);
        Frame {
            x0,
            x1,
            y0: y0 - pad,
            y1: y1 + pad,
        }
    }

    /// Renders the plot.
    pub fn svg(&self) -> String {
        self.svg_view(&View::default())
    }

    /// Renders the plot as `view` says.
    pub fn svg_view(&self, view: &View) -> String {
        let frame = self.frame(view);
        let legend = legend_layout(self.legend_entries(view));
        let legend_h = legend
            .last()
            .map_or(0.0, |e| LEGEND_TOP - 4.0 + LEGEND_ROW * (e.4 + 1) as f64);
        let height = H + legend_h;
        let (pw, ph) = (Frame::PW, Frame::PH);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" class="plot" style="max-width:100%;height:auto" width="{W:.0}" height="{height:.0}" viewBox="0 0 {W:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
        );
        let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
        let _ = writeln!(
            s,
            r#"<text x="{LEFT}" y="16" font-size="13" font-weight="bold">{}</text>"#,
            xml_escape(&self.title)
        );
        let _ = writeln!(
            s,
            r#"<defs><clipPath id="plotarea"><rect x="{LEFT}" y="{TOP}" width="{pw:.1}" height="{ph:.1}"/></clipPath></defs>"#
        );
        self.shades(&frame, &mut s);
        axes(&frame, &self.y_label, &mut s);
        for (y, color, _) in &self.hlines {
            let _ = writeln!(
                s,
                r#"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-dasharray="3 3"/>"#,
                frame.py(*y),
                LEFT + pw
            );
        }
        self.lines(view, &frame, &mut s);
        legend_svg(&legend, &mut s);
        let _ = writeln!(s, "</svg>");
        s
    }

    /// The shaded spans (in time) and bands (in value), clipped to the plot.
    fn shades(&self, frame: &Frame, s: &mut String) {
        for (a, b, color, _) in &self.spans {
            let (xa, xb) = (frame.px(a.max(frame.x0)), frame.px(b.min(frame.x1)));
            if xb > xa {
                let _ = writeln!(
                    s,
                    r#"<rect x="{xa:.1}" y="{TOP}" width="{:.1}" height="{:.1}" fill="{color}" fill-opacity="0.25"/>"#,
                    xb - xa,
                    Frame::PH
                );
            }
        }
        for (a, b, color, _) in &self.bands {
            let (ya, yb) = (frame.py(b.max(*a)), frame.py(a.min(*b)));
            let _ = writeln!(
                s,
                r#"<rect x="{LEFT}" y="{ya:.1}" width="{:.1}" height="{:.1}" fill="{color}" fill-opacity="0.25"/>"#,
                Frame::PW,
                (yb - ya).max(0.0)
            );
        }
    }

    /// The series' lines, clipped to the plot; with [`View::first_on_top`], the first
    /// last.
    fn lines(&self, view: &View, frame: &Frame, s: &mut String) {
        let _ = writeln!(
            s,
            r#"<g clip-path="url(#plotarea)" fill="none" stroke-width="1.6">"#
        );
        let points = self.drawn_points(view, frame);
        let mut order: Vec<usize> = (0..self.series.len()).collect();
        if view.first_on_top {
            order.rotate_left(1);
        }
        for k in order {
            let series = &self.series[k];
            let style = if view.first_on_top && k > 0 {
                r#" stroke-width="1.1" stroke-opacity="0.55""#
            } else if series.dashed {
                r#" stroke-dasharray="6 3""#
            } else {
                ""
            };
            let mut run: Vec<String> = Vec::new();
            let flush = |run: &mut Vec<String>, s: &mut String| {
                if run.len() > 1 {
                    let _ = writeln!(
                        s,
                        r#"<polyline points="{}" stroke="{}"{style}/>"#,
                        run.join(" "),
                        series.color
                    );
                }
                run.clear();
            };
            for &(x, y) in &points[k] {
                match y.filter(|y| y.is_finite()) {
                    Some(y) if x.is_finite() => {
                        run.push(format!("{:.1},{:.1}", frame.px(x), frame.py(y)));
                    }
                    _ => flush(&mut run, s),
                }
            }
            flush(&mut run, s);
        }
        let _ = writeln!(s, "</g>");
    }
}

/// The axes, their ticks and labels, and their titles.
fn axes(frame: &Frame, y_label: &str, s: &mut String) {
    let (pw, ph) = (Frame::PW, Frame::PH);
    let _ = writeln!(s, r##"<g stroke="#999999" stroke-width="1">"##);
    let _ = writeln!(
        s,
        r#"<line x1="{LEFT}" y1="{:.1}" x2="{:.1}" y2="{:.1}"/>"#,
        TOP + ph,
        LEFT + pw,
        TOP + ph
    );
    let _ = writeln!(
        s,
        r#"<line x1="{LEFT}" y1="{TOP}" x2="{LEFT}" y2="{:.1}"/>"#,
        TOP + ph
    );
    let _ = writeln!(s, "</g>");
    // Ticks no closer than their labels allow: on the time axis by the labels'
    // widths, on the y axis by their height.
    let (_, x_ticks) = axis_ticks(frame.x0, frame.x1, pw, text_width_px, TICK_GAP_PX);
    for (t, label) in &x_ticks {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{TOP}" x2="{0:.1}" y2="{1:.1}" stroke="#eeeeee"/><text class="tick-x" x="{0:.1}" y="{2:.1}" text-anchor="middle">{3}</text>"##,
            frame.px(*t),
            TOP + ph,
            TOP + ph + 14.0,
            xml_escape(label)
        );
    }
    let (_, y_ticks) = axis_ticks(frame.y0, frame.y1, ph, |_| TEXT_H_PX, TICK_GAP_Y_PX);
    for (t, label) in &y_ticks {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#eeeeee"/><text class="tick-y" x="{2:.1}" y="{3:.1}" text-anchor="end">{4}</text>"##,
            frame.py(*t),
            LEFT + pw,
            LEFT - 4.0,
            frame.py(*t) + 4.0,
            xml_escape(label)
        );
    }
    let _ = writeln!(
        s,
        r#"<text class="axis-title" x="{:.1}" y="{:.1}" text-anchor="middle">time (s)</text>"#,
        LEFT + pw / 2.0,
        TOP + ph + 30.0
    );
    let _ = writeln!(
        s,
        r#"<text class="axis-title" x="12" y="{:.1}" text-anchor="middle" transform="rotate(-90 12 {:.1})">{}</text>"#,
        TOP + ph / 2.0,
        TOP + ph / 2.0,
        xml_escape(y_label)
    );
}

/// The legend: the entries with a label, in rows below the time axis's title.
fn legend_svg(legend: &[(String, String, &'static str, f64, usize)], s: &mut String) {
    for (label, color, kind, x, row) in legend {
        let (x, y) = (*x, H + LEGEND_TOP + *row as f64 * LEGEND_ROW);
        let mark = match *kind {
            "box" => format!(
                r#"<rect x="{x:.1}" y="{:.1}" width="22" height="10" fill="{color}" fill-opacity="0.35"/>"#,
                y - 8.0
            ),
            "dash" => format!(
                r#"<line x1="{x:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-width="2" stroke-dasharray="6 3"/>"#,
                y - 3.0,
                x + 22.0
            ),
            "faint" => format!(
                r#"<line x1="{x:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-width="1.6" stroke-opacity="0.55"/>"#,
                y - 3.0,
                x + 22.0
            ),
            _ => format!(
                r#"<line x1="{x:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-width="2"/>"#,
                y - 3.0,
                x + 22.0
            ),
        };
        let _ = writeln!(
            s,
            r#"<g class="legend-entry">{mark}<text x="{:.1}" y="{y:.1}">{}</text></g>"#,
            x + 28.0,
            xml_escape(label)
        );
    }
}

pub(crate) fn trim(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_series_bands_and_gaps() {
        let p = Plot {
            title: "distance".into(),
            y_label: "d (m)".into(),
            series: vec![Series {
                label: "true".into(),
                color: "#d62728".into(),
                dashed: false,
                points: vec![
                    (0.0, Some(1.0)),
                    (1.0, Some(1.2)),
                    (2.0, None),
                    (3.0, Some(0.9)),
                    (4.0, Some(1.0)),
                ],
            }],
            bands: vec![(0.8, 1.5, "#2ca02c".into(), "comfort band".into())],
            hlines: vec![(1.0, "#000".into(), "d0".into())],
            spans: vec![(2.0, 3.0, "#999".into(), "target lost".into())],
        };
        let svg = p.svg();
        assert!(svg.starts_with("<svg"));
        // The gap splits the line in two polylines.
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("comfort band") && svg.contains("target lost"));
    }

    /// The tick labels of an axis as drawn: (centre px, width px), left to right.
    fn drawn(lo: f64, hi: f64, len_px: f64) -> Vec<(f64, f64)> {
        let (_, ticks) = axis_ticks(lo, hi, len_px, text_width_px, TICK_GAP_PX);
        ticks
            .iter()
            .map(|(v, label)| ((v - lo) / (hi - lo) * len_px, text_width_px(label)))
            .collect()
    }

    fn assert_apart(labels: &[(f64, f64)], what: &str) {
        for pair in labels.windows(2) {
            let ((a, wa), (b, wb)) = (pair[0], pair[1]);
            assert!(
                b - a >= (wa + wb) / 2.0 + TICK_GAP_PX - 1e-9,
                "{what}: labels at {a:.1} and {b:.1} px, {wa} and {wb} px wide"
            );
        }
    }

    #[test]
    fn tick_labels_of_long_and_short_axes_do_not_overlap() {
        let pw = W - LEFT - RIGHT;
        for (lo, hi, len) in [
            (0.0, 600.0, pw),    // ten minutes
            (0.0, 26.0, pw),     // the corridor
            (0.0, 3.0, pw),      // a short run
            (0.0, 86_400.0, pw), // a day
            (0.0, 600.0, 120.0), // a narrow axis
            (0.0, 86_400.0, 90.0),
            (1e6, 1e6 + 37.0, pw), // long labels
            (-0.37, 1.71, 60.0),
        ] {
            let labels = drawn(lo, hi, len);
            assert!(!labels.is_empty(), "{lo}..{hi} on {len} px: no ticks");
            assert_apart(&labels, &format!("{lo}..{hi} on {len} px"));
        }
        // As many as fit: ten minutes on the plot's width keep a tick every 100 s.
        let (step, ticks) = axis_ticks(0.0, 600.0, pw, text_width_px, TICK_GAP_PX);
        assert_eq!((step, ticks.len()), (100.0, 7));
        // A short axis takes fewer, rounder ticks rather than crowding them.
        let (step, _) = axis_ticks(0.0, 600.0, 120.0, text_width_px, TICK_GAP_PX);
        assert!(step >= 200.0, "{step}");
        // Labels carry as many decimals as the step needs, no more.
        let (_, ticks) = axis_ticks(0.0, 0.05, 400.0, text_width_px, TICK_GAP_PX);
        let labels: Vec<&str> = ticks.iter().map(|(_, t)| t.as_str()).collect();
        assert_eq!(labels, ["0", "0.01", "0.02", "0.03", "0.04", "0.05"]);
    }

    /// The x positions and texts of the `tick-x` labels of a rendered plot.
    fn x_tick_labels(svg: &str) -> Vec<(f64, String)> {
        svg.split("<text class=\"tick-x\" x=\"")
            .skip(1)
            .map(|rest| {
                let x: f64 = rest.split('"').next().unwrap().parse().unwrap();
                let text = rest.split('>').nth(1).unwrap().split('<').next().unwrap();
                (x, text.to_owned())
            })
            .collect()
    }

    fn plot_over(t_end: f64) -> Plot {
        let points: Vec<(f64, Option<f64>)> = (0..=100)
            .map(|k| (t_end * k as f64 / 100.0, Some((k as f64 * 0.1).sin())))
            .collect();
        Plot {
            title: "t".into(),
            y_label: "y".into(),
            series: vec![Series {
                label: "y".into(),
                color: "#000".into(),
                dashed: false,
                points,
            }],
            bands: Vec::new(),
            hlines: Vec::new(),
            // Only the first span is named: the others share its legend entry.
            spans: vec![
                (1.0, 2.0, "#bbb".into(), "no locked target".into()),
                (3.0, 4.0, "#bbb".into(), String::new()),
                (5.0, 6.0, "#bbb".into(), String::new()),
            ],
        }
    }

    #[test]
    fn a_rendered_plots_time_labels_do_not_overlap() {
        for t_end in [3.0, 26.0, 600.0, 3600.0, 86_400.0] {
            let svg = plot_over(t_end).svg();
            let labels: Vec<(f64, f64)> = x_tick_labels(&svg)
                .iter()
                .map(|(x, t)| (*x, text_width_px(t)))
                .collect();
            assert!(labels.len() >= 3, "{t_end}: {labels:?}");
            assert_apart(&labels, &format!("0..{t_end} s"));
        }
    }

    #[test]
    fn every_legend_entry_has_text() {
        let svg = plot_over(30.0).svg();
        let entries: Vec<&str> = svg.split("<g class=\"legend-entry\">").skip(1).collect();
        // The series and one entry for the three spans.
        assert_eq!(entries.len(), 2, "{svg}");
        for e in entries {
            let text = e.split("<text").nth(1).unwrap();
            let text = text.split('>').nth(1).unwrap().split('<').next().unwrap();
            assert!(!text.trim().is_empty(), "{e}");
        }
    }

    #[test]
    fn thinning_keeps_every_peak_and_break_within_the_columns() {
        // Ten minutes at 30 Hz: noise, one spike, one dip, and a gap.
        let mut points: Vec<(f64, Option<f64>)> = (0..18_000)
            .map(|k| {
                let t = k as f64 / 30.0;
                (
                    t,
                    Some(1.0 + 0.05 * ((k * 7919 % 101) as f64 / 101.0 - 0.5)),
                )
            })
            .collect();
        points[3_000].1 = Some(2.1);
        points[9_000].1 = Some(0.2);
        points[12_000].1 = None;
        let columns = W - LEFT - RIGHT;
        let thinned = thin(&points, 0.0, 600.0, columns);
        assert!(
            thinned.len() as f64 <= 2.0 * columns + 4.0,
            "{}",
            thinned.len()
        );
        for kept in [points[3_000], points[9_000], points[12_000]] {
            assert!(thinned.contains(&kept), "{kept:?}");
        }
        // In time order, and a short series is left alone.
        assert!(thinned.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(thin(&points[..500], 0.0, 600.0, columns), points[..500]);
        // A window shows only its part, the y axis fitted to it.
        let plot = Plot {
            series: vec![Series {
                label: "d".into(),
                color: "#000".into(),
                dashed: false,
                points,
            }],
            ..Plot::default()
        };
        let frame = plot.frame(&View {
            window: Some((200.0, 230.0)),
            first_on_top: false,
        });
        assert_eq!((frame.x0, frame.x1), (200.0, 230.0));
        assert!(frame.y1 < 1.1 && frame.y0 > 0.9, "{frame:?}");
    }

    #[test]
    fn the_legend_lies_below_the_time_axis_title() {
        // The `y` of the first text after `opening` in `svg`.
        let text_y = |svg: &str, opening: &str| -> f64 {
            svg.split(opening)
                .nth(1)
                .and_then(|t| t.split("y=\"").nth(1))
                .and_then(|t| t.split('"').next())
                .unwrap()
                .parse()
                .unwrap()
        };
        let svg = plot_over(30.0).svg();
        let title_y = text_y(&svg, "<text class=\"axis-title\" x=\"");
        for entry in svg.split("<g class=\"legend-entry\">").skip(1) {
            let y = text_y(entry, "<text x=\"");
            // A line of 11 px text below the title's.
            assert!(y - title_y >= TEXT_H_PX + 3.0, "{y} under {title_y}");
        }
    }

    #[test]
    fn tick_steps_are_round() {
        assert_eq!(tick_step(30.0), 5.0);
        assert_eq!(tick_step(1.0), 0.2);
        assert_eq!(tick_step(0.0), 1.0);
    }
}
