//! One sweep of a 2-D laser range finder, as `sensor_msgs/LaserScan` carries it, with
//! "no return" kept distinct from any distance.

use thiserror::Error;

use crate::frame::Laser;
use crate::geometry::Point2;
use crate::time::Stamp;

/// Why a scan's header cannot describe a scan.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ScanError {
    /// The angle increment is zero, NaN or infinite: beams would have no direction.
    #[error("scan angle increment must be finite and non-zero, got {0}")]
    BadAngleIncrement(f64),
    /// The start angle is NaN or infinite.
    #[error("scan start angle must be finite, got {0}")]
    BadAngleMin(f64),
    /// The range limits are not `0 <= range_min < range_max` with finite values.
    #[error(
        "scan range limits must satisfy 0 <= range_min < range_max (finite), got {min} .. {max}"
    )]
    BadRangeLimits {
        /// Shortest valid range, m.
        min: f64,
        /// Longest valid range, m.
        max: f64,
    },
    /// No beams at all.
    #[error("scan has no beams")]
    Empty,
    /// More beams than any 2-D scanner gives ([`MAX_BEAMS`]): a damaged message or
    /// a point cloud mistaken for a scan.
    #[error(
        "scan has {0} beams, more than the {MAX_BEAMS} tether takes (2-D scanners give \
         hundreds to a few thousand)"
    )]
    TooManyBeams(usize),
    /// The header promises a different number of beams than the ranges hold.
    #[error("scan header describes {expected} beams but {got} ranges were given")]
    LengthMismatch {
        /// Beams implied by the header (`angle_min`, `angle_max`, `angle_increment`).
        expected: usize,
        /// Ranges present.
        got: usize,
    },
}

/// A laser scan in the sensor's own frame.
///
/// Beam `i` points along `angle_min_rad + i * angle_increment_rad`. Its range is either a
/// distance in `[range_min_m, range_max_m]` or "no return" (nothing hit within range, or
/// an error code from the sensor), stored as `+inf` as REP 117 prescribes: never zero,
/// never a distance. Use [`LaserScan::range_m`] to read a beam as an `Option`.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Time of the first beam.
    pub stamp: Stamp,
    /// Name of the sensor frame (ROS `frame_id`).
    pub frame_id: String,
    /// Direction of beam 0, rad (counter-clockwise from the sensor's x axis).
    pub angle_min_rad: f64,
    /// Angle between consecutive beams, rad (negative for clockwise scanners).
    pub angle_increment_rad: f64,
    /// Shortest distance the sensor reports, m.
    pub range_min_m: f64,
    /// Longest distance the sensor reports, m.
    pub range_max_m: f64,
    ranges_m: Vec<f32>,
    malformed_beams: usize,
}

/// The most beams a scan may hold: 16,384, over three times the densest 2-D scanner's
/// sweep (a SICK LMS5xx at 0.042 degrees over 190 degrees gives 4,561, a Hokuyo
/// UTM-30LX 1,081, a URG-04LX 726, a 0.1-degree projection of a 3-D lidar 3,600). A
/// recording's scan with more is refused, not processed: the cap bounds what one scan
/// costs and holds (leg clustering, near-linear in the beams since issue 16, took 44 s
/// on a million beams when it was quadratic).
pub const MAX_BEAMS: usize = 1 << 14;

/// The value that marks a beam with no return.
pub const NO_RETURN: f32 = f32::INFINITY;

