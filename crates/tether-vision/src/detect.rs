//! Multi-scale detection with a Haar cascade, window for window as OpenCV 4.x's
//! `CascadeClassifier::detectMultiScale` (module objdetect, `cascadedetect.cpp`) does it
//! on the CPU, so that tether and OpenCV report the same boxes (design 3.1).
//!
//! # What OpenCV does, and this module repeats
//!
//! **Scales.** `factor` starts at 1 and is multiplied by `scale_factor` (in `f64`); the
//! window at a factor is `round(W factor) x round(H factor)` for the cascade's `W x H`.
//! The loop stops at the first factor whose window exceeds `max_size` or the image, and
//! skips factors whose window is below `min_size`. Each kept factor is stored as `f32`.
//!
//! **Pyramid.** At scale `s` the image is resized (bilinear, bit-exact
//! `INTER_LINEAR_EXACT`, [`crate::resize`]) to
//! `round(width / s) x round(height / s)` (`f32` division, ties to even) and its integral
//! images are built ([`crate::integral`]). The cascade's own window slides over the
//! scaled image: the features are not scaled.
//!
//! **Windows.** The step is 2 px below scale 2 and 1 px from scale 2 on, in rows and
//! columns. Rows come in stripes: `n = ceil(w0 / 32)` stripes for the first scale's
//! working width `w0`, each `max((h / step + n - 1) / n, 1) * step` rows tall, and only
//! rows below `n` stripes are visited (the last row or two of a scale can be left out).
//! After a window rejected by stage 0 the next window in the row is skipped.
//!
//! **A window** (`HaarEvaluator::setWindow`): over the window minus a 1-px border (area
//! `A`), with pixel sum `S` and squared sum `Q` (32-bit), `nf = A Q - S^2` in `f64`;
//! the window is rejected when `nf <= 0` or when `A * (float)(1 / sqrt(nf)) >= 0.1`
//! (grey-level standard deviation 10 or less). Otherwise `norm = (float)(1 / sqrt(nf))`.
//!
//! **A feature** is `f32` arithmetic in OpenCV's order:
//! `v = w0 S0 + w1 S1`, then `v += w2 S2` when `w2 != 0`, then `v * norm`.
//!
//! **A stage** sums its weak classifiers' leaves in `f64` (`value < threshold` goes
//! left) and rejects the window when the sum is below its threshold.
//!
//! **A hit** at `(x, y)` of scale `s` is the box
//! `(round(x s), round(y s), round(W s), round(H s))` (`f32`, ties to even). The boxes
//! are grouped ([`crate::group`], `eps = 0.2`) and clipped to the image.
//!
//! # How it is fast with the same arithmetic
//!
//! See the private `StagePlan`, `Kind` and `Approx` for the stage evaluation, `Planes` for
//! the memory layout, and `LevelEval::scan_row_lanes` for the lane-parallel scan: eight
//! windows at once with AVX2 when the CPU has it (module `avx2`, chosen at run time; the
//! crate's only `unsafe` code), else two groups of four with SSE2. The plain
//! one-window-at-a-time evaluation is kept for tree cascades and very wide images, and a
//! literal transcription of the rules above is the reference of the property tests, which
//! check both lane paths.

use rayon::prelude::*;
use thiserror::Error;
use wide::{f32x4, f64x2, i32x4};

use tether_core::GrayImage;

use crate::cascade::Cascade;
use crate::group::{Rect, group_rectangles};
use crate::integral::{integral_sum_sqsum, integral_tilted};
use crate::resize::resize_linear_into;

/// `GROUP_EPS` of `detectMultiScale`.
pub const GROUP_EPS: f64 = 0.2;

/// A bound on the number of pyramid levels, reached only with a scale factor very close
/// to 1 on a huge image.
pub const MAX_SCALES: usize = 100_000;

/// Parameters of [`Detector::detect`], named and defaulted as `detectMultiScale`'s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectParams {
    /// Ratio between consecutive pyramid scales; must be > 1. Default 1.1.
    pub scale_factor: f64,
    /// Neighbours a group needs to be kept (`minNeighbors`); 0 returns the raw windows.
    /// Default 3.
    pub min_neighbors: u32,
    /// Smallest window, `[width, height]` px; `[0, 0]` means no limit. Default `[0, 0]`.
    pub min_size_px: [u32; 2],
    /// Largest window, `[width, height]` px; a zero side means the image size. Default
    /// `[0, 0]`.
    pub max_size_px: [u32; 2],
}

impl Default for DetectParams {
    fn default() -> Self {
        DetectParams {
            scale_factor: 1.1,
            min_neighbors: 3,
            min_size_px: [0, 0],
            max_size_px: [0, 0],
        }
    }
}

/// Why a detection cannot run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DetectError {
    /// `scale_factor` is not a number above 1.
    #[error("scale factor {0} is invalid: it must be a number above 1 (OpenCV's default is 1.1)")]
    BadScaleFactor(f64),
    /// The scale factor is so close to 1 that the pyramid would be enormous.
    #[error(
        "scale factor {0} gives more than {MAX_SCALES} pyramid levels for this image; use a larger \
         factor such as 1.05 or 1.1"
    )]
    TooManyScales(f64),
    /// The thread pool could not be created.
    #[error("cannot start {threads} detection threads: {why}")]
    Threads {
        /// Requested threads.
        threads: usize,
        /// The reason.
        why: String,
    },
}

/// What `detectMultiScale` does with the raw windows: `groupRectangles` with
/// `eps = 0.2` (nothing when `min_neighbors` is 0), then `clipObjects`: each box is
/// intersected with the image and empty ones are dropped.
pub fn group_and_clip(raw: &[Rect], min_neighbors: u32, width: usize, height: usize) -> Vec<Rect> {
    let frame = Rect {
        x: 0,
        y: 0,
        width: width as i32,
        height: height as i32,
    };
    group_rectangles(raw, min_neighbors, GROUP_EPS)
        .iter()
        .map(|r| r.intersect(&frame))
        .filter(|r| r.area() > 0)
        .collect()
}

/// One pyramid level, in OpenCV's terms (`FeatureEvaluator::ScaleData`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleLevel {
    /// The scale as OpenCV stores it (`f32`).
    pub scale: f32,
    /// Size of the resized image, px.
    pub width: usize,
    /// Size of the resized image, px.
    pub height: usize,
    /// Window step in the resized image, px (2 below scale 2, else 1).
    pub step: usize,
    /// Number of window columns `x` in `0..scan_width` (before stepping).
    pub scan_width: usize,
    /// Windows rows `y` in `0..scan_height` (stepped; the stripe rule already applied).
    pub scan_height: usize,
    /// Size of a hit's box in the original image, px.
    pub box_width: i32,
    /// Size of a hit's box in the original image, px.
    pub box_height: i32,
}

impl ScaleLevel {
    /// The box of a hit at `(x, y)` of this level, in original image pixels:
    /// `(round(x s), round(y s))` in `f32`, ties to even, and the level's box size.
    pub fn hit_box(&self, x: usize, y: usize) -> Rect {
        Rect {
            x: (x as f32 * self.scale).round_ties_even() as i32,
            y: (y as f32 * self.scale).round_ties_even() as i32,
            width: self.box_width,
            height: self.box_height,
        }
    }
}

/// The pyramid `detectMultiScale` would build for an image, first (finest) level first.
pub fn pyramid(
    image_width: usize,
    image_height: usize,
    window_width: u32,
    window_height: u32,
    params: &DetectParams,
) -> Result<Vec<ScaleLevel>, DetectError> {
    let sf = params.scale_factor;
    if !(sf.is_finite() && sf > 1.0) {
        return Err(DetectError::BadScaleFactor(sf));
    }
    let (img_w, img_h) = (image_width as i64, image_height as i64);
    let [min_w, min_h] = params.min_size_px.map(i64::from);
    let [mut max_w, mut max_h] = params.max_size_px.map(i64::from);
    if max_w == 0 || max_h == 0 {
        (max_w, max_h) = (img_w, img_h);
    }
    let (ww, wh) = (f64::from(window_width), f64::from(window_height));
    let mut scales = Vec::new();
    let mut factor = 1.0f64;
    for _ in 0..MAX_SCALES {
        let win_w = (ww * factor).round_ties_even() as i64;
        let win_h = (wh * factor).round_ties_even() as i64;
        if win_w > max_w || win_h > max_h || win_w > img_w || win_h > img_h {
            break;
        }
        if win_w >= min_w && win_h >= min_h {
            scales.push(factor as f32);
        }
        factor *= sf;
    }
    if scales.len() >= MAX_SCALES {
        return Err(DetectError::TooManyScales(sf));
    }
    let working = |sz: usize, win: u32| (sz + 1).saturating_sub(win as usize);
    let mut levels: Vec<ScaleLevel> = scales
        .iter()
        .map(|&scale| {
            let width = (image_width as f32 / scale).round_ties_even() as usize;
            let height = (image_height as f32 / scale).round_ties_even() as usize;
            ScaleLevel {
                scale,
                width,
                height,
                step: if scale >= 2.0 { 1 } else { 2 },
                scan_width: working(width, window_width),
                scan_height: working(height, window_height),
                box_width: (window_width as f32 * scale).round_ties_even() as i32,
                box_height: (window_height as f32 * scale).round_ties_even() as i32,
            }
        })
        .collect();
    // OpenCV's stripes: nstripes from the first level's working width.
    if let Some(first) = levels.first() {
        let nstripes = first.scan_width.div_ceil(32);
        for l in &mut levels {
            if nstripes == 0 {
                // OpenCV divides by zero here; nothing can be scanned.
                l.scan_height = 0;
                continue;
            }
            let stripe = (l.scan_height / l.step).div_ceil(nstripes).max(1) * l.step;
            l.scan_height = l.scan_height.min(nstripes * stripe);
        }
    }
    Ok(levels)
}

