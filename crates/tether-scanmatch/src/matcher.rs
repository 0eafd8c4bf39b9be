//! Odometry from scans: each scan is matched against a keyframe, the keyframe is renewed
//! when the robot has moved away from it, and the increments are accumulated into
//! `world_from_robot`.

use serde::{Deserialize, Serialize};
use tether_core::{Point2, Pose2, Robot, Stamp, World, wrap_angle_rad};

use crate::icp::{IcpConfig, IcpScratch, MatchFailure, MatchResult, match_scan};
use crate::linalg::{Mat3, add3, compose_jacobians, congruence3, diag3};
use crate::points::ScanPoints;
use crate::reference::{NeighbourSearch, Reference};

/// Settings of a [`ScanMatcher`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct ScanMatcherConfig {
    /// The match itself.
    pub icp: IcpConfig,
    /// A new keyframe when the robot is farther than this from the current one, m...
    #[config(range = "> 0")]
    pub keyframe_translation_m: f64,
    /// ...or has turned more than this, rad...
    #[config(range = "> 0")]
    pub keyframe_rotation_rad: f64,
    /// ...or when fewer than this share of the scan's points found a match (the view
    /// has changed).
    #[config(range = ">= 0, < 1")]
    pub keyframe_min_overlap: f64,
    /// Points of the new scan closer than this to the last point kept are skipped
    /// (the keyframe keeps all): near the scanner, beams are millimetres apart and
    /// add cost, not information, m. 0 keeps every point.
    #[config(range = ">= 0")]
    pub min_point_spacing_m: f64,
    /// Standard deviation of the prior's translation error per second of prediction,
    /// m/s (used along degenerate directions and when the match fails).
    #[config(range = "> 0")]
    pub prior_sigma_m_per_s: f64,
    /// Standard deviation of the prior's rotation error per second, rad/s.
    #[config(range = "> 0")]
    pub prior_sigma_rad_per_s: f64,
    /// A gap between scans longer than this makes the constant-velocity prior
    /// unreliable: it is replaced by "stationary" and the estimate says so, s.
    #[config(range = "> 0")]
    pub max_prior_gap_s: f64,
    /// What the robot can do: a match that would need more is wrong (a false minimum
    /// in a sparse scene) and falls back to the prior.
    pub robot: RobotBounds,
}

/// The motion a ground robot is capable of, in its own frame. A match is taken only if
/// the velocity it implies over the scan interval, `(x, y, yaw) / dt`, is within these
/// bounds, and differs from the last trusted velocity by no more than the acceleration
/// bounds allow over the time since that velocity was measured (plus `slack`, for the
/// noise of a velocity taken from one increment).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct RobotBounds {
    /// Highest speed, m/s.
    #[config(range = "> 0")]
    pub max_speed_mps: f64,
    /// Highest sideways speed, m/s: a differential-drive or car-like base cannot slide
    /// sideways; what remains is the turn seen from a scanner mounted off the axle
    /// (`w * mount_x`) and noise. Raise it for a holonomic base.
    #[config(range = "> 0")]
    pub max_lateral_speed_mps: f64,
    /// Highest turn rate, rad/s.
    #[config(range = "> 0")]
    pub max_turn_rate_radps: f64,
    /// Highest acceleration, m/s^2.
    #[config(range = "> 0")]
    pub max_accel_mps2: f64,
    /// Highest angular acceleration, rad/s^2.
    #[config(range = "> 0")]
    pub max_angular_accel_radps2: f64,
    /// Noise of a velocity measured from one increment, m/s.
    #[config(range = "> 0")]
    pub speed_slack_mps: f64,
    /// Noise of a turn rate measured from one increment, rad/s.
    #[config(range = "> 0")]
    pub turn_rate_slack_radps: f64,
}

