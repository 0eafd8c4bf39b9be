use super::*;
use tether_core::{LaserScan, Stamp};

use crate::preprocess::preprocess;

const INC: f64 = 0.006_135_92;
const ADAPTIVE: Breakpoint = Breakpoint::Adaptive {
    lambda_rad: 10.0 * std::f64::consts::PI / 180.0,
};

fn points(ranges: Vec<f32>) -> Vec<ScanPoint> {
    let scan = LaserScan::new(Stamp::ZERO, "l", 0.0, INC, 0.02, 5.6, ranges).unwrap();
    preprocess(&scan, &RangeNoiseModel::default())
}

fn clusters(points: &[ScanPoint], rule: Breakpoint) -> Vec<Vec<usize>> {
    let (mut order, mut out) = (Vec::new(), Vec::new());
    let mut scratch = ClusterScratch::default();
    let noise = RangeNoiseModel::default();
    cluster_into(
        points,
        INC,
        &noise,
        rule,
        &mut scratch,
        &mut order,
        &mut out,
    );
    for (k, s) in out.iter().enumerate() {
        for &i in &order[s.start..s.end] {
            assert_eq!(scratch.cluster_of()[i], k as u32);
        }
    }
    out.iter().map(|s| order[s.start..s.end].to_vec()).collect()
}

/// Clusters as [`cluster_into`] lists them, with `cluster_of` checked against them,
/// for any angle increment and rule, with the run-based pass given `work_per_point`
/// (0: the grid; `usize::MAX`: the runs).
fn clusters_with(
    points: &[ScanPoint],
    inc: f64,
    rule: Breakpoint,
    work_per_point: usize,
    scratch: &mut ClusterScratch,
) -> Vec<Vec<usize>> {
    let (mut order, mut out) = (Vec::new(), Vec::new());
    let noise = RangeNoiseModel::default();
    cluster_with(
        points,
        inc,
        &noise,
        rule,
        work_per_point,
        scratch,
        &mut order,
        &mut out,
    );
    assert_eq!(scratch.cluster_of().len(), points.len());
    assert_eq!(order.len(), points.len());
    for (k, s) in out.iter().enumerate() {
        for &i in &order[s.start..s.end] {
            assert_eq!(scratch.cluster_of()[i], k as u32);
        }
    }
    out.iter().map(|s| order[s.start..s.end].to_vec()).collect()
}

