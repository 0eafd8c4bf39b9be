//! Top-down pictures of the world, self-contained SVG (no scripts, no external
//! resources): [`MapSvg`] draws the walls and furniture and takes paths, poses and
//! covariance ellipses on top; [`scene_svg`] is the `scene.svg` of a simulation run.
//!
//! A map made with [`MapSvg::fitted`] is for a web page: its scale is chosen so that it
//! fits a given width and height, it shrinks with a narrower page (`max-width: 100%`,
//! its height following through the `viewBox`), its scale bar is a round length, its
//! legend runs in columns, and its text labels are placed apart from each other.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Point2, Pose2, Robot, World};
use tether_svg::{grid_step_m, label_spots, length_text, round_length_m};
/// The helpers this module's users take with its maps (`tether-svg`'s).
pub use tether_svg::{person_color, xml_escape};

use crate::scenario::Scenario;
use crate::world::{ObstacleKind, StaticWorld};

/// A recorded path.
#[derive(Debug, Clone, Default)]
pub struct Track {
    /// Label in the legend.
    pub label: String,
    /// Stroke colour (CSS).
    pub color: String,
    /// Positions in time order.
    pub points: Vec<Point2<World>>,
}

const MARGIN_PX: f64 = 40.0;
const HEADER_PX: f64 = 44.0;
/// Width of a character of the 11 px labels, px (DejaVu Sans' digits are 0.64 em;
/// a little more than most characters, so estimates err on the wide side).
const LABEL_CHAR_PX: f64 = 7.0;
/// Height of an 11 px label, px.
const LABEL_H_PX: f64 = 11.0;
/// Width of a character of the 13 px legend text, px.
const LEGEND_CHAR_PX: f64 = 8.0;
/// Longest scale bar of a fitted map, px.
const SCALE_BAR_MAX_PX: f64 = 160.0;
/// How much farther off each ring of places for a label is, px, when the places
/// beside its point are taken.
const LEAD_PX: f64 = 12.0;

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LegendMark {
    /// A line, dashed or not (a path).
    Line {
        /// Dashed.
        dashed: bool,
    },
    /// A lightly filled ellipse (a covariance).
    Ellipse,
    /// The robot's triangle.
    Robot,
    /// A dashed square (a region shown magnified).
    Square,
    /// A dashed line with the robot's triangle on it: the robot's path and its pose at
    /// a few instants, one entry.
    RobotOnPath,
}

/// One entry of a map's legend.
#[derive(Debug, Clone)]
struct LegendEntry {
    label: String,
    color: String,
    mark: LegendMark,
}

/// A map being drawn: world coordinates (m, y up) to pixels (y down).
#[derive(Debug, Clone)]
pub struct MapSvg {
    px_per_m: f64,
    min_x: f64,
    max_y: f64,
    map_w: f64,
    map_h: f64,
    title: String,
    subtitle: String,
    body: String,
    legend: Vec<LegendEntry>,
    /// Made by [`MapSvg::fitted`]: for a web page.
    fitted: bool,
    /// Boxes of the labels placed so far (left, top, right, bottom), px in the body.
    labels: Vec<[f64; 4]>,
    /// Boxes that labels keep off (the squares of magnified views), px in the body.
    kept_clear: Vec<[f64; 4]>,
}

impl MapSvg {
    /// A map of `world` that also covers `extent` (paths to be drawn), with walls,
    /// table tops and obstacles already drawn.
    pub fn new(
        scenario: &Scenario,
        world: &StaticWorld,
        extent: impl IntoIterator<Item = Point2<World>>,
        px_per_m: f64,
    ) -> Self {
        let (lo, hi) = Self::bounds(world, extent);
        Self::with_bounds(scenario, world, lo, hi, px_per_m)
    }

    /// A map for a web page: like [`MapSvg::new`], at `max_px_per_m` or less, so
    /// that the whole picture is at most `max_width_px` wide and its map (without
    /// title and legend) at most `max_map_height_px` high. The SVG scales down with
    /// a narrower page.
    pub fn fitted(
        scenario: &Scenario,
        world: &StaticWorld,
        extent: impl IntoIterator<Item = Point2<World>>,
        max_px_per_m: f64,
        max_width_px: f64,
        max_map_height_px: f64,
    ) -> Self {
        let (lo, hi) = Self::bounds(world, extent);
        let px_per_m = Self::fitted_px_per_m(
            hi[0] - lo[0] + 1.0,
            hi[1] - lo[1] + 1.0,
            max_px_per_m,
            max_width_px,
            max_map_height_px,
        );
        let mut map = Self::with_bounds(scenario, world, lo, hi, px_per_m);
        map.fitted = true;
        map
    }

