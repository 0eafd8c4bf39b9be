//! Where the follower steers: straight at the target when nothing is in between, else
//! along the target's own trail; and whether the robot may back up.
//!
//! A spring pulled straight at the person cuts corners: around a table the straight
//! line runs through chair legs. The target's trail, the positions it walked through,
//! is free space. When the laser sees something on the straight line, the follower aims
//! at a point of the trail a little ahead of the robot and stretches the spring by the
//! distance along the trail, so the robot takes the corner the way the person did.
//!
//! The laser does not see behind the robot. Backing up (to restore the follow distance
//! after the person stopped short) is allowed only into space the robot has just
//! driven through: the point behind it must lie on its own recent path.

use std::collections::VecDeque;

use tether_core::{Point2, Pose2, Robot, Stamp, World};

/// Spacing of trail points, m.
const TRAIL_STEP_M: f64 = 0.1;
/// A step in the target's trail longer than this is a stretch nobody saw (its track
/// coasted, or the lock was lost and taken up again), m: the trail starts again after
/// it. A walker moves at most a few tenths of a metre between two ticks; the way
/// between two points further apart is not known to be free (the person may have
/// gone round the far side of a pillar), and following it leads the robot round
/// the wrong side while the person walks out of view.
const TRAIL_GAP_M: f64 = 0.5;
/// Longest target trail kept, points.
const TRAIL_MAX_POINTS: usize = 300;
/// How far ahead along the trail the follower aims, m.
const LOOKAHEAD_M: f64 = 0.7;
/// Returns this close to the target are its own legs, not obstacles, m.
const TARGET_RADIUS_M: f64 = 0.4;
/// How long the robot's own path is remembered, s.
const ROBOT_PATH_S: f64 = 10.0;

/// The steering goal of one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aim {
    /// The point to steer at (world).
    pub point: Point2<World>,
    /// Distance to the target the spring should see, m (straight or along the trail).
    pub distance_m: f64,
    /// True when steering along the trail.
    pub via_trail: bool,
}

/// The target's trail and the robot's recent path.
#[derive(Debug, Clone, Default)]
pub struct Trails {
    target: VecDeque<Point2<World>>,
    target_id: Option<u64>,
    robot: VecDeque<(Stamp, Point2<World>)>,
}

/// The point of the segment `a b` nearest to `p`.
fn closest_on_segment(a: Point2<World>, b: Point2<World>, p: Point2<World>) -> Point2<World> {
    let d = b - a;
    let len2 = d.dot(d);
    let t = if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + d * t
}

impl Trails {
    /// Forgets everything (a new target).
    pub fn clear_target(&mut self) {
        self.target.clear();
        self.target_id = None;
    }

    /// Records where the target `id` is. A new id after a re-acquisition is the same
    /// person: the trail carries on, unless it jumps (`TRAIL_GAP_M`).
    pub fn record_target(&mut self, id: u64, p: Point2<World>) {
        if !p.is_finite() {
            return;
        }
        self.target_id = Some(id);
        if self
            .target
            .back()
            .is_some_and(|last| last.distance_m(p) > TRAIL_GAP_M)
        {
            // Nobody saw the way between: the trail starts again here.
            self.target.clear();
        }
        if self
            .target
            .back()
            .is_none_or(|last| last.distance_m(p) >= TRAIL_STEP_M)
        {
            self.target.push_back(p);
            if self.target.len() > TRAIL_MAX_POINTS {
                self.target.pop_front();
            }
        }
    }

    /// Records where the robot is.
    pub fn record_robot(&mut self, stamp: Stamp, p: Point2<World>) {
        if !p.is_finite() {
            return;
        }
        if self
            .robot
            .back()
            .is_none_or(|(_, last)| last.distance_m(p) >= 0.05)
        {
            self.robot.push_back((stamp, p));
        }
        while self
            .robot
            .front()
            .is_some_and(|(t, _)| stamp.secs_since(*t) > ROBOT_PATH_S)
        {
            self.robot.pop_front();
        }
    }

