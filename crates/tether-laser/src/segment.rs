//! Segmentation (SPEC 4.2): split the returns of a scan into segments where two
//! consecutive returns are too far apart to lie on one surface.

use serde::{Deserialize, Serialize};
use tether_core::RangeNoiseModel;

use crate::preprocess::ScanPoint;

/// When two consecutive returns start a new segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case", deny_unknown_fields)]
pub enum Breakpoint {
    /// Borges and Aldon's adaptive breakpoint ("Line extraction in 2D range images for
    /// mobile robotics", J. Intell. Robot. Syst. 40, 2004): returns `p[n-1]`, `p[n]`
    /// whose beams are `dphi` apart belong to one surface while
    ///
    /// ```text
    /// |p[n] - p[n-1]| <= D_max = r[n-1] * sin(dphi) / sin(lambda - dphi) + 3 sigma_r(r[n-1])
    /// ```
    ///
    /// where `lambda` is the shallowest incidence angle at which a surface still counts
    /// as one (the first term is the gap between returns on a surface seen at
    /// `lambda`) and `sigma_r` the range noise. Beams of no return between the two
    /// widen `dphi`; at `dphi >= lambda` the returns are always split.
    Adaptive {
        /// `lambda`, rad. Borges and Aldon use 10 deg.
        lambda_rad: f64,
    },
    /// A fixed jump: split where `|p[n] - p[n-1]| > jump_m` (SPEC: 0.1-0.2 m; the
    /// leg_tracker clustering uses 0.13 m).
    FixedJump {
        /// The largest gap inside a segment, m.
        jump_m: f64,
    },
    /// Both rules: split where either says so, i.e. where the gap exceeds
    /// `min(D_max, jump_m)`. The adaptive threshold separates objects finely near the
    /// sensor; the fixed jump caps it far away, where `D_max` (growing as `r (1 /
    /// sin(lambda) + 3 sigma_r / r)`) would merge two legs one behind the other.
    AdaptiveOrJump {
        /// `lambda` of the adaptive rule, rad.
        lambda_rad: f64,
        /// The largest gap inside a segment, m.
        jump_m: f64,
    },
}

/// The default: [`Breakpoint::AdaptiveOrJump`] with Borges and Aldon's `lambda` = 10
/// deg and a 0.13 m jump. A leg's cross-section is 0.09-0.16 m wide, so two returns
/// on one leg are never farther apart than that, while the gap between two legs in a
/// stride (0.2-0.3 m along the ray) or between a leg and what stands behind it is
/// larger. The adaptive rule alone, with the default noise model (`3 sigma_r` = 3 % of
/// the range), merges the legs of a walker beyond about 2.5 m.
impl Default for Breakpoint {
    fn default() -> Self {
        Breakpoint::AdaptiveOrJump {
            lambda_rad: 10f64.to_radians(),
            jump_m: 0.13,
        }
    }
}

impl Breakpoint {
    /// Checks the parameter ranges; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Breakpoint::Adaptive { lambda_rad } => {
                if lambda_rad.is_finite() && lambda_rad > 0.0 && lambda_rad < 1.5 {
                    Ok(())
                } else {
                    Err(format!(
                        "breakpoint lambda_rad must be in (0, 1.5) rad, got {lambda_rad}"
                    ))
                }
            }
            Breakpoint::FixedJump { jump_m } => check_jump(jump_m),
            Breakpoint::AdaptiveOrJump { lambda_rad, jump_m } => {
                Breakpoint::Adaptive { lambda_rad }.validate()?;
                check_jump(jump_m)
            }
        }
    }
}

fn check_jump(jump_m: f64) -> Result<(), String> {
    if jump_m.is_finite() && jump_m > 0.0 {
        Ok(())
    } else {
        Err(format!("breakpoint jump_m must be > 0 m, got {jump_m}"))
    }
}

/// Borges and Aldon's `D_max` between a return at `range_m` and the next one `dphi`
/// later; infinite-free: `None` when `dphi >= lambda` (always split).
fn adaptive_max_gap_m(
    range_m: f64,
    dphi: f64,
    lambda_rad: f64,
    noise: &RangeNoiseModel,
) -> Option<f64> {
    (dphi < lambda_rad)
        .then(|| range_m * dphi.sin() / (lambda_rad - dphi).sin() + 3.0 * noise.sigma_m(range_m))
}

/// A run of consecutive returns: `points[start..end]` of the pre-processed scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// First point (index into the pre-processed points).
    pub start: usize,
    /// One past the last point.
    pub end: usize,
}

impl Segment {
    /// Number of returns.
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// Always false: a segment has at least one return.
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }
}

