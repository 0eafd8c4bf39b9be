//! The robot's pose while it follows (design 5.7), as the live loop keeps it and as a
//! replay of its recording keeps it again: the dead reckoning of the commands sent,
//! corrected by matching the first laser's scans against the static scene, or the
//! odometry a base publishes.
//!
//! The pose at a datum's stamp `t` is
//! `world_from_robot(t) = correction * dead_reckoned(t)` with
//! `correction = matched * dead_reckoned(t_scan)^-1` updated at each matched scan, or,
//! with odometry, the newest odometry carried along its velocity for up to
//! [`ODOMETRY_EXTRAPOLATION_S`].

use tether_control::Twist;
use tether_core::{LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_scanmatch::MotionPrior;

use crate::ego::ScanOdometry;
use crate::odometry::DeadReckoning;

/// Longest time odometry is carried forward by its velocity, s.
pub const ODOMETRY_EXTRAPOLATION_S: f64 = 0.2;

/// How old the newest odometry may be when a scan or frame needs the robot's pose, ns.
pub const ODOMETRY_TIMEOUT_NS: i64 = 500_000_000;

/// The robot's pose during a run driven by tether's own commands.
#[derive(Debug)]
pub struct RobotPose {
    /// Dead reckoning of the commands.
    commands: DeadReckoning,
    /// Scan matching and its state: the dead-reckoned pose at the last matched scan,
    /// and the correction that takes dead-reckoned poses to scan-matched ones.
    scan_odometry: Option<ScanOdometry>,
    dead_reckoned_at_last_scan: Option<Pose2<World, Robot>>,
    correction: Pose2<World, World>,
    /// Whether odometry messages are the pose (from the first one on).
    odometry_input: bool,
    /// The newest odometry and the velocity with it.
    odometry: Option<(Stamp, Pose2<World, Robot>, Twist)>,
    /// Odometry messages taken as the pose.
    pub odometry_messages: u64,
    /// Scans and frames skipped because the odometry had stopped.
    pub skipped_stale_odometry: u64,
}

impl RobotPose {
    /// Standing at the origin from `start`; scans matched by `scan_odometry` when given;
    /// odometry messages taken as the pose when `odometry_input`.
    pub fn new(start: Stamp, scan_odometry: Option<ScanOdometry>, odometry_input: bool) -> Self {
        RobotPose {
            commands: DeadReckoning::new(start),
            scan_odometry,
            dead_reckoned_at_last_scan: None,
            correction: Pose2::IDENTITY,
            odometry_input,
            odometry: None,
            odometry_messages: 0,
            skipped_stale_odometry: 0,
        }
    }

    /// An odometry message: the robot at `pose` at `stamp`, moving at `moving`. Ignored
    /// unless odometry is the pose.
    pub fn odometry(&mut self, stamp: Stamp, pose: Pose2<World, Robot>, moving: Twist) {
        if !self.odometry_input {
            return;
        }
        if self.odometry.is_none() {
            tracing::info!("odometry arrived: it is the robot's pose from now on");
        }
        self.odometry_messages += 1;
        self.odometry = Some((stamp, pose, moving));
    }

    /// The newest odometry for a datum stamped `stamp`: `None` without odometry,
    /// `Some(None)` when it has stopped (the datum is then skipped).
    fn odometry_for(&mut self, stamp: Stamp) -> Option<Option<Pose2<World, Robot>>> {
        let (at, pose, moving) = self.odometry?;
        if stamp.ns_since(at) > ODOMETRY_TIMEOUT_NS {
            if self.skipped_stale_odometry == 0 {
                tracing::warn!(
                    "the odometry stopped {:.2} s before this datum; scans and frames are \
                     skipped until it comes back (the watchdog stops the robot)",
                    stamp.ns_since(at) as f64 * 1e-9
                );
            }
            self.skipped_stale_odometry += 1;
            return Some(None);
        }
        // Between odometry messages (20-50 Hz on most bases) the base keeps moving:
        // the pose at the datum's stamp, along the arc of the last velocity.
        let dt_s = (stamp.ns_since(at) as f64 * 1e-9).clamp(0.0, ODOMETRY_EXTRAPOLATION_S);
        Some(Some(crate::odometry::integrate(pose, moving, dt_s)))
    }

    /// The pose `scan` is processed with (`None`: skipped, the odometry has stopped).
    /// The matcher aligns the first laser's scans (`first`, at that laser's mount);
    /// another scanner's take the pose between them. `people` are where the moving
    /// people are (their returns are left out of the match).
    pub fn for_scan(
        &mut self,
        scan: &LaserScan,
        first: bool,
        people: impl IntoIterator<Item = Point2<World>>,
    ) -> Option<Pose2<World, Robot>> {
        if let Some(odometry) = self.odometry_for(scan.stamp) {
            return odometry;
        }
        let dead_reckoned = self.commands.pose_at(scan.stamp);
        Some(match self.scan_odometry.as_mut() {
            Some(_) if !first => self.correction * dead_reckoned,
            Some(matcher) => {
                let increment = self
                    .dead_reckoned_at_last_scan
                    .map_or(Pose2::IDENTITY, |last| last.inverse() * dead_reckoned);
                self.dead_reckoned_at_last_scan = Some(dead_reckoned);
                let matched = matcher.update(scan, MotionPrior::Increment(increment), people);
                self.correction = matched * dead_reckoned.inverse();
                matched
            }
            None => dead_reckoned,
        })
    }

    /// The pose at `stamp` between scans (a camera frame): the odometry, or the dead
    /// reckoning corrected by the last scan match.
    pub fn between_scans(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        match self.odometry_for(stamp) {
            Some(odometry) => odometry,
            None => Some(self.correction * self.commands.pose_at(stamp)),
        }
    }

    /// The pose at a timer tick: with stale odometry still a pose (the watchdog stops
    /// the robot), the last the odometry gave.
    pub fn at_timer(&self, stamp: Stamp) -> Pose2<World, Robot> {
        match self.odometry {
            Some((at, pose, moving)) => {
                let dt_s = (stamp.ns_since(at) as f64 * 1e-9).clamp(0.0, ODOMETRY_EXTRAPOLATION_S);
                crate::odometry::integrate(pose, moving, dt_s)
            }
            None => self.correction * self.commands.pose_at(stamp),
        }
    }

    /// From `at` on the robot drives `command`.
    pub fn commanded(&mut self, at: Stamp, command: Twist) {
        self.commands.set_command(at, command);
    }

    /// Where the dead reckoning of the commands puts the robot at `at` (uncorrected).
    pub fn dead_reckoned(&self, at: Stamp) -> Pose2<World, Robot> {
        self.commands.pose_at(at)
    }

    /// The scan matching, when the scans are matched.
    pub fn scan_odometry(&self) -> Option<&ScanOdometry> {
        self.scan_odometry.as_ref()
    }
}
