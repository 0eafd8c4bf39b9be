//! Time-series plots as self-contained SVG, for the HTML report.

use std::fmt::Write as _;

use tether_sim::svg::xml_escape;

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

impl Plot {
    /// Renders the plot.
    pub fn svg(&self) -> String {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for s in &self.series {
            for &(x, y) in &s.points {
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
        let (mut x0, mut x1) = (
            fold(&xs, f64::min, f64::INFINITY),
            fold(&xs, f64::max, f64::NEG_INFINITY),
        );
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
        let (y0, y1) = (y0 - pad, y1 + pad);
        let legend_h = 18.0
            * ((self.series.len() + self.bands.len() + self.hlines.len() + self.spans.len())
                as f64
                / 3.0)
                .ceil();
        let height = H + legend_h;
        let pw = W - LEFT - RIGHT;
        let ph = H - TOP - BOTTOM;
        let px = |x: f64| LEFT + (x - x0) / (x1 - x0) * pw;
        let py = |y: f64| TOP + (y1 - y) / (y1 - y0) * ph;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W:.0}" height="{height:.0}" viewBox="0 0 {W:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
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
        for (a, b, color, _) in &self.spans {
            let (xa, xb) = (px(a.max(x0)), px(b.min(x1)));
            if xb > xa {
                let _ = writeln!(
                    s,
                    r#"<rect x="{xa:.1}" y="{TOP}" width="{:.1}" height="{ph:.1}" fill="{color}" fill-opacity="0.25"/>"#,
                    xb - xa
                );
            }
        }
        for (a, b, color, _) in &self.bands {
            let (ya, yb) = (py(b.max(*a)), py(a.min(*b)));
            let _ = writeln!(
                s,
                r#"<rect x="{LEFT}" y="{ya:.1}" width="{pw:.1}" height="{:.1}" fill="{color}" fill-opacity="0.25"/>"#,
                (yb - ya).max(0.0)
            );
        }
        // Axes and ticks.
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
        let xs_step = tick_step(x1 - x0);
        let mut t = (x0 / xs_step).ceil() * xs_step;
        while t <= x1 + 1e-9 {
            let _ = writeln!(
                s,
                r##"<line x1="{0:.1}" y1="{TOP}" x2="{0:.1}" y2="{1:.1}" stroke="#eeeeee"/><text x="{0:.1}" y="{2:.1}" text-anchor="middle">{3}</text>"##,
                px(t),
                TOP + ph,
                TOP + ph + 14.0,
                trim(t)
            );
            t += xs_step;
        }
        let ys_step = tick_step(y1 - y0);
        let mut t = (y0 / ys_step).ceil() * ys_step;
        while t <= y1 + 1e-9 {
            let _ = writeln!(
                s,
                r##"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#eeeeee"/><text x="{2:.1}" y="{3:.1}" text-anchor="end">{4}</text>"##,
                py(t),
                LEFT + pw,
                LEFT - 4.0,
                py(t) + 4.0,
                trim(t)
            );
            t += ys_step;
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">time (s)</text>"#,
            LEFT + pw / 2.0,
            TOP + ph + 28.0
        );
        let _ = writeln!(
            s,
            r#"<text x="12" y="{:.1}" text-anchor="middle" transform="rotate(-90 12 {:.1})">{}</text>"#,
            TOP + ph / 2.0,
            TOP + ph / 2.0,
            xml_escape(&self.y_label)
        );
        for (y, color, _) in &self.hlines {
            let _ = writeln!(
                s,
                r#"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-dasharray="3 3"/>"#,
                py(*y),
                LEFT + pw
            );
        }
        let _ = writeln!(
            s,
            r#"<g clip-path="url(#plotarea)" fill="none" stroke-width="1.6">"#
        );
        for series in &self.series {
            let dash = if series.dashed {
                r#" stroke-dasharray="6 3""#
            } else {
                ""
            };
            let mut run: Vec<String> = Vec::new();
            let flush = |run: &mut Vec<String>, s: &mut String| {
                if run.len() > 1 {
                    let _ = writeln!(
                        s,
                        r#"<polyline points="{}" stroke="{}"{dash}/>"#,
                        run.join(" "),
                        series.color
                    );
                }
                run.clear();
            };
            for &(x, y) in &series.points {
                match y.filter(|y| y.is_finite()) {
                    Some(y) if x.is_finite() => run.push(format!("{:.1},{:.1}", px(x), py(y))),
                    _ => flush(&mut run, &mut s),
                }
            }
            flush(&mut run, &mut s);
        }
        let _ = writeln!(s, "</g>");
        // Legend, three entries a row.
        let entries: Vec<(String, String, &str)> = self
            .series
            .iter()
            .map(|s| {
                (
                    s.label.clone(),
                    s.color.clone(),
                    if s.dashed { "dash" } else { "line" },
                )
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
            .collect();
        for (k, (label, color, kind)) in entries.iter().enumerate() {
            let x = LEFT + (k % 3) as f64 * 230.0;
            let y = H + 4.0 + (k / 3) as f64 * 18.0;
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
                _ => format!(
                    r#"<line x1="{x:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="{color}" stroke-width="2"/>"#,
                    y - 3.0,
                    x + 22.0
                ),
            };
            let _ = writeln!(
                s,
                r#"{mark}<text x="{:.1}" y="{y:.1}">{}</text>"#,
                x + 28.0,
                xml_escape(label)
            );
        }
        let _ = writeln!(s, "</svg>");
        s
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

    #[test]
    fn tick_steps_are_round() {
        assert_eq!(tick_step(30.0), 5.0);
        assert_eq!(tick_step(1.0), 0.2);
        assert_eq!(tick_step(0.0), 1.0);
    }
}
