//! Top-down pictures of the world, self-contained SVG (no scripts, no external
//! resources): [`MapSvg`] draws the walls and furniture and takes paths, poses and
//! covariance ellipses on top; [`scene_svg`] is the `scene.svg` of a simulation run.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Point2, Pose2, Robot, World};

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

/// Colours for the people: the target in red, others from a colour-blind-safe set.
pub fn person_color(index: usize, is_target: bool) -> &'static str {
    const OTHERS: [&str; 6] = [
        "#0072b2", "#009e73", "#e69f00", "#cc79a7", "#56b4e9", "#f0e442",
    ];
    if is_target {
        "#d62728"
    } else {
        OTHERS[index % OTHERS.len()]
    }
}

/// The grid's spacing for a world `span_m` across: 1 m, or the smallest of 2, 5, 10,
/// 20, 50 m... that draws at most 60 lines.
pub fn grid_step_m(span_m: f64) -> f64 {
    let mut step = 1.0;
    for k in 0..40 {
        if !(span_m.is_finite() && span_m / step > 60.0) {
            break;
        }
        step = [2.0, 5.0, 10.0][k % 3] * 10f64.powi((k / 3) as i32);
    }
    step
}

/// Escapes text for SVG and HTML.
pub fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
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
    legend: Vec<(String, String, bool)>,
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
        };
        map.draw_world(scenario, world, lo, hi);
        map
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

    /// Adds a legend entry without drawing anything.
    pub fn legend(&mut self, label: &str, color: &str, dashed: bool) {
        self.legend
            .push((label.to_owned(), color.to_owned(), dashed));
    }

    /// Draws a path, with a dot at its start and a square at its end when `ends`.
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
            xml_escape(label)
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
        self.legend(label, color, dashed);
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

    /// Writes a small label at a point.
    pub fn label(&mut self, p: Point2<World>, text: &str, color: &str) {
        let _ = writeln!(
            self.body,
            r#"<text x="{:.1}" y="{:.1}" font-size="11" fill="{color}">{}</text>"#,
            self.x(p.x) + 6.0,
            self.y(p.y) - 6.0,
            xml_escape(text)
        );
    }

    /// The finished SVG document: title, map, legend and scale bar.
    pub fn finish(self) -> String {
        let width = self.map_w + 2.0 * MARGIN_PX;
        let legend_h = 22.0 * (self.legend.len() + 1) as f64 + 10.0;
        let height = HEADER_PX + self.map_h + legend_h + MARGIN_PX;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
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
        let mut y = HEADER_PX + self.map_h + 20.0;
        for (label, color, dashed) in &self.legend {
            let dash = if *dashed {
                r#" stroke-dasharray="7 4""#
            } else {
                ""
            };
            let _ = writeln!(
                s,
                r#"<line x1="{MARGIN_PX}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{color}" stroke-width="3"{dash}/><text x="{:.1}" y="{:.1}">{}</text>"#,
                MARGIN_PX + 30.0,
                MARGIN_PX + 38.0,
                y + 4.0,
                xml_escape(label)
            );
            y += 22.0;
        }
        let _ = writeln!(
            s,
            r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#000" stroke-width="2"/><text x="{:.1}" y="{:.1}">1 m · circle = start, square = end</text>"##,
            MARGIN_PX,
            MARGIN_PX + self.px_per_m,
            MARGIN_PX + self.px_per_m + 8.0,
            y + 4.0
        );
        let _ = writeln!(s, "</svg>");
        s
    }
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

    #[test]
    fn the_grid_step_keeps_a_large_world_to_a_few_lines() {
        assert_eq!(grid_step_m(30.0), 1.0);
        assert_eq!(grid_step_m(60.0), 1.0);
        assert_eq!(grid_step_m(61.0), 2.0);
        assert_eq!(grid_step_m(250.0), 5.0);
        assert_eq!(grid_step_m(20_000.0), 500.0);
        assert_eq!(grid_step_m(f64::INFINITY), 1.0);
        for span in [1.0, 77.0, 999.0, 1e4, 1e7] {
            assert!(span / grid_step_m(span) <= 60.0, "{span}");
        }
    }
}