/// Length of the bounds-check-free window view: a window's reads are made through a
/// `&[i32; VIEW]` starting at the window, with offsets masked to `VIEW - 1`, so the
/// compiler needs no bounds check per read. Used whenever every feature offset of a level
/// is below `VIEW` (for a 24-row window: images up to ~5400 px wide with tilted features,
/// ~10900 px without); otherwise reads are bounds-checked. Each buffer is padded by this
/// much (1 MiB).
const VIEW: usize = 1 << 18;

/// Windows evaluated together by the lane-parallel scan: consecutive windows of a row,
/// whose corners are consecutive entries of the integral rows.
const LANES: usize = 4;

/// Extra entries after every buffer, so that a view of two lane groups can start at any
/// window.
const PAD: usize = VIEW + 2 * LANES;

/// A view of `LANES` consecutive windows, the first or second group of a block of
/// `2 LANES`: the masked offset plus the group shift plus the lane stays inside the array,
/// so no bounds check is needed.
#[derive(Clone, Copy)]
struct Wide<'a> {
    data: &'a [i32; PAD],
    shift: usize,
}

impl Wide<'_> {
    #[inline(always)]
    fn at(&self, offset: u32) -> i32x4 {
        let i = (offset as usize & (VIEW - 1)) + (self.shift & LANES);
        let mut lanes = [0; LANES];
        lanes.copy_from_slice(&self.data[i..i + LANES]);
        i32x4::new(lanes)
    }

    /// `CALC_SUM_OFS` for each lane (wrapping 32-bit arithmetic).
    #[inline(always)]
    fn box_sum(&self, o: &[u32; 4]) -> i32x4 {
        self.at(o[0]) - self.at(o[1]) - self.at(o[2]) + self.at(o[3])
    }
}

/// A window's view of an integral buffer.
trait View {
    fn at(&self, offset: u32) -> i32;
}

/// Reads through a fixed-size view: the mask proves the index in range.
struct Fixed<'a>(&'a [i32; VIEW]);

impl View for Fixed<'_> {
    #[inline(always)]
    fn at(&self, offset: u32) -> i32 {
        self.0[offset as usize & (VIEW - 1)]
    }
}

/// Reads with a bounds check.
struct Checked<'a>(&'a [i32]);

impl View for Checked<'_> {
    #[inline(always)]
    fn at(&self, offset: u32) -> i32 {
        self.0[offset as usize]
    }
}

/// `p0 - p1 - p2 + p3` with 32-bit wrap-around (`CALC_SUM_OFS`).
#[inline(always)]
fn box_sum<V: View>(v: &V, o: &[u32; 4]) -> i32 {
    v.at(o[0])
        .wrapping_sub(v.at(o[1]))
        .wrapping_sub(v.at(o[2]))
        .wrapping_add(v.at(o[3]))
}

/// A feature's corner offsets at one level and its weights.
#[derive(Debug, Clone, Copy)]
struct LevelFeature {
    ofs: [[u32; 4]; 3],
    weight: [f32; 3],
}

impl LevelFeature {
    /// `HaarEvaluator::OptFeature::calc(pwin) * varianceNormFactor`, in OpenCV's `f32`
    /// order.
    #[inline(always)]
    fn value<V: View>(&self, v: &V, norm: f32) -> f32 {
        let w = &self.weight;
        let mut r = w[0] * box_sum(v, &self.ofs[0]) as f32 + w[1] * box_sum(v, &self.ofs[1]) as f32;
        if w[2] != 0.0 {
            r += w[2] * box_sum(v, &self.ofs[2]) as f32;
        }
        r * norm
    }
}

impl LevelFeature {
    /// [`LevelFeature::value`] for `LANES` consecutive windows, each with its own
    /// normalisation factor; lane by lane the same `f32` operations in the same order.
    /// `RECTS` is 2 or 3 when the caller knows how many rectangles have a weight, 0 to
    /// test it as OpenCV does.
    #[inline(always)]
    fn values<const RECTS: u8>(&self, v: &Wide<'_>, norm: f32x4) -> f32x4 {
        let w = &self.weight;
        let s0 = v.box_sum(&self.ofs[0]).round_float();
        let s1 = v.box_sum(&self.ofs[1]).round_float();
        let mut r = f32x4::splat(w[0]) * s0 + f32x4::splat(w[1]) * s1;
        if RECTS == 3 || (RECTS == 0 && w[2] != 0.0) {
            r += f32x4::splat(w[2]) * v.box_sum(&self.ofs[2]).round_float();
        }
        r * norm
    }
}

/// A decision stump with its feature inlined, OpenCV's `Stump`.
#[derive(Debug, Clone, Copy)]
struct LevelStump {
    feature: LevelFeature,
    threshold: f32,
    left: f32,
    right: f32,
}

/// A tree node with its feature inlined.
#[derive(Debug, Clone, Copy)]
struct LevelNode {
    feature: LevelFeature,
    threshold: f32,
    left: i32,
    right: i32,
}

/// The outcome of one window (OpenCV's `runAt` result).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// Passed every stage.
    Hit,
    /// Rejected by the variance test.
    Flat,
    /// Rejected by this stage.
    Rejected(usize),
}

/// Corners of a feature rectangle in window coordinates `(column, row)`, in OpenCV's
/// read order `p0 - p1 - p2 + p3`.
fn rect_corners(r: &crate::cascade::WeightedRect, tilted: bool) -> [(i32, i32); 4] {
    let (x, y, w, h) = (r.x, r.y, r.w, r.h);
    if r.weight == 0.0 {
        // An unused rectangle: one corner read four times (sum 0, times weight 0).
        return [(0, 0); 4];
    }
    if tilted {
        [
            (x, y),
            (x - h, y + h),
            (x + w, y + w),
            (x + w - h, y + w + h),
        ]
    } else {
        [(x, y), (x + w, y), (x, y + h), (x + w, y + h)]
    }
}

/// Buffers reused from one level to the next (allocation and zeroing of multi-megabyte
/// buffers would otherwise cost as much as scanning the small levels).
#[derive(Default)]
struct Scratch {
    scaled: Vec<u8>,
    sum: Vec<i32>,
    sq: Vec<i32>,
    tilted: Vec<i32>,
    main: Vec<i32>,
    sq_layout: Vec<i32>,
}

thread_local! {
    /// The scratch space of each detection thread.
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// One scaled image's integral images in the layout the scan reads.
///
/// `main` holds, for each integral row, the row of sums followed (for cascades with
/// tilted features) by the row of tilted sums, so that one view covers both; `sq` holds
/// the squared sums. With a 2-px step every window starts on an even column, so the
/// columns of each row are stored de-interleaved (even columns, then odd ones): the
/// windows of a row then read consecutive entries for every corner. Both buffers are
/// padded by [`PAD`] entries so that a view can start at any window.
struct Planes {
    main: Vec<i32>,
    main_stride: usize,
    sq: Vec<i32>,
    row_len: usize,
    split: bool,
    half: usize,
}

impl Planes {
    /// Builds the planes of a `width x height` image into buffers taken from `scratch`
    /// (give them back with [`Planes::recycle`]).
    fn build(
        image: &[u8],
        width: usize,
        height: usize,
        split: bool,
        tilted: bool,
        scratch: &mut Scratch,
    ) -> Planes {
        let row_len = width + 1;
        let rows = height + 1;
        let plain = rows * row_len;
        // The integral functions write every entry: growing is enough.
        let resized = |v: &mut Vec<i32>, len: usize| v.resize(len, 0);
        resized(&mut scratch.sum, plain);
        resized(&mut scratch.sq, plain);
        integral_sum_sqsum(
            image,
            width,
            height,
            row_len,
            &mut scratch.sum,
            &mut scratch.sq,
        );
        if tilted {
            resized(&mut scratch.tilted, plain);
            integral_tilted(image, width, height, row_len, &mut scratch.tilted);
        }
        let half = row_len.div_ceil(2);
        let main_stride = if tilted { 2 * row_len } else { row_len };
        let mut main = std::mem::take(&mut scratch.main);
        let mut sq = std::mem::take(&mut scratch.sq_layout);
        // Every entry up to the padding is overwritten below; the padding is only read by
        // lanes past the end of a row, whose results are discarded.
        main.resize(rows * main_stride + PAD, 0);
        sq.resize(plain + PAD, 0);
        let place = |dst: &mut [i32], src: &[i32]| {
            if split {
                // Even columns to the first `half` entries, odd columns after them.
                let (even, odd) = dst.split_at_mut(half);
                for (d, v) in even.iter_mut().zip(src.iter().step_by(2)) {
                    *d = *v;
                }
                for (d, v) in odd.iter_mut().zip(src.iter().skip(1).step_by(2)) {
                    *d = *v;
                }
            } else {
                dst.copy_from_slice(src);
            }
        };
        for r in 0..rows {
            let src = r * row_len..(r + 1) * row_len;
            let m = &mut main[r * main_stride..r * main_stride + main_stride];
            place(&mut m[..row_len], &scratch.sum[src.clone()]);
            if tilted {
                place(&mut m[row_len..], &scratch.tilted[src.clone()]);
            }
            place(&mut sq[src.clone()], &scratch.sq[src]);
        }
        Planes {
            main,
            main_stride,
            sq,
            row_len,
            split,
            half,
        }
    }

    /// Returns the buffers to the scratch space for the next level.
    fn recycle(self, scratch: &mut Scratch) {
        scratch.main = self.main;
        scratch.sq_layout = self.sq;
    }

    fn column(&self, dx: usize) -> usize {
        if !self.split {
            dx
        } else if dx.is_multiple_of(2) {
            dx / 2
        } else {
            self.half + dx / 2
        }
    }

    /// Offset in `main` of window-relative corner `(dx, dy)` of the sums (or of the
    /// tilted sums).
    fn main_offset(&self, tilted: bool, dx: i32, dy: i32) -> u32 {
        let channel = if tilted { self.row_len } else { 0 };
        (dy as usize * self.main_stride + channel + self.column(dx as usize)) as u32
    }

    /// Views of the sum and squared-sum buffers that start at window `(x, y)`: the
    /// windows of a lane block read them with masked offsets and no bounds check.
    fn block_views(&self, x: usize, y: usize) -> Option<(&[i32; PAD], &[i32; PAD])> {
        let (bm, bs) = self.bases(x, y);
        let main = self.main.get(bm..bm + PAD)?.try_into().ok()?;
        let sq = self.sq.get(bs..bs + PAD)?.try_into().ok()?;
        Some((main, sq))
    }

    /// Offset in `sq` of window-relative corner `(dx, dy)`.
    fn sq_offset(&self, dx: i32, dy: i32) -> u32 {
        (dy as usize * self.row_len + self.column(dx as usize)) as u32
    }

    /// Bases of the window at `(x, y)` in `main` and `sq`.
    fn bases(&self, x: usize, y: usize) -> (usize, usize) {
        let col = if self.split { x / 2 } else { x };
        (y * self.main_stride + col, y * self.row_len + col)
    }
}

/// How the lanes' quick path computes a stump's feature; the stumps of an exact stage are
/// grouped by kind so that each group runs without per-stump tests.
///
/// The rectangle sums are integers and computed exactly in any association (wrapping
/// 32-bit arithmetic), so a two-rectangle feature whose rectangles share two corners (one
/// added, one subtracted, in both: a half or an edge of the other) reads them once:
/// `S0 = (sp - sm) + (p0 - m0)`, `S1 = (sp - sm) + (p1 - m1)`, six reads instead of
/// eight. When the first weight is -1 (the usual whole-window rectangle),
/// `w0 S0 + w1 S1` is computed as `w1 S1 - S0`: the same `f32` result, one
/// multiplication less.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Two,
    TwoNeg,
    Shared,
    SharedNeg,
    Three,
    ThreeNeg,
}

