//! tether's CLEAR MOT against py-motmetrics (PyPI `motmetrics`) on the same inputs:
//! seeded random multi-object sequences with identity switches, gaps, false positives
//! and near-threshold pairs, written to JSON and scored by
//! `tests/motmetrics_reference.py`; matches, misses, false positives and switches must
//! agree exactly, MOTA and MOTP to 1e-9.
//!
//! Needs `python3` with `motmetrics`; without it the test prints why and skips, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::ffi::OsStr;

use serde_json::{Value, json};
use tether_core::{Point2, World};
use tether_eval::ClearMot;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/motmetrics_reference.py");

/// SplitMix64: a small seeded generator, so that the sequence is the same everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
}

type Frame = (Vec<(u64, Point2<World>)>, Vec<(u64, Point2<World>)>);

/// `n` people walking in a 6 m square, each followed by a track with noise of about
/// 0.3 m, missed now and then (gaps of several frames), losing its id (a new track id,
/// or a neighbour's), plus clutter tracks, some just beyond the threshold.
fn sequence(seed: u64, frames: usize, n: usize) -> Vec<Frame> {
    let mut rng = Rng(seed);
    let mut pos: Vec<(f64, f64)> = (0..n)
        .map(|_| (6.0 * rng.unit(), 6.0 * rng.unit()))
        .collect();
    let mut vel: Vec<(f64, f64)> = (0..n)
        .map(|_| (0.2 * rng.unit() - 0.1, 0.2 * rng.unit() - 0.1))
        .collect();
    let mut track_of: Vec<u64> = (0..n as u64).map(|i| 100 + i).collect();
    let mut next_track = 100 + n as u64;
    let mut gap: Vec<usize> = vec![0; n];
    let mut out = Vec::new();
    for _ in 0..frames {
        let mut objects = Vec::new();
        let mut hypotheses = Vec::new();
        for i in 0..n {
            pos[i].0 += vel[i].0;
            pos[i].1 += vel[i].1;
            if rng.chance(0.1) {
                vel[i] = (0.2 * rng.unit() - 0.1, 0.2 * rng.unit() - 0.1);
            }
            // Some people leave the labels for a while (not seen).
            if rng.chance(0.93) {
                objects.push((i as u64 + 1, Point2::new(pos[i].0, pos[i].1)));
            }
            if gap[i] > 0 {
                gap[i] -= 1;
                continue;
            }
            if rng.chance(0.05) {
                gap[i] = 1 + (rng.next() % 6) as usize;
            }
            if rng.chance(0.03) {
                track_of[i] = next_track;
                next_track += 1;
            }
            if rng.chance(0.02) {
                let j = (rng.next() % n as u64) as usize;
                track_of.swap(i, j);
            }
            let noise = 0.6 * rng.unit();
            let angle = std::f64::consts::TAU * rng.unit();
            hypotheses.push((
                track_of[i],
                Point2::new(
                    pos[i].0 + noise * angle.cos(),
                    pos[i].1 + noise * angle.sin(),
                ),
            ));
        }
        for k in 0..(rng.next() % 3) {
            hypotheses.push((900 + k, Point2::new(6.0 * rng.unit(), 6.0 * rng.unit())));
        }
        // A track near a person but at 0.7 to 0.8 m: either side of the threshold.
        if rng.chance(0.3) && !objects.is_empty() {
            let (_, o) = objects[(rng.next() % objects.len() as u64) as usize];
            let r = 0.7 + 0.1 * rng.unit();
            hypotheses.push((950, Point2::new(o.x + r, o.y)));
        }
        // Hypotheses in a shuffled order.
        for k in (1..hypotheses.len()).rev() {
            let j = (rng.next() % (k as u64 + 1)) as usize;
            hypotheses.swap(k, j);
        }
        let mut seen = std::collections::BTreeSet::new();
        hypotheses.retain(|(id, _)| seen.insert(*id));
        out.push((objects, hypotheses));
    }
    out
}

fn have_motmetrics() -> bool {
    tether_testkit::or_skip(tether_testkit::python_modules(
        &["motmetrics"],
        "motmetrics",
    ))
    .is_some()
}

#[test]
fn clear_mot_agrees_with_motmetrics() {
    if !have_motmetrics() {
        return;
    }
    for (seed, frames, n) in [(1u64, 300usize, 4usize), (2, 200, 7), (3, 150, 1)] {
        let seq = sequence(seed, frames, n);
        let mut mot = ClearMot::new(0.75);
        for (o, h) in &seq {
            mot.add_frame(o, h);
        }
        let s = mot.summary();
        let doc = json!({
            "threshold_m": 0.75,
            "frames": seq.iter().map(|(o, h)| json!({
                "objects": o.iter().map(|(id, p)| json!([id, p.x, p.y])).collect::<Vec<_>>(),
                "hypotheses": h.iter().map(|(id, p)| json!([id, p.x, p.y])).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        });
        let path = std::env::temp_dir().join(format!(
            "tether-clear-mot-{seed}-{}.json",
            std::process::id()
        ));
        std::fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
        // motmetrics's figures; the run must succeed.
        let out = tether_testkit::python(&[OsStr::new(SCRIPT), path.as_os_str()]);
        let _ = std::fs::remove_file(&path);
        let r: Value = serde_json::from_str(&out).unwrap();
        let f = |k: &str| r[k].as_f64().unwrap();
        let what = format!("seed {seed}: tether {s:?} vs motmetrics {r}");
        assert_eq!(s.objects as f64, f("num_objects"), "{what}");
        // tether's matches are all correspondences, motmetrics' num_detections; its
        // num_matches leaves the switches out.
        assert_eq!(s.matches as f64, f("num_detections"), "{what}");
        assert_eq!(
            (s.matches - s.id_switches) as f64,
            f("num_matches"),
            "{what}"
        );
        assert_eq!(s.misses as f64, f("num_misses"), "{what}");
        assert_eq!(s.false_positives as f64, f("num_false_positives"), "{what}");
        assert_eq!(s.id_switches as f64, f("num_switches"), "{what}");
        assert!((s.mota - f("mota")).abs() < 1e-9, "{what}");
        assert!((s.motp_m - f("motp")).abs() < 1e-9, "{what}");
        // A sequence that tests something: switches, misses and false positives occur.
        assert!(
            s.id_switches > 0 || n == 1,
            "{what}: the sequence has no switch"
        );
        assert!(s.misses > 0 && s.false_positives > 0, "{what}");
    }
}