    /// The scale at which a map `w_m` x `h_m` (margins included) fits: at most
    /// `max_px_per_m`, the picture at most `max_width_px` wide, the map at most
    /// `max_map_height_px` high.
    fn fitted_px_per_m(
        w_m: f64,
        h_m: f64,
        max_px_per_m: f64,
        max_width_px: f64,
        max_map_height_px: f64,
    ) -> f64 {
        let k = max_px_per_m
            .min((max_width_px - 2.0 * MARGIN_PX) / w_m)
            .min(max_map_height_px / h_m);
        if k.is_finite() && k > 0.0 {
            k
        } else {
            max_px_per_m
        }
    }

    /// The box holding the walls, the obstacles and `extent`.
    fn bounds(
        world: &StaticWorld,
        extent: impl IntoIterator<Item = Point2<World>>,
    ) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut grow = |p: Point2<World>| {
            if p.is_finite() {
                lo = [lo[0].min(p.x), lo[1].min(p.y)];
                hi = [hi[0].max(p.x), hi[1].max(p.y)];
            }
        };
        for w in &world.walls {
            grow(w.a);
            grow(w.b);
        }
        for o in &world.obstacles {
            grow(o.circle.center);
        }
        extent.into_iter().for_each(&mut grow);
        if !lo[0].is_finite() {
            lo = [0.0, 0.0];
            hi = [1.0, 1.0];
        }
        (lo, hi)
    }

    fn with_bounds(
        scenario: &Scenario,
        world: &StaticWorld,
        lo: [f64; 2],
        hi: [f64; 2],
        px_per_m: f64,
    ) -> Self {
        let mut map = MapSvg {
            px_per_m,
            min_x: lo[0] - 0.5,
            max_y: hi[1] + 0.5,
            map_w: (hi[0] - lo[0] + 1.0) * px_per_m,
            map_h: (hi[1] - lo[1] + 1.0) * px_per_m,
            title: scenario.name.clone(),
            subtitle: scenario.description.clone(),
            body: String::new(),
            legend: Vec::new(),
            fitted: false,
            labels: Vec::new(),
            kept_clear: Vec::new(),
        };
        map.draw_world(scenario, world, lo, hi);
        map
    }

    /// Pixels per metre.
    pub fn px_per_m(&self) -> f64 {
        self.px_per_m
    }

    /// Pixel x of a world x.
    pub fn x(&self, x: f64) -> f64 {
        (x - self.min_x) * self.px_per_m
    }

    /// Pixel y of a world y.
    pub fn y(&self, y: f64) -> f64 {
        (self.max_y - y) * self.px_per_m
    }

    /// Replaces the title lines.
    pub fn set_title(&mut self, title: &str, subtitle: &str) {
        self.title = title.to_owned();
        self.subtitle = subtitle.to_owned();
    }

    fn draw_world(&mut self, scenario: &Scenario, world: &StaticWorld, lo: [f64; 2], hi: [f64; 2]) {
        let mut s = String::new();
        // A grid of 1 m, or of a round step (2, 5, 10, 20, 50 m...) that keeps a large
        // world to about 60 lines a side.
        let _ = writeln!(s, r##"<g stroke="#eeeeee" stroke-width="1">"##);
        let step = grid_step_m((hi[0] - self.min_x).max(self.max_y - lo[1]));
        let (gx0, gx1) = (
            (self.min_x / step).floor() as i64,
            ((hi[0] + 0.5) / step).ceil() as i64,
        );
        let (gy0, gy1) = (
            ((lo[1] - 0.5) / step).floor() as i64,
            (self.max_y / step).ceil() as i64,
        );
        let (gx0, gx1, gy0, gy1) = (
            gx0 as f64 * step,
            gx1 as f64 * step,
            gy0 as f64 * step,
            gy1 as f64 * step,
        );
        let lines = |a: f64, b: f64| {
            let n = ((b - a) / step).round().clamp(0.0, 1000.0) as usize;
            (0..=n).map(move |k| a + k as f64 * step)
        };
        for gx in lines(gx0, gx1) {
            let x = self.x(gx);
            let _ = writeln!(
                s,
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
                self.y(gy0),
                self.y(gy1)
            );
        }
        for gy in lines(gy0, gy1) {
            let y = self.y(gy);
            let _ = writeln!(
                s,
                r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
                self.x(gx0),
                self.x(gx1)
            );
        }
        let _ = writeln!(s, "</g>");
        for t in &scenario.world.tables {
            let (sn, cs) = t.yaw_rad.sin_cos();
            let pts: Vec<String> = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
                .iter()
                .map(|(sx, sy)| {
                    let (hx, hy) = (0.5 * t.size_m[0] * sx, 0.5 * t.size_m[1] * sy);
                    let (x, y) = (
                        t.center[0] + cs * hx - sn * hy,
                        t.center[1] + sn * hx + cs * hy,
                    );
                    format!("{:.1},{:.1}", self.x(x), self.y(y))
                })
                .collect();
            let _ = writeln!(
                s,
                r##"<polygon points="{}" fill="#f3ead9" stroke="#c8b48c" stroke-dasharray="4 3"/>"##,
                pts.join(" ")
            );
        }
        let _ = writeln!(
            s,
            r##"<g stroke="#333333" stroke-width="4" stroke-linecap="round">"##
        );
        for w in &world.walls {
            let _ = writeln!(
                s,
                r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}"/>"#,
                self.x(w.a.x),
                self.y(w.a.y),
                self.x(w.b.x),
                self.y(w.b.y)
            );
        }
        let _ = writeln!(s, "</g>");
        for o in &world.obstacles {
            let fill = match o.kind {
                ObstacleKind::Pillar => "#888888",
                ObstacleKind::Post => "#555555",
                ObstacleKind::TableLeg => "#8c6d3f",
                ObstacleKind::ChairLeg => "#a0522d",
                ObstacleKind::Bin => "#4a6a8a",
                ObstacleKind::Foliage => "#3c8c3c",
            };
            let r = (o.circle.radius_m * self.px_per_m).max(1.5);
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="{r:.1}" fill="{fill}"><title>{}</title></circle>"#,
                self.x(o.circle.center.x),
                self.y(o.circle.center.y),
                o.kind.name()
            );
        }
        self.body.push_str(&s);
    }

    /// Adds a legend entry (a line) without drawing anything. Entries without text
    /// are left out of the legend.
    pub fn legend(&mut self, label: &str, color: &str, dashed: bool) {
        self.legend_mark(label, color, LegendMark::Line { dashed });
    }

    /// Adds a legend entry drawn as `mark`, without drawing anything on the map.
    /// Entries without text are left out of the legend.
    pub fn legend_mark(&mut self, label: &str, color: &str, mark: LegendMark) {
        self.legend.push(LegendEntry {
            label: label.to_owned(),
            color: color.to_owned(),
            mark,
        });
    }

    /// The legend's labels, in order (entries without text are not drawn).
    pub fn legend_labels(&self) -> Vec<&str> {
        self.legend.iter().map(|e| e.label.as_str()).collect()
    }

    /// Draws a path, with a dot at its start and a square at its end when `ends`, and
    /// adds it to the legend.
    pub fn path(
        &mut self,
        points: &[Point2<World>],
        color: &str,
        dashed: bool,
        label: &str,
        ends: bool,
    ) {
        if points.is_empty() {
            return;
        }
        self.draw_path(points, color, dashed, label, ends);
        self.legend(label, color, dashed);
    }

    /// Draws a path like [`MapSvg::path`], titled `title`, without a legend entry (for
    /// paths that share one).
    pub fn draw_path(
        &mut self,
        points: &[Point2<World>],
        color: &str,
        dashed: bool,
        title: &str,
        ends: bool,
    ) {
        if points.is_empty() {
            return;
        }
        let pts: Vec<String> = points
            .iter()
            .filter(|p| p.is_finite())
            .map(|p| format!("{:.1},{:.1}", self.x(p.x), self.y(p.y)))
            .collect();
        let dash = if dashed {
            r#" stroke-dasharray="7 4""#
        } else {
            ""
        };
        let _ = writeln!(
            self.body,
            r#"<polyline points="{}" fill="none" stroke="{color}" stroke-width="2.5" stroke-linejoin="round"{dash}><title>{}</title></polyline>"#,
            pts.join(" "),
            xml_escape(title)
        );
        if ends && let (Some(a), Some(b)) = (points.first(), points.last()) {
            let _ = writeln!(
                self.body,
                r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="{color}"/><rect x="{:.1}" y="{:.1}" width="9" height="9" fill="{color}"/>"#,
                self.x(a.x),
                self.y(a.y),
                self.x(b.x) - 4.5,
                self.y(b.y) - 4.5
            );
        }
    }

    /// Draws the robot as a triangle at `pose`.
    pub fn robot(&mut self, pose: Pose2<World, Robot>, opacity: f64) {
        let tip = pose * Point2::new(0.3, 0.0);
        let l = pose * Point2::new(-0.15, 0.15);
        let r = pose * Point2::new(-0.15, -0.15);
        let _ = writeln!(
            self.body,
            r##"<polygon points="{:.1},{:.1} {:.1},{:.1} {:.1},{:.1}" fill="#222222" fill-opacity="{opacity:.2}"/>"##,
            self.x(tip.x),
            self.y(tip.y),
            self.x(l.x),
            self.y(l.y),
            self.x(r.x),
            self.y(r.y)
        );
    }

    /// Draws the `n_sigma` ellipse of an estimate, with a dot at its mean.
    pub fn ellipse(&mut self, g: &Gaussian2<World>, color: &str, n_sigma: f64) {
        let (major, minor, angle) = g.cov.principal_axes();
        let (rx, ry) = (
            n_sigma * major.sqrt() * self.px_per_m,
            n_sigma * minor.sqrt() * self.px_per_m,
        );
        let (cx, cy) = (self.x(g.mean.x), self.y(g.mean.y));
        // SVG rotates clockwise with y down: the world angle maps to its negative.
        let _ = writeln!(
            self.body,
            r#"<ellipse cx="{cx:.1}" cy="{cy:.1}" rx="{:.1}" ry="{:.1}" transform="rotate({:.1} {cx:.1} {cy:.1})" fill="{color}" fill-opacity="0.15" stroke="{color}" stroke-width="1.5"/><circle cx="{cx:.1}" cy="{cy:.1}" r="2" fill="{color}"/>"#,
            rx.max(0.5),
            ry.max(0.5),
            -angle.to_degrees()
        );
    }

    /// Writes a small label beside a point: above right of it, or at the first of a
    /// few other places beside it where it overlaps no label written before and
    /// stays on the picture.
    pub fn label(&mut self, p: Point2<World>, text: &str, color: &str) {
        let (u, v) = (self.x(p.x), self.y(p.y));
        let (x, y) = self.place_label(u, v, text);
        // Put farther off than the first spots: a thin line leads to it.
        let (w, h) = (label_width_px(text), LABEL_H_PX);
        let (nx, ny) = (u.clamp(x, x + w), v.clamp(y - h, y + 2.0));
        if (nx - u).hypot(ny - v) > 6.0 + LEAD_PX {
            let _ = writeln!(
                self.body,
                r#"<line class="leader" x1="{u:.1}" y1="{v:.1}" x2="{nx:.1}" y2="{ny:.1}" stroke="{color}" stroke-width="0.8"/>"#
            );
        }
        let _ = writeln!(
            self.body,
            r#"<text class="map-label" x="{x:.1}" y="{y:.1}" font-size="11" fill="{color}">{}</text>"#,
            xml_escape(text)
        );
    }

    /// Where a label's left end and baseline go, beside pixel `(u, v)` of the body;
    /// its box is remembered.
    fn place_label(&mut self, u: f64, v: f64, text: &str) -> (f64, f64) {
        let w = label_width_px(text);
        let h = LABEL_H_PX;
        // Beside the point, then in rings farther off when those are taken.
        let candidates: Vec<(f64, f64)> = [0.0, 1.0, 2.0, 3.0, 4.0]
            .iter()
            .flat_map(|k| label_spots((u, v), (w, h), 6.0 + k * LEAD_PX, 4.0 + k * 2.0))
            .collect();
        // The body's area, margins included.
        let (l, t, r, b) = (
            -MARGIN_PX + 2.0,
            0.0,
            self.map_w + MARGIN_PX - 2.0,
            self.map_h,
        );
        let boxed = |(x, y): (f64, f64)| [x, y - h, x + w, y + 3.0];
        let fits = |c: &(f64, f64)| {
            let [x0, y0, x1, y1] = boxed(*c);
            x0 >= l
                && x1 <= r
                && y0 >= t
                && y1 <= b
                && !self
                    .labels
                    .iter()
                    .chain(&self.kept_clear)
                    .any(|q| x0 < q[2] && q[0] < x1 && y0 < q[3] && q[1] < y1)
        };
        let (x, y) = candidates
            .iter()
            .copied()
            .find(|c| fits(c))
            .unwrap_or(candidates[0]);
        self.labels.push(boxed((x, y)));
        (x, y)
    }

    /// Outlines a square `side_m` across (at least 10 px) around `center`, dashed, and
    /// writes `text` beside it in bold: where a magnified view is taken. Labels written
    /// after it keep off the square.
    pub fn zoom_box(&mut self, center: Point2<World>, side_m: f64, color: &str, text: &str) {
        let side = (side_m * self.px_per_m).max(10.0);
        let (u, v) = (self.x(center.x), self.y(center.y));
        let square = [
            u - side / 2.0,
            v - side / 2.0,
            u + side / 2.0,
            v + side / 2.0,
        ];
        self.kept_clear.push(square);
        let (x, y) = self.place_label(u + side / 2.0 - 4.0, v - side / 2.0 + 4.0, text);
        let _ = writeln!(
            self.body,
            r#"<g class="zoom-box"><rect x="{:.1}" y="{:.1}" width="{side:.1}" height="{side:.1}" fill="none" stroke="{color}" stroke-width="1.5" stroke-dasharray="4 2"/><text x="{x:.1}" y="{y:.1}" font-size="11" font-weight="bold" fill="{color}">{}</text></g>"#,
            u - side / 2.0,
            v - side / 2.0,
            xml_escape(text)
        );
    }

    /// The finished SVG document: title, map, legend and scale bar.
    pub fn finish(self) -> String {
        let width = self.map_w + 2.0 * MARGIN_PX;
        let entries: Vec<&LegendEntry> = self
            .legend
            .iter()
            .filter(|e| !e.label.trim().is_empty())
            .collect();
        // A fitted map's legend runs in as many columns as the widest entry allows.
        let (columns, column_w) = if self.fitted {
            let widest = entries
                .iter()
                .map(|e| e.label.chars().count())
                .max()
                .unwrap_or(0) as f64;
            let column_w = 38.0 + LEGEND_CHAR_PX * widest + 20.0;
            (
                (((width - 2.0 * MARGIN_PX) / column_w).floor() as usize).max(1),
                column_w,
            )
        } else {
            (1, 0.0)
        };
        let rows = entries.len().div_ceil(columns);
        let legend_h = 22.0 * (rows + 1) as f64 + 10.0;
        let height = HEADER_PX + self.map_h + legend_h + MARGIN_PX;
        let mut s = String::new();
        let fit = if self.fitted {
            r#" class="map" style="max-width:100%;height:auto""#
        } else {
            ""
        };
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg"{fit} width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
        );
        let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
        let _ = writeln!(
            s,
            r##"<text x="{MARGIN_PX}" y="20" font-size="16" font-weight="bold">{}</text><text x="{MARGIN_PX}" y="36" font-size="12" fill="#444444">{}</text>"##,
            xml_escape(&self.title),
            xml_escape(&self.subtitle)
        );
        let _ = writeln!(s, r#"<g transform="translate({MARGIN_PX} {HEADER_PX})">"#);
        s.push_str(&self.body);
        let _ = writeln!(s, "</g>");
        let top = HEADER_PX + self.map_h + 20.0;
        for (k, e) in entries.iter().enumerate() {
            let (x, y) = (
                MARGIN_PX + (k % columns) as f64 * column_w,
                top + (k / columns) as f64 * 22.0,
            );
            let color = &e.color;
            // (`scene.svg` keeps its bytes: its legend's left end as it always was.)
            let x_text = if self.fitted {
                format!("{x:.1}")
            } else {
                format!("{x}")
            };
            let mark = match e.mark {
                LegendMark::Line { dashed } => format!(
                    r#"<line x1="{x_text}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{color}" stroke-width="3"{}/>"#,
                    x + 30.0,
                    if dashed {
                        r#" stroke-dasharray="7 4""#
                    } else {
                        ""
                    }
                ),
                LegendMark::Ellipse => format!(
                    r#"<ellipse cx="{:.1}" cy="{y:.1}" rx="14" ry="6" fill="{color}" fill-opacity="0.15" stroke="{color}" stroke-width="1.5"/>"#,
                    x + 15.0
                ),
                LegendMark::Robot => format!(
                    r##"<polygon points="{:.1},{y:.1} {:.1},{:.1} {:.1},{:.1}" fill="#222222" fill-opacity="0.5"/>"##,
                    x + 24.0,
                    x + 6.0,
                    y - 7.0,
                    x + 6.0,
                    y + 7.0
                ),
                LegendMark::Square => format!(
                    r#"<rect x="{:.1}" y="{:.1}" width="14" height="14" fill="none" stroke="{color}" stroke-width="1.5" stroke-dasharray="4 2"/>"#,
                    x + 8.0,
                    y - 7.0
                ),
                LegendMark::RobotOnPath => format!(
                    r#"<line x1="{x_text}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{color}" stroke-width="3" stroke-dasharray="7 4"/><polygon points="{:.1},{y:.1} {:.1},{:.1} {:.1},{:.1}" fill="{color}" fill-opacity="0.5"/>"#,
                    x + 30.0,
                    x + 24.0,
                    x + 8.0,
                    y - 7.0,
                    x + 8.0,
                    y + 7.0
                ),
            };
            // A fitted map's legend names its entry's colour (for checks of the page).
            let data = if self.fitted {
                format!(r#" data-color="{}""#, xml_escape(color))
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                r#"{mark}<text x="{:.1}" y="{:.1}"{data}>{}</text>"#,
                x + 38.0,
                y + 4.0,
                xml_escape(&e.label)
            );
        }
        let y = top + rows as f64 * 22.0;
        // The scale bar: 1 m, or on a fitted map the longest round length that fits.
        let bar_m = if self.fitted {
            round_length_m(SCALE_BAR_MAX_PX / self.px_per_m)
        } else {
            1.0
        };
        let bar_text = if self.fitted {
            length_text(bar_m)
        } else {
            "1 m".to_owned()
        };
        let bar_px = bar_m * self.px_per_m;
        let _ = writeln!(
            s,
            r##"<line{} x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#000" stroke-width="2"/><text x="{:.1}" y="{:.1}">{bar_text} · circle = start, square = end</text>"##,
            if self.fitted {
                r#" class="scale-bar""#
            } else {
                ""
            },
            MARGIN_PX,
            MARGIN_PX + bar_px,
            MARGIN_PX + bar_px + 8.0,
            y + 4.0
        );
        let _ = writeln!(s, "</svg>");
        s
    }
}

