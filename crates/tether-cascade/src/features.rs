//! Haar-like features: the pool boosting chooses from, and their evaluation on integral
//! images with exactly the arithmetic of OpenCV's detector (and tether-vision's), so that
//! a threshold learnt here means the same at detection time.
//!
//! The pool is the one `opencv_traincascade -mode` enumerates (Lienhart and Maydt, ICIP
//! 2002): for every top-left corner `(x, y)` and cell size `(dx, dy)` that fits the
//! window,
//!
//! - [`FeatureMode::Basic`]: edge features `x2` (`2dx x dy`, weights -1 on the whole and
//!   +2 on the right half), `y2`, line features `x3` (-1 whole, +3 middle third), `y3`,
//!   and the diagonal `x2_y2` (-1 whole, +2 on two opposite quarters);
//! - [`FeatureMode::Core`]: adds the wider lines `x4`, `y4` (-1 whole, +2 middle half) and
//!   the centre-surround `3dx x 3dy` (-1 whole, +9 centre);
//! - [`FeatureMode::All`]: adds the 45-degree tilted `x2`, `y2`, `x3`, `y3`, `x4`, `y4`.
//!
//! A feature's value on a window is `(w0 S0 + w1 S1 [+ w2 S2]) * norm` in `f32`, in that
//! order, where `S` are rectangle sums (exact 32-bit integers from the integral image) and
//! `norm = 1 / sqrt(A Q - S^2)` over the window without its 1-px border: the feature is
//! divided by the window's grey-level standard deviation times its area.

use serde::{Deserialize, Serialize};

/// Which features the pool holds (`opencv_traincascade -mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FeatureMode {
    /// Upright edge, line and diagonal features (Viola-Jones; OpenCV's `BASIC`).
    Basic,
    /// All upright features (OpenCV's `CORE`).
    Core,
    /// Upright and 45-degree tilted features (OpenCV's `ALL`).
    All,
}

impl FeatureMode {
    /// The name OpenCV writes in `featureParams/mode`.
    pub fn opencv_name(self) -> &'static str {
        match self {
            FeatureMode::Basic => "BASIC",
            FeatureMode::Core => "CORE",
            FeatureMode::All => "ALL",
        }
    }
}

/// One weighted rectangle of a feature, window pixels. A tilted rectangle is rotated by
/// 45 degrees about its top corner `(x, y)` (corners `(x, y)`, `(x + w, y + w)`,
/// `(x - h, y + h)`, `(x + w - h, y + w + h)`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FeatureRect {
    /// Left column (upright) or top corner's column (tilted), px.
    pub x: i32,
    /// Top row, px.
    pub y: i32,
    /// Width, px.
    pub w: i32,
    /// Height, px.
    pub h: i32,
    /// Weight of the rectangle's pixel sum; 0 for an unused third rectangle.
    pub weight: f32,
}

/// A Haar-like feature of two or three rectangles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Feature {
    /// The rectangles; an unused third one has weight 0.
    pub rects: [FeatureRect; 3],
    /// Rotated by 45 degrees (read from the tilted integral image).
    pub tilted: bool,
}

const NONE: FeatureRect = FeatureRect {
    x: 0,
    y: 0,
    w: 0,
    h: 0,
    weight: 0.0,
};

fn rect(x: i32, y: i32, w: i32, h: i32, weight: f32) -> FeatureRect {
    FeatureRect { x, y, w, h, weight }
}

impl Feature {
    fn two(tilted: bool, a: FeatureRect, b: FeatureRect) -> Feature {
        Feature {
            rects: [a, b, NONE],
            tilted,
        }
    }

    /// The number of rectangles in use (2 or 3).
    pub fn rect_count(&self) -> usize {
        if self.rects[2].weight != 0.0 { 3 } else { 2 }
    }

    /// The four integral-image corners of each rectangle, `(column, row)` in the window,
    /// in the order `p0 - p1 - p2 + p3`.
    pub fn corners(&self) -> [[(i32, i32); 4]; 3] {
        self.rects.map(|r| {
            if r.weight == 0.0 {
                [(0, 0); 4]
            } else if self.tilted {
                [
                    (r.x, r.y),
                    (r.x - r.h, r.y + r.h),
                    (r.x + r.w, r.y + r.w),
                    (r.x + r.w - r.h, r.y + r.w + r.h),
                ]
            } else {
                [
                    (r.x, r.y),
                    (r.x + r.w, r.y),
                    (r.x, r.y + r.h),
                    (r.x + r.w, r.y + r.h),
                ]
            }
        })
    }