impl Default for RobotBounds {
    fn default() -> Self {
        // Generous for the small bases tether drives (Create, TurtleBot, Pioneer:
        // 0.5-1.5 m/s, under 3 rad/s), and far below the jumps of a false match.
        RobotBounds {
            max_speed_mps: 2.5,
            max_lateral_speed_mps: 0.4,
            max_turn_rate_radps: 3.0,
            max_accel_mps2: 3.0,
            max_angular_accel_radps2: 8.0,
            speed_slack_mps: 0.25,
            turn_rate_slack_radps: 0.3,
        }
    }
}

impl RobotBounds {
    /// Whether a robot whose trusted velocity was `trusted` (`(vx, vy, w)`, robot
    /// frame) `since_s` ago can move at `velocity` now.
    pub fn allows(
        &self,
        velocity: (f64, f64, f64),
        trusted: (f64, f64, f64),
        since_s: f64,
    ) -> bool {
        let (vx, vy, w) = velocity;
        let (tx, ty, tw) = trusted;
        let since = since_s.max(0.0);
        vx.hypot(vy) <= self.max_speed_mps
            && vy.abs() <= self.max_lateral_speed_mps
            && w.abs() <= self.max_turn_rate_radps
            && (vx - tx).hypot(vy - ty) <= self.max_accel_mps2 * since + self.speed_slack_mps
            && (w - tw).abs() <= self.max_angular_accel_radps2 * since + self.turn_rate_slack_radps
    }
}

/// A setting that cannot work.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("scan matcher setting `{field}` = {value}: {expected}")]
pub struct ConfigError {
    /// The setting's name (as in the TOML table).
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

impl ScanMatcherConfig {
    /// Checks every setting: distances, angles and rates positive and finite, shares in
    /// `[0, 1)`, at least one iteration and three matches.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let icp = &self.icp;
        let r = &self.robot;
        let positive: [(&'static str, f64); 21] = [
            ("robot.max_speed_mps", r.max_speed_mps),
            ("robot.max_lateral_speed_mps", r.max_lateral_speed_mps),
            ("robot.max_turn_rate_radps", r.max_turn_rate_radps),
            ("robot.max_accel_mps2", r.max_accel_mps2),
            ("robot.max_angular_accel_radps2", r.max_angular_accel_radps2),
            ("robot.speed_slack_mps", r.speed_slack_mps),
            ("robot.turn_rate_slack_radps", r.turn_rate_slack_radps),
            ("icp.translation_tolerance_m", icp.translation_tolerance_m),
            ("icp.rotation_tolerance_rad", icp.rotation_tolerance_rad),
            ("icp.max_correspondence_m", icp.max_correspondence_m),
            ("icp.huber_m", icp.huber_m),
            ("icp.rotation_scale_m", icp.rotation_scale_m),
            (
                "icp.degeneracy_min_eigenvalue",
                icp.degeneracy_min_eigenvalue,
            ),
            ("icp.lines.max_gap_m", icp.lines.max_gap_m),
            ("icp.lines.half_span_m", icp.lines.half_span_m),
            ("icp.lines.max_flatness", icp.lines.max_flatness),
            ("keyframe_translation_m", self.keyframe_translation_m),
            ("keyframe_rotation_rad", self.keyframe_rotation_rad),
            ("prior_sigma_m_per_s", self.prior_sigma_m_per_s),
            ("prior_sigma_rad_per_s", self.prior_sigma_rad_per_s),
            ("max_prior_gap_s", self.max_prior_gap_s),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ConfigError {
                    field,
                    value,
                    expected: "a positive finite number",
                });
            }
        }
        let non_negative: [(&'static str, f64); 3] = [
            (
                "icp.reuse_correspondences_below_m",
                icp.reuse_correspondences_below_m,
            ),
            (
                "icp.reuse_correspondences_below_rad",
                icp.reuse_correspondences_below_rad,
            ),
            ("min_point_spacing_m", self.min_point_spacing_m),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ConfigError {
                    field,
                    value,
                    expected: "zero or a positive finite number",
                });
            }
        }
        for (field, value) in [
            ("icp.trim_fraction", icp.trim_fraction),
            ("keyframe_min_overlap", self.keyframe_min_overlap),
        ] {
            if !(0.0..1.0).contains(&value) {
                return Err(ConfigError {
                    field,
                    value,
                    expected: "a share in [0, 1)",
                });
            }
        }
        if icp.max_iterations == 0 {
            return Err(ConfigError {
                field: "icp.max_iterations",
                value: 0.0,
                expected: "at least 1",
            });
        }
        if icp.min_matches < 3 {
            return Err(ConfigError {
                field: "icp.min_matches",
                value: icp.min_matches as f64,
                expected: "at least 3 (an SE(2) pose has three unknowns)",
            });
        }
        Ok(())
    }
}