/// Number of [`Kind`]s.
const KINDS: usize = 6;

impl Kind {
    const ALL: [Kind; KINDS] = [
        Kind::Two,
        Kind::TwoNeg,
        Kind::Shared,
        Kind::SharedNeg,
        Kind::Three,
        Kind::ThreeNeg,
    ];

    /// The kind of a feature and the order in which the lane path reads its twelve
    /// corner slots (`rect * 4 + corner`).
    fn of(f: &crate::cascade::HaarFeature) -> (Kind, [u8; 12]) {
        let natural: [u8; 12] = std::array::from_fn(|i| i as u8);
        let neg = f.rects[0].weight == -1.0;
        let pick = |plain: Kind, negative: Kind| if neg { negative } else { plain };
        if f.rects[2].weight != 0.0 {
            return (pick(Kind::Three, Kind::ThreeNeg), natural);
        }
        if f.rects[1].weight == 0.0 || f.rects[0].weight == 0.0 {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        }
        let c0 = rect_corners(&f.rects[0], f.tilted);
        let c1 = rect_corners(&f.rects[1], f.tilted);
        // Corners 0 and 3 are added, 1 and 2 subtracted (`p0 - p1 - p2 + p3`).
        let plus = |i: usize| i == 0 || i == 3;
        let shared: Vec<(usize, usize)> = (0..4)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .filter(|&(i, j)| c0[i] == c1[j])
            .collect();
        let [(i1, j1), (i2, j2)] = shared.as_slice() else {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        };
        let (i1, j1, i2, j2) = (*i1, *j1, *i2, *j2);
        let proper = |r: &crate::cascade::WeightedRect| r.w > 0 && r.h > 0;
        if plus(i1) != plus(j1)
            || plus(i2) != plus(j2)
            || plus(i1) == plus(i2)
            || !proper(&f.rects[0])
            || !proper(&f.rects[1])
        {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        }
        let (sp, sm) = if plus(i1) { (i1, i2) } else { (i2, i1) };
        let (tp, tm) = if plus(j1) { (j1, j2) } else { (j2, j1) };
        let other = |a: usize, b: usize, want_plus: bool| {
            (0..4)
                .find(|&k| k != a && k != b && plus(k) == want_plus)
                .unwrap_or(0)
        };
        let layout = [
            sp,
            sm,
            other(sp, sm, true),
            other(sp, sm, false),
            4 + other(tp, tm, true),
            4 + other(tp, tm, false),
            0,
            0,
            0,
            0,
            0,
            0,
        ]
        .map(|v| v as u8);
        (pick(Kind::Shared, Kind::SharedNeg), layout)
    }
}

/// One stage as the scan evaluates it.
///
/// When the stage's leaf sums are **exact** in `f64` (every leaf is an `f32`, so every
/// partial sum is a multiple of the smallest leaf's unit in the last place; when the sum
/// of the largest leaves stays below 2^53 of those units, no addition rounds), the order
/// of the additions cannot change the sum, so the stumps can be evaluated in any order:
/// grouped by [`Kind`], two-rectangle features before three-rectangle ones. Stages that
/// are not exact keep OpenCV's order. Every Debian cascade is exact (at most 46 of the
/// 53 bits are needed).
#[derive(Debug, Clone, Copy)]
struct StagePlan {
    /// Threshold as OpenCV compares it (already lowered by 1e-5).
    threshold: f64,
    /// First stump in evaluation order.
    first: usize,
    /// Number of stumps.
    count: usize,
    /// In an exact stage, the number of stumps of each [`Kind`], which follow one another
    /// in that order; `None` when the stage keeps OpenCV's order.
    runs: Option<[usize; KINDS]>,
    /// In an exact stage, the quick `f32` evaluation (see [`Approx`]).
    approx: Option<Approx>,
}

/// A quick, certified evaluation of an exact stage for the lane scan.
///
/// The stage sum is `S = sum(right) + sum over stumps below threshold of (left - right)`.
/// The lanes compute it in `f32` from `start = f32(sum(right))` with
/// `diff = f32(left - right)`, one masked addition per stump (instead of a select,
/// two conversions to `f64` and two additions). Each rounding moves the result by at
/// most 2^-24 of a magnitude bounded by `|sum(right)| + sum |diff|`, so
/// `|approx - S| <= (n + 1) 2^-24 (|sum(right)| + sum |diff|)`; `margin` is twice that.
/// Outside `threshold +- margin` the verdict is certain and equal to OpenCV's (the
/// exact `f64` sum is `S`); inside it the stage is summed again exactly.
#[derive(Debug, Clone, Copy)]
struct Approx {
    start: f32,
    margin: f64,
}

impl Approx {
    fn for_stage(pairs: &[(f32, f32)]) -> Approx {
        let right: f64 = pairs.iter().map(|&(_, r)| f64::from(r)).sum();
        let spread: f64 = pairs
            .iter()
            .map(|&(l, r)| (f64::from(l) - f64::from(r)).abs())
            .sum();
        let n = pairs.len() as f64;
        Approx {
            start: right as f32,
            margin: 2.0 * (n + 1.0) * 2f64.powi(-24) * (right.abs() + spread),
        }
    }

    /// The verdict (`true`: passes) when `approx` is far enough from the threshold.
    fn verdict(&self, approx: f32, threshold: f64) -> Option<bool> {
        let a = f64::from(approx);
        if a < threshold - self.margin {
            Some(false)
        } else if a >= threshold + self.margin {
            Some(true)
        } else {
            None
        }
    }
}

/// OpenCV's stage test: a window is rejected when `sum < threshold`, so it passes
/// otherwise (a NaN sum, impossible with finite leaves, would pass too).
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "OpenCV's test is `sum < threshold`; its negation is the pass condition"
)]
fn passes(sum: f64, threshold: f64) -> bool {
    !(sum < threshold)
}

/// Whether every partial sum of these leaf pairs is exact in `f64`.
fn leaf_sums_are_exact(pairs: &[(f32, f32)]) -> bool {
    // Unit in the last place of an f32, as a power of two.
    let ulp_exp = |v: f32| -> i32 {
        let biased = ((v.to_bits() >> 23) & 0xff) as i32;
        if biased == 0 { -149 } else { biased - 127 - 23 }
    };
    let finest = pairs
        .iter()
        .flat_map(|&(l, r)| [l, r])
        .filter(|v| *v != 0.0)
        .map(ulp_exp)
        .min();
    let Some(finest) = finest else {
        return true;
    };
    let bound: f64 = pairs
        .iter()
        .map(|&(l, r)| f64::from(l.abs().max(r.abs())))
        .sum();
    bound.is_finite() && bound < 2f64.powi(finest + 52)
}

/// A cascade ready to scan images.
#[derive(Debug)]
pub struct Detector {
    cascade: Cascade,
    /// Weak classifiers in evaluation order (see [`StagePlan`]).
    order: Vec<usize>,
    plans: Vec<StagePlan>,
    /// Each feature's rectangle corners in window coordinates ([`rect_corners`]).
    corners: Vec<[[(i32, i32); 4]; 3]>,
    /// For each entry of `order`: the corner slots in the order the lanes read them.
    layouts: Vec<[u8; 12]>,
    /// Per-level tables of the buffer layouts met so far.
    level_cache: std::sync::Mutex<Vec<(LayoutKey, std::sync::Arc<LevelTables>)>>,
    threads: usize,
    pool: Option<rayon::ThreadPool>,
    /// Present when the lane scan uses AVX2 (eight windows at once).
    #[cfg(target_arch = "x86_64")]
    avx2: Option<avx2::Avx2>,
    /// The stages for the AVX2 scan (`None` when a stage is not exact).
    #[cfg(target_arch = "x86_64")]
    stages8: Option<Vec<avx2::Stage8>>,
}

