//! Negative mining: windows of background images (and of annotated frames away from every
//! labelled box) that the cascade trained so far still accepts.
//!
//! The candidate windows are exactly the ones the detector visits: every level of
//! `detectMultiScale`'s pyramid ([`tether_vision::detect::pyramid`], the image resized with
//! OpenCV's bilinear rule) and every window position at its step (2 px below scale 2,
//! 1 px from scale 2 on). A window is taken as it appears in the resized image, so its
//! pixels, variance and feature values are the detector's.
//!
//! To spread the negatives over all images rather than take the first thousands from the
//! first image, each window gets a pseudo-random number `u` in `[0, 1)` from a hash of
//! the stage's seed and its position; a pass considers only the windows with `u` in
//! `[lo, hi)`. The first pass uses a `hi` estimated from the cascade's acceptance ratio
//! so that about twice the wanted number of negatives would be found over all images;
//! images are visited in a shuffled order and mining stops as soon as enough negatives
//! are found. If a pass ends short, the next one widens `[lo, hi)` fourfold (never
//! considering a window twice); when `hi` reaches 1 every window has been considered and
//! mining stops with [`Exhausted`]: it cannot loop forever.

use rayon::prelude::*;
use tether_core::GrayImage;
use tether_vision::Rect;
use tether_vision::detect::{DetectParams, ScaleLevel, pyramid};
use tether_vision::integral::{integral_sum_sqsum, integral_tilted};
use tether_vision::resize::resize_linear;

use crate::features::norm_factor;
use crate::info::iou;
use crate::model::CascadeModel;
use crate::rng::{SplitMix, unit_hash};

/// An image to mine, with the boxes its negatives must stay away from.
#[derive(Debug, Clone)]
pub struct Source {
    /// The image.
    pub image: GrayImage,
    /// Labelled boxes: a window that overlaps one of them with an intersection over union
    /// of the miner's `max_overlap` or more is never a negative (with `max_overlap` 0: a
    /// window that touches one at all).
    pub avoid: Vec<Rect>,
}

/// Negatives could not be found.
#[derive(Debug, Clone, PartialEq)]
pub struct Exhausted {
    /// Negatives found.
    pub found: usize,
    /// Negatives wanted.
    pub wanted: usize,
    /// Windows considered (all of them).
    pub considered: u64,
}

/// The outcome of mining.
#[derive(Debug, Clone)]
pub struct Mined {
    /// The negatives, `width x height` patches row-major.
    pub patches: Vec<Vec<u8>>,
    /// Windows considered (selected by the hash, away from the labelled boxes).
    pub considered: u64,
    /// Of those, windows the cascade accepted.
    pub accepted: u64,
    /// Where the negatives are, in the image's pixels (the detector's hit boxes).
    pub boxes: Vec<(usize, Rect)>,
}

impl Mined {
    /// The cascade's acceptance ratio on the considered windows (OpenCV's "acceptanceRatio").
    pub fn acceptance_ratio(&self) -> f64 {
        if self.considered == 0 {
            0.0
        } else {
            self.accepted as f64 / self.considered as f64
        }
    }
}

/// Mines windows of a fixed size from a set of images.
#[derive(Debug)]
pub struct Miner {
    sources: Vec<Source>,
    levels: Vec<Vec<ScaleLevel>>,
    width: u32,
    height: u32,
    max_overlap: f64,
    total_windows: u64,
}

impl Miner {
    /// A miner for `width x height` windows over `sources`, with the detector's pyramid at
    /// `scale_factor`; windows whose IoU with a labelled box is `max_overlap` or more are
    /// skipped.
    pub fn new(
        sources: Vec<Source>,
        width: u32,
        height: u32,
        scale_factor: f64,
        max_overlap: f64,
    ) -> Result<Miner, tether_vision::DetectError> {
        let params = DetectParams {
            scale_factor,
            min_neighbors: 0,
            ..DetectParams::default()
        };
        let mut levels = Vec::with_capacity(sources.len());
        let mut total = 0u64;
        for s in &sources {
            let l = pyramid(s.image.width(), s.image.height(), width, height, &params)?;
            total += l
                .iter()
                .map(|l| (l.scan_width.div_ceil(l.step) * l.scan_height.div_ceil(l.step)) as u64)
                .sum::<u64>();
            levels.push(l);
        }
        Ok(Miner {
            sources,
            levels,
            width,
            height,
            max_overlap,
            total_windows: total,
        })
    }

    /// Number of windows the detector visits over all images (before the labelled boxes
    /// are avoided).
    pub fn total_windows(&self) -> u64 {
        self.total_windows
    }

    /// Number of images.
    pub fn source_count(&self) -> usize {
        self.sources.len()
    }