/// The estimated width of an 11 px label, px.
fn label_width_px(text: &str) -> f64 {
    LABEL_CHAR_PX * text.chars().count() as f64
}

/// Draws the scene of a simulation run: world, people's and robot's paths, the robot's
/// first and last pose.
pub fn scene_svg(
    scenario: &Scenario,
    world: &StaticWorld,
    people: &[Track],
    robot: &Track,
    robot_poses: &[Pose2<World, Robot>],
) -> String {
    let extent = people
        .iter()
        .chain(std::iter::once(robot))
        .flat_map(|t| t.points.iter().copied());
    let mut map = MapSvg::new(scenario, world, extent, 60.0);
    for t in people {
        map.path(&t.points, &t.color, false, &t.label, true);
    }
    map.path(&robot.points, &robot.color, true, &robot.label, true);
    for pose in [robot_poses.first(), robot_poses.last()]
        .into_iter()
        .flatten()
    {
        map.robot(*pose, 0.8);
    }
    map.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The number in the first attribute `name` of `element` (its text from its start).
    fn attribute(element: &str, name: &str) -> f64 {
        element
            .split(&format!(" {name}=\""))
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    }

    /// The `width` and `height` attributes of the document's `svg` element.
    fn size(svg: &str) -> (f64, f64) {
        let head = svg.split('>').next().unwrap();
        (attribute(head, "width"), attribute(head, "height"))
    }

    fn fitted(name: &str) -> MapSvg {
        let scenario = Scenario::builtin(name).unwrap();
        let world = StaticWorld::from_scenario(&scenario);
        let extent: Vec<Point2<World>> = scenario
            .people
            .iter()
            .flat_map(|p| p.path.iter().map(|&[x, y]| Point2::new(x, y)))
            .collect();
        MapSvg::fitted(&scenario, &world, extent, 50.0, 1040.0, 720.0)
    }

    #[test]
    fn a_fitted_map_fits_the_page_and_shrinks_with_it() {
        for name in crate::BUILTIN_NAMES {
            let map = fitted(name);
            let k = map.px_per_m();
            let svg = map.finish();
            let (w, h) = size(&svg);
            assert!(w <= 1040.0 + 0.5, "{name}: {w} px wide");
            assert!(k > 0.0 && k <= 50.0, "{name}: {k} px/m");
            assert!(
                svg.contains(&format!("viewBox=\"0 0 {w:.0} {h:.0}\"")),
                "{name}"
            );
            assert!(
                svg.contains("style=\"max-width:100%;height:auto\""),
                "{name}"
            );
            // A round scale bar, at most SCALE_BAR_MAX_PX long.
            let bar = svg.split("class=\"scale-bar\"").nth(1).unwrap();
            let x = |a: &str| attribute(bar, a);
            assert!(x("x2") - x("x1") <= SCALE_BAR_MAX_PX + 0.1, "{name}");
        }
        // The ten-minute park (about 60 m across) is drawn at about 15 px/m, its map
        // no higher than asked.
        let park = fitted("outdoor_follow");
        assert!(
            park.px_per_m() < 20.0 && park.map_h <= 720.0 + 1e-6,
            "{}",
            park.px_per_m()
        );
        assert!(park.finish().contains("10 m · circle = start"));
        // A map made with `new` keeps its scale and size (scene.svg).
        let scenario = Scenario::builtin("corridor").unwrap();
        let world = StaticWorld::from_scenario(&scenario);
        let svg = MapSvg::new(&scenario, &world, Vec::new(), 60.0).finish();
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\" width="));
        assert!(svg.contains(">1 m · circle = start"));
    }

    #[test]
    fn every_legend_entry_has_text() {
        let mut map = fitted("office");
        map.path(
            &[Point2::new(1.0, 1.0), Point2::new(2.0, 1.0)],
            "#f00",
            false,
            "walker",
            true,
        );
        map.path(
            &[Point2::new(1.0, 2.0), Point2::new(2.0, 2.0)],
            "#0f0",
            false,
            "",
            true,
        );
        map.legend("", "#00f", true);
        map.legend_mark("fused (2σ)", "#90f", LegendMark::Ellipse);
        map.legend_mark("robot", "#222", LegendMark::Robot);
        map.legend_mark("magnified below (A)", "#444", LegendMark::Square);
        let svg = map.finish();
        let legend = svg.split("</g>").last().unwrap();
        let texts: Vec<&str> = legend
            .split("<text")
            .skip(1)
            .map(|t| t.split('>').nth(1).unwrap().split('<').next().unwrap())
            .collect();
        // Four entries with text and the scale bar; the two without text are left out.
        assert_eq!(texts.len(), 5, "{texts:?}");
        assert!(texts.iter().all(|t| !t.trim().is_empty()), "{texts:?}");
        assert_eq!(texts[0], "walker");
        assert!(legend.contains("<ellipse") && legend.contains("<polygon"));
    }

    #[test]
    fn labels_are_placed_apart() {
        let mut map = fitted("corridor");
        // Five labels at one point: each goes to a free place beside it.
        let p = Point2::new(5.0, 0.0);
        for k in 0..5 {
            map.label(p, &format!("{k}.0 s"), "#444");
        }
        map.zoom_box(p, 0.5, "#444", "A");
        let boxes = &map.labels;
        assert_eq!(boxes.len(), 6);
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                let overlap = a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];
                assert!(!overlap, "{a:?} and {b:?}");
            }
        }
    }

    #[test]
    fn labels_keep_off_the_squares_of_magnified_views() {
        let mut map = fitted("corridor");
        let p = Point2::new(5.0, 0.0);
        map.zoom_box(p, 0.4, "#444", "A");
        let square = map.kept_clear[0];
        // Labels at the square's centre, more than the places beside it hold.
        for k in 0..12 {
            map.label(p, &format!("{k}.0 s"), "#444");
        }
        for b in &map.labels {
            let on = square[0] < b[2] && b[0] < square[2] && square[1] < b[3] && b[1] < square[3];
            assert!(!on, "{b:?} on {square:?}");
        }
        for (i, a) in map.labels.iter().enumerate() {
            for b in &map.labels[i + 1..] {
                let overlap = a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];
                assert!(!overlap, "{a:?} and {b:?}");
            }
        }
        // Those put farther off are led to by a line.
        assert!(map.body.contains("class=\"leader\""));
    }
}
