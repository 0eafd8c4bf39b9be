//! The paper's leg test (Luo et al., section III.B; design 4.3): a segment is a leg
//! candidate when it is an arc of leg size whose centre lies behind it.
//!
//! On a circle the perpendicular bisector of every chord passes through the centre,
//! so the bisectors of a segment's chords meet in one point. The test takes, for every
//! interior point `p[j]` of the middle third of the segment (`j` from `floor(n / 3)`
//! to `n - 1 - floor(n / 3)`, at least the middle point), the chords `p[0] p[j]` and
//! `p[j] p[n-1]`; their bisectors meet at the circumcentre `c_j` of `(p[0], p[j],
//! p[n-1])`. Long chords matter: the sagitta of a chord of length `l` on a leg of
//! radius `R` is `R - sqrt(R^2 - l^2 / 4)`, about 3 cm for the whole visible side of a
//! 6 cm leg but under 3 mm for a third of it, below the range noise. The segment is a
//! leg candidate when
//!
//! 1. every `c_j` lies within `delta` (the paper: 40 mm) of their mean `c`;
//! 2. `c` lies behind the arc: farther from the sensor than the mean of the points;
//! 3. the diameter `2 r`, with `r` the mean distance of the points from `c`, is in
//!    `[diameter_min_m, diameter_max_m]` (the paper says 70-80 mm; real URG-04LX data
//!    at shin height shows 9-16 cm, hence the default 0.05-0.20 m).

use serde::{Deserialize, Serialize};
use tether_core::{Laser, Point2};

use crate::fit::{centroid, circumcentre};
use crate::preprocess::ScanPoint;

/// Parameters of the arc test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct ArcTestConfig {
    /// Largest distance of a bisector intersection from their mean, m (default 0.04,
    /// the paper's delta).
    #[config(range = "> 0")]
    pub delta_m: f64,
    /// Smallest accepted leg diameter, m (default 0.05).
    #[config(range = ">= 0")]
    pub diameter_min_m: f64,
    /// Largest accepted leg diameter, m (default 0.20).
    pub diameter_max_m: f64,
}

impl Default for ArcTestConfig {
    fn default() -> Self {
        ArcTestConfig {
            delta_m: 0.04,
            diameter_min_m: 0.05,
            diameter_max_m: 0.20,
        }
    }
}

impl ArcTestConfig {
    /// Checks the parameter ranges; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.delta_m.is_finite() && self.delta_m > 0.0) {
            return Err(format!("arc delta_m must be > 0, got {}", self.delta_m));
        }
        if !(self.diameter_min_m.is_finite()
            && self.diameter_max_m.is_finite()
            && 0.0 <= self.diameter_min_m
            && self.diameter_min_m < self.diameter_max_m)
        {
            return Err(format!(
                "arc diameters must satisfy 0 <= diameter_min_m < diameter_max_m, got {} .. {}",
                self.diameter_min_m, self.diameter_max_m
            ));
        }
        Ok(())
    }
}

/// A segment that passed the arc test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcLeg {
    /// Mean of the bisector intersections, m.
    pub centre_in_laser: Point2<Laser>,
    /// Mean distance of the points from the centre, m.
    pub radius_m: f64,
    /// Largest distance of an intersection from the centre, m (`<= delta`).
    pub spread_m: f64,
}

/// Why a segment failed the arc test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArcReject {
    /// Fewer than three points.
    TooFewPoints,
    /// Three points are collinear: bisectors are parallel.
    Collinear,
    /// An intersection lies farther than delta from the mean one.
    Spread {
        /// Largest distance, m.
        spread_m: f64,
    },
    /// The centre is in front of the arc (a concave surface such as a corner).
    CentreInFront,
    /// The diameter is outside the leg range.
    Diameter {
        /// Fitted diameter, m.
        diameter_m: f64,
    },
}