impl Default for ScanMatcherConfig {
    fn default() -> Self {
        ScanMatcherConfig {
            icp: IcpConfig::default(),
            keyframe_translation_m: 0.3,
            keyframe_rotation_rad: 0.2,
            keyframe_min_overlap: 0.6,
            min_point_spacing_m: 0.02,
            prior_sigma_m_per_s: 0.3,
            prior_sigma_rad_per_s: 0.3,
            max_prior_gap_s: 1.0,
            robot: RobotBounds::default(),
        }
    }
}

/// A circle around something that moves (a tracked person), in the robot frame of the
/// scan being matched: returns inside are not matched, and not kept in a keyframe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExclusionZone {
    /// Centre, robot frame.
    pub center: Point2<Robot>,
    /// Radius, m.
    pub radius_m: f64,
}

impl ExclusionZone {
    /// True when `p` is inside.
    pub fn contains(&self, p: Point2<Robot>) -> bool {
        let (dx, dy) = (p.x - self.center.x, p.y - self.center.y);
        dx * dx + dy * dy <= self.radius_m * self.radius_m
    }
}

/// The initial guess of the motion since the previous scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotionPrior {
    /// The last estimated velocity, held over the time since the previous scan.
    ConstantVelocity,
    /// Commanded (or wheel) velocities over the time since the previous scan: forward
    /// speed, m/s, and turn rate, rad/s, integrated along the arc.
    Velocity {
        /// Forward speed, m/s.
        v_mps: f64,
        /// Turn rate, rad/s.
        w_radps: f64,
    },
    /// A known increment `previous_from_current` (from wheel odometry, say).
    Increment(Pose2<Robot, Robot>),
    /// The robot did not move.
    Stationary,
}

/// How far an [`Estimate`] can be trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quality {
    /// The first scan: it becomes the keyframe; the pose is the origin.
    First,
    /// The scan constrained every direction of the motion.
    Good,
    /// The scan left `directions` directions unconstrained (a corridor); along them
    /// the estimate is the prior's.
    Degenerate {
        /// Unconstrained directions (1 to 3).
        directions: usize,
    },
    /// The match failed; the estimate is the prior's and the scan is the new keyframe.
    PriorOnly(Failure),
}

/// Why an estimate fell back to the prior.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    /// The scan (after exclusion) or the keyframe had too few points.
    TooFewPoints,
    /// Too few points found a surface of the keyframe.
    TooFewMatches,
    /// The match diverged to a non-finite pose.
    NotFinite,
    /// The stamp is not after the previous scan's: the scan was ignored.
    StampNotIncreasing,
    /// The match implied a motion the robot cannot make ([`RobotBounds`]).
    Implausible,
}

impl From<MatchFailure> for Failure {
    fn from(f: MatchFailure) -> Self {
        match f {
            MatchFailure::TooFewPoints => Failure::TooFewPoints,
            MatchFailure::TooFewMatches => Failure::TooFewMatches,
            MatchFailure::NotFinite => Failure::NotFinite,
        }
    }
}

