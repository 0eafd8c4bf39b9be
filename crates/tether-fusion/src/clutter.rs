//! Static clutter learned over time: places where leg-like clusters keep appearing
//! without anybody walking there (bushes, poles, table and chair legs, bins, the robot's
//! own parts), so that they stop starting person tracks and cannot capture a track
//! that coasts past them.
//!
//! A grid of `cell_m` cells in one frame (the world frame for the scenery; the sensor's
//! frame for the robot's own parts, which move with it). Each scan adds its candidate
//! positions that no walking person explains ([`ClutterMap::observe`]). A cell's
//! evidence `e` (seconds of presence) rises by the scan interval `dt` each scan that has
//! a candidate within `spread_m` of it and decays at `forget_rate` per second otherwise:
//!
//! `e(t) = max(0, e(t_seen) - forget_rate (t - t_seen))`, then `e += dt` on a sighting,
//! capped at `max_evidence_s`.
//!
//! Over a time `T` in which something is seen in a fraction `f` of the scans, the
//! evidence changes by `(f - forget_rate) T`: something seen in every scan becomes
//! static after `static_after_s / (1 - forget_rate)` seconds (5.3 s by default),
//! something seen in two scans of three after 9.6 s, and a flicker seen in fewer than
//! `forget_rate` of the scans (a quarter) never. A cell stays static while it keeps
//! being seen, and is forgotten some time after it is gone.
//!
//! In the spirit of leg_tracker's local occupancy map (Leigh et al., ICRA 2015), which
//! keeps tracks from starting in occupied space; here the map holds only what the leg
//! detector confuses with legs, since walls never look like legs.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::marker::PhantomData;

use serde::{Deserialize, Serialize};
use tether_core::{Frame, Point2, Stamp};

/// Settings of a clutter map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct ClutterConfig {
    /// Learn static clutter (off: nothing is ever static).
    pub enabled: bool,
    /// Grid cell size, m.
    #[config(range = "> 0")]
    pub cell_m: f64,
    /// A sighting counts for every cell whose centre is within this of it, m (the jitter
    /// of a static cluster's centre from scan to scan, ~2-5 cm, plus half a cell).
    #[config(range = ">= 0")]
    pub spread_m: f64,
    /// Evidence that makes a cell static, s of presence.
    #[config(range = "> 0")]
    pub static_after_s: f64,
    /// Evidence lost per second without a sighting (relative to time: 0.25 forgets a
    /// second of presence in four seconds of absence).
    #[config(range = "> 0")]
    pub forget_rate: f64,
    /// Evidence cap, s: how long a static place is remembered once it is gone is
    /// `(max_evidence_s - static_after_s) / forget_rate`.
    pub max_evidence_s: f64,
    /// Longest scan interval credited as presence, s (a gap in the data is not
    /// presence).
    #[config(range = "> 0")]
    pub max_dt_s: f64,
}

impl Default for ClutterConfig {
    fn default() -> Self {
        ClutterConfig {
            enabled: true,
            cell_m: 0.1,
            spread_m: 0.1,
            static_after_s: 4.0,
            forget_rate: 0.25,
            max_evidence_s: 12.0,
            max_dt_s: 0.2,
        }
    }
}

impl ClutterConfig {
    /// Checks every field; says what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("cell_m", self.cell_m),
            ("static_after_s", self.static_after_s),
            ("forget_rate", self.forget_rate),
            ("max_dt_s", self.max_dt_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("clutter {name} must be > 0, got {v}"));
            }
        }
        if !(self.spread_m.is_finite() && self.spread_m >= 0.0) {
            return Err(format!(
                "clutter spread_m must be >= 0, got {}",
                self.spread_m
            ));
        }
        if !(self.max_evidence_s.is_finite() && self.max_evidence_s >= self.static_after_s) {
            return Err(format!(
                "clutter max_evidence_s must be >= static_after_s ({}), got {}",
                self.static_after_s, self.max_evidence_s
            ));
        }
        if self.spread_m / self.cell_m > 8.0 {
            return Err(format!(
                "clutter spread_m ({}) may be at most 8 cells of cell_m ({})",
                self.spread_m, self.cell_m
            ));
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy)]
struct Cell {
    evidence_s: f64,
    seen: Stamp,
}

