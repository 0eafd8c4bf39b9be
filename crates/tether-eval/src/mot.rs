//! CLEAR MOT metrics (Bernardin and Stiefelhagen 2008) for evaluating people tracking,
//! with a match threshold of 0.75 m as Leigh et al. (ICRA 2015) used.
//!
//! Per frame, as py-motmetrics' `MOTAccumulator.update` does it (the reference the
//! tests compare with): first, in the order the objects are given, each object keeps
//! the hypothesis it was last matched to (in any earlier frame, not only the previous
//! one) if that hypothesis is present, not taken, and within the threshold; then the
//! remaining objects and hypotheses are matched by the Hungarian method on distance
//! (pairs beyond the threshold forbidden; as many pairs as possible, then the least
//! total distance). A match whose hypothesis differs from the one last matched to that
//! object is an identity switch. Distances are Euclidean, a pair at exactly the
//! threshold matches.
//!
//! `MOTA = 1 - (misses + false positives + switches) / objects`,
//! `MOTP = mean distance of the matches`.

use std::collections::BTreeMap;

use serde::Serialize;
use tether_core::{Point2, World};

use tether_fusion::assign::assign;

/// Accumulates CLEAR MOT over frames.
#[derive(Debug, Clone)]
pub struct ClearMot {
    threshold_m: f64,
    /// Object id -> hypothesis id of the last match.
    last_match: BTreeMap<u64, u64>,
    /// Matches of the previous frame (object -> hypothesis).
    previous: BTreeMap<u64, u64>,
    objects: u64,
    matches: u64,
    misses: u64,
    false_positives: u64,
    switches: u64,
    distance_sum_m: f64,
}

/// CLEAR MOT figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MotSummary {
    /// Multiple object tracking accuracy.
    pub mota: f64,
    /// Multiple object tracking precision: mean matched distance, m.
    pub motp_m: f64,
    /// Ground-truth objects summed over frames.
    pub objects: u64,
    /// Matched objects summed over frames.
    pub matches: u64,
    /// Objects with no hypothesis.
    pub misses: u64,
    /// Hypotheses with no object.
    pub false_positives: u64,
    /// Identity switches.
    pub id_switches: u64,
}

impl ClearMot {
    /// An accumulator with the given match threshold (0.75 m in the literature).
    pub fn new(threshold_m: f64) -> Self {
        ClearMot {
            threshold_m,
            last_match: BTreeMap::new(),
            previous: BTreeMap::new(),
            objects: 0,
            matches: 0,
            misses: 0,
            false_positives: 0,
            switches: 0,
            distance_sum_m: 0.0,
        }
    }

    /// Adds one frame: ground-truth objects and tracker hypotheses, each `(id, position)`.
    pub fn add_frame(
        &mut self,
        objects: &[(u64, Point2<World>)],
        hypotheses: &[(u64, Point2<World>)],
    ) {
        let t = self.threshold_m;
        let mut matched_o = vec![None::<usize>; objects.len()];
        let mut used_h = vec![false; hypotheses.len()];
        // Keep the last correspondence of each object that still holds.
        for (oi, (oid, op)) in objects.iter().enumerate() {
            if let Some(hid) = self.last_match.get(oid)
                && let Some(hi) = hypotheses.iter().position(|(h, _)| h == hid)
                && !used_h[hi]
                && hypotheses[hi].1.distance_m(*op) <= t
            {
                matched_o[oi] = Some(hi);
                used_h[hi] = true;
            }
        }
        // Hungarian on the rest.
        let free_o: Vec<usize> = (0..objects.len())
            .filter(|&i| matched_o[i].is_none())
            .collect();
        let free_h: Vec<usize> = (0..hypotheses.len()).filter(|&i| !used_h[i]).collect();
        let cost: Vec<Vec<Option<f64>>> = free_o
            .iter()
            .map(|&oi| {
                free_h
                    .iter()
                    .map(|&hi| {
                        let d = objects[oi].1.distance_m(hypotheses[hi].1);
                        (d <= t).then_some(d)
                    })
                    .collect()
            })
            .collect();
        for (k, a) in assign(&cost).into_iter().enumerate() {
            if let Some(j) = a {
                matched_o[free_o[k]] = Some(free_h[j]);
                used_h[free_h[j]] = true;
            }
        }
        let mut current = BTreeMap::new();
        for (oi, m) in matched_o.iter().enumerate() {
            let oid = objects[oi].0;
            match m {
                Some(hi) => {
                    let hid = hypotheses[*hi].0;
                    self.matches += 1;
                    self.distance_sum_m += objects[oi].1.distance_m(hypotheses[*hi].1);
                    if let Some(prev) = self.last_match.insert(oid, hid)
                        && prev != hid
                    {
                        self.switches += 1;
                    }
                    current.insert(oid, hid);
                }
                None => self.misses += 1,
            }
        }
        self.objects += objects.len() as u64;
        self.false_positives += used_h.iter().filter(|u| !**u).count() as u64;
        self.previous = current;
    }