impl LaserScan {
    /// Builds a scan, checking the header and sorting every range into a distance or
    /// "no return".
    ///
    /// Ranges outside `[range_min_m, range_max_m]` and `+inf` become "no return" (the
    /// sensor's way of saying nothing came back). NaN, negative values and `-inf` also
    /// become "no return" but are counted in [`LaserScan::malformed_beams`], so that a
    /// caller can warn about a sick sensor instead of losing the fact silently.
    pub fn new(
        stamp: Stamp,
        frame_id: impl Into<String>,
        angle_min_rad: f64,
        angle_increment_rad: f64,
        range_min_m: f64,
        range_max_m: f64,
        ranges_m: Vec<f32>,
    ) -> Result<Self, ScanError> {
        if !angle_min_rad.is_finite() {
            return Err(ScanError::BadAngleMin(angle_min_rad));
        }
        if !angle_increment_rad.is_finite() || angle_increment_rad == 0.0 {
            return Err(ScanError::BadAngleIncrement(angle_increment_rad));
        }
        if !(range_min_m.is_finite()
            && range_max_m.is_finite()
            && range_min_m >= 0.0
            && range_min_m < range_max_m)
        {
            return Err(ScanError::BadRangeLimits {
                min: range_min_m,
                max: range_max_m,
            });
        }
        if ranges_m.is_empty() {
            return Err(ScanError::Empty);
        }
        if ranges_m.len() > MAX_BEAMS {
            return Err(ScanError::TooManyBeams(ranges_m.len()));
        }
        let mut ranges_m = ranges_m;
        let mut malformed_beams = 0;
        let (lo, hi) = (range_min_m as f32, range_max_m as f32);
        for r in &mut ranges_m {
            if r.is_nan() || *r < 0.0 {
                malformed_beams += 1;
                *r = NO_RETURN;
            } else if *r < lo || *r > hi {
                *r = NO_RETURN;
            }
        }
        Ok(LaserScan {
            stamp,
            frame_id: frame_id.into(),
            angle_min_rad,
            angle_increment_rad,
            range_min_m,
            range_max_m,
            ranges_m,
            malformed_beams,
        })
    }

    /// Like [`LaserScan::new`], but from a ROS-style header that also states
    /// `angle_max_rad`; refuses a header whose beam count disagrees with the ranges.
    #[allow(clippy::too_many_arguments)]
    pub fn with_angle_max(
        stamp: Stamp,
        frame_id: impl Into<String>,
        angle_min_rad: f64,
        angle_max_rad: f64,
        angle_increment_rad: f64,
        range_min_m: f64,
        range_max_m: f64,
        ranges_m: Vec<f32>,
    ) -> Result<Self, ScanError> {
        if !angle_increment_rad.is_finite() || angle_increment_rad == 0.0 {
            return Err(ScanError::BadAngleIncrement(angle_increment_rad));
        }
        // Compare in floating point: a damaged header can imply more beams than any
        // integer type holds.
        let span = (angle_max_rad - angle_min_rad) / angle_increment_rad;
        let got = ranges_m.len();
        if !span.is_finite() || span < -0.5 || (span.round() + 1.0) != got as f64 {
            let expected = if span.is_finite() && (-0.5..1e15).contains(&span) {
                span.round() as usize + 1
            } else {
                0
            };
            return Err(ScanError::LengthMismatch { expected, got });
        }
        Self::new(
            stamp,
            frame_id,
            angle_min_rad,
            angle_increment_rad,
            range_min_m,
            range_max_m,
            ranges_m,
        )
    }