impl Detector {
    /// A single-threaded detector for a cascade.
    pub fn new(cascade: Cascade) -> Detector {
        let stumps = cascade.is_stump_based();
        let leaves = |t: usize| {
            let first = cascade.trees()[t].first_leaf as usize;
            (cascade.leaves()[first], cascade.leaves()[first + 1])
        };
        let kinds: Vec<(Kind, [u8; 12])> = cascade
            .trees()
            .iter()
            .map(|t| {
                Kind::of(
                    &cascade.features()[cascade.nodes()[t.first_node as usize].feature as usize],
                )
            })
            .collect();
        let kind = |t: usize| kinds[t];
        let mut order = Vec::with_capacity(cascade.trees().len());
        let mut layouts = Vec::with_capacity(cascade.trees().len());
        let mut plans = Vec::with_capacity(cascade.stages().len());
        for stage in cascade.stages() {
            let first = stage.first_tree as usize;
            let mut trees: Vec<usize> = (first..first + stage.tree_count as usize).collect();
            let exact = stumps
                && leaf_sums_are_exact(&trees.iter().map(|&t| leaves(t)).collect::<Vec<_>>());
            let runs = exact.then(|| {
                trees.sort_by_key(|&t| (kind(t).0, t));
                Kind::ALL.map(|k| trees.iter().filter(|&&t| kind(t).0 == k).count())
            });
            layouts.extend(trees.iter().map(|&t| {
                if exact {
                    kind(t).1
                } else {
                    std::array::from_fn(|i| i as u8)
                }
            }));
            let approx = exact
                .then(|| Approx::for_stage(&trees.iter().map(|&t| leaves(t)).collect::<Vec<_>>()));
            plans.push(StagePlan {
                threshold: f64::from(stage.threshold),
                first: order.len(),
                count: trees.len(),
                runs,
                approx,
            });
            order.extend(trees);
        }
        let corners = cascade
            .features()
            .iter()
            .map(|f| f.rects.map(|r| rect_corners(&r, f.tilted)))
            .collect();
        #[cfg(target_arch = "x86_64")]
        let stages8 = if stumps {
            avx2::Stage8::for_plans(&plans)
        } else {
            None
        };
        Detector {
            cascade,
            order,
            #[cfg(target_arch = "x86_64")]
            stages8,
            plans,
            corners,
            layouts,
            level_cache: std::sync::Mutex::new(Vec::new()),
            threads: 1,
            pool: None,
            #[cfg(target_arch = "x86_64")]
            avx2: avx2::Avx2::detect(),
        }
    }

    /// Whether the scan may use AVX2 when the CPU has it (the default). The boxes are
    /// the same either way; `false` keeps the portable SSE2 path, for comparison.
    pub fn with_avx2(self, allowed: bool) -> Detector {
        Detector {
            #[cfg(target_arch = "x86_64")]
            avx2: if allowed { avx2::Avx2::detect() } else { None },
            ..self
        }
    }

    /// Whether the scan uses AVX2 (eight windows at once) on this CPU.
    pub fn uses_avx2(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.avx2.is_some();
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// Uses `threads` threads (scales are shared among them). Default 1; 0 means one per
    /// core. The result does not depend on the number of threads.
    pub fn with_threads(mut self, threads: usize) -> Result<Detector, DetectError> {
        if threads == 1 {
            self.threads = 1;
            self.pool = None;
            return Ok(self);
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| DetectError::Threads {
                threads,
                why: e.to_string(),
            })?;
        self.threads = pool.current_num_threads();
        self.pool = Some(pool);
        Ok(self)
    }

    /// The cascade.
    pub fn cascade(&self) -> &Cascade {
        &self.cascade
    }

    /// Threads used.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Detects objects: `detectMultiScale(image, scale_factor, min_neighbors, 0, min_size,
    /// max_size)` followed by its clipping to the image.
    pub fn detect(
        &self,
        image: &GrayImage,
        params: &DetectParams,
    ) -> Result<Vec<Rect>, DetectError> {
        let raw = self.detect_raw(image, params)?;
        Ok(group_and_clip(
            &raw,
            params.min_neighbors,
            image.width(),
            image.height(),
        ))
    }

    /// Every window that passes the cascade, before grouping and clipping, in OpenCV's scan
    /// order (scale by scale, row by row).
    pub fn detect_raw(
        &self,
        image: &GrayImage,
        params: &DetectParams,
    ) -> Result<Vec<Rect>, DetectError> {
        let levels = pyramid(
            image.width(),
            image.height(),
            self.cascade.window_width_px(),
            self.cascade.window_height_px(),
            params,
        )?;
        let hits: Vec<Vec<Rect>> = match &self.pool {
            Some(pool) => pool.install(|| {
                // One scratch space per worker thread, kept for the next levels and
                // images (allocating and zeroing megabytes per level would cost more
                // than scanning the small levels).
                levels
                    .par_iter()
                    .with_max_len(1)
                    .map(|level| {
                        SCRATCH.with_borrow_mut(|scratch| self.scan_level(image, level, scratch))
                    })
                    .collect()
            }),
            None => SCRATCH.with_borrow_mut(|scratch| {
                levels
                    .iter()
                    .map(|level| self.scan_level(image, level, scratch))
                    .collect()
            }),
        };
        Ok(hits.concat())
    }

    /// Resizes, integrates and scans one level.
    fn scan_level(
        &self,
        image: &GrayImage,
        level: &ScaleLevel,
        scratch: &mut Scratch,
    ) -> Vec<Rect> {
        let mut hits = Vec::new();
        if level.scan_width == 0 || level.scan_height == 0 {
            return hits;
        }
        let mut scaled = std::mem::take(&mut scratch.scaled);
        scaled.resize(level.width * level.height, 0);
        resize_linear_into(
            image.pixels(),
            image.width(),
            image.height(),
            &mut scaled,
            level.width,
            level.height,
        );
        let planes = Planes::build(
            &scaled,
            level.width,
            level.height,
            level.step == 2,
            self.cascade.has_tilted_features(),
            scratch,
        );
        scratch.scaled = scaled;
        self.scan_planes(&planes, level, &mut hits);
        planes.recycle(scratch);
        hits
    }

    /// Scans the windows of one level's planes.
    fn scan_planes(&self, planes: &Planes, level: &ScaleLevel, hits: &mut Vec<Rect>) {
        let eval = LevelEval::new(self, planes);
        let step = level.step;
        if eval.t.fits_view && !eval.t.stumps.is_empty() {
            for y in (0..level.scan_height).step_by(step) {
                eval.scan_row_lanes(planes, level, y, hits);
            }
            return;
        }
        for y in (0..level.scan_height).step_by(step) {
            let mut x = 0;
            while x < level.scan_width {
                let (bm, bs) = planes.bases(x, y);
                let outcome = eval.window(planes, bm, bs);
                if outcome == Outcome::Hit {
                    hits.push(level.hit_box(x, y));
                }
                if outcome == Outcome::Rejected(0) {
                    x += step;
                }
                x += step;
            }
        }
    }
}

/// Adds each stump's leaf (`value < threshold ? left : right`) to the lanes' `f64`
/// sums, in slice order.
#[inline(always)]
fn accumulate<const RECTS: u8>(
    stumps: &[LevelStump],
    main: &Wide<'_>,
    norm: f32x4,
    sum: &mut [f64x2; 2],
) {
    for s in stumps {
        let v = s.feature.values::<RECTS>(main, norm);
        let leaf = v
            .simd_lt(f32x4::splat(s.threshold))
            .bitselect(f32x4::splat(s.left), f32x4::splat(s.right))
            .to_array();
        sum[0] += f64x2::new([f64::from(leaf[0]), f64::from(leaf[1])]);
        sum[1] += f64x2::new([f64::from(leaf[2]), f64::from(leaf[3])]);
    }
}

/// A stump as the lanes' quick path reads it: corner offsets in [`Kind`] order, constants
/// already broadcast to every lane.
#[derive(Debug, Clone, Copy)]
struct LaneStump {
    ofs: [u32; 12],
    weight: [f32x4; 3],
    threshold: f32x4,
    /// `f32(left - right)`.
    diff: f32x4,
}

impl LaneStump {
    fn new(s: &LevelStump, layout: &[u8; 12]) -> LaneStump {
        let flat = s.feature.ofs.as_flattened();
        let w = &s.feature.weight;
        LaneStump {
            ofs: std::array::from_fn(|i| flat[usize::from(layout[i]) % 12]),
            weight: [f32x4::splat(w[0]), f32x4::splat(w[1]), f32x4::splat(w[2])],
            threshold: f32x4::splat(s.threshold),
            diff: f32x4::splat((f64::from(s.left) - f64::from(s.right)) as f32),
        }
    }

