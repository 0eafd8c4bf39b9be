//! The returns of one scan, in the robot frame, ordered by beam direction.

use tether_core::{Laser, LaserScan, Point2, Pose2, RangeNoiseModel, Robot};
use thiserror::Error;

/// Why the beams given cannot make a scan to match.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ScanPointsError {
    /// The angle and range slices differ in length.
    #[error("{angles} beam angles but {ranges} ranges were given")]
    LengthMismatch {
        /// Angles given.
        angles: usize,
        /// Ranges given.
        ranges: usize,
    },
    /// A beam angle is NaN or infinite.
    #[error("beam {index} has a non-finite angle {angle_rad}")]
    BadAngle {
        /// Beam index.
        index: usize,
        /// The angle, rad.
        angle_rad: f64,
    },
    /// The beam angles do not increase strictly (after the scan's own direction is
    /// taken into account), so the scan cannot be searched by direction.
    #[error(
        "beam angles must increase strictly: beam {index} at {angle_rad} rad follows {previous_rad} rad"
    )]
    NotIncreasing {
        /// Beam index.
        index: usize,
        /// Its angle, rad.
        angle_rad: f64,
        /// The previous beam's angle, rad.
        previous_rad: f64,
    },
    /// The beams cover a full turn or more, so a direction would not name one beam.
    #[error("beam directions must span less than a full turn, got {span_rad} rad")]
    SpanTooWide {
        /// Last direction minus first, rad.
        span_rad: f64,
    },
    /// The mount is not a finite pose.
    #[error("robot_from_laser must be finite, got ({x}, {y}, {yaw})")]
    BadMount {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// yaw, rad.
        yaw: f64,
    },
}

/// The returns of one scan: each as a point in the robot frame and as the direction of
/// its beam in the laser frame, ordered by that direction (strictly increasing).
///
/// Keeping the beam direction is what lets a later scan find its nearest points without a
/// k-d tree: a point seen from the laser at bearing `b` can only be close to reference
/// points whose beams point near `b` (see [`crate::Reference`]).
///
/// Beams with no return, and ranges that are not positive finite numbers, are dropped
/// and counted in [`ScanPoints::dropped`].
#[derive(Debug, Clone)]
pub struct ScanPoints {
    robot_from_laser: Pose2<Robot, Laser>,
    bearings_rad: Vec<f64>,
    /// `(cos, sin)` of each bearing.
    directions: Vec<(f64, f64)>,
    ranges_m: Vec<f64>,
    points: Vec<Point2<Robot>>,
    dropped: usize,
}

impl Default for ScanPoints {
    fn default() -> Self {
        ScanPoints {
            robot_from_laser: Pose2::IDENTITY,
            bearings_rad: Vec::new(),
            directions: Vec::new(),
            ranges_m: Vec::new(),
            points: Vec::new(),
            dropped: 0,
        }
    }
}

fn check_mount(robot_from_laser: Pose2<Robot, Laser>) -> Result<(), ScanPointsError> {
    if robot_from_laser.is_finite() {
        Ok(())
    } else {
        Err(ScanPointsError::BadMount {
            x: robot_from_laser.x,
            y: robot_from_laser.y,
            yaw: robot_from_laser.yaw,
        })
    }
}

impl ScanPoints {
    /// The returns of `scan`, a scanner mounted at `robot_from_laser`.
    pub fn from_scan(
        scan: &LaserScan,
        robot_from_laser: Pose2<Robot, Laser>,
    ) -> Result<Self, ScanPointsError> {
        let mut s = ScanPoints::default();
        s.fill_from_scan(scan, robot_from_laser)?;
        Ok(s)
    }