    /// Rounds the geometry (angles, range limits) to what a `sensor_msgs/LaserScan`
    /// carries, 32-bit floats: a live run processes each scan as its recording holds
    /// it, so that a replay of the recording processes the very same scan.
    #[allow(
        clippy::cast_possible_truncation,
        reason = "the rounding to 32 bits is the point"
    )]
    pub fn round_to_message(&mut self) {
        let round = |x: f64| f64::from(x as f32);
        self.angle_min_rad = round(self.angle_min_rad);
        self.angle_increment_rad = round(self.angle_increment_rad);
        self.range_min_m = round(self.range_min_m);
        self.range_max_m = round(self.range_max_m);
    }

    /// Number of beams.
    pub fn len(&self) -> usize {
        self.ranges_m.len()
    }

    /// Always false: a scan has at least one beam.
    pub fn is_empty(&self) -> bool {
        self.ranges_m.is_empty()
    }

    /// Direction of beam `i`, rad.
    pub fn angle_rad(&self, i: usize) -> f64 {
        self.angle_min_rad + i as f64 * self.angle_increment_rad
    }

    /// Direction of the last beam, rad.
    pub fn angle_max_rad(&self) -> f64 {
        self.angle_rad(self.len() - 1)
    }

    /// Range of beam `i` in metres, or `None` when the beam has no return (or `i` is out
    /// of bounds).
    pub fn range_m(&self, i: usize) -> Option<f32> {
        self.ranges_m.get(i).copied().filter(|r| r.is_finite())
    }

    /// The same scan (stamp, frame, geometry, limits) with other ranges, checked as
    /// [`LaserScan::new`] checks them.
    pub fn with_ranges(&self, ranges_m: Vec<f32>) -> Result<Self, ScanError> {
        LaserScan::new(
            self.stamp,
            self.frame_id.clone(),
            self.angle_min_rad,
            self.angle_increment_rad,
            self.range_min_m,
            self.range_max_m,
            ranges_m,
        )
    }

    /// All ranges, `+inf` marking "no return".
    pub fn ranges_m(&self) -> &[f32] {
        &self.ranges_m
    }

    /// Beams that came in as NaN, negative or `-inf` and were turned into "no return".
    pub fn malformed_beams(&self) -> usize {
        self.malformed_beams
    }

    /// Number of beams with a return.
    pub fn returns(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_finite()).count()
    }

    /// The returns as `(beam index, point in the sensor frame)`.
    pub fn points(&self) -> impl Iterator<Item = (usize, Point2<Laser>)> + '_ {
        self.ranges_m
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_finite())
            .map(|(i, &r)| (i, Point2::from_polar(f64::from(r), self.angle_rad(i))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges: Vec<f32>) -> Result<LaserScan, ScanError> {
        LaserScan::new(Stamp::ZERO, "laser", -1.0, 0.5, 0.02, 5.6, ranges)
    }

    #[test]
    fn no_return_is_not_a_distance() {
        let s = scan(vec![
            1.0,
            f32::INFINITY,
            0.01,
            6.0,
            f32::NAN,
            -1.0,
            f32::NEG_INFINITY,
        ])
        .unwrap();
        assert_eq!(s.range_m(0), Some(1.0));
        for i in 1..7 {
            assert_eq!(s.range_m(i), None, "beam {i}");
        }
        assert_eq!(s.malformed_beams(), 3);
        assert_eq!(s.returns(), 1);
        assert_eq!(s.points().count(), 1);
        assert_eq!(s.range_m(99), None);
    }

    #[test]
    fn refuses_bad_headers() {
        assert!(matches!(
            LaserScan::new(Stamp::ZERO, "l", 0.0, 0.0, 0.0, 1.0, vec![1.0]),
            Err(ScanError::BadAngleIncrement(_))
        ));
        assert!(matches!(
            LaserScan::new(Stamp::ZERO, "l", f64::NAN, 0.1, 0.0, 1.0, vec![1.0]),
            Err(ScanError::BadAngleMin(_))
        ));
        assert!(matches!(
            LaserScan::new(Stamp::ZERO, "l", 0.0, 0.1, 2.0, 1.0, vec![1.0]),
            Err(ScanError::BadRangeLimits { .. })
        ));
        assert!(matches!(scan(vec![]), Err(ScanError::Empty)));
        // A million beams (once 44 s of leg clustering) is refused; the cap itself taken.
        assert_eq!(
            scan(vec![1.0; 1_000_000]).unwrap_err(),
            ScanError::TooManyBeams(1_000_000)
        );
        assert!(scan(vec![1.0; MAX_BEAMS]).is_ok());
        assert!(matches!(
            LaserScan::with_angle_max(Stamp::ZERO, "l", -1.0, 1.0, 0.5, 0.0, 5.0, vec![1.0; 4]),
            Err(ScanError::LengthMismatch {
                expected: 5,
                got: 4
            })
        ));
        assert!(
            LaserScan::with_angle_max(Stamp::ZERO, "l", -1.0, 1.0, 0.5, 0.0, 5.0, vec![1.0; 5])
                .is_ok()
        );
    }

    #[test]
    fn points_follow_beam_angles() {
        let s = LaserScan::new(
            Stamp::ZERO,
            "l",
            0.0,
            std::f64::consts::FRAC_PI_2,
            0.0,
            5.0,
            vec![1.0, 2.0],
        )
        .unwrap();
        let pts: Vec<_> = s.points().collect();
        assert!((pts[0].1.x - 1.0).abs() < 1e-9);
        assert!((pts[1].1.y - 2.0).abs() < 1e-6 && pts[1].1.x.abs() < 1e-6);
    }
}
