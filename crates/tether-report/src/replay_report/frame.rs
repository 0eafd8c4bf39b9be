//! A map's frame: world metres to pixels at one scale both ways, its axes and scale
//! bar, and the placing of labels.

use std::fmt::Write as _;

use tether_core::{Point2, World};
use tether_svg::xml_escape;

use crate::plot::{tick_step, trim};

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
    pub(super) fn at_least(self, m: f64) -> Bounds {
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
    pub(super) fn squared(self) -> Bounds {
        self.at_least((self.x1 - self.x0).max(self.y1 - self.y0))
    }

    pub(super) fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }
}

/// The longest "round" length (1, 2 or 5 times a power of ten) of at most `max_m`: a
/// scale bar's length, as the simulator's maps draw it.
pub use tether_svg::round_length_m as scale_bar_m;

pub(super) const AXIS_LEFT: f64 = 48.0;
pub(super) const AXIS_RIGHT: f64 = 14.0;
pub(super) const AXIS_BOTTOM: f64 = 38.0;

/// A map's drawing area: world metres to pixels at one scale both ways (y up), with
/// room for the axes.
#[derive(Debug, Clone, Copy)]
pub struct MapFrame {
    pub(super) b: Bounds,
    pub(super) k: f64,
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
    pub(super) fn area(&self) -> (f64, f64, f64, f64) {
        (AXIS_LEFT, self.top, self.w, self.h)
    }

    /// The opening `svg` tag, a white background and the clip path `clip_id` of the
    /// plot.
    pub(super) fn open(&self, class: &str, clip_id: &str) -> String {
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
pub(super) struct Labels {
    placed: Vec<(f64, f64, f64, f64)>,
}

impl Labels {
    /// Text at 11 px: about 6.3 px a character.
    pub(super) const CHAR_W: f64 = 6.3;
    const H: f64 = 11.0;

    /// Where to put the text's left end and baseline, beside pixel `(u, v)`.
    pub(super) fn place(
        &mut self,
        u: f64,
        v: f64,
        text: &str,
        area: (f64, f64, f64, f64),
    ) -> (f64, f64) {
        let w = Self::CHAR_W * text.chars().count() as f64;
        let h = Self::H;
        // The first eight of the map's spots, nearer.
        let spots = tether_svg::label_spots((u, v), (w, h), 7.0, 2.0);
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