    /// The feature value for the lanes of one group, for a stump of kind `K` (the index of
    /// a [`Kind`]): OpenCV's `f32` value, bit for bit.
    #[inline(always)]
    fn value<const K: u8>(&self, m: &Wide<'_>, norm: f32x4) -> f32x4 {
        let o = &self.ofs;
        let shared = K == Kind::Shared as u8 || K == Kind::SharedNeg as u8;
        let neg =
            K == Kind::TwoNeg as u8 || K == Kind::SharedNeg as u8 || K == Kind::ThreeNeg as u8;
        let three = K == Kind::Three as u8 || K == Kind::ThreeNeg as u8;
        let (s0, s1) = if shared {
            let d = m.at(o[0]) - m.at(o[1]);
            (d + (m.at(o[2]) - m.at(o[3])), d + (m.at(o[4]) - m.at(o[5])))
        } else {
            (
                m.box_sum(&[o[0], o[1], o[2], o[3]]),
                m.box_sum(&[o[4], o[5], o[6], o[7]]),
            )
        };
        let (s0, s1) = (s0.round_float(), s1.round_float());
        let mut r = if neg {
            self.weight[1] * s1 - s0
        } else {
            self.weight[0] * s0 + self.weight[1] * s1
        };
        if three {
            r += self.weight[2] * m.box_sum(&[o[8], o[9], o[10], o[11]]).round_float();
        }
        r * norm
    }
}

/// The quick `f32` stage sum of [`Approx`] over stumps of kind `K`:
/// `sum += (value < threshold) & diff`.
#[inline(always)]
fn accumulate_approx<const K: u8>(
    stumps: &[LaneStump],
    main: &Wide<'_>,
    norm: f32x4,
    sum: &mut f32x4,
) {
    for s in stumps {
        *sum += s.value::<K>(main, norm).simd_lt(s.threshold) & s.diff;
    }
}

/// [`accumulate_approx`] for the two lane groups of a block at once: the stump's
/// offsets and constants are read once for both.
#[inline(always)]
fn accumulate_approx_pair<const K: u8>(
    stumps: &[LaneStump],
    main: [Wide<'_>; 2],
    norm: [f32x4; 2],
    sum: &mut [f32x4; 2],
) {
    for s in stumps {
        for g in 0..2 {
            sum[g] += s.value::<K>(&main[g], norm[g]).simd_lt(s.threshold) & s.diff;
        }
    }
}

/// Runs `f::<K>` over the consecutive runs of stumps of each kind.
macro_rules! for_each_kind {
    ($runs:expr, $stumps:expr, |$k:ident, $slice:ident| $body:expr) => {{
        let runs: [usize; KINDS] = $runs;
        let stumps = $stumps;
        let mut start = 0;
        macro_rules! run {
            ($kind:expr) => {{
                const $k: u8 = $kind as u8;
                let end = start + runs[$kind as usize];
                let $slice = &stumps[start..end];
                $body;
                start = end;
            }};
        }
        run!(Kind::Two);
        run!(Kind::TwoNeg);
        run!(Kind::Shared);
        run!(Kind::SharedNeg);
        run!(Kind::Three);
        run!(Kind::ThreeNeg);
        let _ = start;
    }};
}

#[cfg(target_arch = "x86_64")]
mod avx2;

/// The cascade laid out for one level: features inlined into stumps or nodes, offsets
/// for this level's buffers.
struct LevelEval<'d> {
    detector: &'d Detector,
    t: std::sync::Arc<LevelTables>,
}

/// The per-level tables of [`LevelEval`]; they depend only on the layout of the level's
/// buffers, so the detector keeps them for the next image of the same size.
#[derive(Debug)]
struct LevelTables {
    /// Stumps in the detector's evaluation order (stump cascades only).
    stumps: Vec<LevelStump>,
    /// The same stumps for the lanes' quick path.
    lane: LaneStumps,
    /// Tree nodes in the cascade's order (tree cascades only).
    nodes: Vec<LevelNode>,
    norm_main: [u32; 4],
    norm_sq: [u32; 4],
    area: f64,
    fits_view: bool,
}

/// A level's stumps for the lane scans; checked for the AVX2 scan's loads when all
/// their offsets fit its view.
#[derive(Debug)]
enum LaneStumps {
    Plain(Vec<LaneStump>),
    #[cfg(target_arch = "x86_64")]
    Checked(avx2::Table),
}

impl LaneStumps {
    fn stumps(&self) -> &[LaneStump] {
        match self {
            LaneStumps::Plain(s) => s,
            #[cfg(target_arch = "x86_64")]
            LaneStumps::Checked(t) => t.stumps(),
        }
    }

    /// The checked table, if the stumps are checked.
    #[cfg(target_arch = "x86_64")]
    fn table8(&self) -> Option<&avx2::Table> {
        match self {
            LaneStumps::Checked(t) => Some(t),
            LaneStumps::Plain(_) => None,
        }
    }
}

/// What identifies a level's buffer layout: (main stride, row length, de-interleaved).
type LayoutKey = (usize, usize, bool);

/// The most layouts the detector remembers (35 levels of a 640x480 image, three image
/// sizes).
const MAX_CACHED_LAYOUTS: usize = 128;

impl<'d> LevelEval<'d> {
    fn new(detector: &'d Detector, planes: &Planes) -> LevelEval<'d> {
        let key: LayoutKey = (planes.main_stride, planes.row_len, planes.split);
        let cached = detector.level_cache.lock().ok().and_then(|cache| {
            cache
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, t)| t.clone())
        });
        let t = cached.unwrap_or_else(|| {
            let t = std::sync::Arc::new(LevelTables::new(detector, planes));
            if let Ok(mut cache) = detector.level_cache.lock() {
                if cache.len() >= MAX_CACHED_LAYOUTS {
                    cache.clear();
                }
                cache.push((key, t.clone()));
            }
            t
        });
        LevelEval { detector, t }
    }
}