/// The rule of [`Breakpoint::Euclidean`] as documented, pair by pair: the window of
/// `a` as `floor(asin(d / r) / |inc|)` (unbounded for `r <= d` or from `n` beams on),
/// the distance compared squared. Components by union-find over every pair;
/// clusters numbered by their first point, points in beam order.
fn reference(points: &[ScanPoint], inc: f64, d: f64) -> Vec<Vec<usize>> {
    let n = points.len();
    let unbounded = |a: &ScanPoint| {
        !(a.range_m > d && inc != 0.0) || (d / a.range_m).asin() / inc.abs() >= n as f64
    };
    let windows: Vec<f64> = points
        .iter()
        .map(|a| {
            if unbounded(a) {
                f64::INFINITY
            } else {
                ((d / a.range_m).asin() / inc.abs()).floor()
            }
        })
        .collect();
    let mut label: Vec<usize> = (0..n).collect();
    fn root(label: &mut [usize], mut i: usize) -> usize {
        while label[i] != i {
            i = label[i];
        }
        i
    }
    for i in 0..n {
        for j in i + 1..n {
            let (a, b) = (&points[i], &points[j]);
            let (dx, dy) = (
                b.point_in_laser.x - a.point_in_laser.x,
                b.point_in_laser.y - a.point_in_laser.y,
            );
            if ((b.beam - a.beam) as f64) < windows[i] && dx * dx + dy * dy < d * d {
                let (ri, rj) = (root(&mut label, i), root(&mut label, j));
                label[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut number = vec![usize::MAX; n];
    for i in 0..n {
        let r = root(&mut label, i);
        if number[r] == usize::MAX {
            number[r] = out.len();
            out.push(Vec::new());
        }
        out[number[r]].push(i);
    }
    out
}

/// A pseudo-random scan: `n` beams of one of several patterns, some beams without
/// a return (NaN, infinite, beyond the range limits).
fn random_ranges(n: usize, pattern: u8, drop: f64, d: f64, seed: u64) -> Vec<f32> {
    let mut state = seed | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (a, b) = (0.01 + 0.8 * next(), 0.01 + 0.8 * next());
    let mut walks = [0.3 + 3.0 * next(), 0.3 + 3.0 * next(), 0.3 + 3.0 * next()];
    let mut object = (0.0, 0usize);
    (0..n)
        .map(|i| {
            let r = match pattern {
                // Anywhere within the limits.
                0 => 0.01 + 6.0 * next(),
                // Near the sensor, some within the clustering distance.
                1 => 0.003 + 3.0 * d * next(),
                // Two ranges alternating beam by beam, slightly jittered.
                2 => (if i % 2 == 0 { a } else { b }) + 0.002 * next(),
                // Objects of a few beams at random ranges.
                3 => {
                    if object.1 == 0 {
                        object = (0.02 + 4.0 * next(), 1 + (12.0 * next()) as usize);
                    }
                    object.1 -= 1;
                    object.0 + 0.05 * (next() - 0.5)
                }
                // Three surfaces seen in turn, beam by beam or in short runs.
                _ => {
                    let w = if next() < 0.5 { i % 3 } else { (i / 4) % 3 };
                    walks[w] = (walks[w] + 0.03 * (next() - 0.5)).clamp(0.02, 8.0);
                    walks[w]
                }
            };
            let u = next();
            if u < drop {
                [f32::NAN, f32::INFINITY, 50.0, 0.001][(4.0 * u / drop) as usize % 4]
            } else {
                r as f32
            }
        })
        .collect()
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|c| c.parse().ok())
            .unwrap_or(48),
        ..proptest::test_runner::Config::default()
    })]

    /// Both ways of clustering (the runs, the grid) and the default mix give the
    /// rule's components, numbered and ordered as the reference, on random scans:
    /// beam counts, missing beams, patterns near the sensor and interleaved, angle
    /// increments up to half a radian either way (wide scans whose beams come
    /// round again).
    #[test]
    fn euclidean_clustering_matches_the_rule(
        n in proptest::prop_oneof![1usize..60, 1usize..3000],
        pattern in 0u8..5,
        drop in proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0f64..0.4],
        log_inc in -4.0f64..-0.3,
        clockwise: bool,
        angle_min in -3.2f64..3.2,
        d in proptest::prop_oneof![
            proptest::strategy::Just(0.13),
            proptest::strategy::Just(0.05),
            0.01f64..0.6,
        ],
        seed: u64,
    ) {
        let inc = if clockwise { -1.0 } else { 1.0 } * 10f64.powf(log_inc);
        let ranges = random_ranges(n, pattern, drop, d, seed);
        let scan = LaserScan::new(Stamp::ZERO, "l", angle_min, inc, 0.002, 10.0, ranges)
            .unwrap();
        let pts = preprocess(&scan, &RangeNoiseModel::default());
        let rule = Breakpoint::Euclidean { distance_m: d };
        let want = reference(&pts, inc, d);
        let half = &pts[..pts.len() / 2];
        let want_half = reference(half, inc, d);
        for work in [0, usize::MAX, RUNS_WORK_PER_POINT] {
            let mut scratch = ClusterScratch::default();
            let got = clusters_with(&pts, inc, rule, work, &mut scratch);
            proptest::prop_assert_eq!(&got, &want, "work {}", work);
            // The same buffers again, after a scan of another size: same result.
            let again = clusters_with(half, inc, rule, work, &mut scratch);
            proptest::prop_assert_eq!(&again, &want_half, "work {}", work);
            let again = clusters_with(&pts, inc, rule, work, &mut scratch);
            proptest::prop_assert_eq!(&again, &want, "work {}", work);
        }
    }
}

