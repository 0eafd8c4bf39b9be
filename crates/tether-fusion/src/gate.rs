//! Mahalanobis gating of two independent estimates (design 5, paper section IV):
//! `D^2 = (mu_a - mu_b)^T S^-1 (mu_a - mu_b)` with `S = P_a + P_b`, accepted when
//! `D^2 < T` for a chi-square quantile `T` with 2 degrees of freedom.

use serde::{Deserialize, Serialize};
use tether_core::{Frame, Gaussian2};

/// Chi-square quantile, 2 degrees of freedom, 95 %.
pub const CHI2_2DOF_95: f64 = 5.991;
/// 99 % quantile of chi-square with 1 degree of freedom (a scalar innovation, e.g. a
/// bearing).
pub const CHI2_1DOF_99: f64 = 6.635;
/// Chi-square quantile, 2 degrees of freedom, 99 % (the default gate).
pub const CHI2_2DOF_99: f64 = 9.210;
/// Chi-square quantile, 2 degrees of freedom, 99.9 %.
pub const CHI2_2DOF_999: f64 = 13.816;

/// Squared Mahalanobis distance between two independent estimates of the same point.
pub fn mahalanobis_sq<F: Frame>(a: &Gaussian2<F>, b: &Gaussian2<F>) -> f64 {
    let s = a.cov.add(&b.cov);
    s.mahalanobis_sq(a.mean.x - b.mean.x, a.mean.y - b.mean.y)
}

/// A chi-square gate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields)]
pub struct Gate {
    /// Threshold on `D^2` (default 9.21, the 99 % quantile for 2 degrees of freedom).
    #[config(range = "> 0")]
    pub threshold: f64,
}

impl Default for Gate {
    fn default() -> Self {
        Gate {
            threshold: CHI2_2DOF_99,
        }
    }
}

impl Gate {
    /// `Some(D^2)` when the two estimates may be the same point, `None` otherwise.
    pub fn test<F: Frame>(&self, a: &Gaussian2<F>, b: &Gaussian2<F>) -> Option<f64> {
        let d2 = mahalanobis_sq(a, b);
        (d2 < self.threshold).then_some(d2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Cov2, Point2, World};

    fn g(x: f64, y: f64, sigma: f64) -> Gaussian2<World> {
        Gaussian2::new(Point2::new(x, y), Cov2::isotropic(sigma).unwrap()).unwrap()
    }

    #[test]
    fn distance_uses_the_sum_of_covariances() {
        // S = 2 * 0.5^2 I = 0.5 I, d = (1, 0): D^2 = 1 / 0.5 = 2.
        assert!((mahalanobis_sq(&g(0.0, 0.0, 0.5), &g(1.0, 0.0, 0.5)) - 2.0).abs() < 1e-12);
        let gate = Gate::default();
        assert!(gate.test(&g(0.0, 0.0, 0.5), &g(1.0, 0.0, 0.5)).is_some());
        assert!(gate.test(&g(0.0, 0.0, 0.1), &g(1.0, 0.0, 0.1)).is_none());
    }
}