    /// True when a return lies within `clearance_m` of the segment `a`-`b` (returns
    /// near the target itself excepted).
    fn blocked(
        a: Point2<World>,
        b: Point2<World>,
        target: Point2<World>,
        obstacles: &[Point2<World>],
        clearance_m: f64,
    ) -> bool {
        // `distance_above` and `distance_below` are `distance_m` compared, mostly
        // without its `hypot`.
        obstacles.iter().any(|o| {
            o.distance_above(target, TARGET_RADIUS_M)
                && closest_on_segment(a, b, *o).distance_below(*o, clearance_m)
        })
    }

    /// The steering goal: the target itself when the way is clear, else a trail point.
    /// `attach` is the spring's attachment point (world), `obstacles` the scan's
    /// returns (world), `clearance_m` the half-width the robot needs.
    pub fn aim(
        &mut self,
        robot: Pose2<World, Robot>,
        attach: Point2<World>,
        target: Point2<World>,
        obstacles: &[Point2<World>],
        clearance_m: f64,
        always_trail: bool,
    ) -> Aim {
        let here = robot.translation();
        let straight = Aim {
            point: target,
            distance_m: attach.distance_m(target),
            via_trail: false,
        };
        let blocked = Self::blocked(here, target, target, obstacles, clearance_m);
        if (!blocked && !always_trail) || self.target.is_empty() {
            return straight;
        }
        // Drop the part of the trail the robot has already passed.
        let closest = self
            .target
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.distance_m(here).total_cmp(&b.1.distance_m(here)))
            .map_or(0, |(i, _)| i);
        self.target.drain(..closest);
        let trail: Vec<Point2<World>> = self.target.iter().copied().collect();
        // The first trail point at least the look-ahead away that the robot can reach
        // in a straight line; else the farthest reachable one.
        let mut pick = None;
        for (i, p) in trail.iter().enumerate() {
            if Self::blocked(here, *p, target, obstacles, clearance_m) {
                break;
            }
            pick = Some(i);
            if p.distance_m(here) >= LOOKAHEAD_M {
                break;
            }
        }
        let Some(i) = pick else { return straight };
        let along: f64 = trail[i..]
            .windows(2)
            .map(|w| w[0].distance_m(w[1]))
            .sum::<f64>()
            + trail.last().map_or(0.0, |last| last.distance_m(target));
        Aim {
            point: trail[i],
            distance_m: attach.distance_m(trail[i]) + along,
            via_trail: true,
        }
    }

    /// True when the space just behind the robot is on its own recent path (driven
    /// through more than half a second ago), so it may back up into it.
    pub fn may_reverse(&self, now: Stamp, robot: Pose2<World, Robot>, radius_m: f64) -> bool {
        let behind = robot * Point2::new(-(radius_m + 0.15), 0.0);
        self.robot
            .iter()
            .any(|(t, p)| now.secs_since(*t) > 0.5 && p.distance_m(behind) < 0.15)
    }
}

