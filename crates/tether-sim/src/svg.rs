//! `scene.svg`: a top-down picture of the world with the paths of the people and the
//! robot, self-contained (no scripts, no external resources).

use std::fmt::Write as _;

use tether_core::{Point2, Pose2, Robot, World};

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

const PX_PER_M: f64 = 60.0;
const MARGIN_PX: f64 = 40.0;

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

struct Frame {
    min_x: f64,
    max_y: f64,
}

impl Frame {
    fn x(&self, x: f64) -> f64 {
        MARGIN_PX + (x - self.min_x) * PX_PER_M
    }
    fn y(&self, y: f64) -> f64 {
        MARGIN_PX + (self.max_y - y) * PX_PER_M
    }
}

/// Draws the scene.
pub fn scene_svg(
    scenario: &Scenario,
    world: &StaticWorld,
    people: &[Track],
    robot: &Track,
    robot_poses: &[Pose2<World, Robot>],
) -> String {
    // Extent: walls, obstacles and every path point.
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
    for t in people.iter().chain(std::iter::once(robot)) {
        t.points.iter().copied().for_each(&mut grow);
    }
    if !lo[0].is_finite() {
        lo = [0.0, 0.0];
        hi = [1.0, 1.0];
    }
    let f = Frame {
        min_x: lo[0] - 0.5,
        max_y: hi[1] + 0.5,
    };
    let width = (hi[0] - lo[0] + 1.0) * PX_PER_M + 2.0 * MARGIN_PX;
    let legend_h = 24.0 * (people.len() + 2) as f64;
    let height = (hi[1] - lo[1] + 1.0) * PX_PER_M + 2.0 * MARGIN_PX + legend_h;

    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#ffffff"/>"##);
    let _ = writeln!(
        s,
        r##"<text x="{MARGIN_PX}" y="20" font-size="16" font-weight="bold">{}</text><text x="{MARGIN_PX}" y="36" font-size="12" fill="#444444">{}</text>"##,
        xml_escape(&scenario.name),
        xml_escape(&scenario.description)
    );
    // 1 m grid.
    let _ = writeln!(s, r##"<g stroke="#eeeeee" stroke-width="1">"##);
    let (gx0, gx1) = (f.min_x.floor() as i64, (hi[0] + 0.5).ceil() as i64);
    let (gy0, gy1) = ((lo[1] - 0.5).floor() as i64, f.max_y.ceil() as i64);
    for gx in gx0..=gx1 {
        let x = f.x(gx as f64);
        let _ = writeln!(
            s,
            r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}"/>"#,
            f.y(gy0 as f64),
            f.y(gy1 as f64)
        );
    }
    for gy in gy0..=gy1 {
        let y = f.y(gy as f64);
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
            f.x(gx0 as f64),
            f.x(gx1 as f64)
        );
    }
    let _ = writeln!(s, "</g>");
    // Tables' tops, for context.
    for t in &scenario.world.tables {
        let (c, yaw) = (t.center, t.yaw_rad);
        let pts: Vec<String> = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
            .iter()
            .map(|(sx, sy)| {
                let (hx, hy) = (0.5 * t.size_m[0] * sx, 0.5 * t.size_m[1] * sy);
                let (sn, cs) = yaw.sin_cos();
                let (x, y) = (c[0] + cs * hx - sn * hy, c[1] + sn * hx + cs * hy);
                format!("{:.1},{:.1}", f.x(x), f.y(y))
            })
            .collect();
        let _ = writeln!(
            s,
            r##"<polygon points="{}" fill="#f3ead9" stroke="#c8b48c" stroke-dasharray="4 3"/>"##,
            pts.join(" ")
        );
    }
    // Walls.
    let _ = writeln!(
        s,
        r##"<g stroke="#333333" stroke-width="4" stroke-linecap="round">"##
    );
    for w in &world.walls {
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}"/>"#,
            f.x(w.a.x),
            f.y(w.a.y),
            f.x(w.b.x),
            f.y(w.b.y)
        );
    }
    let _ = writeln!(s, "</g>");
    // Obstacles.
    for o in &world.obstacles {
        let fill = match o.kind {
            ObstacleKind::Pillar => "#888888",
            ObstacleKind::Post => "#555555",
            ObstacleKind::TableLeg => "#8c6d3f",
            ObstacleKind::ChairLeg => "#a0522d",
        };
        let r = (o.circle.radius_m * PX_PER_M).max(1.5);
        let _ = writeln!(
            s,
            r#"<circle cx="{:.1}" cy="{:.1}" r="{r:.1}" fill="{fill}"><title>{}</title></circle>"#,
            f.x(o.circle.center.x),
            f.y(o.circle.center.y),
            o.kind.name()
        );
    }
    // Paths.
    let polyline = |s: &mut String, t: &Track, dash: &str| {
        if t.points.is_empty() {
            return;
        }
        let pts: Vec<String> = t
            .points
            .iter()
            .map(|p| format!("{:.1},{:.1}", f.x(p.x), f.y(p.y)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2.5" stroke-linejoin="round"{dash}><title>{}</title></polyline>"#,
            pts.join(" "),
            t.color,
            xml_escape(&t.label)
        );
        if let (Some(a), Some(b)) = (t.points.first(), t.points.last()) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="{}"/>"#,
                f.x(a.x),
                f.y(a.y),
                t.color
            );
            let _ = writeln!(
                s,
                r#"<rect x="{:.1}" y="{:.1}" width="9" height="9" fill="{}"/>"#,
                f.x(b.x) - 4.5,
                f.y(b.y) - 4.5,
                t.color
            );
        }
    };
    for t in people {
        polyline(&mut s, t, "");
    }
    polyline(&mut s, robot, r#" stroke-dasharray="7 4""#);
    // Robot poses as triangles: start and end.
    for pose in [robot_poses.first(), robot_poses.last()]
        .into_iter()
        .flatten()
    {
        let tip = *pose * Point2::new(0.3, 0.0);
        let l = *pose * Point2::new(-0.15, 0.15);
        let r = *pose * Point2::new(-0.15, -0.15);
        let _ = writeln!(
            s,
            r##"<polygon points="{:.1},{:.1} {:.1},{:.1} {:.1},{:.1}" fill="#222222" fill-opacity="0.8"/>"##,
            f.x(tip.x),
            f.y(tip.y),
            f.x(l.x),
            f.y(l.y),
            f.x(r.x),
            f.y(r.y)
        );
    }
    // Legend and scale bar.
    let mut y = height - legend_h + 10.0;
    for t in people.iter().chain(std::iter::once(robot)) {
        let _ = writeln!(
            s,
            r#"<line x1="{MARGIN_PX}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}" stroke-width="3"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            MARGIN_PX + 30.0,
            t.color,
            MARGIN_PX + 38.0,
            y + 4.0,
            xml_escape(&t.label)
        );
        y += 22.0;
    }
    let _ = writeln!(
        s,
        r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#000" stroke-width="2"/><text x="{:.1}" y="{:.1}">1 m · circle = start, square = end</text>"##,
        MARGIN_PX,
        MARGIN_PX + PX_PER_M,
        MARGIN_PX + PX_PER_M + 8.0,
        y + 4.0
    );
    let _ = writeln!(s, "</svg>");
    s
}

fn xml_escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
