//! The pictures and the track table of `tether replay`'s report (issue 17): a top view
//! with metre axes and a scale bar, snapshots of chosen instants drawn the way
//! leg_tracker users look at rviz (the scan's returns, the detected legs, the laser's
//! person observations, the tracks with their ids, velocities and covariances, the
//! target, the robot), and one row per confirmed track.
//!
//! Everything is drawn in the replay's output frame (`odom`, `scan_odom` or
//! `base_link`), one metre the same length across and up, and comes out the same bytes
//! for the same replay (no hashing, no clock).
//!
//! # Which instants
//!
//! At most [`MAX_SNAPSHOTS`] (8), in time order:
//!
//! - **Target losses**: each loss of the target is a candidate when it happens (with
//!   the scan of that tick, or the last scan before it when a camera frame lost it); at
//!   most [`MAX_LOSS_SNAPSHOTS`] (4) are drawn, spread evenly over the losses by their
//!   order (all of them when there are no more).
//! - **Evenly spaced**: the rest (4 to 8) are the scans nearest the middles of as many
//!   equal parts of the recording's scans, by scan index.
//!
//! A recording's number of scans is known only at its end (a recording cut short has
//! no index to count them beforehand), and a 12-minute log has 7,200 scans, too many to
//! hold. So candidates are thinned as they come ([`Thinned`]): scan `i` is kept when
//! `i` is a multiple of a stride that doubles (dropping every other candidate) whenever
//! more than 32 are held. At most 32 scans are ever held, spaced at most a
//! sixteenth of the recording apart, so each evenly spaced snapshot is within a
//! sixteenth of the recording of its ideal place (and exactly there for recordings of
//! up to 32 scans). Losses are thinned the same way by loss number, at most 8 held.
//! The legs are found again, with the pipeline's own detector and configuration, only
//! for the scans drawn.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use tether_core::{Gaussian2, Laser, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_fusion::tracker::Track;
use tether_fusion::{LossReason, TargetState};
use tether_laser::{DetectorKind, Leg, LegClassifier, LegDetector};
use tether_pipeline::{PipelineConfig, TrackView};
use tether_sim::svg::xml_escape;

use crate::plot::{tick_step, trim};

/// Most snapshots in a report.
pub const MAX_SNAPSHOTS: usize = 8;
/// Most of them at target losses.
pub const MAX_LOSS_SNAPSHOTS: usize = 4;
/// Scans held as candidates for the evenly spaced snapshots.
const EVEN_CANDIDATES: usize = 32;
/// Losses held as candidates.
const LOSS_CANDIDATES: usize = 8;
/// A track's walk is counted in steps of at least this, m: a standing person's
/// estimate jitters by centimetres (and by a leg's width when one leg updates it), which
/// is no walking.
pub const WALK_STEP_M: f64 = 0.25;
/// Most rows of the track table.
pub const MAX_TRACK_ROWS: usize = 50;

/// The target's colour everywhere in the report.
const TARGET: &str = "#d62728";
const SCAN: &str = "#3a3a3a";
const LEG: &str = "#2ca02c";
const PERSON: &str = "#1f77b4";
const TENTATIVE: &str = "#999999";
const ROBOT: &str = "#222222";

/// A track's colour: red for the target, else by id, the same in every picture. Dark
/// enough for an id written in it on white, and apart from the legs' green and the laser
/// people's blue.
pub fn track_color(id: u64, target: bool) -> &'static str {
    const OTHERS: [&str; 6] = [
        "#9467bd", "#d95f02", "#8c564b", "#c51b8a", "#0e8a9a", "#6b6b00",
    ];
    if target {
        TARGET
    } else {
        OTHERS[(id % OTHERS.len() as u64) as usize]
    }
}

/// `n` and the noun, singular or plural.
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// An axis-aligned box in the world, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Least x.
    pub x0: f64,
    /// Greatest x.
    pub x1: f64,
    /// Least y.
    pub y0: f64,
    /// Greatest y.
    pub y1: f64,
}

impl Bounds {
    /// Holds nothing.
    pub const EMPTY: Bounds = Bounds {
        x0: f64::INFINITY,
        x1: f64::NEG_INFINITY,
        y0: f64::INFINITY,
        y1: f64::NEG_INFINITY,
    };

    /// Grows to hold a point (non-finite points are ignored).
    pub fn add(&mut self, x: f64, y: f64) {
        if x.is_finite() && y.is_finite() {
            self.x0 = self.x0.min(x);
            self.x1 = self.x1.max(x);
            self.y0 = self.y0.min(y);
            self.y1 = self.y1.max(y);
        }
    }

    /// Grows to hold a disc.
    pub fn add_disc(&mut self, p: Point2<World>, r: f64) {
        self.add(p.x - r, p.y - r);
        self.add(p.x + r, p.y + r);
    }

    /// True when it holds no point.
    pub fn is_empty(&self) -> bool {
        !(self.x0 <= self.x1 && self.y0 <= self.y1)
    }

    /// Grown by `m` on every side.
    pub fn padded(self, m: f64) -> Bounds {
        Bounds {
            x0: self.x0 - m,
            x1: self.x1 + m,
            y0: self.y0 - m,
            y1: self.y1 + m,
        }
    }