/// `out` = `items` for which `keep` holds, each through `map`, in order: what
/// `items.iter().filter(keep).map(map).collect()` gives, into a buffer kept between
/// ticks, and with no branch on `keep` (every item is written at the end of the kept
/// ones, which only move past it when it is kept), which on a scan's returns the CPU
/// cannot predict.
pub fn keep_mapped<T: Copy, U: Copy>(
    items: &[T],
    keep: impl Fn(&T) -> bool,
    map: impl Fn(T) -> U,
    out: &mut Vec<U>,
) {
    let Some(&first) = items.first() else {
        out.clear();
        return;
    };
    // What `out` holds from the last call is written over: only more items fill new
    // room.
    out.resize(items.len(), map(first));
    let mut kept = 0;
    for item in items {
        out[kept] = map(*item);
        kept += usize::from(keep(item));
    }
    out.truncate(kept);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point2<World> {
        Point2::new(x, y)
    }

    #[test]
    fn goes_straight_when_clear_and_along_the_trail_when_blocked() {
        let mut trails = Trails::default();
        // The target walked (0,0) -> (2,0) -> (2,2); the robot is at (0.5, 0).
        for k in 0..=20 {
            trails.record_target(1, p(0.1 * k as f64, 0.0));
        }
        for k in 1..=20 {
            trails.record_target(1, p(2.0, 0.1 * k as f64));
        }
        let robot = Pose2::<World, Robot>::new(0.5, 0.0, 0.0);
        let attach = robot * Point2::new(0.3, 0.0);
        let target = p(2.0, 2.0);
        let clear = trails.aim(robot, attach, target, &[], 0.25, false);
        assert!(!clear.via_trail && clear.point == target);
        // A chair leg on the diagonal.
        let chair = [p(1.3, 1.0)];
        let around = trails.aim(robot, attach, target, &chair, 0.25, false);
        assert!(around.via_trail);
        assert!(
            around.point.y.abs() < 1e-9 && around.point.x > 1.0,
            "{:?}",
            around.point
        );
        // The spring sees the distance along the trail.
        assert!(
            (around.distance_m - (attach.distance_m(around.point) + (2.0 - around.point.x) + 2.0))
                .abs()
                < 0.11
        );
    }

    #[test]
    fn a_trail_that_jumps_starts_again_after_the_jump() {
        // The target walked up the right side of a pillar at (1, 1), went out of sight
        // behind it and was seen again on its left, 1.4 m from where it was last seen.
        let mut trails = Trails::default();
        for k in 0..=10 {
            trails.record_target(1, p(1.7, 0.1 * k as f64));
        }
        trails.record_target(1, p(0.3, 1.3));
        let pillar: Vec<Point2<World>> = (0..36)
            .map(|k| {
                let a = f64::from(k) * 10_f64.to_radians();
                p(1.0 + 0.3 * a.cos(), 1.0 + 0.3 * a.sin())
            })
            .collect();
        // The robot stands where the pillar is in the way of the straight line.
        let robot = Pose2::<World, Robot>::new(1.2, -0.5, 0.0);
        let attach = robot * Point2::new(0.3, 0.0);
        let target = p(0.3, 1.3);
        // Nothing is known of the way round the far side: no trail to follow there, and
        // the robot steers at the person (the obstacle stop keeps it off the pillar).
        let aim = trails.aim(robot, attach, target, &pillar, 0.25, false);
        assert!(!aim.via_trail, "{aim:?}");
        assert_eq!(aim.point, target);
        // Seen walking all the way round the far side, the target left a trail the
        // robot follows.
        let mut seen = Trails::default();
        for k in 0..=10 {
            seen.record_target(1, p(1.7, 0.1 * k as f64));
        }
        for k in 1..=14 {
            let a = f64::from(k) * 11.2_f64.to_radians();
            seen.record_target(1, p(1.0 + 0.7 * a.cos(), 1.0 + 0.7 * a.sin()));
        }
        let around = seen.aim(robot, attach, target, &pillar, 0.25, false);
        assert!(around.via_trail && around.point.x > 1.3, "{around:?}");
    }

    #[test]
    fn reverses_only_over_its_own_path() {
        let mut trails = Trails::default();
        for k in 0..30 {
            trails.record_robot(Stamp::from_ns(k * 100_000_000), p(0.05 * k as f64, 0.0));
        }
        let now = Stamp::from_ns(3_000_000_000);
        let forward = Pose2::<World, Robot>::new(1.45, 0.0, 0.0);
        assert!(trails.may_reverse(now, forward, 0.2));
        let turned = Pose2::<World, Robot>::new(1.45, 0.0, std::f64::consts::FRAC_PI_2);
        assert!(!trails.may_reverse(now, turned, 0.2));
    }
}
