//! The marks the pictures are drawn with (ellipses, arrows, the robot) and the
//! legends that show them.

use std::fmt::Write as _;

use tether_core::{Gaussian2, Pose2, Robot, World};
use tether_svg::xml_escape;

use super::ROBOT;
use super::frame::{Labels, MapFrame};

pub(super) fn ellipse(
    frame: &MapFrame,
    g: &Gaussian2<World>,
    color: &str,
    fill_opacity: f64,
) -> String {
    let (major, minor, angle) = g.cov.principal_axes();
    let (rx, ry) = (
        (2.0 * major.max(0.0).sqrt() * frame.k).max(1.0),
        (2.0 * minor.max(0.0).sqrt() * frame.k).max(1.0),
    );
    let (cx, cy) = frame.px(g.mean.x, g.mean.y);
    // SVG turns clockwise with y down: the world's angle maps to its negative.
    format!(
        "<ellipse cx=\"{cx:.1}\" cy=\"{cy:.1}\" rx=\"{rx:.1}\" ry=\"{ry:.1}\" \
         transform=\"rotate({:.1} {cx:.1} {cy:.1})\" fill=\"{color}\" \
         fill-opacity=\"{fill_opacity}\" stroke=\"{color}\" stroke-opacity=\"0.6\"/>",
        -angle.to_degrees()
    )
}

/// A line from `(u, v)` to `(u2, v2)` with an arrowhead at the end, px.
pub(super) fn arrow(u: f64, v: f64, u2: f64, v2: f64, color: &str) -> String {
    let (dx, dy) = (u2 - u, v2 - v);
    let len = dx.hypot(dy).max(1e-9);
    let (ex, ey) = (dx / len, dy / len);
    let head = 6.0_f64.min(0.6 * len);
    let (bx, by) = (u2 - head * ex, v2 - head * ey);
    let (nx, ny) = (-ey * head * 0.5, ex * head * 0.5);
    format!(
        "<line x1=\"{u:.1}\" y1=\"{v:.1}\" x2=\"{bx:.1}\" y2=\"{by:.1}\" stroke=\"{color}\" \
         stroke-width=\"1.6\"/><polygon points=\"{u2:.1},{v2:.1} {:.1},{:.1} {:.1},{:.1}\" \
         fill=\"{color}\"/>",
        bx + nx,
        by + ny,
        bx - nx,
        by - ny
    )
}

/// The robot as a triangle pointing along its heading, about 20 px long.
pub(super) fn robot_marker(frame: &MapFrame, pose: Pose2<World, Robot>) -> String {
    let (u, v) = frame.px(pose.x, pose.y);
    robot_marker_px(u, v, pose.yaw)
}

/// The robot's triangle at pixel `(u, v)`, heading `yaw` (world, counter-clockwise).
fn robot_marker_px(u: f64, v: f64, yaw: f64) -> String {
    let (s, c) = yaw.sin_cos();
    // Heading in pixels (y down).
    let (hx, hy) = (c, -s);
    let (nx, ny) = (-hy, hx);
    let p = |a: f64, b: f64| format!("{:.1},{:.1}", u + a * hx + b * nx, v + a * hy + b * ny);
    format!(
        "<polygon class=\"robot\" points=\"{} {} {} {}\" fill=\"{ROBOT}\" fill-opacity=\"0.85\" \
         stroke=\"#ffffff\" stroke-width=\"1\"><title>robot</title></polygon>",
        p(13.0, 0.0),
        p(-7.0, 8.0),
        p(-3.0, 0.0),
        p(-7.0, -8.0)
    )
}