    /// Mines `wanted` negatives the cascade accepts. `acceptance_estimate` is the expected
    /// share of windows the cascade accepts (1 without stages); `progress` is called with
    /// `(found, considered)` from the calling thread.
    pub fn mine(
        &self,
        cascade: &CascadeModel,
        wanted: usize,
        seed: u64,
        acceptance_estimate: f64,
        progress: &dyn Fn(usize, u64),
    ) -> Result<Mined, Exhausted> {
        let mut order: Vec<usize> = (0..self.sources.len()).collect();
        SplitMix::new(seed).shuffle(&mut order);
        let expected = self.total_windows as f64 * acceptance_estimate.clamp(1e-12, 1.0);
        let mut hi = (2.0 * wanted as f64 / expected.max(1.0)).clamp(1e-9, 1.0);
        let mut lo = 0.0;
        let mut out = Mined {
            patches: Vec::with_capacity(wanted),
            considered: 0,
            accepted: 0,
            boxes: Vec::with_capacity(wanted),
        };
        let batch = rayon::current_num_threads().max(1) * 2;
        loop {
            for chunk in order.chunks(batch) {
                let results: Vec<Mined> = chunk
                    .par_iter()
                    .map(|&s| self.mine_source(cascade, s, seed, lo, hi))
                    .collect();
                for r in results {
                    out.considered += r.considered;
                    out.accepted += r.accepted;
                    out.patches.extend(r.patches);
                    out.boxes.extend(r.boxes);
                }
                progress(out.patches.len().min(wanted), out.considered);
                if out.patches.len() >= wanted {
                    out.patches.truncate(wanted);
                    out.boxes.truncate(wanted);
                    return Ok(out);
                }
            }
            if hi >= 1.0 {
                return Err(Exhausted {
                    found: out.patches.len(),
                    wanted,
                    considered: out.considered,
                });
            }
            lo = hi;
            hi = (hi * 4.0).min(1.0);
        }
    }

    /// Every window of image `s` the cascade accepts (labelled boxes avoided), as the
    /// detector's raw hit boxes, in scan order.
    pub fn accepted_windows(&self, cascade: &CascadeModel, s: usize) -> Vec<Rect> {
        self.mine_source(cascade, s, 0, 0.0, 1.0)
            .boxes
            .into_iter()
            .map(|(_, r)| r)
            .collect()
    }

