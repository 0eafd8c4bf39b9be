//! The safety layer, always on (design 6): no motion before a target is locked, stop when
//! the target is lost or the data are stale (watchdog), never drive towards a laser
//! return closer than a stop distance in the direction of travel.

use serde::{Deserialize, Serialize};
use tether_core::{Point2, Robot, Stamp};

/// The turn rate of the opt-in search for a lost target, rad/s: slow enough for the
/// sensors to see what sweeps past (a camera frame every 2 degrees at 15 Hz).
pub const SEARCH_RATE_RADPS: f64 = 0.5;

/// Safety settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyConfig {
    /// Stop when the newest laser scan is older than this, s.
    #[config(range = "> 0, <= 1")]
    pub laser_timeout_s: f64,
    /// Stop when the target's estimate has not been updated for this long, s. Until
    /// then the robot follows the target where it should be (its track's prediction),
    /// at a pace that falls to zero by then (see `unseen_full_pace_s`).
    #[config(range = "> 0, <= 2")]
    pub target_timeout_s: f64,
    /// For this long an unseen target is followed at full pace, s; from then the pace
    /// falls linearly to zero at `target_timeout_s`, and the robot stops at once when
    /// another person is within `unseen_clear_m` of where the target should be (design
    /// 6, safety 2). A missed scan or two changes nothing.
    #[config(range = ">= 0, <= 2")]
    pub unseen_full_pace_s: f64,
    /// Another person this near where an unseen target should be makes the guess
    /// ambiguous, m: the robot stops (`unseen_among_others`).
    #[config(range = ">= 0, <= 5")]
    pub unseen_clear_m: f64,
    /// Free space kept ahead of the footprint in the direction of travel, m.
    #[config(range = ">= 0.1, <= 3")]
    pub stop_distance_m: f64,
    /// Radius of the robot's footprint, m.
    #[config(range = "> 0, <= 2")]
    pub robot_radius_m: f64,
    /// Extra width on each side of the footprint's corridor, m.
    #[config(range = ">= 0, <= 1")]
    pub corridor_margin_m: f64,
    /// For this long after losing the target the robot, standing, turns on the spot
    /// towards where the target should be, s (0: it only stands).
    #[config(range = ">= 0, <= 60")]
    pub search_turn_s: f64,
    /// The opt-in search for a lost target (0: off): once that turn is done, the robot
    /// rotates on the spot on toward the side where the target was last seen, at
    /// `SEARCH_RATE_RADPS`, until it has turned this far since the loss, rad, as Nav2's
    /// Following Server rotates to search.
    #[config(range = ">= 0, <= 2pi")]
    pub search_rotate_rad: f64,
    /// The search ends this long after the loss, s, whatever it has turned.
    #[config(range = ">= 0, <= 60")]
    pub search_rotate_s: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig {
            laser_timeout_s: 0.3,
            target_timeout_s: 1.0,
            unseen_full_pace_s: 0.3,
            unseen_clear_m: 1.0,
            stop_distance_m: 0.35,
            robot_radius_m: 0.2,
            corridor_margin_m: 0.05,
            search_turn_s: 3.0,
            search_rotate_rad: 0.0,
            search_rotate_s: 10.0,
        }
    }
}

/// Why the robot may not drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// No target has been locked yet.
    NoTarget,
    /// The target was lost.
    TargetLost,
    /// The laser went silent.
    StaleLaser,
    /// The target's estimate is too old.
    StaleTarget,
    /// The target has gone unseen with another person near where it should be: the
    /// robot does not follow a guess that could be somebody else.
    UnseenAmongOthers,
    /// Something is in the way ahead (turning is still allowed).
    Obstacle,
}

impl StopReason {
    /// Name used in files.
    pub fn name(self) -> &'static str {
        match self {
            StopReason::NoTarget => "no_target",
            StopReason::TargetLost => "target_lost",
            StopReason::StaleLaser => "stale_laser",
            StopReason::StaleTarget => "stale_target",
            StopReason::UnseenAmongOthers => "unseen_among_others",
            StopReason::Obstacle => "obstacle",
        }
    }
}

/// A safety setting out of its safe range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("safety `{field}` = {value:?} is refused: {why}")]
pub struct SafetyConfigError {
    /// Field.
    pub field: &'static str,
    /// Value.
    pub value: f64,
    /// The range and why.
    pub why: &'static str,
}