/// The legend's marks.
#[derive(Debug, Clone, Copy)]
pub(super) enum Mark {
    Line(&'static str, f64, bool),
    /// Short lines side by side, one of each colour (tracks coloured by id).
    Lines(&'static [&'static str], f64),
    Dot(&'static str),
    Ring(&'static str, bool),
    Disc(&'static str),
    /// Small discs side by side, one of each colour (tracks coloured by id).
    Discs(&'static [&'static str]),
    /// The target's track: its disc inside the target's ring.
    DiscInRing(&'static str),
    Cross(&'static str),
    Arrow(&'static str),
    Robot,
}

impl Mark {
    /// How wide the mark is drawn, px.
    fn width(self) -> f64 {
        match self {
            Mark::Lines(colors, _) | Mark::Discs(colors) => 7.0 * colors.len() as f64,
            _ => 22.0,
        }
    }

    /// The mark drawn with its left end at `x`, centred on `cy`.
    fn svg(self, x: f64, cy: f64) -> String {
        let cx = x + 11.0;
        match self {
            Mark::Line(color, width, dashed) => format!(
                "<line x1=\"{x:.1}\" y1=\"{cy:.1}\" x2=\"{:.1}\" y2=\"{cy:.1}\" \
                 stroke=\"{color}\" stroke-width=\"{width}\"{}/>",
                x + 22.0,
                if dashed {
                    " stroke-dasharray=\"5 3\""
                } else {
                    ""
                }
            ),
            Mark::Lines(colors, width) => colors
                .iter()
                .enumerate()
                .map(|(k, color)| {
                    let a = x + 7.0 * k as f64;
                    format!(
                        "<line x1=\"{a:.1}\" y1=\"{cy:.1}\" x2=\"{:.1}\" y2=\"{cy:.1}\" \
                         stroke=\"{color}\" stroke-width=\"{}\"/>",
                        a + 6.0,
                        width.max(2.0)
                    )
                })
                .collect(),
            Mark::Dot(color) => format!(
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"1.8\" fill=\"{color}\"/><circle \
                 cx=\"{:.1}\" cy=\"{:.1}\" r=\"1.8\" fill=\"{color}\"/><circle cx=\"{:.1}\" \
                 cy=\"{:.1}\" r=\"1.8\" fill=\"{color}\"/>",
                cx - 6.0,
                cy + 2.0,
                cx + 6.0,
                cy - 2.0
            ),
            Mark::Ring(color, dashed) => format!(
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"7\" fill=\"none\" \
                 stroke=\"{color}\" stroke-width=\"2\"{}/>",
                if dashed {
                    " stroke-dasharray=\"3 2\""
                } else {
                    ""
                }
            ),
            Mark::Disc(color) => format!(
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"5\" fill=\"{color}\" \
                 stroke=\"#ffffff\"/>"
            ),
            Mark::Discs(colors) => colors
                .iter()
                .enumerate()
                .map(|(k, color)| {
                    format!(
                        "<circle cx=\"{:.1}\" cy=\"{cy:.1}\" r=\"3.2\" fill=\"{color}\"/>",
                        x + 3.5 + 7.0 * k as f64
                    )
                })
                .collect(),
            Mark::DiscInRing(color) => format!(
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"4\" fill=\"{color}\" \
                 stroke=\"#ffffff\"/><circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"7.5\" \
                 fill=\"none\" stroke=\"{color}\" stroke-width=\"2\"/>"
            ),
            Mark::Cross(color) => format!(
                "<path d=\"M{:.1} {:.1}l8 8m0 -8l-8 8\" stroke=\"{color}\" \
                 stroke-width=\"2\"/>",
                cx - 4.0,
                cy - 4.0
            ),
            Mark::Arrow(color) => arrow(x, cy, x + 22.0, cy, color),
            Mark::Robot => robot_marker_px(cx, cy, 0.0),
        }
    }
}

/// One legend entry: its mark, its text, and what it stands for on the pictures: the
/// marks drawn, as `class:colour` (or `class`) separated by spaces, which the browser
/// test checks every drawn mark against.
pub(super) type Entry<'a> = (Mark, &'a str, String);

/// A row (or rows) of legend entries, wrapping at `width` px.
pub(super) fn legend_svg(entries: &[Entry<'_>], width: f64) -> String {
    let mut items = String::new();
    let (mut x, mut y) = (8.0, 16.0);
    for (mark, label, stands_for) in entries {
        let text_x = mark.width() + 8.0;
        let w = text_x + Labels::CHAR_W * label.chars().count() as f64 + 18.0;
        if x + w > width && x > 8.0 {
            x = 8.0;
            y += 20.0;
        }
        let _ = write!(
            items,
            "<g class=\"legend-entry\" data-marks=\"{}\">{}<text x=\"{:.1}\" y=\"{y:.1}\">{}\
             </text></g>",
            xml_escape(stands_for),
            mark.svg(x, y - 4.0),
            x + text_x,
            xml_escape(label)
        );
        x += w;
    }
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"legend\" width=\"{width:.0}\" \
         height=\"{:.0}\" font-family=\"sans-serif\" font-size=\"11\">{items}</svg>",
        y + 8.0
    )
}