    /// Grown about its centre to at least `m` across each way.
    fn at_least(self, m: f64) -> Bounds {
        let grow = |a: f64, b: f64| {
            let half = 0.5 * (b - a).max(m);
            let c = 0.5 * (a + b);
            (c - half, c + half)
        };
        let (x0, x1) = grow(self.x0, self.x1);
        let (y0, y1) = grow(self.y0, self.y1);
        Bounds { x0, x1, y0, y1 }
    }

    /// Grown about its centre to a square.
    fn squared(self) -> Bounds {
        self.at_least((self.x1 - self.x0).max(self.y1 - self.y0))
    }

    fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }
}

/// The longest "round" length (1, 2 or 5 times a power of ten) of at most `max_m`: a
/// scale bar's length, as the simulator's maps draw it.
pub use tether_sim::svg::round_length_m as scale_bar_m;

const AXIS_LEFT: f64 = 48.0;
const AXIS_RIGHT: f64 = 14.0;
const AXIS_BOTTOM: f64 = 38.0;

/// A map's drawing area: world metres to pixels at one scale both ways (y up), with
/// room for the axes.
#[derive(Debug, Clone, Copy)]
pub struct MapFrame {
    b: Bounds,
    k: f64,
    top: f64,
    w: f64,
    h: f64,
}

impl MapFrame {
    /// Fits `bounds` (grown to at least 1 m each way) into at most `max_w` x `max_h`
    /// pixels of plot, `top` pixels below the picture's top edge.
    pub fn fit(bounds: Bounds, max_w: f64, max_h: f64, top: f64) -> MapFrame {
        let b = if bounds.is_empty() {
            Bounds {
                x0: -0.5,
                x1: 0.5,
                y0: -0.5,
                y1: 0.5,
            }
        } else {
            bounds.at_least(1.0)
        };
        let k = (max_w / (b.x1 - b.x0)).min(max_h / (b.y1 - b.y0));
        MapFrame {
            b,
            k,
            top,
            w: (b.x1 - b.x0) * k,
            h: (b.y1 - b.y0) * k,
        }
    }

    /// Pixels per metre.
    pub fn px_per_m(&self) -> f64 {
        self.k
    }

    /// The picture's width, px.
    pub fn width(&self) -> f64 {
        AXIS_LEFT + self.w + AXIS_RIGHT
    }

    /// The picture's height, px (the plot and the axes below it).
    pub fn height(&self) -> f64 {
        self.top + self.h + AXIS_BOTTOM
    }

    /// Pixel position of a world point.
    pub fn px(&self, x: f64, y: f64) -> (f64, f64) {
        (
            AXIS_LEFT + (x - self.b.x0) * self.k,
            self.top + (self.b.y1 - y) * self.k,
        )
    }

    /// True when the world point is inside the plot.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.b.contains(x, y)
    }

    /// The plot's rectangle in pixels: left, top, width, height.
    fn area(&self) -> (f64, f64, f64, f64) {
        (AXIS_LEFT, self.top, self.w, self.h)
    }

    /// The opening `svg` tag, a white background and the clip path `clip_id` of the
    /// plot.
    fn open(&self, class: &str, clip_id: &str) -> String {
        let (w, h) = (self.width(), self.height());
        let (l, t, pw, ph) = self.area();
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"{class}\" width=\"{w:.0}\" \
             height=\"{h:.0}\" viewBox=\"0 0 {w:.0} {h:.0}\" font-family=\"sans-serif\" \
             font-size=\"11\"><rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\
             <defs><clipPath id=\"{clip_id}\"><rect x=\"{l:.1}\" y=\"{t:.1}\" \
             width=\"{pw:.1}\" height=\"{ph:.1}\"/></clipPath></defs>"
        )
    }

    /// The grid, the axes with a tick and a label every round number of metres (the
    /// same step both ways), and the axes' titles naming the frame.
    pub fn axes(&self, frame: &str) -> String {
        let (l, t, w, h) = self.area();
        let step = tick_step((self.b.x1 - self.b.x0).max(self.b.y1 - self.b.y0));
        let mut s = String::from("<g class=\"axes\">");
        let _ = write!(
            s,
            "<rect x=\"{l:.1}\" y=\"{t:.1}\" width=\"{w:.1}\" height=\"{h:.1}\" \
             fill=\"#fcfcfc\" stroke=\"#888888\"/>"
        );
        let ticks = |a: f64, b: f64| {
            let (first, last) = ((a / step).ceil() as i64, (b / step).floor() as i64);
            (first..=last).map(move |i| i as f64 * step)
        };
        for x in ticks(self.b.x0, self.b.x1) {
            let (u, _) = self.px(x, 0.0);
            let _ = write!(
                s,
                "<line x1=\"{u:.1}\" y1=\"{t:.1}\" x2=\"{u:.1}\" y2=\"{:.1}\" \
                 stroke=\"#e4e4e4\"/><line x1=\"{u:.1}\" y1=\"{:.1}\" x2=\"{u:.1}\" \
                 y2=\"{:.1}\" stroke=\"#888888\"/><text x=\"{u:.1}\" y=\"{:.1}\" \
                 text-anchor=\"middle\">{}</text>",
                t + h,
                t + h,
                t + h + 4.0,
                t + h + 15.0,
                trim(x)
            );
        }
        for y in ticks(self.b.y0, self.b.y1) {
            let (_, v) = self.px(0.0, y);
            let _ = write!(
                s,
                "<line x1=\"{l:.1}\" y1=\"{v:.1}\" x2=\"{:.1}\" y2=\"{v:.1}\" \
                 stroke=\"#e4e4e4\"/><line x1=\"{:.1}\" y1=\"{v:.1}\" x2=\"{l:.1}\" \
                 y2=\"{v:.1}\" stroke=\"#888888\"/><text x=\"{:.1}\" y=\"{:.1}\" \
                 text-anchor=\"end\">{}</text>",
                l + w,
                l - 4.0,
                l - 6.0,
                v + 4.0,
                trim(y)
            );
        }
        let frame = xml_escape(frame);
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">x (m, {frame})</text>\
             <text x=\"12\" y=\"{:.1}\" text-anchor=\"middle\" \
             transform=\"rotate(-90 12 {:.1})\">y (m, {frame})</text></g>",
            l + w / 2.0,
            t + h + 31.0,
            t + h / 2.0,
            t + h / 2.0
        );
        s
    }

    /// A scale bar in the plot's lower right corner: a round length of at most a
    /// quarter of the plot's width, labelled.
    pub fn scale_bar(&self) -> String {
        let (l, t, w, h) = self.area();
        let len_m = scale_bar_m(0.25 * w / self.k);
        let len = len_m * self.k;
        let (x1, y) = (l + w - 12.0, t + h - 12.0);
        let x0 = x1 - len;
        format!(
            "<g class=\"scale-bar\"><rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" \
             height=\"28\" fill=\"#ffffff\" fill-opacity=\"0.85\"/><path d=\"M{x0:.1} \
             {:.1}V{y:.1}H{x1:.1}V{:.1}\" fill=\"none\" stroke=\"#000000\" \
             stroke-width=\"2\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\" \
             font-weight=\"bold\">{} m</text></g>",
            x0 - 6.0,
            y - 22.0,
            len + 12.0,
            y - 5.0,
            y - 5.0,
            (x0 + x1) / 2.0,
            y - 8.0,
            trim(len_m)
        )
    }
}