/// Runs the arc test on the points of one segment (in beam order).
pub fn arc_test(points: &[ScanPoint], config: &ArcTestConfig) -> Result<ArcLeg, ArcReject> {
    let n = points.len();
    if n < 3 {
        return Err(ArcReject::TooFewPoints);
    }
    let third = n / 3;
    let (lo, hi) = if n - 1 - third > third {
        (third, n - 1 - third)
    } else {
        (n / 2, n / 2)
    };
    let (first, last) = (points[0].point_in_laser, points[n - 1].point_in_laser);
    let count = hi - lo + 1;
    // At most n / 3 + 1 intersections: a small stack buffer avoids a heap allocation
    // for all but very long segments.
    let mut stack = [Point2::<Laser>::ORIGIN; 32];
    let mut heap = Vec::new();
    let centres: &mut [Point2<Laser>] = if count <= stack.len() {
        &mut stack[..count]
    } else {
        heap.resize(count, Point2::ORIGIN);
        &mut heap
    };
    let (mut sx, mut sy) = (0.0, 0.0);
    for (slot, j) in centres.iter_mut().zip(lo..=hi) {
        let c = circumcentre(first, points[j].point_in_laser, last).ok_or(ArcReject::Collinear)?;
        sx += c.x;
        sy += c.y;
        *slot = c;
    }
    let centre = Point2::new(sx / count as f64, sy / count as f64);
    let spread_sq = centres
        .iter()
        .map(|c| {
            let (dx, dy) = (c.x - centre.x, c.y - centre.y);
            dx * dx + dy * dy
        })
        .fold(0.0, f64::max);
    let spread_m = spread_sq.sqrt();
    if spread_m > config.delta_m {
        return Err(ArcReject::Spread { spread_m });
    }
    let mean = centroid(points);
    if centre.range_m() <= mean.range_m() {
        return Err(ArcReject::CentreInFront);
    }
    let radius_m = points
        .iter()
        .map(|p| p.point_in_laser.distance_m(centre))
        .sum::<f64>()
        / n as f64;
    let diameter_m = 2.0 * radius_m;
    if !(diameter_m >= config.diameter_min_m && diameter_m <= config.diameter_max_m) {
        return Err(ArcReject::Diameter { diameter_m });
    }
    Ok(ArcLeg {
        centre_in_laser: centre,
        radius_m,
        spread_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::tests::points_at;
    use proptest::prelude::*;

    /// Points where the beams from the origin hit a circle of radius `r` at distance
    /// `d` and bearing `b`, for beams `inc` apart (the visible side only).
    fn seen_circle(d: f64, b: f64, r: f64, inc: f64, noise: &[f64]) -> Vec<(f64, f64)> {
        let half = (r / d).asin();
        let mut out = Vec::new();
        let mut k = 0;
        let mut t = b - half + 1e-6;
        while t < b + half {
            // Ray-circle intersection, nearer root.
            let (c, s) = (t.cos(), t.sin());
            let (cx, cy) = (d * b.cos(), d * b.sin());
            let proj = c * cx + s * cy;
            let disc = proj * proj - (cx * cx + cy * cy - r * r);
            if disc >= 0.0 {
                let range = proj - disc.sqrt() + noise.get(k).copied().unwrap_or(0.0);
                out.push((range * c, range * s));
                k += 1;
            }
            t += inc;
        }
        out
    }

    #[test]
    fn accepts_a_leg_and_finds_its_centre() {
        let pts = points_at(&seen_circle(1.7, 0.3, 0.06, 0.006_136, &[]));
        assert!(pts.len() >= 10, "{}", pts.len());
        let leg = arc_test(&pts, &ArcTestConfig::default()).unwrap();
        let truth = Point2::<Laser>::from_polar(1.7, 0.3);
        assert!(leg.centre_in_laser.distance_m(truth) < 1e-6);
        assert!((leg.radius_m - 0.06).abs() < 1e-6);
    }

    #[test]
    fn rejects_lines_corners_and_big_arcs() {
        let line = points_at(&(0..10).map(|i| (2.0, 0.01 * i as f64)).collect::<Vec<_>>());
        assert_eq!(
            arc_test(&line, &ArcTestConfig::default()),
            Err(ArcReject::Collinear)
        );
        // Concave: the inside of a circle, centre in front.
        let concave: Vec<(f64, f64)> = (0..10)
            .map(|i| {
                let t = -0.5 + 0.1 * i as f64;
                (1.0 + 0.1 * t.cos(), 0.1 * t.sin())
            })
            .collect();
        assert_eq!(
            arc_test(&points_at(&concave), &ArcTestConfig::default()),
            Err(ArcReject::CentreInFront)
        );
        let pillar = points_at(&seen_circle(2.0, 0.0, 0.25, 0.006_136, &[]));
        assert!(matches!(
            arc_test(&pillar, &ArcTestConfig::default()),
            Err(ArcReject::Diameter { .. })
        ));
        assert_eq!(
            arc_test(&pillar[..2], &ArcTestConfig::default()),
            Err(ArcReject::TooFewPoints)
        );
    }

    proptest! {
        /// Arcs of leg-sized circles seen with 1 mm noise and at least 8 points pass;
        /// straight segments never do.
        #[test]
        fn circles_pass_and_lines_fail(
            d in 0.5..3.0f64,
            b in -1.5..1.5f64,
            r in 0.035..0.09f64,
            noise in prop::collection::vec(-0.001..0.001f64, 64),
            along in 0.1..0.6f64,
            heading in 0.0..std::f64::consts::PI,
        ) {
            let pts = points_at(&seen_circle(d, b, r, 0.006_136, &noise));
            prop_assume!(pts.len() >= 8);
            let leg = arc_test(&pts, &ArcTestConfig::default());
            prop_assert!(leg.is_ok(), "{:?} for d {d} r {r} ({} points)", leg, pts.len());
            let leg = leg.unwrap();
            prop_assert!(leg.centre_in_laser.distance_m(Point2::from_polar(d, b)) < 0.03);

            let start = Point2::<Laser>::from_polar(d, b);
            let line: Vec<(f64, f64)> = (0..12)
                .map(|i| {
                    let s = along * i as f64 / 11.0;
                    (start.x + s * heading.cos() + noise[i] * 0.1, start.y + s * heading.sin())
                })
                .collect();
            prop_assert!(arc_test(&points_at(&line), &ArcTestConfig::default()).is_err());
        }
    }
}