/// What one scan says about the robot's motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Stamp of the scan.
    pub stamp: Stamp,
    /// The motion since the previous scan: the previous robot frame from this one's.
    pub robot_from_robot: Pose2<Robot, Robot>,
    /// Covariance of `(x, y, yaw)` of `robot_from_robot`. Approximated by the
    /// covariance of the match against the keyframe: the previous scan's error
    /// against the same keyframe is strongly correlated with this one's, so their
    /// difference is not more uncertain than either.
    pub increment_covariance: Mat3,
    /// Accumulated odometry: the robot in the frame of the first scan.
    pub world_from_robot: Pose2<World, Robot>,
    /// Covariance of `world_from_robot` (grows with every keyframe).
    pub world_covariance: Mat3,
    /// Points of the scan that found a keyframe surface.
    pub matched_points: usize,
    /// Points of the scan inside an exclusion zone (not matched).
    pub excluded_points: usize,
    /// Mean absolute point-to-line residual, m (0 without a match).
    pub mean_residual_m: f64,
    /// Smallest eigenvalue of the match's normalised Hessian (how well the worst
    /// direction is constrained; see [`IcpConfig::degeneracy_min_eigenvalue`]); 0
    /// without a match.
    pub min_eigenvalue: f64,
    /// Gauss-Newton iterations.
    pub iterations: u32,
    /// The match converged within the iteration limit.
    pub converged: bool,
    /// How far to trust it.
    pub quality: Quality,
    /// This scan became the keyframe.
    pub new_keyframe: bool,
    /// The constant-velocity prior was reset for a gap longer than
    /// [`ScanMatcherConfig::max_prior_gap_s`] since the previous scan.
    pub prior_reset: bool,
}

impl Estimate {
    /// A scan that was not matched: the first one (`Quality::First`, which becomes the
    /// keyframe and counts as converged) or one whose stamp does not increase; the
    /// robot is where `world` (pose and covariance) says, and has not moved.
    fn unmatched(
        stamp: Stamp,
        world: (Pose2<World, Robot>, Mat3),
        excluded_points: usize,
        quality: Quality,
    ) -> Self {
        let first = quality == Quality::First;
        Estimate {
            stamp,
            robot_from_robot: Pose2::IDENTITY,
            increment_covariance: diag3(0.0, 0.0, 0.0),
            world_from_robot: world.0,
            world_covariance: world.1,
            matched_points: 0,
            excluded_points,
            mean_residual_m: 0.0,
            min_eigenvalue: 0.0,
            iterations: 0,
            converged: first,
            quality,
            new_keyframe: first,
            prior_reset: false,
        }
    }
}

/// Counts of what went wrong over the life of a matcher.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MatcherCounts {
    /// Scans given.
    pub scans: u64,
    /// Scans whose match failed (prior used).
    pub failed: u64,
    /// Scans with a degenerate direction.
    pub degenerate: u64,
    /// Scans ignored for a stamp that did not advance.
    pub stamps_not_increasing: u64,
    /// Gaps longer than the prior allows.
    pub prior_resets: u64,
    /// Of the failed scans, matches refused for a motion the robot cannot make.
    pub implausible: u64,
    /// Keyframes taken.
    pub keyframes: u64,
}

#[derive(Debug, Clone)]
struct State {
    last_stamp: Stamp,
    world_from_keyframe: Pose2<World, Robot>,
    world_from_keyframe_cov: Mat3,
    keyframe_from_last: Pose2<Robot, Robot>,
    /// Last increment per second `(x, y, yaw)`.
    velocity: (f64, f64, f64),
    /// The last velocity measured by a match, and when (`None` before the first match
    /// and after a gap: a recording may start, or resume, with the robot driving).
    trusted: Option<((f64, f64, f64), Stamp)>,
}

/// Estimates the robot's motion from consecutive scans (design 11: ego-motion without
/// odometry).
///
/// Each scan is matched by point-to-line ICP ([`match_scan`]) against a keyframe, not
/// the previous scan: small errors of consecutive matches would add up at every scan,
/// while against a keyframe they add up only once per keyframe. The keyframe is renewed
/// when the robot has moved [`ScanMatcherConfig::keyframe_translation_m`] or turned
/// [`ScanMatcherConfig::keyframe_rotation_rad`] from it, or when the overlap drops.
/// Points near tracked people are passed in as [`ExclusionZone`]s and left out of both
/// the match and the keyframe, so that a walking person does not drag the estimate.
#[derive(Debug, Clone)]
pub struct ScanMatcher {
    config: ScanMatcherConfig,
    search: NeighbourSearch,
    keyframe: Reference,
    state: Option<State>,
    scratch: IcpScratch,
    keep: Vec<bool>,
    query: Vec<Point2<Robot>>,
    counts: MatcherCounts,
}

