//! Confirmation over the last scans (design 4.6): a candidate that the classifier
//! accepts only narrowly is a leg when a candidate it accepted stood near it a moment
//! ago; alone, it is a weak leg.
//!
//! Most of the false legs a room gives (a chair's leg seen for one scan through a gap,
//! a fold of a curtain, a bin's edge) flicker: about half of those on the test
//! recording's rear scanner have no accepted candidate within 0.2 m in the scan before.
//! A person's legs do not vanish between scans, and a walking leg moves at most about
//! one stride a scan. So the decision margin `d` is kept for a candidate supported by
//! the recent past, and raised by `extra_margin` for one that is not:
//!
//! ```text
//! leg    <=>  F(x) >= d + extra_margin
//!             or  (F(x) >= d  and  |c - c'| <= radius_m  for some c' accepted
//!                  (F >= d) in a scan of the last window_s seconds)
//! ```
//!
//! `c` are leg centres in the scan's frame: a robot turning at 1 rad/s moves a leg
//! 1 m away by 0.4 m in 0.4 s, inside the radius. A candidate between `d` and
//! `d + extra_margin` without support is reported among the weak legs and as an
//! unconfirmed person (`Detection::unconfirmed_people`). The three values of
//! [`ConfirmConfig::PER_SCAN`] were chosen by cross-validation on the training split
//! (design 4.6).
//!
//! A candidate that the last scan could not see needs no support: where that scan's
//! beam toward it returned from at least [`SHADOW_DEPTH_M`] nearer, something stood in
//! the way, and a person stepping out from behind a pillar or a passer-by is judged at
//! the plain margin.
//!
//! Off in [`ConfirmConfig::default`] (the pipeline's: its tracker confirms people over
//! scans itself, and there a leg this rule holds back still updates tracks, tentative
//! ones too, but starts none); on ([`ConfirmConfig::PER_SCAN`]) where the legs of each
//! scan are the product: `tether legs` and `tether eval-legs`.

use serde::{Deserialize, Serialize};
use tether_core::{Laser, LaserScan, Point2, Stamp};

/// A return this much nearer than a candidate's centre, on a scan's beam toward it,
/// hid the candidate from that scan, m: farther than a person's other leg stands
/// in front of a leg (0.2-0.4 m; that leg supports it anyway), so that what hid it was
/// something else (a pillar, a passer-by).
pub const SHADOW_DEPTH_M: f64 = 0.5;

/// Parameters of the confirmation of narrow legs over the last scans (design 4.6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct ConfirmConfig {
    /// How far above the decision margin a candidate without support must score to be
    /// a leg, in units of the margin's [-1, 1] range (default 0: no confirmation, the
    /// pipeline's choice; 0.06 in `tether legs` and `eval-legs`).
    #[config(range = ">= 0, <= 2")]
    pub extra_margin: f64,
    /// Largest distance from an accepted candidate of a recent scan that supports a
    /// candidate, m (default 0.8).
    #[config(range = "> 0")]
    pub radius_m: f64,
    /// How far back the scans that support a candidate go, s (default 0.4: three scans
    /// at 7.5 Hz, sixteen at 40 Hz).
    #[config(range = "> 0, <= 5")]
    pub window_s: f64,
}

impl Default for ConfirmConfig {
    fn default() -> Self {
        ConfirmConfig {
            extra_margin: 0.0,
            radius_m: 0.8,
            window_s: 0.4,
        }
    }
}

impl ConfirmConfig {
    /// The confirmation of the legs of each scan as a product (`tether legs`, `tether
    /// eval-legs`): the grid point with the highest F1 of the held-out folds of the
    /// training split (`cargo run --release -p tether-laser --example confirm_choice`).
    pub const PER_SCAN: ConfirmConfig = ConfirmConfig {
        extra_margin: 0.06,
        radius_m: 0.8,
        window_s: 0.4,
    };

    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.extra_margin.is_finite() && (0.0..=2.0).contains(&self.extra_margin)) {
            return Err(format!(
                "confirm.extra_margin must be in [0, 2], got {}",
                self.extra_margin
            ));
        }
        if !(self.radius_m.is_finite() && self.radius_m > 0.0) {
            return Err(format!(
                "confirm.radius_m must be > 0, got {}",
                self.radius_m
            ));
        }
        if !(self.window_s.is_finite() && self.window_s > 0.0 && self.window_s <= 5.0) {
            return Err(format!(
                "confirm.window_s must be in (0, 5], got {}",
                self.window_s
            ));
        }
        Ok(())
    }
}