impl SafetyConfig {
    /// Checks every field against a range that keeps the safety layer on: a watchdog
    /// of `inf` or 1e9 s never fires, a stop distance of 0 or below lets the robot
    /// touch what is ahead.
    pub fn validate(&self) -> Result<(), SafetyConfigError> {
        for (field, value, low, high, why) in [
            (
                "laser_timeout_s",
                self.laser_timeout_s,
                f64::MIN_POSITIVE,
                1.0,
                "must be in (0, 1] s: at 1.4 m/s a robot drives 1.4 m blind in a second \
                 (a scanner's period is 0.025-0.2 s)",
            ),
            (
                "target_timeout_s",
                self.target_timeout_s,
                f64::MIN_POSITIVE,
                2.0,
                "must be in (0, 2] s: longer drives on towards a guess",
            ),
            (
                "unseen_full_pace_s",
                self.unseen_full_pace_s,
                0.0,
                self.target_timeout_s,
                "must be in [0, target_timeout_s] s",
            ),
            (
                "unseen_clear_m",
                self.unseen_clear_m,
                0.0,
                5.0,
                "must be in [0, 5] m (0: never ambiguous)",
            ),
            (
                "stop_distance_m",
                self.stop_distance_m,
                0.1,
                3.0,
                "must be in [0.1, 3] m of free space ahead of the footprint",
            ),
            (
                "robot_radius_m",
                self.robot_radius_m,
                f64::MIN_POSITIVE,
                2.0,
                "must be in (0, 2] m",
            ),
            (
                "corridor_margin_m",
                self.corridor_margin_m,
                0.0,
                1.0,
                "must be in [0, 1] m",
            ),
            (
                "search_turn_s",
                self.search_turn_s,
                0.0,
                60.0,
                "must be in [0, 60] s",
            ),
            (
                "search_rotate_rad",
                self.search_rotate_rad,
                0.0,
                std::f64::consts::TAU,
                "must be in [0, 6.28] rad (0: no search; 6.28: one whole turn)",
            ),
            (
                "search_rotate_s",
                self.search_rotate_s,
                0.0,
                60.0,
                "must be in [0, 60] s",
            ),
        ] {
            if !(value.is_finite() && (low..=high).contains(&value)) {
                return Err(SafetyConfigError { field, value, why });
            }
        }
        Ok(())
    }

    /// Checks the watchdogs at `now` given when the last scan and the last target update
    /// arrived.
    pub fn watchdog(
        &self,
        now: Stamp,
        last_scan: Option<Stamp>,
        last_target_update: Option<Stamp>,
    ) -> Option<StopReason> {
        match last_scan {
            Some(t) if now.secs_since(t) <= self.laser_timeout_s => {}
            _ => return Some(StopReason::StaleLaser),
        }
        match last_target_update {
            Some(t) if now.secs_since(t) <= self.target_timeout_s => None,
            _ => Some(StopReason::StaleTarget),
        }
    }

    /// Distance from the footprint's front to the nearest return in the corridor the
    /// robot sweeps when driving forward, m (`None` when the corridor is clear up to the
    /// stop distance).
    pub fn obstacle_ahead_m(
        &self,
        points_in_robot: impl IntoIterator<Item = Point2<Robot>>,
    ) -> Option<f64> {
        let half_width = self.robot_radius_m + self.corridor_margin_m;
        points_in_robot
            .into_iter()
            .filter(|p| p.is_finite() && p.y.abs() <= half_width && p.x > 0.0)
            .map(|p| p.x - self.robot_radius_m)
            .filter(|gap| *gap < self.stop_distance_m)
            .min_by(f64::total_cmp)
    }
}