#[test]
fn coordinates_beyond_the_grid_take_the_exact_sweep() {
    // Returns 10^9 m away: beyond 2^30 cells of 9 cm, so the grid is not used.
    // Runs of ten beams at one of three ranges 512 m apart, a beam in 37 missing;
    // then a return every 100 beams (0.1 m apart, joined only at that distance).
    let mut ranges: Vec<f32> = (0..2000)
        .map(|i| {
            if i % 37 == 5 || (i >= 400 && i % 100 != 0) {
                f32::NAN
            } else if i < 400 {
                1e9 + 512.0 * ((i / 10) % 3) as f32
            } else {
                1e9 + 2048.0
            }
        })
        .collect();
    ranges[7] = 0.5;
    let inc = 1e-12;
    let scan = LaserScan::new(Stamp::ZERO, "l", 1.2, inc, 0.002, 1e10, ranges).unwrap();
    let pts = preprocess(&scan, &RangeNoiseModel::default());
    for (d, count) in [(0.13, 6), (1.0, 5), (1e3, 3)] {
        let rule = Breakpoint::Euclidean { distance_m: d };
        let got = clusters_with(&pts, inc, rule, 0, &mut ClusterScratch::default());
        assert_eq!(got, reference(&pts, inc, d), "d = {d}");
        assert_eq!(got.len(), count, "d = {d}");
    }
    // A distance whose square underflows joins nothing.
    let pts = points(random_ranges(300, 3, 0.1, 0.13, 8));
    let rule = Breakpoint::Euclidean { distance_m: 1e-200 };
    let got = clusters_with(&pts, INC, rule, 0, &mut ClusterScratch::default());
    assert_eq!(got, reference(&pts, INC, 1e-200));
    assert_eq!(got.len(), pts.len());
}

#[test]
fn dense_scans_match_the_rule() {
    // The benchmark's adversaries at a few thousand beams: ranges alternating
    // 0.03 / 0.25 m, and interleaved surfaces 0.13-0.14 m apart.
    for (n, pattern) in [(4000, 0), (4000, 1), (3000, 2)] {
        let inc = 1.5 * std::f64::consts::PI / n as f64;
        let ranges = (0..n)
            .map(|i| match pattern {
                0 => [0.03, 0.25][i % 2],
                1 => [1.0, 1.13, 1.2601][i % 3],
                _ => 0.2 + 0.1 * ((i * 7919) % 101) as f32 / 101.0,
            })
            .collect();
        let scan = LaserScan::new(Stamp::ZERO, "l", -2.36, inc, 0.002, 10.0, ranges).unwrap();
        let pts = preprocess(&scan, &RangeNoiseModel::default());
        let rule = Breakpoint::default();
        let want = reference(&pts, inc, 0.13);
        for work in [0, usize::MAX, RUNS_WORK_PER_POINT] {
            let got = clusters_with(&pts, inc, rule, work, &mut ClusterScratch::default());
            assert_eq!(got, want, "pattern {pattern}, work {work}");
        }
    }
}

#[test]
fn the_grid_compares_cells_two_apart_either_way() {
    // Two returns at the facing corners of two cells (of the grid's size) at
    // every offset up to two cells each way: even two apart diagonally, they are
    // closer than the distance, and are joined.
    let d = 0.13;
    let side = d * std::f64::consts::FRAC_1_SQRT_2 * (1.0 - 1.0 / 1024.0);
    let eps = 1e-5;
    // A coordinate of the first return, in cell 10 (or 7), towards cell `k` away,
    // and of the second, in that cell, towards the first.
    let first = |cell: f64, k: i32| match k {
        0 => (cell + 0.5) * side,
        k if k > 0 => (cell + 1.0) * side - eps,
        _ => cell * side + eps,
    };
    let second = |cell: f64, k: i32| match k {
        0 => (cell + 0.5) * side,
        k if k > 0 => (cell + f64::from(k)) * side + eps,
        _ => (cell + f64::from(k) + 1.0) * side - eps,
    };
    let point = |beam: usize, x: f64, y: f64| {
        let p = tether_core::Point2::new(x, y);
        ScanPoint {
            beam,
            range_m: x.hypot(y),
            bearing_rad: y.atan2(x),
            point_in_laser: p,
        }
    };
    let rule = Breakpoint::Euclidean { distance_m: d };
    for dx in -2..=2 {
        for dy in -2..=2 {
            if (dx, dy) == (0, 0) {
                continue;
            }
            let a = point(0, first(10.0, dx), first(7.0, dy));
            let b = point(1, second(10.0, dx), second(7.0, dy));
            assert!(a.point_in_laser.distance_m(b.point_in_laser) < d);
            for pts in [
                [a, b],
                [ScanPoint { beam: 0, ..b }, ScanPoint { beam: 1, ..a }],
            ] {
                let got = clusters_with(&pts, 1e-4, rule, 0, &mut ClusterScratch::default());
                assert_eq!(got, vec![vec![0, 1]], "offset ({dx}, {dy})");
                assert_eq!(got, reference(&pts, 1e-4, d));
            }
        }
    }
}