    /// The feature's offsets for integral images with `stride` entries per row.
    pub fn compile(&self, stride: usize) -> CompiledFeature {
        let corners = self.corners();
        let ofs = corners.map(|c| c.map(|(x, y)| (y as usize) * stride + x as usize));
        CompiledFeature {
            ofs,
            weight: self.rects.map(|r| r.weight),
            tilted: self.tilted,
        }
    }
}

/// Every feature of `mode` that fits a `width x height` window, in OpenCV's enumeration
/// order.
pub fn enumerate(width: u32, height: u32, mode: FeatureMode) -> Vec<Feature> {
    // One arm a feature type, in OpenCV's order, parallel on purpose: each arm's
    // rectangles read as the feature's drawing, and the order is the features' numbering.
    let (ww, wh) = (width as i32, height as i32);
    let mut out = Vec::new();
    for x in 0..ww {
        for y in 0..wh {
            for dx in 1..=ww {
                for dy in 1..=wh {
                    let fits = |w: i32, h: i32| x + w <= ww && y + h <= wh;
                    if fits(2 * dx, dy) {
                        out.push(Feature::two(
                            false,
                            rect(x, y, 2 * dx, dy, -1.0),
                            rect(x + dx, y, dx, dy, 2.0),
                        ));
                    }
                    if fits(dx, 2 * dy) {
                        out.push(Feature::two(
                            false,
                            rect(x, y, dx, 2 * dy, -1.0),
                            rect(x, y + dy, dx, dy, 2.0),
                        ));
                    }
                    if fits(3 * dx, dy) {
                        out.push(Feature::two(
                            false,
                            rect(x, y, 3 * dx, dy, -1.0),
                            rect(x + dx, y, dx, dy, 3.0),
                        ));
                    }
                    if fits(dx, 3 * dy) {
                        out.push(Feature::two(
                            false,
                            rect(x, y, dx, 3 * dy, -1.0),
                            rect(x, y + dy, dx, dy, 3.0),
                        ));
                    }
                    if mode != FeatureMode::Basic {
                        if fits(4 * dx, dy) {
                            out.push(Feature::two(
                                false,
                                rect(x, y, 4 * dx, dy, -1.0),
                                rect(x + dx, y, 2 * dx, dy, 2.0),
                            ));
                        }
                        if fits(dx, 4 * dy) {
                            out.push(Feature::two(
                                false,
                                rect(x, y, dx, 4 * dy, -1.0),
                                rect(x, y + dy, dx, 2 * dy, 2.0),
                            ));
                        }
                    }
                    if fits(2 * dx, 2 * dy) {
                        out.push(Feature {
                            rects: [
                                rect(x, y, 2 * dx, 2 * dy, -1.0),
                                rect(x, y, dx, dy, 2.0),
                                rect(x + dx, y + dy, dx, dy, 2.0),
                            ],
                            tilted: false,
                        });
                    }
                    if mode != FeatureMode::Basic && fits(3 * dx, 3 * dy) {
                        out.push(Feature::two(
                            false,
                            rect(x, y, 3 * dx, 3 * dy, -1.0),
                            rect(x + dx, y + dy, dx, dy, 9.0),
                        ));
                    }
                    if mode == FeatureMode::All {
                        // A tilted w x h rectangle at (x, y) spans columns x - h ..= x + w
                        // and rows y ..= y + w + h.
                        let tfits = |w: i32, h: i32| x + w <= ww && y + w + h <= wh && x - h >= 0;
                        if tfits(2 * dx, dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, 2 * dx, dy, -1.0),
                                rect(x, y, dx, dy, 2.0),
                            ));
                        }
                        if tfits(dx, 2 * dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, dx, 2 * dy, -1.0),
                                rect(x, y, dx, dy, 2.0),
                            ));
                        }
                        if tfits(3 * dx, dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, 3 * dx, dy, -1.0),
                                rect(x + dx, y + dx, dx, dy, 3.0),
                            ));
                        }
                        if tfits(dx, 3 * dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, dx, 3 * dy, -1.0),
                                rect(x - dy, y + dy, dx, dy, 3.0),
                            ));
                        }
                        if tfits(4 * dx, dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, 4 * dx, dy, -1.0),
                                rect(x + dx, y + dx, 2 * dx, dy, 2.0),
                            ));
                        }
                        if tfits(dx, 4 * dy) {
                            out.push(Feature::two(
                                true,
                                rect(x, y, dx, 4 * dy, -1.0),
                                rect(x - dy, y + dy, dx, 2 * dy, 2.0),
                            ));
                        }
                    }
                }
            }
        }
    }
    out
}