/// The beams of one scan: its stamp, first direction, step and ranges.
#[derive(Debug, Clone, Default)]
struct Beams {
    stamp: Stamp,
    angle_min_rad: f64,
    step_rad: f64,
    ranges_m: Vec<f32>,
}

impl Beams {
    /// Whether this scan's beam toward `centre` returned from [`SHADOW_DEPTH_M`] or
    /// more nearer.
    fn hid(&self, centre: Point2<Laser>) -> bool {
        let n = self.ranges_m.len() as f64;
        if n == 0.0 || self.step_rad == 0.0 {
            return false;
        }
        let turn = std::f64::consts::TAU / self.step_rad.abs();
        // The beam index of the centre's bearing, a whole turn on or back if needed.
        let mut k = (centre.bearing_rad() - self.angle_min_rad) / self.step_rad;
        if k < -0.5 {
            k += turn;
        } else if k > n - 0.5 {
            k -= turn;
        }
        let k = k.round();
        (0.0..n).contains(&k)
            && f64::from(self.ranges_m[k as usize]) < centre.range_m() - SHADOW_DEPTH_M
    }
}

/// What the last scans of one scanner showed: the candidates they accepted and their
/// beams, by stamp. After the first scans it allocates only when a scan holds more
/// than any before.
#[derive(Debug, Clone, Default)]
pub struct RecentLegs {
    /// (stamp of the scan, leg centre in its frame), oldest first.
    recent: Vec<(Stamp, Point2<Laser>)>,
    /// This scan's accepted candidates, added to `recent` by [`RecentLegs::finish_scan`].
    current: Vec<Point2<Laser>>,
    /// The stamp of the scan being detected.
    now: Option<Stamp>,
    /// The beams of the scans in the window, this one's last once kept.
    beams: Vec<Beams>,
    /// Buffers of scans that left the window, for reuse.
    spare: Vec<Beams>,
}

impl RecentLegs {
    /// Starts the scan stamped `now`: forgets what lies outside `(now - window_s, now)`
    /// and, when the stamps run backwards (a replay started again, another recording),
    /// everything.
    pub fn start_scan(&mut self, now: Stamp, window_s: f64) {
        if self.now.is_some_and(|last| now < last) {
            self.recent.clear();
        }
        let inside = |t: Stamp| t < now && now.secs_since(t) <= window_s;
        self.recent.retain(|&(t, _)| inside(t));
        let mut k = 0;
        while k < self.beams.len() {
            if inside(self.beams[k].stamp) {
                k += 1;
            } else {
                self.spare.push(self.beams.remove(k));
            }
        }
        self.current.clear();
        self.now = Some(now);
    }

    /// Keeps `scan`'s beams (the scan being detected) for [`RecentLegs::was_hidden`]
    /// on the next scans.
    pub fn keep_beams(&mut self, scan: &LaserScan) {
        let mut b = self.spare.pop().unwrap_or_default();
        b.stamp = scan.stamp;
        (b.angle_min_rad, b.step_rad) = (scan.angle_min_rad, scan.angle_increment_rad);
        b.ranges_m.clear();
        b.ranges_m.extend_from_slice(scan.ranges_m());
        self.beams.push(b);
    }

    /// Whether the last scan before this one (inside the window) could not see
    /// `centre`: its beam toward it returned from [`SHADOW_DEPTH_M`] or more nearer.
    pub fn was_hidden(&self, centre: Point2<Laser>) -> bool {
        let now = self.now;
        self.beams
            .iter()
            .rev()
            .find(|b| now.is_some_and(|now| b.stamp < now))
            .is_some_and(|b| b.hid(centre))
    }

    /// Whether an accepted candidate of a recent scan (not this one) stood within
    /// `radius_m` of `centre`.
    pub fn supports(&self, centre: Point2<Laser>, radius_m: f64) -> bool {
        self.recent
            .iter()
            .any(|&(_, c)| c.distance_m(centre) <= radius_m)
    }