#[test]
fn the_grid_and_the_runs_agree_on_the_real_recordings() {
    // Every scan of every laser topic of leg_tracker's recordings (3,773 scans),
    // at the default distance and at 0.3 m, clustered both ways.
    let Some(dir) = tether_testkit::shared("data/laser/leg_tracker") else {
        return;
    };
    let mut topics: Vec<(String, &str)> = (1..=7)
        .filter(|k| *k != 5)
        .map(|k| (format!("positive_{k}_extracted.bag"), "/training_scan"))
        .collect();
    for topic in ["/left_scan", "/rear_scan", "/right_scan"] {
        topics.push(("negative_2.bag".into(), topic));
    }
    topics.push(("demo_stationary_simple_environment.bag".into(), "/scan"));
    let (mut by_grid, mut by_runs) = (ClusterScratch::default(), ClusterScratch::default());
    let mut scans = 0;
    for (bag, topic) in &topics {
        let read = tether_recording::rosbag::read_scans(dir.join(bag), topic).unwrap();
        for m in &read.scans {
            let pts = preprocess(&m.scan, &RangeNoiseModel::default());
            let inc = m.scan.angle_increment_rad;
            for d in [0.13, 0.3] {
                let rule = Breakpoint::Euclidean { distance_m: d };
                assert_eq!(
                    clusters_with(&pts, inc, rule, 0, &mut by_grid),
                    clusters_with(&pts, inc, rule, usize::MAX, &mut by_runs),
                    "{bag} {topic}, d = {d}"
                );
            }
            scans += 1;
        }
    }
    assert_eq!(scans, 3773);
}

fn lens(points: &[ScanPoint], rule: Breakpoint) -> Vec<usize> {
    clusters(points, rule).iter().map(Vec::len).collect()
}

#[test]
fn splits_at_range_jumps() {
    let mut ranges = vec![2.0f32; 10];
    ranges.extend(vec![1.5f32; 5]);
    ranges.extend(vec![2.0f32; 10]);
    let pts = points(ranges);
    assert_eq!(lens(&pts, ADAPTIVE), vec![10, 5, 10]);
    assert_eq!(
        lens(&pts, Breakpoint::FixedJump { jump_m: 0.13 }),
        vec![10, 5, 10]
    );
    assert_eq!(lens(&pts, Breakpoint::FixedJump { jump_m: 0.6 }), vec![25]);
    // Euclidean clustering joins the wall across the narrow object in front (its
    // two pieces are 7 cm apart), listed from its first beam.
    let default = clusters(&pts, Breakpoint::default());
    assert_eq!(default.len(), 2);
    assert_eq!(default[0], (0..10).chain(15..25).collect::<Vec<_>>());
    assert_eq!(default[1], (10..15).collect::<Vec<_>>());
}

#[test]
fn adaptive_threshold_grows_with_range() {
    // A 7 cm step: the same surface at 4 m (D_max ~ 0.27 m), a new one at 0.5 m
    // (D_max ~ 0.048 m); one surface for the 0.13 m clustering.
    let far = points(vec![4.0, 4.0, 4.07, 4.07]);
    assert_eq!(lens(&far, ADAPTIVE), vec![4]);
    let near = points(vec![0.5, 0.5, 0.57, 0.57]);
    assert_eq!(lens(&near, ADAPTIVE), vec![2, 2]);
    assert_eq!(lens(&near, Breakpoint::default()), vec![4]);
}