/// A feature's integral-image offsets for one row stride.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompiledFeature {
    /// `p0, p1, p2, p3` of each rectangle, relative to the window's top-left entry.
    pub ofs: [[usize; 4]; 3],
    /// The rectangles' weights.
    pub weight: [f32; 3],
    /// Read from the tilted integral.
    pub tilted: bool,
}

impl CompiledFeature {
    /// The feature's value on the window whose top-left integral entries are
    /// `sum[base]` and `tilted[base]`, normalised by `norm`: OpenCV's
    /// `HaarEvaluator::OptFeature::calc` in `f32`.
    ///
    /// # Panics
    /// If the window does not fit in the slices (a programming error).
    #[inline(always)]
    pub fn value(&self, sum: &[i32], tilted: &[i32], base: usize, norm: f32) -> f32 {
        let table = if self.tilted { tilted } else { sum };
        let s = |o: &[usize; 4]| -> f32 {
            table[base + o[0]]
                .wrapping_sub(table[base + o[1]])
                .wrapping_sub(table[base + o[2]])
                .wrapping_add(table[base + o[3]]) as f32
        };
        let mut v = self.weight[0] * s(&self.ofs[0]) + self.weight[1] * s(&self.ofs[1]);
        if self.weight[2] != 0.0 {
            v += self.weight[2] * s(&self.ofs[2]);
        }
        v * norm
    }
}

/// OpenCV's variance normalisation of a `width x height` window whose top-left integral
/// entries are `sum[base]` and `sqsum[base]` (rows `stride` apart): over the window
/// without its 1-px border (area `A`), `nf = A Q - S^2` in `f64`; `None` (the detector
/// rejects the window) when `nf <= 0` or `A * (f32)(1 / sqrt(nf)) >= 0.1`, i.e. the
/// grey-level standard deviation is 10 or less; otherwise `(f32)(1 / sqrt(nf))`.
#[inline]
pub fn norm_factor(
    sum: &[i32],
    sqsum: &[i32],
    base: usize,
    stride: usize,
    width: usize,
    height: usize,
) -> Option<f32> {
    let (p0, p1, p2, p3) = (
        base + stride + 1,
        base + stride + width - 1,
        base + (height - 1) * stride + 1,
        base + (height - 1) * stride + width - 1,
    );
    let s = sum[p0]
        .wrapping_sub(sum[p1])
        .wrapping_sub(sum[p2])
        .wrapping_add(sum[p3]);
    let q = sqsum[p0]
        .wrapping_sub(sqsum[p1])
        .wrapping_sub(sqsum[p2])
        .wrapping_add(sqsum[p3]) as u32;
    let area = ((width - 2) * (height - 2)) as f64;
    let nf = area * f64::from(q) - f64::from(s) * f64::from(s);
    if nf <= 0.0 {
        return None;
    }
    let norm = (1.0 / nf.sqrt()) as f32;
    (area * f64::from(norm) < 0.1).then_some(norm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pool_sizes_match_opencv_traincascade() {
        // A 24x24 window holds the 162,336 features of Viola and Jones's paper (the
        // figure opencv_traincascade -mode BASIC reports); CORE and ALL add to them.
        assert_eq!(enumerate(24, 24, FeatureMode::Basic).len(), 162_336);
        assert_eq!(enumerate(24, 24, FeatureMode::Core).len(), 210_400);
        assert!(enumerate(24, 24, FeatureMode::All).len() > 210_400);
    }

    #[test]
    fn every_feature_fits_the_window_and_sums_to_zero_on_flat_patches() {
        for mode in [FeatureMode::Basic, FeatureMode::All] {
            for f in enumerate(7, 9, mode) {
                for c in f.corners().iter().flatten() {
                    assert!((0..=7).contains(&c.0) && (0..=9).contains(&c.1), "{f:?}");
                }
                // Weighted areas cancel: a flat patch gives 0.
                let area = |r: &FeatureRect| (r.w * r.h) as f32 * r.weight;
                let total: f32 = f.rects.iter().map(area).sum();
                assert_eq!(total, 0.0, "{f:?}");
            }
        }
    }
}