impl ScanMatcher {
    /// A matcher that has seen no scan. The settings should have passed
    /// [`ScanMatcherConfig::validate`] (read from a file, they must): unchecked nonsense
    /// never panics, but gives failed or meaningless estimates.
    pub fn new(config: ScanMatcherConfig) -> Self {
        ScanMatcher {
            config,
            search: NeighbourSearch::AngularWindow,
            keyframe: Reference::default(),
            state: None,
            scratch: IcpScratch::default(),
            keep: Vec::new(),
            query: Vec::new(),
            counts: MatcherCounts::default(),
        }
    }

    /// The same matcher finding neighbours by `search` (the brute-force search exists to
    /// test the fast one).
    pub fn with_search(mut self, search: NeighbourSearch) -> Self {
        self.search = search;
        self
    }

    /// The settings.
    pub fn config(&self) -> &ScanMatcherConfig {
        &self.config
    }

    /// What went wrong so far.
    pub fn counts(&self) -> MatcherCounts {
        self.counts
    }

    /// The current keyframe.
    pub fn keyframe(&self) -> &Reference {
        &self.keyframe
    }

    /// Forgets every scan: the next one starts a new odometry frame.
    pub fn reset(&mut self) {
        self.state = None;
        self.keyframe = Reference::default();
    }

