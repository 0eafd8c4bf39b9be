//! The robot's motion when nothing else tells it: odometry from the scans themselves
//! (issue 14; design section 11). Each scan is matched against a keyframe of the static
//! scene by point-to-line ICP (`tether-scanmatch`), leaving out the returns around the
//! people being tracked, so that tracks live in one consistent frame while the robot
//! drives even when a recording or a robot gives no odometry.

use tether_core::{Laser, LaserScan, Point2, Pose2, Robot, World};
use tether_scanmatch::{
    ExclusionZone, MatcherCounts, MotionPrior, ScanMatcher, ScanMatcherConfig, ScanPoints,
};

/// Returns within this distance of a tracked person's last position are left out of
/// the match: a person moves at most about 0.2 m between two scans at 10 Hz, and their
/// legs spread 0.3 m about their centre, m.
pub const PERSON_EXCLUSION_M: f64 = 0.6;

/// A track is left out of the match when it moves faster than this, m/s...
pub const MOVING_SPEED_MPS: f64 = 0.3;
/// ...or has walked this far from where it started, m (a person who stopped for a
/// moment will walk on).
pub const MOVING_WALKED_M: f64 = 1.0;

/// Where the people who move are: the tracks whose returns the match must leave out.
/// Tracks that stay put (a bush, a post, a bin the detector takes for legs, a person
/// standing) are static structure, and in a sparse scene (a park) they are most of what
/// there is to match against.
pub fn moving_people(
    tracks: &[tether_fusion::tracker::Track],
) -> impl Iterator<Item = Point2<World>> + '_ {
    tracks
        .iter()
        .filter(|t| t.velocity().norm() > MOVING_SPEED_MPS || t.walked_m >= MOVING_WALKED_M)
        .map(|t| t.position().mean)
}

/// Odometry from consecutive scans.
#[derive(Debug)]
pub struct ScanOdometry {
    matcher: ScanMatcher,
    points: ScanPoints,
    robot_from_laser: Pose2<Robot, Laser>,
    zones: Vec<ExclusionZone>,
    world_from_robot: Pose2<World, Robot>,
    unusable_scans: u64,
}

impl ScanOdometry {
    /// Odometry for a scanner mounted at `robot_from_laser`.
    pub fn new(config: ScanMatcherConfig, robot_from_laser: Pose2<Robot, Laser>) -> Self {
        ScanOdometry {
            matcher: ScanMatcher::new(config),
            points: ScanPoints::default(),
            robot_from_laser,
            zones: Vec::new(),
            world_from_robot: Pose2::IDENTITY,
            unusable_scans: 0,
        }
    }

    /// The robot's pose at `scan`'s stamp in the frame of the first scan, given a
    /// `prior` for the motion since the previous scan and where the people being
    /// tracked are (world frame; their returns are left out). A scan that cannot be
    /// read as points (a bad header) leaves the pose where it was and is counted.
    pub fn update(
        &mut self,
        scan: &LaserScan,
        prior: MotionPrior,
        people: impl IntoIterator<Item = Point2<World>>,
    ) -> Pose2<World, Robot> {
        let robot_from_world = self.world_from_robot.inverse();
        self.zones.clear();
        self.zones.extend(people.into_iter().map(|p| ExclusionZone {
            center: robot_from_world * p,
            radius_m: PERSON_EXCLUSION_M,
        }));
        if self
            .points
            .fill_from_scan(scan, self.robot_from_laser)
            .is_err()
        {
            self.unusable_scans += 1;
            return self.world_from_robot;
        }
        let estimate = self
            .matcher
            .update(scan.stamp, &self.points, prior, &self.zones);
        if estimate.world_from_robot.is_finite() {
            self.world_from_robot = estimate.world_from_robot;
        }
        self.world_from_robot
    }

    /// The pose after the last scan.
    pub fn world_from_robot(&self) -> Pose2<World, Robot> {
        self.world_from_robot
    }

    /// What the matcher counted.
    pub fn counts(&self) -> MatcherCounts {
        self.matcher.counts()
    }

    /// One line for a command's closing message.
    pub fn summary(&self) -> String {
        let c = self.matcher.counts();
        format!(
            "scan odometry: {} scans, {} keyframes, {} degenerate (along a corridor's axis the \
             prior), {} on the prior alone ({} of them matches refused as a motion the robot \
             cannot make), {} gaps that reset the prior, {} unreadable",
            c.scans,
            c.keyframes,
            c.degenerate,
            c.failed,
            c.implausible,
            c.prior_resets,
            self.unusable_scans
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::Stamp;

    /// A 682-beam scan of a rectangular room 8 m x 6 m seen from `(x, y)`, heading 0,
    /// with a pillar so that no direction is unconstrained.
    fn room_scan(stamp_ms: i64, x: f64, y: f64) -> LaserScan {
        let (n, angle_min, inc) = (682, -2.0944, 4.1888 / 681.0);
        let (x0, x1, y0, y1) = (-3.0, 5.0, -3.0, 3.0);
        let ranges = (0..n)
            .map(|i| {
                let a: f64 = angle_min + inc * i as f64;
                let (c, s) = (a.cos(), a.sin());
                let tx = if c > 0.0 { (x1 - x) / c } else { (x0 - x) / c };
                let ty = if s > 0.0 { (y1 - y) / s } else { (y0 - y) / s };
                // A pillar of radius 0.3 m at (2, 1.5).
                let (px, py) = (2.0 - x, 1.5 - y);
                let along = px * c + py * s;
                let off2 = px * px + py * py - along * along;
                let tp = if along > 0.0 && off2 < 0.09 {
                    along - (0.09 - off2).sqrt()
                } else {
                    f64::INFINITY
                };
                tx.min(ty).min(tp) as f32
            })
            .collect();
        LaserScan::new(
            Stamp::from_ns(stamp_ms * 1_000_000),
            "laser",
            angle_min,
            inc,
            0.02,
            5.6,
            ranges,
        )
        .unwrap()
    }

    #[test]
    fn a_robot_driving_through_a_room_is_followed_by_its_scans() {
        let mut odom = ScanOdometry::new(ScanMatcherConfig::default(), Pose2::IDENTITY);
        let mut last = Pose2::IDENTITY;
        for k in 0..30 {
            let x = 0.05 * k as f64;
            last = odom.update(
                &room_scan(100 * k, x, 0.0),
                MotionPrior::ConstantVelocity,
                [],
            );
        }
        let p = last.translation();
        assert!((p.x - 1.45).abs() < 0.02 && p.y.abs() < 0.02, "{last:?}");
        assert!(odom.summary().contains("30 scans"), "{}", odom.summary());
    }
}