/// Places labels where they overlap neither each other nor the plot's edges, when one
/// of a few places beside the point will do.
#[derive(Debug, Default)]
struct Labels {
    placed: Vec<(f64, f64, f64, f64)>,
}

impl Labels {
    /// Text at 11 px: about 6.3 px a character.
    const CHAR_W: f64 = 6.3;
    const H: f64 = 11.0;

    /// Where to put the text's left end and baseline, beside pixel `(u, v)`.
    fn place(&mut self, u: f64, v: f64, text: &str, area: (f64, f64, f64, f64)) -> (f64, f64) {
        let w = Self::CHAR_W * text.chars().count() as f64;
        let h = Self::H;
        // The first eight of the map's spots, nearer.
        let spots = tether_sim::svg::label_spots((u, v), (w, h), 7.0, 2.0);
        let candidates = &spots[..8];
        let (l, t, aw, ah) = area;
        let fits = |&(x, y): &(f64, f64)| {
            let (x0, y0, x1, y1) = (x, y - h, x + w, y + 2.0);
            x0 >= l
                && x1 <= l + aw
                && y0 >= t
                && y1 <= t + ah
                && !self
                    .placed
                    .iter()
                    .any(|&(a0, b0, a1, b1)| x0 < a1 && a0 < x1 && y0 < b1 && b0 < y1)
        };
        let (x, y) = candidates
            .iter()
            .copied()
            .find(|c| fits(c))
            .unwrap_or(candidates[0]);
        self.placed.push((x, y - h, x + w, y + 2.0));
        (x, y)
    }
}