    /// Matches `scan` (taken at `stamp`) against the keyframe, starting from `prior`,
    /// leaving out the returns inside `exclusion` (robot frame of this scan), and
    /// accumulates the result into `world_from_robot`.
    pub fn update(
        &mut self,
        stamp: Stamp,
        scan: &ScanPoints,
        prior: MotionPrior,
        exclusion: &[ExclusionZone],
    ) -> Estimate {
        self.counts.scans += 1;
        self.keep.clear();
        self.keep.extend(
            scan.points()
                .iter()
                .map(|&p| !exclusion.iter().any(|z| z.contains(p))),
        );
        let excluded_points = self.keep.iter().filter(|k| !**k).count();
        let Some(state) = self.state.clone() else {
            self.take_keyframe(scan, stamp, Pose2::IDENTITY, diag3(0.0, 0.0, 0.0));
            return Estimate::unmatched(
                stamp,
                (Pose2::IDENTITY, diag3(0.0, 0.0, 0.0)),
                excluded_points,
                Quality::First,
            );
        };
        let world_from_last = state.world_from_keyframe * state.keyframe_from_last;
        if stamp <= state.last_stamp {
            self.counts.stamps_not_increasing += 1;
            return Estimate::unmatched(
                stamp,
                (world_from_last, state.world_from_keyframe_cov),
                excluded_points,
                Quality::PriorOnly(Failure::StampNotIncreasing),
            );
        }
        let dt_s = stamp.secs_since(state.last_stamp);
        let prior_reset =
            dt_s > self.config.max_prior_gap_s && prior == MotionPrior::ConstantVelocity;
        if prior_reset {
            self.counts.prior_resets += 1;
        }
        let last_from_now = self.prior_increment(prior, &state, dt_s, prior_reset);
        let guess = state.keyframe_from_last * last_from_now;
        let st = self.config.prior_sigma_m_per_s * dt_s;
        let sr = self.config.prior_sigma_rad_per_s * dt_s;
        let prior_cov = diag3(st * st + 1e-6, st * st + 1e-6, sr * sr + 1e-6);

        self.select_query(scan);

        let outcome = match_scan(
            &self.keyframe,
            &self.query,
            guess,
            &prior_cov,
            &self.config.icp,
            self.search,
            &mut self.scratch,
        );
        // A match the robot could not have made is a false minimum.
        let outcome = outcome.map_err(Failure::from).and_then(|r| {
            let inc = state.keyframe_from_last.inverse() * r.keyframe_from_robot;
            let v = (inc.x / dt_s, inc.y / dt_s, wrap_angle_rad(inc.yaw) / dt_s);
            // Unknown earlier velocity: only the speed limits hold.
            let (trusted, since_s) = match (state.trusted, prior_reset) {
                (Some((t, at)), false) => (t, stamp.secs_since(at)),
                _ => (v, 0.0),
            };
            if self.config.robot.allows(v, trusted, since_s) {
                Ok(r)
            } else {
                Err(Failure::Implausible)
            }
        });
        let (keyframe_from_now, match_cov, quality, result): (_, _, _, Option<MatchResult>) =
            match outcome {
                Ok(r) => {
                    let quality = if r.degenerate_directions > 0 {
                        self.counts.degenerate += 1;
                        Quality::Degenerate {
                            directions: r.degenerate_directions,
                        }
                    } else {
                        Quality::Good
                    };
                    (r.keyframe_from_robot, r.covariance, quality, Some(r))
                }
                Err(f) => {
                    self.counts.failed += 1;
                    self.counts.implausible += u64::from(f == Failure::Implausible);
                    (guess, prior_cov, Quality::PriorOnly(f), None)
                }
            };
        let robot_from_robot =
            (state.keyframe_from_last.inverse() * keyframe_from_now).normalized();
        let world_from_robot = state.world_from_keyframe * keyframe_from_now;
        let (ja, jb) = compose_jacobians(state.world_from_keyframe, keyframe_from_now);
        let world_covariance = add3(
            &congruence3(&ja, &state.world_from_keyframe_cov),
            &congruence3(&jb, &match_cov),
        );
        let overlap = result
            .as_ref()
            .map_or(0.0, |r| r.matched as f64 / r.candidates.max(1) as f64);
        let moved_far = keyframe_from_now.x.hypot(keyframe_from_now.y)
            > self.config.keyframe_translation_m
            || wrap_angle_rad(keyframe_from_now.yaw).abs() > self.config.keyframe_rotation_rad;
        let new_keyframe =
            result.is_none() || moved_far || overlap < self.config.keyframe_min_overlap;
        let velocity = (
            robot_from_robot.x / dt_s,
            robot_from_robot.y / dt_s,
            robot_from_robot.yaw / dt_s,
        );
        // Only a match that constrained every direction measures the velocity (along a
        // corridor's axis a degenerate match repeats the prior).
        let trusted = match (&result, prior_reset) {
            (Some(_), _) if quality == Quality::Good => Some((velocity, stamp)),
            (Some(_), _) => state.trusted,
            (None, true) => None,
            (None, false) => state.trusted,
        };
        if new_keyframe {
            self.take_keyframe(scan, stamp, world_from_robot, world_covariance);
            if let Some(s) = self.state.as_mut() {
                s.velocity = velocity;
                s.trusted = trusted;
            }
        } else {
            self.state = Some(State {
                last_stamp: stamp,
                keyframe_from_last: keyframe_from_now,
                velocity,
                trusted,
                ..state
            });
        }
        Estimate {
            stamp,
            robot_from_robot,
            increment_covariance: match_cov,
            world_from_robot,
            world_covariance,
            matched_points: result.as_ref().map_or(0, |r| r.matched),
            excluded_points,
            mean_residual_m: result.as_ref().map_or(0.0, |r| r.mean_residual_m),
            min_eigenvalue: result.as_ref().map_or(0.0, |r| r.eigenvalues[0]),
            iterations: result.as_ref().map_or(0, |r| r.iterations),
            converged: result.as_ref().is_some_and(|r| r.converged),
            quality,
            new_keyframe,
            prior_reset,
        }
    }

    /// The points of `scan` to match, into `self.query`: those `self.keep` keeps (not
    /// excluded), each at least `min_point_spacing_m` from the last one taken.
    fn select_query(&mut self, scan: &ScanPoints) {
        self.query.clear();
        let spacing_sq = self.config.min_point_spacing_m * self.config.min_point_spacing_m;
        let mut last_kept: Option<Point2<Robot>> = None;
        for (&p, &k) in scan.points().iter().zip(&self.keep) {
            if !k {
                continue;
            }
            if let Some(l) = last_kept {
                let (dx, dy) = (p.x - l.x, p.y - l.y);
                if dx * dx + dy * dy < spacing_sq {
                    continue;
                }
            }
            last_kept = Some(p);
            self.query.push(p);
        }
    }