    /// Notes a candidate of this scan that reached the decision margin.
    pub fn accepted(&mut self, centre: Point2<Laser>) {
        self.current.push(centre);
    }

    /// Ends the scan: its accepted candidates support the next scans'.
    pub fn finish_scan(&mut self) {
        if let Some(now) = self.now {
            self.recent.extend(self.current.drain(..).map(|c| (now, c)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> Stamp {
        Stamp::from_secs_f64(s).expect("a stamp")
    }

    fn p(x: f64, y: f64) -> Point2<Laser> {
        Point2::new(x, y)
    }

    #[test]
    fn a_candidate_is_supported_by_the_last_scans_within_the_window_only() {
        let mut r = RecentLegs::default();
        r.start_scan(at(1.0), 0.4);
        assert!(!r.supports(p(1.0, 0.0), 0.8), "nothing seen yet");
        r.accepted(p(1.0, 0.0));
        assert!(
            !r.supports(p(1.0, 0.0), 0.8),
            "a scan's own candidates do not support each other"
        );
        r.finish_scan();
        r.start_scan(at(1.1), 0.4);
        assert!(r.supports(p(1.5, 0.5), 0.8));
        assert!(!r.supports(p(2.0, 0.0), 0.8), "farther than the radius");
        r.finish_scan();
        r.start_scan(at(1.5), 0.4);
        assert!(!r.supports(p(1.0, 0.0), 0.8), "older than the window");
    }

    #[test]
    fn stamps_that_run_backwards_forget_the_past() {
        let mut r = RecentLegs::default();
        r.start_scan(at(5.0), 0.4);
        r.accepted(p(1.0, 0.0));
        r.finish_scan();
        r.start_scan(at(4.9), 0.4);
        assert!(!r.supports(p(1.0, 0.0), 0.8));
        r.finish_scan();
        // The same stamp again (a view of the same scan) is no support either.
        r.start_scan(at(4.9), 0.4);
        r.accepted(p(1.0, 0.0));
        r.finish_scan();
        r.start_scan(at(4.9), 0.4);
        assert!(!r.supports(p(1.0, 0.0), 0.8));
    }

    fn scan(stamp_s: f64, angle_min_rad: f64, step_rad: f64, ranges: Vec<f32>) -> LaserScan {
        LaserScan::new(
            at(stamp_s),
            "laser",
            angle_min_rad,
            step_rad,
            0.02,
            30.0,
            ranges,
        )
        .expect("a scan")
    }

    #[test]
    fn a_candidate_behind_something_in_the_last_scan_was_hidden() {
        let step = 1f64.to_radians();
        // A 360-degree scan, clockwise: a pillar at 1 m straight ahead (bearing 0).
        let mut ranges = vec![5.0f32; 360];
        ranges[180] = 1.0;
        let mut r = RecentLegs::default();
        r.start_scan(at(1.0), 0.4);
        r.keep_beams(&scan(1.0, std::f64::consts::PI, -step, ranges));
        r.finish_scan();
        r.start_scan(at(1.1), 0.4);
        assert!(r.was_hidden(p(2.0, 0.0)), "behind the pillar");
        assert!(!r.was_hidden(p(1.3, 0.0)), "just behind it: not hidden");
        assert!(!r.was_hidden(p(2.0, 0.2)), "beside it");
        // Older than the window: nothing is known.
        r.finish_scan();
        r.start_scan(at(2.0), 0.4);
        assert!(!r.was_hidden(p(2.0, 0.0)));
    }

    #[test]
    fn bad_configs_are_refused() {
        assert!(ConfirmConfig::default().validate().is_ok());
        for bad in [
            ConfirmConfig {
                extra_margin: f64::NAN,
                ..ConfirmConfig::default()
            },
            ConfirmConfig {
                extra_margin: -0.1,
                ..ConfirmConfig::default()
            },
            ConfirmConfig {
                radius_m: 0.0,
                ..ConfirmConfig::default()
            },
            ConfirmConfig {
                window_s: f64::INFINITY,
                ..ConfirmConfig::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