impl LevelTables {
    fn new(detector: &Detector, planes: &Planes) -> LevelTables {
        let cascade = &detector.cascade;
        let features: Vec<LevelFeature> = detector
            .corners
            .iter()
            .zip(cascade.features())
            .map(|(corners, f)| LevelFeature {
                ofs: corners.map(|rect| rect.map(|(dx, dy)| planes.main_offset(f.tilted, dx, dy))),
                weight: f.rects.map(|r| r.weight),
            })
            .collect();
        let level_node = |n: &crate::cascade::TreeNode| LevelNode {
            feature: features[n.feature as usize],
            threshold: n.threshold,
            left: n.left,
            right: n.right,
        };
        let (stumps, nodes) = if cascade.is_stump_based() {
            // OpenCV's stump fast path: leaf 0 when below the threshold, else leaf 1.
            let stumps = detector
                .order
                .iter()
                .map(|&t| {
                    let tree = &cascade.trees()[t];
                    let n = level_node(&cascade.nodes()[tree.first_node as usize]);
                    let leaf = tree.first_leaf as usize;
                    LevelStump {
                        feature: n.feature,
                        threshold: n.threshold,
                        left: cascade.leaves()[leaf],
                        right: cascade.leaves()[leaf + 1],
                    }
                })
                .collect();
            (stumps, Vec::new())
        } else {
            (Vec::new(), cascade.nodes().iter().map(level_node).collect())
        };
        let (ww, wh) = (
            cascade.window_width_px() as i32,
            cascade.window_height_px() as i32,
        );
        let corners = [(1, 1), (ww - 1, 1), (1, wh - 1), (ww - 1, wh - 1)];
        let norm_main = corners.map(|(x, y)| planes.main_offset(false, x, y));
        let norm_sq = corners.map(|(x, y)| planes.sq_offset(x, y));
        let max_offset = features
            .iter()
            .flat_map(|f| f.ofs.iter().flatten())
            .chain(norm_main.iter())
            .chain(norm_sq.iter())
            .copied()
            .max()
            .unwrap_or(0);
        let lane_stumps: Vec<LaneStump> = stumps
            .iter()
            .zip(&detector.layouts)
            .map(|(s, l)| LaneStump::new(s, l))
            .collect();
        let area = f64::from((ww - 2) * (wh - 2));
        #[cfg(target_arch = "x86_64")]
        let lane = if stumps.is_empty() {
            LaneStumps::Plain(lane_stumps)
        } else {
            avx2::Table::new(lane_stumps, norm_main, norm_sq, area)
                .map_or_else(LaneStumps::Plain, LaneStumps::Checked)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let lane = LaneStumps::Plain(lane_stumps);
        LevelTables {
            lane,
            stumps,
            nodes,
            norm_main,
            norm_sq,
            area,
            fits_view: (max_offset as usize) < VIEW,
        }
    }
}

impl LevelEval<'_> {
    /// Scans row `y` of a level `LANES` windows at a time (stump cascades whose offsets
    /// fit a view). Every window gets exactly the arithmetic of [`LevelEval::run`]; the
    /// lanes only share instructions. OpenCV's rule that a window rejected by stage 0
    /// skips the next one is resolved lane by lane after stage 0, which is computed for
    /// every lane (a skipped lane's result is discarded).
    fn scan_row_lanes(&self, planes: &Planes, level: &ScaleLevel, y: usize, hits: &mut Vec<Rect>) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(token), Some(stages), Some(table)) = (
            self.detector.avx2,
            self.detector.stages8.as_deref(),
            self.t.lane.table8(),
        ) {
            self.scan_row_8(token, stages, table, planes, level, y, hits);
            return;
        }
        const BLOCK: usize = 2 * LANES;
        let step = level.step;
        let mut skip_next = false;
        let mut x0 = 0;
        while x0 < level.scan_width {
            let Some((main, sq)) = planes.block_views(x0, y) else {
                // Unreachable: the buffers are padded by PAD.
                x0 += BLOCK * step;
                continue;
            };
            let main = [
                Wide {
                    data: main,
                    shift: 0,
                },
                Wide {
                    data: main,
                    shift: LANES,
                },
            ];
            let sq = [
                Wide { data: sq, shift: 0 },
                Wide {
                    data: sq,
                    shift: LANES,
                },
            ];
            let lanes_here = (level.scan_width - x0).div_ceil(step).min(BLOCK);
            let (norm0, ok0) = self.norm_lanes(&main[0], &sq[0]);
            let (norm1, ok1) = self.norm_lanes(&main[1], &sq[1]);
            let norm = [norm0, norm1];
            let mut alive: [bool; BLOCK] = std::array::from_fn(|l| {
                l < lanes_here && if l < LANES { ok0[l] } else { ok1[l - LANES] }
            });
            if !alive.iter().any(|&a| a) {
                // Every window is too flat: none is evaluated, none skips the next.
                if skip_next && lanes_here > 0 {
                    skip_next = false;
                }
                x0 += BLOCK * step;
                continue;
            }
            let pass = self.block_pass(0, main, norm, alive);
            // Resolve which lanes OpenCV evaluates, and their stage-0 verdicts.
            for l in 0..BLOCK {
                if l >= lanes_here {
                    alive[l] = false;
                } else if skip_next {
                    alive[l] = false;
                    skip_next = false;
                } else if alive[l] && !pass[l] {
                    alive[l] = false;
                    skip_next = true;
                }
            }
            let mut si = 1;
            while si < self.detector.plans.len() && alive.iter().any(|&a| a) {
                let pass = self.block_pass(si, main, norm, alive);
                for l in 0..BLOCK {
                    alive[l] &= pass[l];
                }
                si += 1;
            }
            for (l, &hit) in alive.iter().enumerate() {
                if hit {
                    hits.push(level.hit_box(x0 + l * step, y));
                }
            }
            x0 += BLOCK * step;
        }
    }

    /// [`LevelEval::scan_row_lanes`] with AVX2: eight windows per block
    /// ([`avx2::Avx2::block`]); a lane the quick sum cannot decide is decided by
    /// [`LevelEval::stage_pass_exact`].
    #[cfg(target_arch = "x86_64")]
    #[expect(clippy::too_many_arguments, reason = "the row and the AVX2 tables")]
    fn scan_row_8(
        &self,
        token: avx2::Avx2,
        stages: &[avx2::Stage8],
        table: &avx2::Table,
        planes: &Planes,
        level: &ScaleLevel,
        y: usize,
        hits: &mut Vec<Rect>,
    ) {
        const BLOCK: usize = avx2::LANES8;
        let step = level.step;
        let mut skip_next = false;
        let mut x0 = 0;
        while x0 < level.scan_width {
            let Some((main, sq)) = planes.block_views(x0, y) else {
                // Unreachable: the buffers are padded by PAD.
                x0 += BLOCK * step;
                continue;
            };
            let lanes = (level.scan_width - x0).div_ceil(step).min(BLOCK);
            let exact = |si: usize, norms: &avx2::Norms| -> u8 {
                let plan = &self.detector.plans[si];
                let mut bits = 0u8;
                for g in 0..BLOCK / LANES {
                    let view = Wide {
                        data: main,
                        shift: g * LANES,
                    };
                    let norm = f32x4::new(std::array::from_fn(|l| norms[g * LANES + l]));
                    let pass = self.stage_pass_exact(plan, &view, norm);
                    for (l, &p) in pass.iter().enumerate() {
                        bits |= u8::from(p) << (g * LANES + l);
                    }
                }
                bits
            };
            let mut hit = token.block(table, stages, main, sq, lanes, &mut skip_next, exact);
            while hit != 0 {
                let l = hit.trailing_zeros() as usize;
                hits.push(level.hit_box(x0 + l * step, y));
                hit &= hit - 1;
            }
            x0 += BLOCK * step;
        }
    }

    /// Stage `si` for the lanes of a block that `matter`: both groups together while both
    /// have such lanes, else only the group that does.
    #[inline(always)]
    fn block_pass(
        &self,
        si: usize,
        main: [Wide<'_>; 2],
        norm: [f32x4; 2],
        matter: [bool; 2 * LANES],
    ) -> [bool; 2 * LANES] {
        let first: [bool; LANES] = std::array::from_fn(|l| matter[l]);
        let second: [bool; LANES] = std::array::from_fn(|l| matter[LANES + l]);
        let (a, b) = (first.iter().any(|&m| m), second.iter().any(|&m| m));
        let (pa, pb) = match (a, b) {
            (true, true) => self.stage_pass_pair(si, main, norm, first, second),
            (true, false) => (
                self.stage_pass(si, &main[0], norm[0], first),
                [false; LANES],
            ),
            (false, true) => (
                [false; LANES],
                self.stage_pass(si, &main[1], norm[1], second),
            ),
            (false, false) => ([false; LANES], [false; LANES]),
        };
        std::array::from_fn(|l| if l < LANES { pa[l] } else { pb[l - LANES] })
    }

    /// [`LevelEval::stage_pass`] for both groups of a block.
    #[inline(always)]
    fn stage_pass_pair(
        &self,
        si: usize,
        main: [Wide<'_>; 2],
        norm: [f32x4; 2],
        first: [bool; LANES],
        second: [bool; LANES],
    ) -> ([bool; LANES], [bool; LANES]) {
        let plan = &self.detector.plans[si];
        if let (Some(approx), Some(runs)) = (plan.approx, plan.runs) {
            let stumps = &self.t.lane.stumps()[plan.first..plan.first + plan.count];
            let mut sum = [f32x4::splat(approx.start); 2];
            for_each_kind!(runs, stumps, |K, run| accumulate_approx_pair::<K>(
                run, main, norm, &mut sum
            ));
            let decide = |sum: f32x4, matter: [bool; LANES]| -> Option<[bool; LANES]> {
                let sums = sum.to_array();
                let mut verdict = [false; LANES];
                for l in 0..LANES {
                    match approx.verdict(sums[l], plan.threshold) {
                        Some(v) => verdict[l] = v,
                        None if matter[l] => return None,
                        None => {}
                    }
                }
                Some(verdict)
            };
            let pa = decide(sum[0], first)
                .unwrap_or_else(|| self.stage_pass_exact(plan, &main[0], norm[0]));
            let pb = decide(sum[1], second)
                .unwrap_or_else(|| self.stage_pass_exact(plan, &main[1], norm[1]));
            return (pa, pb);
        }
        (
            self.stage_pass_exact(plan, &main[0], norm[0]),
            self.stage_pass_exact(plan, &main[1], norm[1]),
        )
    }

    /// The normalisation factor of each lane and whether it passes the variance test
    /// ([`LevelEval::norm_factor`] lane by lane).
    #[inline(always)]
    fn norm_lanes(&self, main: &Wide<'_>, sq: &Wide<'_>) -> (f32x4, [bool; LANES]) {
        let sum = main.box_sum(&self.t.norm_main).to_array();
        let sqsum = sq.box_sum(&self.t.norm_sq).to_array();
        let mut norm = [1.0f32; LANES];
        let mut ok = [false; LANES];
        for l in 0..LANES {
            let s = f64::from(sum[l]);
            let nf = self.t.area * f64::from(sqsum[l] as u32) - s * s;
            if nf > 0.0 {
                norm[l] = (1.0 / nf.sqrt()) as f32;
                ok[l] = self.t.area * f64::from(norm[l]) < 0.1;
            }
        }
        (f32x4::new(norm), ok)
    }

    /// Whether each lane passes stage `si`: the leaf sum, accumulated in `f64` stump by
    /// stump, is not below the threshold (`predictOrderedStump`). Exact stages are first
    /// decided by the quick certified sum ([`Approx`]); only when a lane that `matters`
    /// lies within the margin is the stage summed exactly.
    #[inline(always)]
    fn stage_pass(
        &self,
        si: usize,
        main: &Wide<'_>,
        norm: f32x4,
        matter: [bool; LANES],
    ) -> [bool; LANES] {
        let plan = &self.detector.plans[si];
        if let (Some(approx), Some(runs)) = (plan.approx, plan.runs) {
            let stumps = &self.t.lane.stumps()[plan.first..plan.first + plan.count];
            let mut sum = f32x4::splat(approx.start);
            for_each_kind!(runs, stumps, |K, run| accumulate_approx::<K>(
                run, main, norm, &mut sum
            ));
            let sums = sum.to_array();
            let mut verdict = [false; LANES];
            let mut certain = true;
            for l in 0..LANES {
                match approx.verdict(sums[l], plan.threshold) {
                    Some(v) => verdict[l] = v,
                    None => certain &= !matter[l],
                }
            }
            if certain {
                return verdict;
            }
        }
        self.stage_pass_exact(plan, main, norm)
    }

    /// [`LevelEval::stage_pass`] by OpenCV's own `f64` sum.
    #[inline(never)]
    fn stage_pass_exact(&self, plan: &StagePlan, main: &Wide<'_>, norm: f32x4) -> [bool; LANES] {
        let stumps = &self.t.stumps[plan.first..plan.first + plan.count];
        let mut sum = [f64x2::ZERO; 2];
        match plan.runs.map(|r| r[..4].iter().sum::<usize>()) {
            Some(two) => {
                accumulate::<2>(&stumps[..two], main, norm, &mut sum);
                accumulate::<3>(&stumps[two..], main, norm, &mut sum);
            }
            None => accumulate::<0>(stumps, main, norm, &mut sum),
        }
        let (lo, hi) = (sum[0].to_array(), sum[1].to_array());
        [lo[0], lo[1], hi[0], hi[1]].map(|total| passes(total, plan.threshold))
    }

    /// `runAt` for the window whose bases in `main` and `sq` are given.
    #[inline]
    fn window(&self, planes: &Planes, base_main: usize, base_sq: usize) -> Outcome {
        if self.t.fits_view {
            let main = <&[i32; VIEW]>::try_from(&planes.main[base_main..base_main + VIEW]);
            let sq = <&[i32; VIEW]>::try_from(&planes.sq[base_sq..base_sq + VIEW]);
            if let (Ok(main), Ok(sq)) = (main, sq) {
                return self.run(&Fixed(main), &Fixed(sq));
            }
        }
        self.run(
            &Checked(&planes.main[base_main..]),
            &Checked(&planes.sq[base_sq..]),
        )
    }

    /// `HaarEvaluator::setWindow`: the variance normalisation factor, or `None` when the
    /// window is too flat to evaluate.
    #[inline(always)]
    fn norm_factor<V: View>(&self, main: &V, sq: &V) -> Option<f32> {
        let sum = box_sum(main, &self.t.norm_main);
        let sqsum = box_sum(sq, &self.t.norm_sq) as u32;
        let nf = self.t.area * f64::from(sqsum) - f64::from(sum) * f64::from(sum);
        if nf > 0.0 {
            let norm = (1.0 / nf.sqrt()) as f32;
            (self.t.area * f64::from(norm) < 0.1).then_some(norm)
        } else {
            None
        }
    }

    /// The variance test, then the stages (`predictOrderedStump` or `predictOrdered`).
    #[inline(always)]
    fn run<V: View>(&self, main: &V, sq: &V) -> Outcome {
        let Some(norm) = self.norm_factor(main, sq) else {
            return Outcome::Flat;
        };
        let cascade = &self.detector.cascade;
        if !self.t.stumps.is_empty() {
            for (si, plan) in self.detector.plans.iter().enumerate() {
                let mut sum = 0.0f64;
                for s in &self.t.stumps[plan.first..plan.first + plan.count] {
                    let v = s.feature.value(main, norm);
                    sum += f64::from(if v < s.threshold { s.left } else { s.right });
                }
                if sum < plan.threshold {
                    return Outcome::Rejected(si);
                }
            }
        } else {
            let (trees, leaves) = (cascade.trees(), cascade.leaves());
            for (si, stage) in cascade.stages().iter().enumerate() {
                let first = stage.first_tree as usize;
                let mut sum = 0.0f64;
                for t in &trees[first..first + stage.tree_count as usize] {
                    let mut idx = 0i32;
                    loop {
                        let node = &self.t.nodes[t.first_node as usize + idx as usize];
                        let v = node.feature.value(main, norm);
                        idx = if v < node.threshold {
                            node.left
                        } else {
                            node.right
                        };
                        if idx <= 0 {
                            break;
                        }
                    }
                    sum += f64::from(leaves[t.first_leaf as usize + (-idx) as usize]);
                }
                if sum < f64::from(stage.threshold) {
                    return Outcome::Rejected(si);
                }
            }
        }
        Outcome::Hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::resize::resize_linear;
    use proptest::prelude::*;

    /// OpenCV's algorithm written the plain way, straight from the cascade model: plain
    /// integral images, every rectangle summed from its four corners, every stage summed
    /// in `f64` in the file's order, one window at a time. The slow, obvious reference
    /// for the lane scan, the de-interleaved layout, the stage plans and the views.
    fn reference_raw(cascade: &Cascade, image: &GrayImage, params: &DetectParams) -> Vec<Rect> {
        let (ww, wh) = (
            cascade.window_width_px() as usize,
            cascade.window_height_px() as usize,
        );
        let mut hits = Vec::new();
        for level in pyramid(image.width(), image.height(), ww as u32, wh as u32, params).unwrap() {
            let (w, h) = (level.width, level.height);
            let img = resize_linear(image.pixels(), image.width(), image.height(), w, h);
            let s = w + 1;
            let (mut sum, mut sq, mut tilt) = (
                vec![0; (h + 1) * s],
                vec![0; (h + 1) * s],
                vec![0; (h + 1) * s],
            );
            integral_sum_sqsum(&img, w, h, s, &mut sum, &mut sq);
            integral_tilted(&img, w, h, s, &mut tilt);
            let at = |a: &[i32], x: i32, y: i32| a[y as usize * s + x as usize];
            let rect =
                |x0: usize, y0: usize, r: &crate::cascade::WeightedRect, tilted: bool| -> i32 {
                    let (x, y) = ((x0 as i32) + r.x, (y0 as i32) + r.y);
                    if r.weight == 0.0 {
                        0
                    } else if tilted {
                        at(&tilt, x, y) - at(&tilt, x - r.h, y + r.h) - at(&tilt, x + r.w, y + r.w)
                            + at(&tilt, x + r.w - r.h, y + r.w + r.h)
                    } else {
                        at(&sum, x, y) - at(&sum, x + r.w, y) - at(&sum, x, y + r.h)
                            + at(&sum, x + r.w, y + r.h)
                    }
                };
            let outcome = |x: usize, y: usize| -> Outcome {
                let (x1, y1, x2, y2) = (
                    x as i32 + 1,
                    y as i32 + 1,
                    (x + ww) as i32 - 1,
                    (y + wh) as i32 - 1,
                );
                let vs = at(&sum, x1, y1) - at(&sum, x2, y1) - at(&sum, x1, y2) + at(&sum, x2, y2);
                let vq = at(&sq, x1, y1)
                    .wrapping_sub(at(&sq, x2, y1))
                    .wrapping_sub(at(&sq, x1, y2))
                    .wrapping_add(at(&sq, x2, y2)) as u32;
                let area = ((ww - 2) * (wh - 2)) as f64;
                let nf = area * f64::from(vq) - f64::from(vs) * f64::from(vs);
                if nf <= 0.0 {
                    return Outcome::Flat;
                }
                let norm = (1.0 / nf.sqrt()) as f32;
                if area * f64::from(norm) >= 0.1 {
                    return Outcome::Flat;
                }
                let value = |fi: u32| -> f32 {
                    let f = &cascade.features()[fi as usize];
                    let mut v = f.rects[0].weight * rect(x, y, &f.rects[0], f.tilted) as f32
                        + f.rects[1].weight * rect(x, y, &f.rects[1], f.tilted) as f32;
                    if f.rects[2].weight != 0.0 {
                        v += f.rects[2].weight * rect(x, y, &f.rects[2], f.tilted) as f32;
                    }
                    v * norm
                };
                for (si, stage) in cascade.stages().iter().enumerate() {
                    let mut total = 0.0f64;
                    for t in &cascade.trees()
                        [stage.first_tree as usize..(stage.first_tree + stage.tree_count) as usize]
                    {
                        let leaves = &cascade.leaves()[t.first_leaf as usize..];
                        if cascade.is_stump_based() {
                            let n = &cascade.nodes()[t.first_node as usize];
                            total += f64::from(if value(n.feature) < n.threshold {
                                leaves[0]
                            } else {
                                leaves[1]
                            });
                        } else {
                            let mut idx = 0i32;
                            loop {
                                let n = &cascade.nodes()[(t.first_node as i32 + idx) as usize];
                                idx = if value(n.feature) < n.threshold {
                                    n.left
                                } else {
                                    n.right
                                };
                                if idx <= 0 {
                                    break;
                                }
                            }
                            total += f64::from(leaves[(-idx) as usize]);
                        }
                    }
                    if total < f64::from(stage.threshold) {
                        return Outcome::Rejected(si);
                    }
                }
                Outcome::Hit
            };
            for y in (0..level.scan_height).step_by(level.step) {
                let mut x = 0;
                while x < level.scan_width {
                    let o = outcome(x, y);
                    if o == Outcome::Hit {
                        hits.push(level.hit_box(x, y));
                    }
                    if o == Outcome::Rejected(0) {
                        x += level.step;
                    }
                    x += level.step;
                }
            }
        }
        hits
    }

    /// A random cascade: `stages` stages of stumps (or two-node trees) over a `w x h`
    /// window, upright and tilted, two- and three-rectangle features. `leaf_scale` spreads
    /// the leaf magnitudes (a large spread makes the stage sums inexact in `f64`).
    fn random_cascade(
        seed: u64,
        w: i32,
        h: i32,
        stages: usize,
        trees: bool,
        leaf_scale: f64,
    ) -> Cascade {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut uniform =
            move |lo: f64, hi: f64| lo + (hi - lo) * ((next() >> 11) as f64 / (1u64 << 53) as f64);
        let mut features = String::new();
        let mut stage_xml = String::new();
        let mut nfeat = 0;
        for si in 0..stages {
            let nweak = 2 + si * 3;
            let mut weaks = String::new();
            for _ in 0..nweak {
                let nodes = if trees { 2 } else { 1 };
                let mut internal = String::new();
                for k in 0..nodes {
                    let tilted = uniform(0.0, 1.0) < 0.3;
                    let three = uniform(0.0, 1.0) < 0.3;
                    let rect = |uniform: &mut dyn FnMut(f64, f64) -> f64| -> (i32, i32, i32, i32) {
                        if tilted {
                            let rw = uniform(1.0, 3.0) as i32;
                            let rh = uniform(1.0, 3.0) as i32;
                            let x = uniform(f64::from(rh), f64::from(w - rw) + 0.99) as i32;
                            let y = uniform(0.0, f64::from(h - rw - rh) + 0.99) as i32;
                            (x, y, rw, rh)
                        } else {
                            let rw = uniform(1.0, f64::from(w) - 1.0) as i32;
                            let rh = uniform(1.0, f64::from(h) - 1.0) as i32;
                            let x = uniform(0.0, f64::from(w - rw) + 0.99) as i32;
                            let y = uniform(0.0, f64::from(h - rh) + 0.99) as i32;
                            (x, y, rw, rh)
                        }
                    };
                    let mut rects = String::new();
                    for (i, weight) in
                        [-1.0, 2.0, 3.0]
                            .iter()
                            .enumerate()
                            .take(if three { 3 } else { 2 })
                    {
                        let (x, y, rw, rh) = rect(&mut uniform);
                        let _ = i;
                        rects.push_str(&format!("<_>{x} {y} {rw} {rh} {weight}</_>"));
                    }
                    features.push_str(&format!(
                        "<_><rects>{rects}</rects><tilted>{}</tilted></_>",
                        u8::from(tilted)
                    ));
                    let (left, right) = if trees && k == 0 {
                        (1, 0)
                    } else if trees {
                        (-1, -2)
                    } else {
                        (0, -1)
                    };
                    internal.push_str(&format!("{left} {right} {nfeat} {} ", uniform(-0.15, 0.15)));
                    nfeat += 1;
                }
                let leaves: Vec<String> = (0..=nodes)
                    .map(|_| {
                        let mag = if uniform(0.0, 1.0) < 0.5 {
                            leaf_scale
                        } else {
                            1.0
                        };
                        format!("{:e}", uniform(-1.0, 1.0) * mag)
                    })
                    .collect();
                weaks.push_str(&format!(
                    "<_><internalNodes>{internal}</internalNodes><leafValues>{}</leafValues></_>",
                    leaves.join(" ")
                ));
            }
            stage_xml.push_str(&format!(
                "<_><stageThreshold>{}</stageThreshold><weakClassifiers>{weaks}</weakClassifiers></_>",
                -0.2 * nweak as f64
            ));
        }
        let xml = format!(
            "<opencv_storage><cascade type_id=\"opencv-cascade-classifier\"><stageType>BOOST</stageType>\
             <featureType>HAAR</featureType><height>{h}</height><width>{w}</width>\
             <featureParams><maxCatCount>0</maxCatCount></featureParams><stages>{stage_xml}</stages>\
             <features>{features}</features></cascade></opencv_storage>"
        );
        Cascade::from_xml(&xml).unwrap()
    }

    /// A textured image: blobs and ramps, so that windows pass the variance test and
    /// features vary.
    fn random_image(seed: u64, w: usize, h: usize) -> GrayImage {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f64 / (1u64 << 24) as f64
        };
        let blobs: Vec<(f64, f64, f64, f64)> = (0..12)
            .map(|_| {
                (
                    next() * w as f64,
                    next() * h as f64,
                    3.0 + next() * 20.0,
                    next() * 200.0 - 100.0,
                )
            })
            .collect();
        let noise_amp = next() * 30.0;
        let px = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let mut v = 128.0 + 40.0 * (x * 0.11).sin() * (y * 0.07).cos();
                for &(bx, by, r, a) in &blobs {
                    v += a * (-((x - bx).powi(2) + (y - by).powi(2)) / (r * r)).exp();
                }
                (v + noise_amp * (next() - 0.5)).clamp(0.0, 255.0) as u8
            })
            .collect();
        GrayImage::from_raw(w, h, px).unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// The optimised scan finds exactly the windows of the plain reference, for stump
        /// and tree cascades, exact and inexact stage sums, both window steps.
        #[test]
        fn scan_matches_the_plain_reference(seed in any::<u64>(), trees in any::<bool>(), inexact in any::<bool>(),
                                            w in 40usize..110, h in 30usize..80, factor in 1.05f64..1.4,
                                            stages in 1usize..5) {
            // With one or two stages many windows pass, so OpenCV's skip after a stage-0
            // rejection decides many of them.
            let cascade = random_cascade(seed, 12, 10, stages, trees, if inexact { 1e-12 } else { 0.25 });
            let image = random_image(seed ^ 0x5eed, w, h);
            let params = DetectParams { scale_factor: factor, min_neighbors: 0, ..DetectParams::default() };
            let expected = reference_raw(&cascade, &image, &params);
            let detector = Detector::new(cascade);
            let got = detector.detect_raw(&image, &params).unwrap();
            prop_assert_eq!(&got, &expected);
            // The portable SSE2 path, and the AVX2 path with every quick verdict deferred
            // to the exact sum, give the same windows.
            let portable = Detector::new(detector.cascade().clone()).with_avx2(false);
            prop_assert_eq!(&portable.detect_raw(&image, &params).unwrap(), &expected);
            #[cfg(target_arch = "x86_64")]
            {
                let mut deferred = Detector::new(detector.cascade().clone());
                deferred.stages8 = deferred.stages8.map(|stages| {
                    stages.into_iter().map(avx2::Stage8::undecided).collect()
                });
                prop_assert_eq!(&deferred.detect_raw(&image, &params).unwrap(), &expected);
            }
            let two = detector.with_threads(2).unwrap().detect_raw(&image, &params).unwrap();
            prop_assert_eq!(two, expected);
        }
    }

    #[test]
    fn reference_finds_something_to_compare() {
        // Guard against a vacuous property test: the random cascades do accept windows.
        let total: usize = (0..8u64)
            .map(|seed| {
                let cascade = random_cascade(seed, 12, 10, 4, seed % 2 == 0, 0.25);
                let params = DetectParams {
                    min_neighbors: 0,
                    ..DetectParams::default()
                };
                reference_raw(&cascade, &random_image(seed, 90, 70), &params).len()
            })
            .sum();
        assert!(total > 10, "{total}");
    }

    #[test]
    fn wide_images_use_checked_reads_and_agree() {
        // A 24-row tilted window over a 5600-px-wide image: offsets exceed the view, so the
        // scan falls back to bounds-checked reads.
        let cascade = random_cascade(99, 24, 24, 3, false, 0.25);
        let image = random_image(7, 5600, 26);
        let params = DetectParams {
            min_neighbors: 0,
            ..DetectParams::default()
        };
        let planes = Planes::build(
            image.pixels(),
            5600,
            26,
            true,
            true,
            &mut Scratch::default(),
        );
        let detector = Detector::new(cascade.clone());
        assert!(!LevelEval::new(&detector, &planes).t.fits_view);
        assert_eq!(
            detector.detect_raw(&image, &params).unwrap(),
            reference_raw(&cascade, &image, &params)
        );
    }

    #[test]
    fn exactness_check() {
        assert!(leaf_sums_are_exact(&[(0.5, -0.25), (1.0, 0.125)]));
        assert!(!leaf_sums_are_exact(&[(1e-12, 1.0), (2.0, 3.0e6)]));
        assert!(leaf_sums_are_exact(&[]));
    }

    #[test]
    fn approximate_verdicts_are_certain_or_deferred() {
        let pairs = [(0.5f32, -0.25f32), (0.75, -0.5), (0.1, 0.3)];
        let a = Approx::for_stage(&pairs);
        let threshold = 0.35;
        assert_eq!(a.verdict(1.0, threshold), Some(true));
        assert_eq!(a.verdict(-1.0, threshold), Some(false));
        // Within the margin: deferred to the exact sum.
        assert_eq!(a.verdict(0.35, threshold), None);
        assert_eq!(a.verdict(0.35 + (a.margin * 0.5) as f32, threshold), None);
        assert!(a.margin > 0.0 && a.margin < 1e-5);
    }

    #[test]
    fn pyramid_follows_opencv_rules() {
        let p = DetectParams::default();
        let levels = pyramid(640, 480, 22, 18, &p).unwrap();
        assert_eq!(levels[0].scale, 1.0);
        assert_eq!(
            (levels[0].width, levels[0].height, levels[0].step),
            (640, 480, 2)
        );
        // 1.1^k window heights grow until 18 * f > 480.
        let last = levels.last().unwrap();
        assert!(last.box_height <= 480 && (18.0 * last.scale * 1.1).round() > 480.0);
        assert!(levels.iter().all(|l| (l.step == 1) == (l.scale >= 2.0)));
        // Window sizes respect min and max.
        let q = DetectParams {
            min_size_px: [40, 0],
            max_size_px: [100, 100],
            ..p
        };
        let limited = pyramid(640, 480, 22, 18, &q).unwrap();
        assert!(
            limited
                .iter()
                .all(|l| l.box_width >= 40 && l.box_width <= 100 && l.box_height <= 100)
        );
        assert!(limited.len() < levels.len());
        assert!(
            pyramid(
                640,
                480,
                22,
                18,
                &DetectParams {
                    scale_factor: 1.0,
                    ..p
                }
            )
            .is_err()
        );
        assert!(
            pyramid(
                640,
                480,
                22,
                18,
                &DetectParams {
                    scale_factor: f64::NAN,
                    ..p
                }
            )
            .is_err()
        );
        // An image smaller than the window has no levels.
        assert!(pyramid(20, 10, 22, 18, &p).unwrap().is_empty());
    }

    #[test]
    fn stripes_can_drop_the_last_rows() {
        // 64 px wide: working width 64 + 1 - 22 = 43 -> 2 stripes. A level of working
        // height 5 with step 2: stripe = max((5 / 2 + 1) / 2, 1) * 2 = 2, so rows 0..4
        // are scanned (0 and 2), and row 4 is not.
        let p = DetectParams::default();
        let levels = pyramid(64, 22, 22, 18, &p).unwrap();
        assert_eq!(levels[0].scan_width, 43);
        assert_eq!(levels[0].scan_height, 4);
    }

    #[test]
    fn flat_images_give_nothing() {
        let cascade = Cascade::from_xml(crate::cascade::tests::TINY_TRAINCASCADE).unwrap();
        let det = Detector::new(cascade);
        let img = GrayImage::filled(40, 30, 128).unwrap();
        assert!(
            det.detect_raw(&img, &DetectParams::default())
                .unwrap()
                .is_empty()
        );
    }
}
