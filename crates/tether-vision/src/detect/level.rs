//! One pyramid level as the scan sees it: the integral images laid out for the scan
//! ([`Planes`]), the cascade's features at this layout's offsets ([`LevelTables`], kept
//! per layout for the next image of the same size), and the plain evaluation of one
//! window at a time (`LevelEval::run`), used for tree cascades and for images too wide
//! for the fixed-size view.

use crate::integral::{integral_sum_sqsum, integral_tilted};

use super::Detector;
#[cfg(target_arch = "x86_64")]
use super::avx2;
use super::lanes::{LANES, LaneStump, LaneStumps};

/// Length of the bounds-check-free window view: a window's reads are made through a
/// `&[i32; VIEW]` starting at the window, with offsets masked to `VIEW - 1`, so the
/// compiler needs no bounds check per read. Used whenever every feature offset of a level
/// is below `VIEW` (for a 24-row window: images up to ~5400 px wide with tilted features,
/// ~10900 px without); otherwise reads are bounds-checked. Each buffer is padded by this
/// much (1 MiB).
pub(super) const VIEW: usize = 1 << 18;

/// Extra entries after every buffer, so that a view of two lane groups can start at any
/// window.
pub(super) const PAD: usize = VIEW + 2 * LANES;

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
pub(super) struct LevelFeature {
    pub(super) ofs: [[u32; 4]; 3],
    pub(super) weight: [f32; 3],
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

/// A decision stump with its feature inlined, OpenCV's `Stump`.
#[derive(Debug, Clone, Copy)]
pub(super) struct LevelStump {
    pub(super) feature: LevelFeature,
    pub(super) threshold: f32,
    pub(super) left: f32,
    pub(super) right: f32,
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
pub(super) enum Outcome {
    /// Passed every stage.
    Hit,
    /// Rejected by the variance test.
    Flat,
    /// Rejected by this stage.
    Rejected(usize),
}

/// Buffers reused from one level to the next (allocation and zeroing of multi-megabyte
/// buffers would otherwise cost as much as scanning the small levels).
#[derive(Default)]
pub(super) struct Scratch {
    pub(super) scaled: Vec<u8>,
    sum: Vec<i32>,
    sq: Vec<i32>,
    tilted: Vec<i32>,
    main: Vec<i32>,
    sq_layout: Vec<i32>,
}

thread_local! {
    /// The scratch space of each detection thread.
    pub(super) static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// One scaled image's integral images in the layout the scan reads.
///
/// `main` holds, for each integral row, the row of sums followed (for cascades with
/// tilted features) by the row of tilted sums, so that one view covers both; `sq` holds
/// the squared sums. With a 2-px step every window starts on an even column, so the
/// columns of each row are stored de-interleaved (even columns, then odd ones): the
/// windows of a row then read consecutive entries for every corner. Both buffers are
/// padded by [`PAD`] entries so that a view can start at any window.
pub(super) struct Planes {
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
    pub(super) fn build(
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
    pub(super) fn recycle(self, scratch: &mut Scratch) {
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
    pub(super) fn block_views(&self, x: usize, y: usize) -> Option<(&[i32; PAD], &[i32; PAD])> {
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
    pub(super) fn bases(&self, x: usize, y: usize) -> (usize, usize) {
        let col = if self.split { x / 2 } else { x };
        (y * self.main_stride + col, y * self.row_len + col)
    }
}

/// The cascade laid out for one level: features inlined into stumps or nodes, offsets
/// for this level's buffers.
pub(super) struct LevelEval<'d> {
    pub(super) detector: &'d Detector,
    pub(super) t: std::sync::Arc<LevelTables>,
}

/// The per-level tables of [`LevelEval`]; they depend only on the layout of the level's
/// buffers, so the detector keeps them for the next image of the same size.
#[derive(Debug)]
pub(super) struct LevelTables {
    /// Stumps in the detector's evaluation order (stump cascades only).
    pub(super) stumps: Vec<LevelStump>,
    /// The same stumps for the lanes' quick path.
    pub(super) lane: LaneStumps,
    /// Tree nodes in the cascade's order (tree cascades only).
    nodes: Vec<LevelNode>,
    pub(super) norm_main: [u32; 4],
    pub(super) norm_sq: [u32; 4],
    pub(super) area: f64,
    pub(super) fits_view: bool,
}

/// What identifies a level's buffer layout: (main stride, row length, de-interleaved).
pub(super) type LayoutKey = (usize, usize, bool);

/// The most layouts the detector remembers (35 levels of a 640x480 image, three image
/// sizes).
const MAX_CACHED_LAYOUTS: usize = 128;

impl<'d> LevelEval<'d> {
    pub(super) fn new(detector: &'d Detector, planes: &Planes) -> LevelEval<'d> {
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
    /// `runAt` for the window whose bases in `main` and `sq` are given.
    #[inline]
    pub(super) fn window(&self, planes: &Planes, base_main: usize, base_sq: usize) -> Outcome {
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