impl Cell {
    fn evidence_at(&self, now: Stamp, forget_rate: f64) -> f64 {
        (self.evidence_s - forget_rate * now.secs_since(self.seen).max(0.0)).max(0.0)
    }
}

/// A deterministic hasher for the grid (the same map gives the same answers on every
/// run; the std default is seeded at random).
type GridHasher = BuildHasherDefault<std::collections::hash_map::DefaultHasher>;

/// Static clutter in frame `F`.
#[derive(Debug, Clone)]
pub struct ClutterMap<F: Frame> {
    config: ClutterConfig,
    cells: HashMap<(i32, i32), Cell, GridHasher>,
    last_scan: Option<Stamp>,
    scans: u64,
    frame: PhantomData<F>,
}

impl<F: Frame> ClutterMap<F> {
    /// An empty map with checked settings.
    pub fn new(config: ClutterConfig) -> Result<Self, String> {
        config.validate()?;
        Ok(ClutterMap {
            config,
            cells: HashMap::default(),
            last_scan: None,
            scans: 0,
            frame: PhantomData,
        })
    }

    /// Settings.
    pub fn config(&self) -> &ClutterConfig {
        &self.config
    }

    /// Cells held (for statistics).
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether no cell is held.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    fn key(&self, x: f64, y: f64) -> Option<(i32, i32)> {
        let (i, j) = (
            (x / self.config.cell_m).round(),
            (y / self.config.cell_m).round(),
        );
        // Far outside any scan's reach (or NaN): not a place.
        (i.abs() < 1e8 && j.abs() < 1e8).then_some((i as i32, j as i32))
    }

    /// Adds one scan's candidate positions taken at `stamp` (candidates that a walking
    /// person explains should be left out by the caller). A scan older than the last one
    /// is ignored.
    pub fn observe(&mut self, stamp: Stamp, points: &[Point2<F>]) {
        if !self.config.enabled || self.last_scan.is_some_and(|t| stamp <= t) {
            return;
        }
        let dt_s = self
            .last_scan
            .map_or(0.1, |t| stamp.secs_since(t))
            .min(self.config.max_dt_s);
        self.last_scan = Some(stamp);
        let c = &self.config;
        let reach = (c.spread_m / c.cell_m).ceil() as i32;
        let spread_sq = c.spread_m * c.spread_m;
        for p in points {
            let Some((i0, j0)) = self.key(p.x, p.y) else {
                continue;
            };
            for i in i0 - reach..=i0 + reach {
                for j in j0 - reach..=j0 + reach {
                    let (cx, cy) = (f64::from(i) * c.cell_m, f64::from(j) * c.cell_m);
                    let d_sq = (cx - p.x).powi(2) + (cy - p.y).powi(2);
                    if d_sq > spread_sq && (i, j) != (i0, j0) {
                        continue;
                    }
                    let cell = self.cells.entry((i, j)).or_insert(Cell {
                        evidence_s: 0.0,
                        seen: stamp,
                    });
                    if cell.seen == stamp && cell.evidence_s > 0.0 {
                        continue; // already credited by another candidate of this scan
                    }
                    let e = cell.evidence_at(stamp, c.forget_rate) + dt_s;
                    *cell = Cell {
                        evidence_s: e.min(c.max_evidence_s),
                        seen: stamp,
                    };
                }
            }
        }
        self.scans += 1;
        if self.scans.is_multiple_of(64) {
            let rate = c.forget_rate;
            self.cells
                .retain(|_, cell| cell.evidence_at(stamp, rate) > 0.0);
        }
    }