    fn prior_increment(
        &self,
        prior: MotionPrior,
        state: &State,
        dt_s: f64,
        reset: bool,
    ) -> Pose2<Robot, Robot> {
        match prior {
            MotionPrior::ConstantVelocity if reset => Pose2::IDENTITY,
            MotionPrior::ConstantVelocity => {
                let (vx, vy, w) = state.velocity;
                Pose2::new(vx * dt_s, vy * dt_s, w * dt_s)
            }
            MotionPrior::Velocity { v_mps, w_radps } => arc(v_mps, w_radps, dt_s),
            MotionPrior::Increment(p) if p.is_finite() => p,
            MotionPrior::Increment(_) | MotionPrior::Stationary => Pose2::IDENTITY,
        }
    }

    fn take_keyframe(
        &mut self,
        scan: &ScanPoints,
        stamp: Stamp,
        world_from_robot: Pose2<World, Robot>,
        cov: Mat3,
    ) {
        self.counts.keyframes += 1;
        let keep = &self.keep;
        self.keyframe
            .rebuild(scan, &self.config.icp.lines, |i| keep[i]);
        let velocity = self.state.as_ref().map_or((0.0, 0.0, 0.0), |s| s.velocity);
        let trusted = self.state.as_ref().and_then(|s| s.trusted);
        self.state = Some(State {
            last_stamp: stamp,
            world_from_keyframe: world_from_robot,
            world_from_keyframe_cov: cov,
            keyframe_from_last: Pose2::IDENTITY,
            velocity,
            trusted,
        });
    }
}

/// The pose reached by driving at `v_mps` and turning at `w_radps` for `dt_s` from the
/// origin (the exact unicycle arc: `x = v/w sin(w dt)`, `y = v/w (1 - cos(w dt))`).
pub fn arc(v_mps: f64, w_radps: f64, dt_s: f64) -> Pose2<Robot, Robot> {
    if !(v_mps.is_finite() && w_radps.is_finite() && dt_s.is_finite()) {
        return Pose2::IDENTITY;
    }
    let th = w_radps * dt_s;
    if th.abs() < 1e-9 {
        return Pose2::new(v_mps * dt_s, 0.0, th);
    }
    let r = v_mps / w_radps;
    Pose2::new(r * th.sin(), r * (1.0 - th.cos()), th)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_bounds_allow_what_a_base_does_and_nothing_more() {
        let b = RobotBounds::default();
        let still = (0.0, 0.0, 0.0);
        // Cruising and turning, from an unknown earlier velocity (only the limits).
        assert!(b.allows((1.5, 0.1, 1.0), (1.5, 0.1, 1.0), 0.0));
        assert!(!b.allows((3.0, 0.0, 0.0), (3.0, 0.0, 0.0), 0.0), "too fast");
        assert!(!b.allows((0.5, 0.8, 0.0), (0.5, 0.8, 0.0), 0.0), "sideways");
        assert!(
            !b.allows((0.0, 0.0, 4.0), (0.0, 0.0, 4.0), 0.0),
            "spins too fast"
        );
        // From standing: 0.5 m/s in 0.1 s is within 3 m/s^2 plus the slack, 1 m/s is not,
        // but it is after half a second.
        assert!(b.allows((0.5, 0.0, 0.0), still, 0.1));
        assert!(!b.allows((1.0, 0.0, 0.0), still, 0.1));
        assert!(b.allows((1.0, 0.0, 0.0), still, 0.5));
        assert!(
            !b.allows((0.0, 0.0, 1.5), still, 0.1),
            "angular acceleration"
        );
        assert!(b.allows((0.0, 0.0, 1.5), still, 0.2));
    }
}