/// Splits `points` (in beam order) into segments by `rule`, writing them to `out`.
/// `angle_increment_rad` is the scan's; `noise` gives `sigma_r` for the adaptive rule.
pub fn segment_into(
    points: &[ScanPoint],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    rule: Breakpoint,
    out: &mut Vec<Segment>,
) {
    out.clear();
    if points.is_empty() {
        return;
    }
    let dphi_one = angle_increment_rad.abs();
    let mut start = 0;
    for k in 1..points.len() {
        let (a, b) = (&points[k - 1], &points[k]);
        let gap_sq = {
            let d = b.point_in_laser - a.point_in_laser;
            d.x * d.x + d.y * d.y
        };
        let dphi = (b.beam - a.beam) as f64 * dphi_one;
        let max_gap_m = match rule {
            Breakpoint::FixedJump { jump_m } => Some(jump_m),
            Breakpoint::Adaptive { lambda_rad } => {
                adaptive_max_gap_m(a.range_m, dphi, lambda_rad, noise)
            }
            Breakpoint::AdaptiveOrJump { lambda_rad, jump_m } => {
                adaptive_max_gap_m(a.range_m, dphi, lambda_rad, noise).map(|d| d.min(jump_m))
            }
        };
        let split = max_gap_m.is_none_or(|d| gap_sq > d * d);
        if split {
            out.push(Segment { start, end: k });
            start = k;
        }
    }
    out.push(Segment {
        start,
        end: points.len(),
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{LaserScan, Stamp};

    use crate::preprocess::preprocess;

    const INC: f64 = 0.006_135_92;
    const ADAPTIVE: Breakpoint = Breakpoint::Adaptive {
        lambda_rad: 10.0 * std::f64::consts::PI / 180.0,
    };

    fn points(ranges: Vec<f32>) -> Vec<ScanPoint> {
        let scan = LaserScan::new(Stamp::ZERO, "l", 0.0, INC, 0.02, 5.6, ranges).unwrap();
        preprocess(&scan, &RangeNoiseModel::default())
    }

    fn lens(points: &[ScanPoint], rule: Breakpoint) -> Vec<usize> {
        let mut out = Vec::new();
        segment_into(points, INC, &RangeNoiseModel::default(), rule, &mut out);
        out.iter().map(|s| s.len()).collect()
    }

    #[test]
    fn splits_at_range_jumps() {
        let mut ranges = vec![2.0f32; 10];
        ranges.extend(vec![1.5f32; 5]);
        ranges.extend(vec![2.0f32; 10]);
        let pts = points(ranges);
        assert_eq!(lens(&pts, Breakpoint::default()), vec![10, 5, 10]);
        assert_eq!(lens(&pts, ADAPTIVE), vec![10, 5, 10]);
        assert_eq!(
            lens(&pts, Breakpoint::FixedJump { jump_m: 0.13 }),
            vec![10, 5, 10]
        );
        assert_eq!(lens(&pts, Breakpoint::FixedJump { jump_m: 0.6 }), vec![25]);
    }

    #[test]
    fn adaptive_threshold_grows_with_range() {
        // A 7 cm step: the same surface at 4 m (D_max ~ 0.27 m), a new one at 0.5 m
        // (D_max ~ 0.048 m).
        let far = points(vec![4.0, 4.0, 4.07, 4.07]);
        assert_eq!(lens(&far, ADAPTIVE), vec![4]);
        let near = points(vec![0.5, 0.5, 0.57, 0.57]);
        assert_eq!(lens(&near, ADAPTIVE), vec![2, 2]);
        assert_eq!(lens(&near, Breakpoint::default()), vec![2, 2]);
    }

    #[test]
    fn the_jump_caps_the_adaptive_threshold_far_away() {
        // Two legs of a stride at 3 m, 0.15 m apart along the ray: D_max ~ 0.2 m merges
        // them, the 0.13 m cap does not.
        let stride = points(vec![3.0, 3.0, 3.0, 2.85, 2.85, 2.85]);
        assert_eq!(lens(&stride, ADAPTIVE), vec![6]);
        assert_eq!(lens(&stride, Breakpoint::default()), vec![3, 3]);
    }

    #[test]
    fn missing_beams_widen_the_gap_and_long_gaps_split() {
        let mut ranges = vec![2.0f32; 3];
        ranges.extend(vec![f32::INFINITY; 2]);
        ranges.extend(vec![2.0f32; 3]);
        assert_eq!(
            lens(&points(ranges.clone()), Breakpoint::default()),
            vec![6]
        );
        assert_eq!(lens(&points(ranges), ADAPTIVE), vec![6]);
        let mut ranges = vec![2.0f32; 3];
        ranges.extend(vec![f32::INFINITY; 40]); // 40 beams = 14 deg > lambda
        ranges.extend(vec![2.0f32; 3]);
        assert_eq!(lens(&points(ranges), Breakpoint::default()), vec![3, 3]);
    }

    #[test]
    fn empty_input_gives_no_segment() {
        assert!(lens(&[], Breakpoint::default()).is_empty());
    }

    #[test]
    fn validates_parameters() {
        assert!(Breakpoint::default().validate().is_ok());
        assert!(Breakpoint::Adaptive { lambda_rad: 0.0 }.validate().is_err());
        assert!(
            Breakpoint::AdaptiveOrJump {
                lambda_rad: 0.2,
                jump_m: 0.0
            }
            .validate()
            .is_err()
        );
        assert!(
            Breakpoint::FixedJump { jump_m: f64::NAN }
                .validate()
                .is_err()
        );
    }
}