#[test]
fn euclidean_clustering_looks_past_a_stray_return() {
    // A leg at 1.5 m whose middle beam returned from the wall at 3 m (a mixed
    // pixel): the rules of consecutive returns cut the leg in two.
    let mut ranges = vec![1.5f32; 9];
    ranges[4] = 3.0;
    let pts = points(ranges);
    assert_eq!(
        lens(&pts, Breakpoint::FixedJump { jump_m: 0.13 }),
        vec![4, 1, 4]
    );
    let c = clusters(&pts, Breakpoint::default());
    assert_eq!(c, vec![vec![0, 1, 2, 3, 5, 6, 7, 8], vec![4]]);
}

/// Connected components of the definition of [`Breakpoint::Euclidean`], by
/// comparing every pair.
fn brute_force(points: &[ScanPoint], d: f64) -> Vec<Vec<usize>> {
    let n = points.len();
    let joined = |i: usize, j: usize| {
        let (a, b) = if i < j {
            (&points[i], &points[j])
        } else {
            (&points[j], &points[i])
        };
        let window = if a.range_m > d {
            ((d / a.range_m).asin() / INC).floor()
        } else {
            f64::INFINITY
        };
        ((b.beam - a.beam) as f64) < window && a.point_in_laser.distance_m(b.point_in_laser) < d
    };
    let mut label: Vec<usize> = (0..n).collect();
    loop {
        let mut changed = false;
        for i in 0..n {
            for j in 0..n {
                if i != j && joined(i, j) && label[j] < label[i] {
                    label[i] = label[j];
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut seen = std::collections::BTreeMap::new();
    for (i, &l) in label.iter().enumerate() {
        let k = *seen.entry(l).or_insert_with(|| {
            out.push(Vec::new());
            out.len() - 1
        });
        out[k].push(i);
    }
    out
}

#[test]
fn euclidean_clustering_is_exact() {
    // Cluttered scans: random objects at random ranges, some beams missing.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..40 {
        let mut ranges = Vec::new();
        while ranges.len() < 300 {
            let (r, len) = (0.05 + 4.0 * next(), 1 + (12.0 * next()) as usize);
            for _ in 0..len {
                let jitter = 0.05 * (next() - 0.5);
                ranges.push(if next() < 0.1 {
                    f32::NAN
                } else {
                    (r + jitter) as f32
                });
            }
        }
        let pts = points(ranges);
        for d in [0.05, 0.13, 0.3] {
            let rule = Breakpoint::Euclidean { distance_m: d };
            assert_eq!(clusters(&pts, rule), brute_force(&pts, d), "d = {d}");
        }
    }
}

#[test]
fn the_jump_caps_the_adaptive_threshold_far_away() {
    // Two legs of a stride at 3 m, 0.15 m apart along the ray: D_max ~ 0.2 m merges
    // them, the 0.13 m cap does not.
    let stride = points(vec![3.0, 3.0, 3.0, 2.85, 2.85, 2.85]);
    assert_eq!(lens(&stride, ADAPTIVE), vec![6]);
    assert_eq!(lens(&stride, Breakpoint::default()), vec![3, 3]);
}

#[test]
fn missing_beams_widen_the_gap_and_long_gaps_split() {
    let mut ranges = vec![2.0f32; 3];
    ranges.extend(vec![f32::INFINITY; 2]);
    ranges.extend(vec![2.0f32; 3]);
    assert_eq!(
        lens(&points(ranges.clone()), Breakpoint::default()),
        vec![6]
    );
    assert_eq!(lens(&points(ranges), ADAPTIVE), vec![6]);
    let mut ranges = vec![2.0f32; 3];
    ranges.extend(vec![f32::INFINITY; 40]); // 40 beams = 14 deg > lambda
    ranges.extend(vec![2.0f32; 3]);
    assert_eq!(lens(&points(ranges), Breakpoint::default()), vec![3, 3]);
}

#[test]
fn empty_input_gives_no_segment() {
    assert!(lens(&[], Breakpoint::default()).is_empty());
}

#[test]
fn validates_parameters() {
    assert!(Breakpoint::default().validate().is_ok());
    assert!(Breakpoint::Adaptive { lambda_rad: 0.0 }.validate().is_err());
    assert!(
        Breakpoint::AdaptiveOrJump {
            lambda_rad: 0.2,
            jump_m: 0.0
        }
        .validate()
        .is_err()
    );
    assert!(
        Breakpoint::FixedJump { jump_m: f64::NAN }
            .validate()
            .is_err()
    );
}