    /// Refills `self` from `scan` without allocating once the buffers are large enough.
    /// A clockwise scanner (negative angle increment) is read backwards so that the
    /// directions increase.
    pub fn fill_from_scan(
        &mut self,
        scan: &LaserScan,
        robot_from_laser: Pose2<Robot, Laser>,
    ) -> Result<(), ScanPointsError> {
        check_mount(robot_from_laser)?;
        self.clear(robot_from_laser);
        let n = scan.len();
        let span_rad = (scan.angle_increment_rad * (n as f64 - 1.0)).abs();
        if span_rad >= std::f64::consts::TAU {
            return Err(ScanPointsError::SpanTooWide { span_rad });
        }
        let ranges = scan.ranges_m();
        for k in 0..n {
            let i = if scan.angle_increment_rad > 0.0 {
                k
            } else {
                n - 1 - k
            };
            self.push(scan.angle_rad(i), f64::from(ranges[i]));
        }
        Ok(())
    }

    /// Like [`ScanPoints::fill_from_scan`], with the calibrated range bias removed from
    /// every return first (`r - bias(r)`, design 2.1), as tether-laser's pre-processing
    /// does; a corrected range that is not positive is dropped and counted.
    pub fn fill_from_scan_corrected(
        &mut self,
        scan: &LaserScan,
        robot_from_laser: Pose2<Robot, Laser>,
        noise: &RangeNoiseModel,
    ) -> Result<(), ScanPointsError> {
        if noise.bias_m.0.is_empty() {
            return self.fill_from_scan(scan, robot_from_laser);
        }
        // Parallel to fill_from_scan on purpose: that is scan odometry's per-scan fill, and
        // one loop shared with a range closure measured 1-2 % slower (issue 18).
        check_mount(robot_from_laser)?;
        self.clear(robot_from_laser);
        let n = scan.len();
        let span_rad = (scan.angle_increment_rad * (n as f64 - 1.0)).abs();
        if span_rad >= std::f64::consts::TAU {
            return Err(ScanPointsError::SpanTooWide { span_rad });
        }
        let ranges = scan.ranges_m();
        for k in 0..n {
            let i = if scan.angle_increment_rad > 0.0 {
                k
            } else {
                n - 1 - k
            };
            let r = f64::from(ranges[i]);
            let r = if r.is_finite() {
                noise.corrected_m(r)
            } else {
                r
            };
            self.push(scan.angle_rad(i), r);
        }
        Ok(())
    }

    /// The returns of beams at `angles_rad` (laser frame, strictly increasing) with
    /// `ranges_m` (`+inf`, NaN or non-positive: no return), from a scanner mounted at
    /// `robot_from_laser`.
    pub fn from_polar(
        angles_rad: &[f64],
        ranges_m: &[f64],
        robot_from_laser: Pose2<Robot, Laser>,
    ) -> Result<Self, ScanPointsError> {
        if angles_rad.len() != ranges_m.len() {
            return Err(ScanPointsError::LengthMismatch {
                angles: angles_rad.len(),
                ranges: ranges_m.len(),
            });
        }
        check_mount(robot_from_laser)?;
        if let (Some(first), Some(last)) = (angles_rad.first(), angles_rad.last()) {
            let span_rad = last - first;
            if span_rad >= std::f64::consts::TAU {
                return Err(ScanPointsError::SpanTooWide { span_rad });
            }
        }
        let mut s = ScanPoints::default();
        s.clear(robot_from_laser);
        let mut previous = f64::NEG_INFINITY;
        for (index, (&a, &r)) in angles_rad.iter().zip(ranges_m).enumerate() {
            if !a.is_finite() {
                return Err(ScanPointsError::BadAngle {
                    index,
                    angle_rad: a,
                });
            }
            if a <= previous {
                return Err(ScanPointsError::NotIncreasing {
                    index,
                    angle_rad: a,
                    previous_rad: previous,
                });
            }
            previous = a;
            s.push(a, r);
        }
        Ok(s)
    }

    fn clear(&mut self, robot_from_laser: Pose2<Robot, Laser>) {
        self.robot_from_laser = robot_from_laser;
        self.bearings_rad.clear();
        self.directions.clear();
        self.ranges_m.clear();
        self.points.clear();
        self.dropped = 0;
    }

    fn push(&mut self, bearing_rad: f64, range_m: f64) {
        if !(range_m.is_finite() && range_m > 0.0) {
            self.dropped += 1;
            return;
        }
        let (s, c) = bearing_rad.sin_cos();
        let in_laser = Point2::<Laser>::new(range_m * c, range_m * s);
        self.bearings_rad.push(bearing_rad);
        self.directions.push((c, s));
        self.ranges_m.push(range_m);
        self.points.push(self.robot_from_laser * in_laser);
    }