    /// The correspondences of the last frame: object id -> hypothesis id.
    pub fn current_matches(&self) -> &BTreeMap<u64, u64> {
        &self.previous
    }

    /// The figures so far.
    pub fn summary(&self) -> MotSummary {
        let mota = if self.objects > 0 {
            1.0 - (self.misses + self.false_positives + self.switches) as f64 / self.objects as f64
        } else {
            f64::NAN
        };
        MotSummary {
            mota,
            motp_m: if self.matches > 0 {
                self.distance_sum_m / self.matches as f64
            } else {
                f64::NAN
            },
            objects: self.objects,
            matches: self.matches,
            misses: self.misses,
            false_positives: self.false_positives,
            id_switches: self.switches,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point2<World> {
        Point2::new(x, y)
    }

    #[test]
    fn perfect_tracking_scores_one() {
        let mut m = ClearMot::new(0.75);
        for k in 0..10 {
            let x = k as f64 * 0.1;
            m.add_frame(
                &[(1, p(x, 0.0)), (2, p(x, 2.0))],
                &[(10, p(x + 0.1, 0.0)), (20, p(x, 2.0))],
            );
        }
        let s = m.summary();
        assert_eq!((s.misses, s.false_positives, s.id_switches), (0, 0, 0));
        assert!((s.mota - 1.0).abs() < 1e-12);
        assert!((s.motp_m - 0.05).abs() < 1e-12);
    }

    #[test]
    fn counts_misses_false_positives_and_switches() {
        let mut m = ClearMot::new(0.75);
        m.add_frame(&[(1, p(0.0, 0.0))], &[(10, p(0.0, 0.0))]);
        // The track changes identity: one switch.
        m.add_frame(&[(1, p(0.0, 0.0))], &[(11, p(0.1, 0.0))]);
        // Nothing tracked: a miss; a hypothesis far away: a false positive.
        m.add_frame(&[(1, p(0.0, 0.0))], &[(12, p(5.0, 0.0))]);
        let s = m.summary();
        assert_eq!(
            (
                s.objects,
                s.matches,
                s.misses,
                s.false_positives,
                s.id_switches
            ),
            (3, 2, 1, 1, 1)
        );
        assert!((s.mota - (1.0 - 3.0 / 3.0)).abs() < 1e-12);
    }

    #[test]
    fn keeps_a_correspondence_across_a_missed_frame() {
        // Object 1 matched to 10, then missed (10 too far), then 10 is back within the
        // threshold with 11 nearer: 10 is kept, no switch (py-motmetrics' rule).
        let mut m = ClearMot::new(0.75);
        m.add_frame(&[(1, p(0.0, 0.0))], &[(10, p(0.1, 0.0))]);
        m.add_frame(&[(1, p(0.0, 0.0))], &[(10, p(2.0, 0.0))]);
        m.add_frame(
            &[(1, p(0.0, 0.0))],
            &[(10, p(0.5, 0.0)), (11, p(0.05, 0.0))],
        );
        let s = m.summary();
        assert_eq!((s.matches, s.misses, s.id_switches), (2, 1, 0));
        assert_eq!(m.current_matches().get(&1), Some(&10));
    }

    #[test]
    fn keeps_a_correspondence_while_it_holds() {
        // Two hypotheses near one object: the one matched before stays matched even if
        // the other is slightly closer now.
        let mut m = ClearMot::new(0.75);
        m.add_frame(&[(1, p(0.0, 0.0))], &[(10, p(0.1, 0.0))]);
        m.add_frame(
            &[(1, p(0.0, 0.0))],
            &[(10, p(0.3, 0.0)), (11, p(0.05, 0.0))],
        );
        let s = m.summary();
        assert_eq!((s.id_switches, s.false_positives), (0, 1));
    }
}
