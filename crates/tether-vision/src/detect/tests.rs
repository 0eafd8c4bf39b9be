//! The plain reference (OpenCV's rules written the obvious way) and the property tests
//! that hold the optimised scan to it.

use proptest::prelude::*;

use super::plan::{Approx, leaf_sums_are_exact};
use super::*;
use crate::integral::{integral_sum_sqsum, integral_tilted};
use crate::resize::resize_linear;

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
        let rect = |x0: usize, y0: usize, r: &crate::cascade::WeightedRect, tilted: bool| -> i32 {
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
    for scale_factor in [1.0, f64::NAN] {
        let bad = DetectParams { scale_factor, ..p };
        assert!(pyramid(640, 480, 22, 18, &bad).is_err(), "{scale_factor}");
    }
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
