//! The paper's per-frame "complementary fusion algorithm" (section IV), kept as a mode
//! of its own so that its behaviour can be compared with the tracker's.
//!
//! For each vision observation `(mu_v, P_vv)`, compute the Mahalanobis distance to every
//! laser person `(mu_l, P_ll)` of the scan, `D^2 = (mu_l - mu_v)^T (P_ll + P_vv)^-1
//! (mu_l - mu_v)`; if the nearest is within the threshold, "assume it is the same
//! tracking object" and fuse the two (Covariance Intersection in the paper). Nothing
//! carries over from one frame to the next. (The paper loops over the laser features
//! and keeps the last one that passes; the nearest one is what it means and is
//! independent of the order the features come in.)

use serde::{Deserialize, Serialize};
use tether_core::{Frame, Gaussian2};

use crate::ci::{CiCriterion, covariance_intersection, independent_fusion};
use crate::gate::Gate;

/// How two gated estimates are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FusionRule {
    /// Covariance Intersection, weight minimising the determinant (the paper's choice).
    #[default]
    CiDeterminant,
    /// Covariance Intersection, weight minimising the trace.
    CiTrace,
    /// Independent-error (Kalman) fusion: tighter, right only if the errors really are
    /// independent.
    Kalman,
}

impl FusionRule {
    /// Fuses a vision estimate and a laser estimate.
    pub fn fuse<F: Frame>(self, vision: &Gaussian2<F>, laser: &Gaussian2<F>) -> Gaussian2<F> {
        match self {
            FusionRule::CiDeterminant => {
                covariance_intersection(vision, laser, CiCriterion::Determinant).estimate
            }
            FusionRule::CiTrace => {
                covariance_intersection(vision, laser, CiCriterion::Trace).estimate
            }
            FusionRule::Kalman => independent_fusion(vision, laser).estimate,
        }
    }
}

/// One fused person of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusedPerson<F: Frame> {
    /// The fused estimate.
    pub estimate: Gaussian2<F>,
    /// Index of the vision observation.
    pub vision: usize,
    /// Index of the laser observation.
    pub laser: usize,
    /// Their squared Mahalanobis distance.
    pub d2: f64,
}

/// Pairs each vision observation with its nearest gated laser observation and fuses
/// them. Vision observations with no laser partner are left out, as in the paper.
pub fn complementary_fusion<F: Frame>(
    vision: &[Gaussian2<F>],
    laser: &[Gaussian2<F>],
    gate: &Gate,
    rule: FusionRule,
) -> Vec<FusedPerson<F>> {
    vision
        .iter()
        .enumerate()
        .filter_map(|(vi, v)| {
            laser
                .iter()
                .enumerate()
                .filter_map(|(li, l)| gate.test(v, l).map(|d2| (li, d2)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(li, d2)| FusedPerson {
                    estimate: rule.fuse(v, &laser[li]),
                    vision: vi,
                    laser: li,
                    d2,
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Cov2, Point2, World};

    #[test]
    fn pairs_each_person_with_the_nearest_gated_laser_blob() {
        let g = |x: f64, y: f64, a: f64, b: f64| {
            Gaussian2::<World>::new(Point2::new(x, y), Cov2::from_axes(a, b, 0.0).unwrap()).unwrap()
        };
        let vision = [g(2.2, 0.0, 0.3, 0.03), g(4.0, 2.0, 0.4, 0.05)];
        // A table leg far off the ray, the person's legs, and nothing near the 2nd.
        let laser = [g(2.0, 0.6, 0.03, 0.03), g(2.02, 0.01, 0.04, 0.04)];
        let fused =
            complementary_fusion(&vision, &laser, &Gate::default(), FusionRule::CiDeterminant);
        assert_eq!(fused.len(), 1);
        assert_eq!((fused[0].vision, fused[0].laser), (0, 1));
        assert!((fused[0].estimate.mean.x - 2.02).abs() < 0.03);
    }
}