    /// The evidence of static clutter at `p` at `now`, s of presence.
    pub fn evidence_s(&self, p: Point2<F>, now: Stamp) -> f64 {
        self.key(p.x, p.y)
            .and_then(|k| self.cells.get(&k))
            .map_or(0.0, |cell| cell.evidence_at(now, self.config.forget_rate))
    }

    /// Whether `p` is in static clutter at `now`.
    pub fn is_static(&self, p: Point2<F>, now: Stamp) -> bool {
        self.config.enabled && self.evidence_s(p, now) >= self.config.static_after_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::World;

    fn at(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    fn map() -> ClutterMap<World> {
        ClutterMap::new(ClutterConfig::default()).unwrap()
    }

    #[test]
    fn a_pole_becomes_static_and_a_walker_does_not() {
        let mut m = map();
        let pole = Point2::new(2.0, 1.0);
        let mut became = None;
        for k in 0..100 {
            // The pole jitters by a few cm; a walker passes at 1 m/s.
            let jitter = 0.03 * ((k % 3) as f64 - 1.0);
            let walker = Point2::new(-3.0 + 0.1 * k as f64, -1.0);
            m.observe(at(100 * k), &[Point2::new(pole.x + jitter, pole.y), walker]);
            if became.is_none() && m.is_static(pole, at(100 * k)) {
                became = Some(k);
            }
            assert!(
                !m.is_static(walker, at(100 * k)),
                "walker static at scan {k}"
            );
        }
        // 4 s of evidence at 0.075 s gained per 0.1 s scan: ~5.3 s.
        let k = became.expect("the pole is learned");
        assert!((50..=56).contains(&k), "static after {k} scans");
        // Forgotten some time after it is gone: (12 - 4) / 0.25 = 32 s at most.
        for k in 100..500 {
            m.observe(at(100 * k), &[]);
        }
        assert!(!m.is_static(pole, at(50_000)));
        assert!(m.len() < 10, "empty cells are pruned: {}", m.len());
    }

    #[test]
    fn flicker_below_half_the_scans_is_not_static() {
        let mut m = map();
        let p = Point2::new(1.0, 1.0);
        for k in 0..600 {
            let seen: &[Point2<World>] = if k % 5 == 0 { &[p] } else { &[] };
            m.observe(at(100 * k), seen);
        }
        assert!(!m.is_static(p, at(59_900)));
        let mut m = map();
        for k in 0..600 {
            let seen: &[Point2<World>] = if k % 3 != 0 { &[p] } else { &[] };
            m.observe(at(100 * k), seen);
        }
        assert!(
            m.is_static(p, at(59_900)),
            "seen in 2 of 3 scans for a minute"
        );
    }

    #[test]
    fn a_data_gap_is_not_presence_and_old_scans_are_ignored() {
        let mut m = map();
        let p = Point2::new(1.0, 0.0);
        m.observe(at(0), &[p]);
        m.observe(at(60_000), &[p]);
        assert!(m.evidence_s(p, at(60_000)) <= 0.2 + 1e-9);
        m.observe(at(50_000), &[p; 3]);
        assert!(m.evidence_s(p, at(60_000)) <= 0.2 + 1e-9);
        m.observe(
            at(60_100),
            &[Point2::new(f64::NAN, 0.0), Point2::new(1e12, 0.0)],
        );
    }

    #[test]
    fn settings_are_checked_and_disabled_maps_learn_nothing() {
        let bad = ClutterConfig {
            cell_m: 0.0,
            ..ClutterConfig::default()
        };
        assert!(ClutterMap::<World>::new(bad).is_err());
        let bad = ClutterConfig {
            max_evidence_s: 1.0,
            ..ClutterConfig::default()
        };
        assert!(bad.validate().is_err());
        let mut m = ClutterMap::<World>::new(ClutterConfig {
            enabled: false,
            ..ClutterConfig::default()
        })
        .unwrap();
        for k in 0..200 {
            m.observe(at(100 * k), &[Point2::new(1.0, 1.0)]);
        }
        assert!(!m.is_static(Point2::new(1.0, 1.0), at(20_000)));
    }
}