    /// The scanner's pose on the robot.
    pub fn robot_from_laser(&self) -> Pose2<Robot, Laser> {
        self.robot_from_laser
    }

    /// The returns in the robot frame, in beam order.
    pub fn points(&self) -> &[Point2<Robot>] {
        &self.points
    }

    /// The direction of each return's beam in the laser frame, rad, increasing.
    pub fn bearings_rad(&self) -> &[f64] {
        &self.bearings_rad
    }

    /// The unit vector `(cos, sin)` of each return's beam, laser frame.
    pub fn directions(&self) -> &[(f64, f64)] {
        &self.directions
    }

    /// The range of each return, m.
    pub fn ranges_m(&self) -> &[f64] {
        &self.ranges_m
    }

    /// Number of returns.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the scan has no return at all.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Beams dropped for having no return (or a range that is not a positive number).
    pub fn dropped(&self) -> usize {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]
    use super::*;
    use tether_core::Stamp;

    #[test]
    fn clockwise_scans_are_read_in_increasing_direction() {
        let scan =
            LaserScan::new(Stamp::ZERO, "l", 1.0, -0.5, 0.02, 5.0, vec![1.0, 2.0, 3.0]).unwrap();
        let p = ScanPoints::from_scan(&scan, Pose2::new(0.1, 0.0, 0.0)).unwrap();
        assert_eq!(p.bearings_rad(), &[0.0, 0.5, 1.0]);
        assert_eq!(p.ranges_m(), &[3.0, 2.0, 1.0]);
        assert!((p.points()[0].x - 3.1).abs() < 1e-12);
    }

    #[test]
    fn range_bias_is_removed_when_asked() {
        use tether_core::Polynomial;
        let scan = LaserScan::new(Stamp::ZERO, "l", 0.0, 0.1, 0.02, 5.0, vec![1.0, 2.0]).unwrap();
        let noise = RangeNoiseModel {
            bias_m: Polynomial(vec![0.01, 0.02]),
            ..RangeNoiseModel::default()
        };
        let mut p = ScanPoints::default();
        p.fill_from_scan_corrected(&scan, Pose2::IDENTITY, &noise)
            .unwrap();
        assert!((p.ranges_m()[0] - (1.0 - 0.03)).abs() < 1e-9);
        assert!((p.ranges_m()[1] - (2.0 - 0.05)).abs() < 1e-9);
        p.fill_from_scan_corrected(&scan, Pose2::IDENTITY, &RangeNoiseModel::default())
            .unwrap();
        assert_eq!(p.ranges_m(), &[1.0, 2.0]);
    }

    #[test]
    fn bad_beams_are_dropped_and_bad_headers_refused() {
        let p = ScanPoints::from_polar(
            &[0.0, 0.1, 0.2, 0.3],
            &[1.0, f64::NAN, -1.0, f64::INFINITY],
            Pose2::IDENTITY,
        )
        .unwrap();
        assert_eq!((p.len(), p.dropped()), (1, 3));
        assert!(matches!(
            ScanPoints::from_polar(&[0.0, 0.0], &[1.0, 1.0], Pose2::IDENTITY),
            Err(ScanPointsError::NotIncreasing { index: 1, .. })
        ));
        assert!(matches!(
            ScanPoints::from_polar(&[0.0], &[1.0, 1.0], Pose2::IDENTITY),
            Err(ScanPointsError::LengthMismatch { .. })
        ));
        assert!(matches!(
            ScanPoints::from_polar(&[f64::NAN], &[1.0], Pose2::IDENTITY),
            Err(ScanPointsError::BadAngle { .. })
        ));
        assert!(matches!(
            ScanPoints::from_polar(&[0.0], &[1.0], Pose2::new(f64::NAN, 0.0, 0.0)),
            Err(ScanPointsError::BadMount { .. })
        ));
    }
}