    /// The windows of one image with `u` in `[lo, hi)` that the cascade accepts.
    fn mine_source(&self, cascade: &CascadeModel, s: usize, seed: u64, lo: f64, hi: f64) -> Mined {
        let src = &self.sources[s];
        let (ww, wh) = (self.width as usize, self.height as usize);
        let tilted_needed = cascade
            .stages
            .iter()
            .flat_map(|st| &st.stumps)
            .any(|st| st.feature.tilted);
        let mut out = Mined {
            patches: Vec::new(),
            considered: 0,
            accepted: 0,
            boxes: Vec::new(),
        };
        let source_key = unit_hash(seed, s as u64);
        for (li, level) in self.levels[s].iter().enumerate() {
            if level.scan_width == 0 || level.scan_height == 0 {
                continue;
            }
            let level_key = unit_hash(source_key, li as u64);
            // Which windows of this level are selected at all: skip the level's resize
            // when none is.
            let selected = |x: usize, y: usize| {
                let u = (unit_hash(level_key, ((y as u64) << 32) | x as u64) >> 11) as f64
                    / (1u64 << 53) as f64;
                u >= lo && u < hi
            };
            let mut any = false;
            'scan: for y in (0..level.scan_height).step_by(level.step) {
                for x in (0..level.scan_width).step_by(level.step) {
                    if selected(x, y) {
                        any = true;
                        break 'scan;
                    }
                }
            }
            if !any {
                continue;
            }
            let (w, h) = (level.width, level.height);
            let scaled = resize_linear(
                src.image.pixels(),
                src.image.width(),
                src.image.height(),
                w,
                h,
            );
            let stride = w + 1;
            let mut sum = vec![0i32; stride * (h + 1)];
            let mut sq = vec![0i32; stride * (h + 1)];
            integral_sum_sqsum(&scaled, w, h, stride, &mut sum, &mut sq);
            let mut tilted = Vec::new();
            if tilted_needed {
                tilted = vec![0i32; stride * (h + 1)];
                integral_tilted(&scaled, w, h, stride, &mut tilted);
            }
            let compiled = cascade.compile(stride);
            for y in (0..level.scan_height).step_by(level.step) {
                for x in (0..level.scan_width).step_by(level.step) {
                    if !selected(x, y) {
                        continue;
                    }
                    let hit = level.hit_box(x, y);
                    if src.avoid.iter().any(|b| {
                        let o = iou(b, &hit);
                        o > 0.0 && o >= self.max_overlap
                    }) {
                        continue;
                    }
                    out.considered += 1;
                    let base = y * stride + x;
                    let Some(norm) = norm_factor(&sum, &sq, base, stride, ww, wh) else {
                        continue;
                    };
                    if !compiled.accepts(&sum, &tilted, base, norm) {
                        continue;
                    }
                    out.accepted += 1;
                    let mut patch = Vec::with_capacity(ww * wh);
                    for row in y..y + wh {
                        patch.extend_from_slice(&scaled[row * w + x..row * w + x + ww]);
                    }
                    out.patches.push(patch);
                    out.boxes.push((s, hit));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trainer's view of a cascade (feature arithmetic, variance normalisation,
    /// thresholds lowered by 1e-5, the windows of the pyramid) is the detector's: a random
    /// cascade with upright and tilted features, written as XML and run by tether-vision,
    /// accepts exactly the windows the miner finds accepted.
    #[test]
    fn the_miner_sees_what_the_detector_sees() {
        use crate::features::{FeatureMode, enumerate};
        use crate::model::{Stage, Stump};
        let pool = enumerate(12, 16, FeatureMode::All);
        let mut r = SplitMix::new(99);
        // A smooth image with texture, so that feature values spread around 0.
        let (w, h) = (90usize, 70usize);
        let pixels: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                (128.0 + 60.0 * (x * 0.3).sin() * (y * 0.17).cos() + (r.unit() - 0.5) * 60.0)
                    .clamp(0.0, 255.0) as u8
            })
            .collect();
        let image = GrayImage::from_raw(w, h, pixels).unwrap();
        let mut stages = Vec::new();
        for _ in 0..3 {
            let mut stumps = Vec::new();
            for _ in 0..4 {
                stumps.push(Stump {
                    feature: pool[r.below(pool.len())],
                    threshold: ((r.unit() - 0.5) * 0.02) as f32,
                    left: ((r.unit() - 0.5) * 2.0) as f32,
                    right: ((r.unit() - 0.5) * 2.0) as f32,
                });
            }
            stages.push(Stage {
                threshold: -0.6,
                stumps,
            });
        }
        let model = CascadeModel {
            width: 12,
            height: 16,
            mode: FeatureMode::All,
            stages,
        };
        let params = crate::boost::StageParams {
            boost: crate::boost::BoostType::Gentle,
            min_hit_rate: 0.995,
            max_false_alarm: 0.5,
            max_weak_count: 100,
        };
        let detector = tether_vision::Detector::new(
            tether_vision::Cascade::from_xml(&crate::xml::to_xml(&model, &params)).unwrap(),
        );
        let dp = DetectParams {
            min_neighbors: 0,
            ..DetectParams::default()
        };
        let mut want = detector.detect_raw(&image, &dp).unwrap();
        let miner = Miner::new(
            vec![Source {
                image,
                avoid: vec![],
            }],
            12,
            16,
            1.1,
            0.2,
        )
        .unwrap();
        let mut got = miner.accepted_windows(&model, 0);
        // The detector skips the window after one rejected by stage 0; the miner looks at
        // every window. Compare on the windows the detector looked at.
        assert!(
            got.len() >= want.len() && !want.is_empty(),
            "{} {}",
            got.len(),
            want.len()
        );
        want.sort();
        got.sort();
        for b in &want {
            assert!(got.binary_search(b).is_ok(), "detector hit {b:?} not mined");
        }
        // And the extra ones are all right after a stage-0 rejection: few.
        assert!(
            got.len() - want.len() <= want.len(),
            "{} vs {}",
            got.len(),
            want.len()
        );
    }

    fn noise_image(w: usize, h: usize, seed: u64) -> GrayImage {
        let mut r = SplitMix::new(seed);
        GrayImage::from_raw(
            w,
            h,
            (0..w * h).map(|_| (r.next_u64() % 256) as u8).collect(),
        )
        .unwrap()
    }

    #[test]
    fn mines_distinct_windows_and_stops_when_exhausted() {
        let sources = vec![
            Source {
                image: noise_image(40, 30, 1),
                avoid: vec![],
            },
            Source {
                image: noise_image(40, 30, 2),
                avoid: vec![Rect {
                    x: 0,
                    y: 0,
                    width: 40,
                    height: 30,
                }],
            },
        ];
        let miner = Miner::new(sources.clone(), 8, 8, 1.1, 0.2).unwrap();
        let cascade = CascadeModel::empty(8, 8, crate::features::FeatureMode::Basic);
        let got = miner.mine(&cascade, 50, 7, 1.0, &|_, _| {}).unwrap();
        assert_eq!(got.patches.len(), 50);
        let mut unique = got.patches.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), 50, "a window was taken twice");
        // Far more than the images hold: every window is considered once, then an error.
        let e = miner
            .mine(&cascade, 100_000, 7, 1.0, &|_, _| {})
            .unwrap_err();
        assert!(e.found > 0 && e.found < 100_000);
        assert!(e.considered as usize >= e.found);
        // Large windows of the second image overlap its box by IoU >= 0.2: not considered.
        assert!(e.considered > miner.total_windows() / 2 && e.considered < miner.total_windows());
        // With max_overlap 0 no window touching a box counts: the second image is one
        // box, so only the first image's windows are considered.
        let strict = Miner::new(sources, 8, 8, 1.1, 0.0).unwrap();
        let e = strict
            .mine(&cascade, 100_000, 7, 1.0, &|_, _| {})
            .unwrap_err();
        assert_eq!(e.considered, strict.total_windows() / 2);
    }
}