impl SafetyConfig {
    /// Distance along the arc the robot drives at turn rate `w` for speed `v` (> 0) to
    /// the first return its footprint (plus margin) would touch, if that happens within
    /// the stop distance; `None` when the arc is clear. The straight corridor of
    /// [`SafetyConfig::obstacle_ahead_m`] misses what a turning robot sweeps into.
    pub fn obstacle_on_arc_m(
        &self,
        points_in_robot: &[Point2<Robot>],
        v_mps: f64,
        w_radps: f64,
    ) -> Option<f64> {
        if !(v_mps > 0.0) || !w_radps.is_finite() {
            return None;
        }
        let reach = self.robot_radius_m + self.corridor_margin_m;
        let curvature = w_radps / v_mps;
        let steps = 12;
        let length = self.stop_distance_m;
        // Poses along the arc, from just ahead of the start.
        (1..=steps).find_map(|k| {
            let s = length * f64::from(k) / f64::from(steps);
            let (x, y) = if curvature.abs() < 1e-6 {
                (s, 0.0)
            } else {
                let th = curvature * s;
                (th.sin() / curvature, (1.0 - th.cos()) / curvature)
            };
            let centre = Point2::<Robot>::new(x, y);
            points_in_robot
                .iter()
                .filter(|p| p.is_finite() && p.x > -0.05)
                .any(|p| p.distance_below(centre, reach))
                .then_some(s)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_that_switch_safety_off_are_refused() {
        assert_eq!(SafetyConfig::default().validate(), Ok(()));
        for (field, set) in [
            (
                "laser_timeout_s",
                (|s: &mut SafetyConfig| s.laser_timeout_s = f64::INFINITY) as fn(&mut SafetyConfig),
            ),
            ("laser_timeout_s", |s| s.laser_timeout_s = 1e9),
            ("laser_timeout_s", |s| s.laser_timeout_s = 0.0),
            ("target_timeout_s", |s| s.target_timeout_s = 1e9),
            ("target_timeout_s", |s| s.target_timeout_s = f64::NAN),
            ("stop_distance_m", |s| s.stop_distance_m = -2.0),
            ("stop_distance_m", |s| s.stop_distance_m = 0.0),
            ("robot_radius_m", |s| s.robot_radius_m = 0.0),
            ("corridor_margin_m", |s| s.corridor_margin_m = -0.1),
            ("search_turn_s", |s| s.search_turn_s = f64::INFINITY),
            ("unseen_full_pace_s", |s| s.unseen_full_pace_s = 1.5),
            ("unseen_clear_m", |s| s.unseen_clear_m = f64::NAN),
            ("search_rotate_rad", |s| s.search_rotate_rad = 7.0),
            ("search_rotate_s", |s| s.search_rotate_s = -1.0),
        ] {
            let mut s = SafetyConfig::default();
            set(&mut s);
            assert_eq!(s.validate().map_err(|e| e.field), Err(field));
        }
    }

    #[test]
    fn watchdog_trips_on_stale_laser_then_stale_target() {
        let s = SafetyConfig::default();
        let at = |ms: i64| Stamp::from_ns(ms * 1_000_000);
        assert_eq!(s.watchdog(at(1000), Some(at(950)), Some(at(950))), None);
        assert_eq!(
            s.watchdog(at(1000), Some(at(600)), Some(at(950))),
            Some(StopReason::StaleLaser)
        );
        assert_eq!(
            s.watchdog(at(1000), None, Some(at(950))),
            Some(StopReason::StaleLaser)
        );
        assert_eq!(s.watchdog(at(1000), Some(at(950)), Some(at(400))), None);
        assert_eq!(
            s.watchdog(at(1000), Some(at(950)), Some(at(-100))),
            Some(StopReason::StaleTarget)
        );
    }

    #[test]
    fn a_turning_robot_sees_what_it_will_sweep() {
        let s = SafetyConfig::default();
        // A chair leg ahead-left, clear of the straight corridor.
        let leg = [Point2::<Robot>::new(0.45, 0.33)];
        assert_eq!(s.obstacle_ahead_m(leg), None);
        assert_eq!(s.obstacle_on_arc_m(&leg, 0.5, 0.0), None);
        assert!(
            s.obstacle_on_arc_m(&leg, 0.5, 1.5).is_some(),
            "turning left into it"
        );
        assert_eq!(s.obstacle_on_arc_m(&leg, 0.5, -1.5), None, "turning away");
        assert_eq!(
            s.obstacle_on_arc_m(&leg, 0.0, 1.5),
            None,
            "turning on the spot"
        );
    }

    #[test]
    fn only_returns_in_the_corridor_ahead_block() {
        let s = SafetyConfig::default();
        let p = |x: f64, y: f64| Point2::<Robot>::new(x, y);
        assert_eq!(
            s.obstacle_ahead_m([p(1.5, 0.0), p(0.3, 0.6), p(-0.3, 0.0)]),
            None
        );
        let gap = s.obstacle_ahead_m([p(0.45, 0.1), p(0.5, -0.2)]).unwrap();
        assert!((gap - 0.25).abs() < 1e-12);
        assert_eq!(s.obstacle_ahead_m([p(f64::NAN, 0.0)]), None);
    }
}