fn ellipse(frame: &MapFrame, g: &Gaussian2<World>, color: &str, fill_opacity: f64) -> String {
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
fn arrow(u: f64, v: f64, u2: f64, v2: f64, color: &str) -> String {
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
fn robot_marker(frame: &MapFrame, pose: Pose2<World, Robot>) -> String {
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
enum Mark {
    Line(&'static str, f64, bool),
    Dot(&'static str),
    Ring(&'static str, bool),
    Disc(&'static str),
    Cross(&'static str),
    Arrow(&'static str),
    Robot,
}

/// A row (or rows) of legend entries, wrapping at `width` px.
fn legend_svg(entries: &[(Mark, &str)], width: f64) -> String {
    let mut items = String::new();
    let (mut x, mut y) = (8.0, 16.0);
    for (mark, label) in entries {
        let w = 30.0 + Labels::CHAR_W * label.chars().count() as f64 + 18.0;
        if x + w > width && x > 8.0 {
            x = 8.0;
            y += 20.0;
        }
        let (cx, cy) = (x + 11.0, y - 4.0);
        let m = match *mark {
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
            Mark::Cross(color) => format!(
                "<path d=\"M{:.1} {:.1}l8 8m0 -8l-8 8\" stroke=\"{color}\" \
                 stroke-width=\"2\"/>",
                cx - 4.0,
                cy - 4.0
            ),
            Mark::Arrow(color) => arrow(x, cy, x + 22.0, cy, color),
            Mark::Robot => robot_marker_px(cx, cy, 0.0),
        };
        let _ = write!(
            items,
            "{m}<text x=\"{:.1}\" y=\"{y:.1}\">{}</text>",
            x + 30.0,
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

/// The top view of the whole replay: each confirmed track's trail (the target's in
/// red, the others coloured by id, the longest labelled with their ids), the robot's
/// path, metre axes and a scale bar, fitted at one scale both ways into the page.
pub fn overview_svg(
    trails: &BTreeMap<u64, Vec<(f64, f64)>>,
    robot_path: &[(f64, f64)],
    target_ids: &[u64],
    frame: &str,
) -> String {
    let mut b = Bounds::EMPTY;
    for &(x, y) in trails.values().flatten().chain(robot_path) {
        b.add(x, y);
    }
    if b.is_empty() {
        return String::from("<p>No tracks.</p>");
    }
    let map = MapFrame::fit(b.padded(0.3), 900.0, 680.0, 8.0);
    let mut s = map.open("map", "map-clip");
    s.push_str(&map.axes(frame));
    s.push_str("<g clip-path=\"url(#map-clip)\" fill=\"none\">");
    let points = |pts: &[(f64, f64)]| {
        pts.iter()
            .map(|&(x, y)| {
                let (u, v) = map.px(x, y);
                format!("{u:.1},{v:.1}")
            })
            .collect::<Vec<_>>()
            .join(" ")
    };
    // The target's trails last, on top.
    let order = trails
        .iter()
        .filter(|(id, _)| !target_ids.contains(id))
        .chain(trails.iter().filter(|(id, _)| target_ids.contains(id)));
    for (id, pts) in order {
        let target = target_ids.contains(id);
        let _ = write!(
            s,
            "<polyline stroke=\"{}\" stroke-width=\"{}\" stroke-opacity=\"0.85\" \
             points=\"{}\"><title>track {id}</title></polyline>",
            track_color(*id, target),
            if target { 2.2 } else { 1.2 },
            points(pts)
        );
    }
    let _ = write!(
        s,
        "<polyline stroke=\"{ROBOT}\" stroke-width=\"1.6\" stroke-dasharray=\"5 3\" \
         points=\"{}\"><title>robot</title></polyline>",
        points(robot_path)
    );
    if let Some(&(x, y)) = robot_path.first() {
        let (u, v) = map.px(x, y);
        let _ = write!(
            s,
            "<circle cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"4\" fill=\"{ROBOT}\"><title>robot at \
             the start</title></circle>"
        );
    }
    s.push_str("</g>");
    // Ids at the end of the longest trails (and every target's).
    let mut by_length: Vec<(&u64, &Vec<(f64, f64)>)> = trails.iter().collect();
    by_length.sort_by(|a, b| {
        let key = |(id, pts): &(&u64, &Vec<(f64, f64)>)| (!target_ids.contains(id), pts.len());
        let (ta, la) = key(a);
        let (tb, lb) = key(b);
        ta.cmp(&tb).then(lb.cmp(&la)).then(a.0.cmp(b.0))
    });
    let mut labels = Labels::default();
    for (id, pts) in by_length.into_iter().take(20) {
        let Some(&(x, y)) = pts.last() else { continue };
        let (u, v) = map.px(x, y);
        let text = id.to_string();
        let (lx, ly) = labels.place(u, v, &text, map.area());
        let target = target_ids.contains(id);
        let _ = write!(
            s,
            "<text x=\"{lx:.1}\" y=\"{ly:.1}\" fill=\"{}\" font-weight=\"bold\" \
             stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\">{text}</text>",
            track_color(*id, target)
        );
    }
    s.push_str(&map.scale_bar());
    s.push_str("</svg>");
    let legend = legend_svg(
        &[
            (Mark::Line(TARGET, 2.2, false), "the target's tracks"),
            (
                Mark::Line(track_color(0, false), 1.2, false),
                "other confirmed tracks (colour by id; ids at their ends)",
            ),
            (Mark::Line(ROBOT, 1.6, true), "robot"),
            (Mark::Disc(ROBOT), "robot at the start"),
        ],
        map.width().max(520.0),
    );
    format!("<div class=\"figure\">{s}<br>{legend}</div>")
}

/// Why a snapshot was drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chosen {
    /// Evenly spaced over the recording.
    Evenly,
    /// At a loss of the target.
    Loss(LossReason),
}

/// What a snapshot draws: the last scan (in the laser's frame) with the robot's pose
/// at it, that scan's laser people, and the tracks and target of the tick.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Seconds from the replay's first tick.
    pub t_s: f64,
    /// The tick's stamp.
    pub stamp: Stamp,
    /// Index of the scan among the scans replayed (from 0).
    pub scan_index: usize,
    /// Why it was chosen.
    pub chosen: Chosen,
    /// The scan.
    pub scan: LaserScan,
    /// The robot's pose at the scan.
    pub world_from_robot: Pose2<World, Robot>,
    /// Where the laser sits on the robot.
    pub robot_from_laser: Pose2<Robot, Laser>,
    /// The scan's person observations (world).
    pub laser_people: Vec<Gaussian2<World>>,
    /// The tracks after the tick.
    pub tracks: Vec<TrackView>,
    /// The target's state after the tick.
    pub target: TargetState,
    /// The target's estimate while locked.
    pub target_estimate: Option<Gaussian2<World>>,
}

impl Snapshot {
    /// One line on the target's state.
    fn target_text(&self) -> String {
        match self.target {
            TargetState::Searching => "no target chosen yet".to_owned(),
            TargetState::Locked { track } => format!("target locked on track {track}"),
            TargetState::Lost {
                track,
                reason,
                since,
                ..
            } => format!(
                "target lost ({}): track {track}, last updated {:.1} s before",
                reason.name(),
                self.stamp.secs_since(since).max(0.0)
            ),
        }
    }

    /// The caption: number, time, why chosen, the target's state and what is drawn.
    pub fn caption(&self, number: usize, legs: usize) -> String {
        let why = match self.chosen {
            Chosen::Evenly => "evenly spaced".to_owned(),
            Chosen::Loss(reason) => format!("at a loss of the target ({})", reason.name()),
        };
        let confirmed = self.tracks.iter().filter(|t| t.confirmed).count();
        format!(
            "S{number} · t = {:.1} s · {why} · {} · scan {}: {}, {}, {}; {}",
            self.t_s,
            self.target_text(),
            self.scan_index + 1,
            count(self.scan.returns(), "return", "returns"),
            count(legs, "leg", "legs"),
            count(self.laser_people.len(), "person", "people"),
            count(confirmed, "confirmed track", "confirmed tracks")
        )
    }

    /// The picture: the scan's returns, the legs (in the laser's frame, as found in
    /// this scan), the laser people with 2-sigma ellipses, the tracks (confirmed: a
    /// disc with its id, its 2-sigma ellipse and where its velocity takes it in 1 s;
    /// tentative: a grey ring), the target (a red ring; while lost, a dashed ring at
    /// its last good estimate) and the robot; axes in metres and a scale bar.
    pub fn svg(&self, number: usize, legs: &[Leg], frame: &str) -> String {
        let world_from_laser = self.world_from_robot * self.robot_from_laser;
        let robot = self.world_from_robot.translation();
        let legs: Vec<(Point2<World>, f64)> = legs
            .iter()
            .map(|l| (world_from_laser * l.centre_in_laser, l.radius_m))
            .collect();
        let target_track = self.target.locked_track();
        let lost_at = match self.target {
            TargetState::Lost { track, last, .. } => Some((track, last)),
            _ => None,
        };
        // What the picture is about, and the returns around it.
        let mut interest: Vec<Point2<World>> = self
            .tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| t.position.mean)
            .chain(self.laser_people.iter().map(|g| g.mean))
            .chain(legs.iter().map(|l| l.0))
            .chain(self.target_estimate.map(|g| g.mean))
            .chain(lost_at.map(|(_, g)| g.mean))
            .filter(|p| p.is_finite())
            .collect();
        let reach = interest
            .iter()
            .map(|p| p.distance_m(robot))
            .fold(0.0, f64::max);
        let radius = (reach + 2.0).clamp(4.0, 12.0);
        let points: Vec<Point2<World>> = self
            .scan
            .points()
            .map(|(_, p)| world_from_laser * p)
            .filter(|p| p.distance_m(robot) <= radius)
            .collect();
        let mut b = Bounds::EMPTY;
        b.add_disc(robot, 1.0);
        interest.retain(|p| p.distance_m(robot) <= radius);
        for p in &interest {
            b.add_disc(*p, 0.6);
        }
        for p in &points {
            b.add(p.x, p.y);
        }
        // Where the confirmed tracks' velocity arrows end.
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let p = t.position.mean + t.velocity;
            if p.distance_m(robot) <= radius {
                b.add_disc(p, 0.2);
            }
        }
        // Square, as rviz shows a scan: the pictures side by side at one size.
        let map = MapFrame::fit(b.padded(0.3).squared(), 470.0, 470.0, 8.0);
        let clip = format!("snapshot-clip-{number}");
        let mut s = map.open("snapshot-map", &clip);
        s.push_str(&map.axes(frame));
        let _ = write!(s, "<g clip-path=\"url(#{clip})\">");
        // The returns: one path of round dots.
        let mut d = String::new();
        for p in &points {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(d, "M{u:.1} {v:.1}h0");
        }
        let _ = write!(
            s,
            "<path class=\"scan\" d=\"{d}\" stroke=\"{SCAN}\" stroke-width=\"2.6\" \
             stroke-linecap=\"round\" fill=\"none\"/>"
        );
        // Tracks' ellipses under everything else.
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let color = track_color(t.id, Some(t.id) == target_track);
            s.push_str(&ellipse(&map, &t.position, color, 0.10));
        }
        for g in &self.laser_people {
            s.push_str(&ellipse(&map, g, PERSON, 0.0));
        }
        for t in self.tracks.iter().filter(|t| !t.confirmed) {
            let (u, v) = map.px(t.position.mean.x, t.position.mean.y);
            let _ = write!(
                s,
                "<circle cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"4\" fill=\"none\" \
                 stroke=\"{TENTATIVE}\" stroke-width=\"1.4\"><title>tentative track {}\
                 </title></circle>",
                t.id
            );
        }
        for t in self.tracks.iter().filter(|t| t.confirmed) {
            let color = track_color(t.id, Some(t.id) == target_track);
            let p = t.position.mean;
            let (u, v) = map.px(p.x, p.y);
            let speed = t.velocity.norm();
            if speed > 0.15 && speed.is_finite() {
                let (u2, v2) = map.px(p.x + t.velocity.x, p.y + t.velocity.y);
                s.push_str(&arrow(u, v, u2, v2, color));
            }
            let _ = write!(
                s,
                "<circle class=\"track\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"5\" fill=\"{color}\" \
                 stroke=\"#ffffff\" stroke-width=\"1\"><title>track {} ({:.2} m/s)</title>\
                 </circle>",
                t.id, speed
            );
        }
        let target_at = target_track
            .and_then(|id| self.tracks.iter().find(|t| t.id == id))
            .map(|t| t.position.mean)
            .or(self.target_estimate.map(|g| g.mean));
        if let Some(p) = target_at {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(
                s,
                "<circle class=\"target\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"10\" fill=\"none\" \
                 stroke=\"{TARGET}\" stroke-width=\"2.5\"/>"
            );
        }
        if let Some((_, last)) = lost_at {
            let (u, v) = map.px(last.mean.x, last.mean.y);
            let _ = write!(
                s,
                "<circle class=\"target-lost\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"10\" \
                 fill=\"none\" stroke=\"{TARGET}\" stroke-width=\"2\" \
                 stroke-dasharray=\"4 3\"/>"
            );
        }
        // The observations on top: they are what the tracks are made of.
        for g in &self.laser_people {
            let (u, v) = map.px(g.mean.x, g.mean.y);
            let _ = write!(
                s,
                "<path class=\"person\" d=\"M{:.1} {:.1}l8 8m0 -8l-8 8\" stroke=\"{PERSON}\" \
                 stroke-width=\"2\"/>",
                u - 4.0,
                v - 4.0
            );
        }
        for (p, r) in &legs {
            let (u, v) = map.px(p.x, p.y);
            let _ = write!(
                s,
                "<circle class=\"leg\" cx=\"{u:.1}\" cy=\"{v:.1}\" r=\"{:.1}\" fill=\"none\" \
                 stroke=\"{LEG}\" stroke-width=\"2\"/>",
                (r * map.k).max(4.5)
            );
        }
        s.push_str(&robot_marker(&map, self.world_from_robot));
        s.push_str("</g>");
        // Labels last, on top, the target's first.
        let mut labels = Labels::default();
        let mut label = |p: Point2<World>, text: &str, color: &str, s: &mut String| {
            if !map.contains(p.x, p.y) {
                return;
            }
            let (u, v) = map.px(p.x, p.y);
            let (x, y) = labels.place(u, v, text, map.area());
            let _ = write!(
                s,
                "<text x=\"{x:.1}\" y=\"{y:.1}\" fill=\"{color}\" font-weight=\"bold\" \
                 stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\">{}</text>",
                xml_escape(text)
            );
        };
        if let Some(p) = target_at {
            let text = match target_track {
                Some(id) => format!("{id} target"),
                None => "target".to_owned(),
            };
            label(p, &text, TARGET, &mut s);
        }
        if let Some((track, last)) = lost_at {
            label(
                last.mean,
                &format!("{track} target, last seen"),
                TARGET,
                &mut s,
            );
        }
        for t in self
            .tracks
            .iter()
            .filter(|t| t.confirmed && Some(t.id) != target_track)
        {
            label(
                t.position.mean,
                &t.id.to_string(),
                track_color(t.id, false),
                &mut s,
            );
        }
        s.push_str(&map.scale_bar());
        s.push_str("</svg>");
        s
    }
}

/// Keeps every `stride`-th of a stream of items by their index, doubling the stride
/// (and dropping every other item held) whenever more than `cap` are held: a bounded,
/// evenly spread sample of a stream whose length is known only at its end.
#[derive(Debug, Clone)]
pub struct Thinned<T> {
    cap: usize,
    stride: usize,
    items: Vec<(usize, T)>,
}

impl<T> Thinned<T> {
    /// Holds at most `cap` (at least 2) items.
    pub fn new(cap: usize) -> Self {
        Thinned {
            cap: cap.max(2),
            stride: 1,
            items: Vec::new(),
        }
    }

    /// Whether the item of this index would be kept.
    pub fn wants(&self, index: usize) -> bool {
        index.is_multiple_of(self.stride)
    }

    /// Offers the item of `index` (indices increasing); `make` is called only when it
    /// is kept.
    pub fn offer(&mut self, index: usize, make: impl FnOnce() -> T) {
        if !self.wants(index) {
            return;
        }
        self.items.push((index, make()));
        if self.items.len() > self.cap {
            self.stride *= 2;
            let stride = self.stride;
            self.items.retain(|(i, _)| i.is_multiple_of(stride));
        }
    }

    /// The indices held.
    pub fn indices(&self) -> Vec<usize> {
        self.items.iter().map(|(i, _)| *i).collect()
    }

    /// `n` items of a stream of `total`: for each of `n` equal parts of the stream,
    /// the item held nearest its middle (not one taken already); all of them when
    /// `n` or fewer are held.
    pub fn pick(self, n: usize, total: usize) -> Vec<(usize, T)> {
        if self.items.len() <= n {
            return self.items;
        }
        let mut taken = vec![false; self.items.len()];
        for k in 0..n {
            let middle = (k as f64 + 0.5) * total as f64 / n as f64 - 0.5;
            let best = self
                .items
                .iter()
                .enumerate()
                .filter(|(j, _)| !taken[*j])
                .min_by(|(_, a), (_, b)| {
                    (a.0 as f64 - middle)
                        .abs()
                        .total_cmp(&(b.0 as f64 - middle).abs())
                        .then(a.0.cmp(&b.0))
                })
                .map(|(j, _)| j);
            if let Some(j) = best {
                taken[j] = true;
            }
        }
        self.items
            .into_iter()
            .zip(taken)
            .filter(|(_, t)| *t)
            .map(|(item, _)| item)
            .collect()
    }
}

/// Chooses the snapshots as a replay goes (see the module's documentation).
#[derive(Debug, Clone)]
pub struct SnapshotPicker {
    evenly: Thinned<Snapshot>,
    losses: Thinned<Snapshot>,
    loss_count: usize,
}

impl Default for SnapshotPicker {
    fn default() -> Self {
        SnapshotPicker {
            evenly: Thinned::new(EVEN_CANDIDATES),
            losses: Thinned::new(LOSS_CANDIDATES),
            loss_count: 0,
        }
    }
}

impl SnapshotPicker {
    /// Nothing chosen yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Scan `index` (counted from 0, in order) has been replayed; `make` builds its
    /// snapshot, called only when the scan is kept as a candidate.
    pub fn scan(&mut self, index: usize, make: impl FnOnce() -> Snapshot) {
        self.evenly.offer(index, make);
    }

    /// The target was just lost; `make` builds the snapshot, called only when the
    /// loss is kept as a candidate.
    pub fn loss(&mut self, make: impl FnOnce() -> Snapshot) {
        self.losses.offer(self.loss_count, make);
        self.loss_count += 1;
    }

    /// The snapshots of a replay of `scans` scans, in time order.
    pub fn finish(self, scans: usize) -> Vec<Snapshot> {
        let losses: Vec<Snapshot> = self
            .losses
            .pick(MAX_LOSS_SNAPSHOTS, self.loss_count)
            .into_iter()
            .map(|(_, s)| s)
            .collect();
        let mut out: Vec<Snapshot> = self
            .evenly
            .pick(MAX_SNAPSHOTS - losses.len(), scans)
            .into_iter()
            .map(|(_, s)| s)
            .filter(|s| !losses.iter().any(|l| l.scan_index == s.scan_index))
            .collect();
        out.extend(losses);
        out.sort_by(|a, b| {
            a.stamp
                .cmp(&b.stamp)
                .then(a.scan_index.cmp(&b.scan_index))
                .then((a.chosen == Chosen::Evenly).cmp(&(b.chosen == Chosen::Evenly)))
        });
        out
    }
}

/// The pipeline's leg detector, built as the pipeline builds it, to find the legs of
/// the scans drawn.
pub fn leg_detector(config: &PipelineConfig) -> anyhow::Result<LegDetector> {
    let noise = config.laser.noise.clone();
    Ok(match config.legs.detector {
        DetectorKind::Arc => LegDetector::arc(config.legs.config, noise)?,
        DetectorKind::Learned => {
            let named = tether_live::leg_model::classifier(&config.legs)?;
            let model = named.map_or_else(LegClassifier::default_model, Ok)?;
            LegDetector::learned(config.legs.config, noise, model)?
        }
    })
}

/// The snapshots' section: a legend, then each snapshot as a figure with its caption.
pub fn snapshots_html(snapshots: &[Snapshot], detector: &mut LegDetector, frame: &str) -> String {
    if snapshots.is_empty() {
        return String::from("<p>No scan was replayed.</p>");
    }
    let mut s = String::from(
        "<p>The scan at chosen instants, as rviz shows it: evenly spaced over the \
         recording, and at losses of the target (at most 8 in all, at most 4 losses, \
         spread over them). Each picture is centred on what the scan saw near the robot; \
         returns farther than the people seen plus 2 m (at least 4, at most 12 m) are \
         left out.</p>",
    );
    s.push_str(&legend_svg(
        &[
            (Mark::Dot(SCAN), "laser returns"),
            (Mark::Ring(LEG, false), "legs found"),
            (Mark::Cross(PERSON), "laser person (2σ ellipse)"),
            (Mark::Disc(track_color(0, false)), "confirmed track and id"),
            (
                Mark::Arrow(track_color(1, false)),
                "its velocity (where in 1 s)",
            ),
            (Mark::Ring(TENTATIVE, false), "tentative track"),
            (Mark::Ring(TARGET, false), "target"),
            (Mark::Ring(TARGET, true), "lost target's last estimate"),
            (Mark::Robot, "robot (pointing ahead)"),
        ],
        1050.0,
    ));
    s.push_str("<div class=\"snapshots\">");
    for (k, snap) in snapshots.iter().enumerate() {
        let legs = detector.detect(&snap.scan).legs;
        let _ = write!(
            s,
            "<figure class=\"snapshot\" id=\"snapshot-{0}\" style=\"display:inline-block;\
             vertical-align:top;margin:6px 8px;width:{1:.0}px\">{2}<figcaption \
             style=\"font-size:13px\">{3}</figcaption></figure>",
            k + 1,
            530.0,
            snap.svg(k + 1, &legs, frame),
            xml_escape(&snap.caption(k + 1, legs.len()))
        );
    }
    s.push_str("</div>");
    s
}

/// What the track table needs of a track at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSeen {
    /// Id.
    pub id: u64,
    /// Confirmed.
    pub confirmed: bool,
    /// When it was born.
    pub born: Stamp,
    /// Its last update by any observation.
    pub last_update: Stamp,
    /// Its last update by the laser.
    pub last_laser: Option<Stamp>,
    /// Its position estimate.
    pub position: Point2<World>,
}

impl TrackSeen {
    /// Of a tracker's track.
    pub fn of(t: &Track) -> Self {
        TrackSeen {
            id: t.id,
            confirmed: t.confirmed,
            born: t.born,
            last_update: t.last_update,
            last_laser: t.last_laser,
            position: t.position().mean,
        }
    }
}

#[derive(Debug, Clone)]
struct TrackRecord {
    born: Stamp,
    last_update: Stamp,
    confirmed: bool,
    target: bool,
    walked_m: f64,
    walk_anchor: Point2<World>,
    scans_updated: u32,
}

/// One row of the track table.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRow {
    /// Track id.
    pub id: u64,
    /// Born, s from the replay's first tick.
    pub first_s: f64,
    /// Last updated by an observation, s from the first tick.
    pub last_s: f64,
    /// `last_s - first_s`.
    pub duration_s: f64,
    /// Walked, m (in steps of at least [`WALK_STEP_M`]).
    pub walked_m: f64,
    /// `walked_m / duration_s`, when it lasted.
    pub mean_speed_mps: Option<f64>,
    /// Scans whose laser observations updated it.
    pub scans_updated: u32,
    /// Ever followed as the target.
    pub target: bool,
}

/// Per-track figures over a replay, for the tracks that were ever confirmed.
#[derive(Debug, Clone, Default)]
pub struct TrackTable {
    records: BTreeMap<u64, TrackRecord>,
    forgotten: usize,
}

impl TrackTable {
    /// Empty.
    pub fn new() -> Self {
        Self::default()
    }

    /// The tracker's tracks after a tick at `stamp` (a scan's when `scan`), and the
    /// track followed as the target then.
    pub fn update(&mut self, stamp: Stamp, scan: bool, tracks: &[TrackSeen], target: Option<u64>) {
        for t in tracks {
            let r = self.records.entry(t.id).or_insert_with(|| TrackRecord {
                born: t.born,
                last_update: t.last_update,
                confirmed: false,
                target: false,
                walked_m: 0.0,
                walk_anchor: t.position,
                scans_updated: 0,
            });
            r.confirmed |= t.confirmed;
            r.target |= target == Some(t.id);
            if t.last_update == stamp {
                r.last_update = stamp;
                let d = t.position.distance_m(r.walk_anchor);
                if d >= WALK_STEP_M && d.is_finite() {
                    r.walked_m += d;
                    r.walk_anchor = t.position;
                }
                if scan && t.last_laser == Some(stamp) {
                    r.scans_updated += 1;
                }
            }
        }
        // A tentative track that is gone was nobody: forget it.
        let before = self.records.len();
        self.records
            .retain(|id, r| r.confirmed || tracks.iter().any(|t| t.id == *id));
        self.forgotten += before - self.records.len();
    }

    /// The rows, at most [`MAX_TRACK_ROWS`] (every target's track, then the longest),
    /// sorted by first seen; and how many confirmed tracks were left out.
    pub fn rows(&self, start: Stamp) -> (Vec<TrackRow>, usize) {
        let mut rows: Vec<TrackRow> = self
            .records
            .iter()
            .filter(|(_, r)| r.confirmed)
            .map(|(&id, r)| {
                let first_s = r.born.secs_since(start);
                let last_s = r.last_update.secs_since(start);
                let duration_s = (last_s - first_s).max(0.0);
                TrackRow {
                    id,
                    first_s,
                    last_s,
                    duration_s,
                    walked_m: r.walked_m,
                    mean_speed_mps: (duration_s > 0.0).then(|| r.walked_m / duration_s),
                    scans_updated: r.scans_updated,
                    target: r.target,
                }
            })
            .collect();
        rows.sort_by(|a, b| {
            b.target
                .cmp(&a.target)
                .then(b.duration_s.total_cmp(&a.duration_s))
                .then(a.id.cmp(&b.id))
        });
        let left_out = rows.len().saturating_sub(MAX_TRACK_ROWS);
        rows.truncate(MAX_TRACK_ROWS);
        rows.sort_by(|a, b| a.first_s.total_cmp(&b.first_s).then(a.id.cmp(&b.id)));
        (rows, left_out)
    }

    /// The table, with a line saying what the columns are and what was left out.
    pub fn html(&self, start: Stamp) -> String {
        let (rows, left_out) = self.rows(start);
        if rows.is_empty() {
            return String::from("<p>No track was confirmed.</p>");
        }
        let mut s = format!(
            "<p>{} confirmed tracks{}. First seen: the track's birth; last seen: its last \
             update by an observation (s from the start of the replay); walked: along its \
             updated estimates, in steps of at least {WALK_STEP_M} m (a standing person's \
             jitter is no walk); scans: the scans whose laser observations updated it; \
             target: followed as the target at some tick.{}</p>",
            rows.len() + left_out,
            if self.forgotten > 0 {
                format!(
                    " ({} tentative tracks that were never confirmed are not listed)",
                    self.forgotten
                )
            } else {
                String::new()
            },
            if left_out > 0 {
                format!(
                    " The {MAX_TRACK_ROWS} listed are the target's and the longest; {left_out} \
                     shorter ones are left out."
                )
            } else {
                String::new()
            }
        );
        s.push_str(
            "<table class=\"tracks\"><tr><th>track</th><th>first seen (s)</th><th>last \
             seen (s)</th><th>duration (s)</th><th>walked (m)</th><th>mean speed (m/s)</th>\
             <th>scans updated</th><th>target</th></tr>",
        );
        for r in &rows {
            let _ = write!(
                s,
                "<tr><td><span style=\"color:{}\">●</span> {}</td><td>{:.1}</td><td>{:.1}</td>\
                 <td>{:.1}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                track_color(r.id, r.target),
                r.id,
                r.first_s,
                r.last_s,
                r.duration_s,
                r.walked_m,
                r.mean_speed_mps
                    .map_or("–".to_owned(), |v| format!("{v:.2}")),
                r.scans_updated,
                if r.target { "yes" } else { "" }
            );
        }
        s.push_str("</table>");
        s
    }
}

#[cfg(test)]
mod tests;
