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
//! This file holds the public API; the scan is in the module's other files:
//!
//! - `plan.rs`, the stage plan: the private `StagePlan`, `Kind` and `Approx` (the order
//!   and grouping of each stage's stumps, and a certified quick sum);
//! - `level.rs`, one pyramid level: `Planes` (the memory layout of its integral images),
//!   the cascade's offsets for that layout, and the plain one-window-at-a-time
//!   evaluation, kept for tree cascades and very wide images;
//! - `lanes.rs`, the lane-parallel scan (`LevelEval::scan_row_lanes`): eight windows at
//!   once with AVX2 when the CPU has it (`avx2.rs`, chosen at run time; the crate's only
//!   `unsafe` code), else two groups of four with SSE2;
//! - `tests.rs`: a literal transcription of the rules above, the reference of the
//!   property tests, which check both lane paths.

mod lanes;
mod level;
mod plan;

#[cfg(target_arch = "x86_64")]
mod avx2;

#[cfg(test)]
mod tests;

use rayon::prelude::*;
use thiserror::Error;

use tether_core::GrayImage;

use crate::cascade::Cascade;
use crate::group::{Rect, group_rectangles};
use crate::resize::resize_linear_into;

use level::{LayoutKey, LevelEval, LevelTables, Outcome, Planes, SCRATCH, Scratch};
use plan::{Plan, StagePlan};

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

/// A cascade ready to scan images.
#[derive(Debug)]
pub struct Detector {
    cascade: Cascade,
    /// Weak classifiers in evaluation order (see [`StagePlan`]).
    order: Vec<usize>,
    plans: Vec<StagePlan>,
    /// Each feature's rectangle corners in window coordinates (`plan::rect_corners`).
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
        let Plan {
            order,
            stages: plans,
            corners,
            layouts,
        } = Plan::new(&cascade);
        #[cfg(target_arch = "x86_64")]
        let stages8 = if cascade.is_stump_based() {
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
