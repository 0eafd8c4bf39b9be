//! Two-dimensional Gaussian estimates: a mean and a symmetric positive-definite
//! covariance (design section 1).
//!
//! [`Cov2`] can only hold a matrix that is finite, symmetric and positive definite; the
//! constructors check it, so gating, fusion and tracking never meet a singular or NaN
//! covariance that came from outside.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::frame::Frame;
use crate::geometry::{Point2, Pose2, Vector2};

/// Why a matrix is not a valid covariance.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CovError {
    /// An entry is NaN or infinite.
    #[error("covariance has a non-finite entry: [[{xx}, {xy}], [{yx}, {yy}]]")]
    NotFinite {
        /// Row 0, column 0.
        xx: f64,
        /// Row 0, column 1.
        xy: f64,
        /// Row 1, column 0.
        yx: f64,
        /// Row 1, column 1.
        yy: f64,
    },
    /// The off-diagonal entries differ by more than rounding.
    #[error("covariance is not symmetric: xy = {xy} but yx = {yx}")]
    NotSymmetric {
        /// Row 0, column 1.
        xy: f64,
        /// Row 1, column 0.
        yx: f64,
    },
    /// The mean of an estimate is NaN or infinite.
    #[error("estimate has a non-finite mean ({x}, {y})")]
    MeanNotFinite {
        /// x of the mean.
        x: f64,
        /// y of the mean.
        y: f64,
    },
    /// A diagonal entry or the determinant is not positive.
    #[error(
        "covariance is not positive definite (xx = {xx}, yy = {yy}, det = {det}); \
         a variance must be > 0 and |xy| < sqrt(xx * yy)"
    )]
    NotPositiveDefinite {
        /// Row 0, column 0.
        xx: f64,
        /// Row 1, column 1.
        yy: f64,
        /// Determinant.
        det: f64,
    },
}

/// A symmetric positive-definite 2x2 covariance, m^2:
///
/// ```text
/// P = [[xx, xy],
///      [xy, yy]]
/// ```
///
/// Serialised as `[xx, xy, xy, yy]` (row-major), the layout of the `cov` fields in
/// tether's files.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "[f64; 4]", into = "[f64; 4]")]
pub struct Cov2 {
    xx: f64,
    xy: f64,
    yy: f64,
}

/// Relative tolerance for the symmetry check.
const SYMMETRY_REL_TOL: f64 = 1e-9;

impl Cov2 {
    /// The identity, 1 m^2 along each axis.
    pub const IDENTITY: Cov2 = Cov2 {
        xx: 1.0,
        xy: 0.0,
        yy: 1.0,
    };

    /// The nearest covariance whose variances along every direction are at least
    /// `min_var` (eigenvalues clamped from below). `None` when an entry is not finite.
    /// Use it to repair a matrix that rounding made indefinite, never to accept data
    /// from outside.
    pub fn repaired(xx: f64, xy: f64, yy: f64, min_var: f64) -> Option<Cov2> {
        if !(xx.is_finite()
            && xy.is_finite()
            && yy.is_finite()
            && min_var.is_finite()
            && min_var > 0.0)
        {
            return None;
        }
        let mean = 0.5 * (xx + yy);
        let radius = (0.5 * (xx - yy)).hypot(xy);
        let angle = 0.5 * (2.0 * xy).atan2(xx - yy);
        let major = (mean + radius).max(min_var);
        let minor = (mean - radius).max(min_var);
        Cov2::from_axes(major.sqrt(), minor.sqrt(), angle).ok()
    }

    /// Checks and builds a covariance from its three distinct entries.
    pub fn new(xx: f64, xy: f64, yy: f64) -> Result<Self, CovError> {
        Self::from_rows([[xx, xy], [xy, yy]])
    }

    /// Checks and builds a covariance from a full matrix (rows). The off-diagonal
    /// entries must agree to rounding; their mean is kept.
    pub fn from_rows(rows: [[f64; 2]; 2]) -> Result<Self, CovError> {
        let [[xx, xy], [yx, yy]] = rows;
        if !(xx.is_finite() && xy.is_finite() && yx.is_finite() && yy.is_finite()) {
            return Err(CovError::NotFinite { xx, xy, yx, yy });
        }
        let scale = xx.abs().max(yy.abs()).max(xy.abs()).max(f64::MIN_POSITIVE);
        if (xy - yx).abs() > SYMMETRY_REL_TOL * scale {
            return Err(CovError::NotSymmetric { xy, yx });
        }
        let xy = 0.5 * (xy + yx);
        let det = xx * yy - xy * xy;
        // Positive definite: leading minors positive. Demand the determinant be
        // meaningfully positive, not a rounding residue of a singular matrix.
        if !(xx > 0.0 && yy > 0.0 && det > 1e-12 * xx * yy) {
            return Err(CovError::NotPositiveDefinite { xx, yy, det });
        }
        Ok(Cov2 { xx, xy, yy })
    }

    /// An isotropic covariance `sigma_m^2 * I`.
    pub fn isotropic(sigma_m: f64) -> Result<Self, CovError> {
        let v = sigma_m * sigma_m;
        Self::new(v, 0.0, v)
    }

    /// A covariance with standard deviations `sigma_major_m` along `angle_rad` and
    /// `sigma_minor_m` across it: `R diag(a^2, b^2) R^T`.
    pub fn from_axes(
        sigma_major_m: f64,
        sigma_minor_m: f64,
        angle_rad: f64,
    ) -> Result<Self, CovError> {
        let (s, c) = angle_rad.sin_cos();
        let a2 = sigma_major_m * sigma_major_m;
        let b2 = sigma_minor_m * sigma_minor_m;
        Self::new(
            a2 * c * c + b2 * s * s,
            (a2 - b2) * s * c,
            a2 * s * s + b2 * c * c,
        )
    }

    /// Variance along x, m^2.
    pub fn xx(&self) -> f64 {
        self.xx
    }

    /// Covariance of x and y, m^2.
    pub fn xy(&self) -> f64 {
        self.xy
    }

    /// Variance along y, m^2.
    pub fn yy(&self) -> f64 {
        self.yy
    }

    /// Row-major entries `[xx, xy, xy, yy]`.
    pub fn to_array(&self) -> [f64; 4] {
        [self.xx, self.xy, self.xy, self.yy]
    }

    /// Determinant, m^4 (always > 0).
    pub fn det(&self) -> f64 {
        self.xx * self.yy - self.xy * self.xy
    }

    /// Trace, m^2.
    pub fn trace(&self) -> f64 {
        self.xx + self.yy
    }

    /// The inverse (information matrix), also symmetric positive definite.
    pub fn inverse(&self) -> Cov2 {
        let d = self.det();
        Cov2 {
            xx: self.yy / d,
            xy: -self.xy / d,
            yy: self.xx / d,
        }
    }

    /// `self + other`, the covariance of the sum of independent variables.
    pub fn add(&self, other: &Cov2) -> Cov2 {
        Cov2 {
            xx: self.xx + other.xx,
            xy: self.xy + other.xy,
            yy: self.yy + other.yy,
        }
    }

    /// `k * self`. Fails unless `k` is finite and positive.
    pub fn scaled(&self, k: f64) -> Result<Cov2, CovError> {
        Cov2::new(k * self.xx, k * self.xy, k * self.yy)
    }

    /// `R(angle) P R(angle)^T`: the covariance of a rotated variable.
    pub fn rotated(&self, angle_rad: f64) -> Cov2 {
        let (s, c) = angle_rad.sin_cos();
        let (xx, xy, yy) = (self.xx, self.xy, self.yy);
        Cov2 {
            xx: c * c * xx - 2.0 * s * c * xy + s * s * yy,
            xy: s * c * (xx - yy) + (c * c - s * s) * xy,
            yy: s * s * xx + 2.0 * s * c * xy + c * c * yy,
        }
    }

    /// Squared Mahalanobis length of `d`: `d^T P^-1 d`.
    pub fn mahalanobis_sq(&self, dx: f64, dy: f64) -> f64 {
        let inv = self.inverse();
        dx * (inv.xx * dx + inv.xy * dy) + dy * (inv.xy * dx + inv.yy * dy)
    }

    /// Eigen-decomposition: (largest variance, smallest variance, direction of the
    /// largest in rad). The square roots are the 1-sigma ellipse's half-axes.
    pub fn principal_axes(&self) -> (f64, f64, f64) {
        let mean = 0.5 * (self.xx + self.yy);
        let half_diff = 0.5 * (self.xx - self.yy);
        let radius = half_diff.hypot(self.xy);
        let angle = 0.5 * (2.0 * self.xy).atan2(self.xx - self.yy);
        (mean + radius, (mean - radius).max(0.0), angle)
    }

    /// Lower-triangular Cholesky factor `L` with `L L^T = P`, as `(l11, l21, l22)`.
    /// Maps independent unit normals (a, b) to a draw `(l11 a, l21 a + l22 b)`.
    pub fn cholesky(&self) -> (f64, f64, f64) {
        let l11 = self.xx.sqrt();
        let l21 = self.xy / l11;
        let l22 = (self.yy - l21 * l21).max(0.0).sqrt();
        (l11, l21, l22)
    }
}

impl TryFrom<[f64; 4]> for Cov2 {
    type Error = CovError;
    fn try_from(a: [f64; 4]) -> Result<Self, CovError> {
        Cov2::from_rows([[a[0], a[1]], [a[2], a[3]]])
    }
}

impl From<Cov2> for [f64; 4] {
    fn from(c: Cov2) -> [f64; 4] {
        c.to_array()
    }
}

/// A 2-D Gaussian estimate of a position in frame `F`.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Gaussian2<F: Frame> {
    /// Mean position, m.
    pub mean: Point2<F>,
    /// Covariance, m^2.
    pub cov: Cov2,
}

impl<F: Frame> Clone for Gaussian2<F> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<F: Frame> Copy for Gaussian2<F> {}
impl<F: Frame> PartialEq for Gaussian2<F> {
    fn eq(&self, other: &Self) -> bool {
        self.mean == other.mean && self.cov == other.cov
    }
}
impl<F: Frame> std::fmt::Debug for Gaussian2<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gaussian2")
            .field("frame", &F::NAME)
            .field("mean", &(self.mean.x, self.mean.y))
            .field("cov", &self.cov.to_array())
            .finish()
    }
}

impl<F: Frame> Gaussian2<F> {
    /// An estimate with the given mean and covariance. The covariance is already checked
    /// by its own constructor; the mean must be finite.
    pub fn new(mean: Point2<F>, cov: Cov2) -> Result<Self, CovError> {
        if !mean.is_finite() {
            return Err(CovError::MeanNotFinite {
                x: mean.x,
                y: mean.y,
            });
        }
        Ok(Gaussian2 { mean, cov })
    }

    /// The same estimate in another frame: `mean' = T * mean`, `P' = R P R^T`.
    pub fn transformed<To: Frame>(&self, to_from: Pose2<To, F>) -> Gaussian2<To> {
        Gaussian2 {
            mean: to_from * self.mean,
            cov: self.cov.rotated(to_from.yaw),
        }
    }

    /// Squared Mahalanobis distance of a point from this estimate.
    pub fn mahalanobis_sq(&self, p: Point2<F>) -> f64 {
        let d: Vector2<F> = p - self.mean;
        self.cov.mahalanobis_sq(d.x, d.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Robot, World};
    use proptest::prelude::*;

    #[test]
    fn refuses_invalid_matrices() {
        assert!(matches!(
            Cov2::new(f64::NAN, 0.0, 1.0),
            Err(CovError::NotFinite { .. })
        ));
        assert!(matches!(
            Cov2::from_rows([[1.0, 0.2], [0.3, 1.0]]),
            Err(CovError::NotSymmetric { .. })
        ));
        assert!(matches!(
            Cov2::new(1.0, 1.0, 1.0),
            Err(CovError::NotPositiveDefinite { .. })
        ));
        assert!(matches!(
            Cov2::new(-1.0, 0.0, 1.0),
            Err(CovError::NotPositiveDefinite { .. })
        ));
        assert!(matches!(
            Cov2::new(0.0, 0.0, 0.0),
            Err(CovError::NotPositiveDefinite { .. })
        ));
        assert!(Cov2::new(1.0, 0.5, 1.0).is_ok());
    }

    #[test]
    fn deserialising_checks_too() {
        let bad: Result<Cov2, _> = serde_json::from_str("[1.0, 2.0, 2.0, 1.0]");
        assert!(bad.is_err());
        let good: Cov2 = serde_json::from_str("[2.0, 0.5, 0.5, 1.0]").unwrap();
        assert_eq!(good.to_array(), [2.0, 0.5, 0.5, 1.0]);
    }

    #[test]
    fn repair_clamps_eigenvalues() {
        let c = Cov2::repaired(1.0, 1.0, 1.0, 1e-4).unwrap();
        let (major, minor, _) = c.principal_axes();
        assert!((major - 2.0).abs() < 1e-9 && (minor - 1e-4).abs() < 1e-9);
        assert!(Cov2::repaired(f64::NAN, 0.0, 1.0, 1e-4).is_none());
        let good = Cov2::new(2.0, 0.3, 1.0).unwrap();
        let same = Cov2::repaired(2.0, 0.3, 1.0, 1e-6).unwrap();
        assert!((good.xx() - same.xx()).abs() < 1e-12 && (good.xy() - same.xy()).abs() < 1e-12);
    }

    #[test]
    fn axes_round_trip() {
        let c = Cov2::from_axes(0.5, 0.1, 0.7).unwrap();
        let (major, minor, angle) = c.principal_axes();
        assert!((major - 0.25).abs() < 1e-12 && (minor - 0.01).abs() < 1e-12);
        assert!((angle - 0.7).abs() < 1e-9);
    }

    proptest! {
        #[test]
        fn inverse_is_inverse(a in 0.01..10.0f64, b in 0.01..10.0f64, angle in -4.0..4.0f64) {
            let c = Cov2::from_axes(a, b, angle).unwrap();
            let i = c.inverse();
            // P * P^-1 = I
            let m00 = c.xx() * i.xx() + c.xy() * i.xy();
            let m01 = c.xx() * i.xy() + c.xy() * i.yy();
            let m11 = c.xy() * i.xy() + c.yy() * i.yy();
            prop_assert!((m00 - 1.0).abs() < 1e-6 && m01.abs() < 1e-6 && (m11 - 1.0).abs() < 1e-6);
        }

        #[test]
        fn rotation_preserves_invariants(a in 0.01..10.0f64, b in 0.01..10.0f64, angle in -4.0..4.0f64, rot in -7.0..7.0f64) {
            let c = Cov2::from_axes(a, b, angle).unwrap();
            let r = c.rotated(rot);
            prop_assert!((r.det() - c.det()).abs() <= 1e-9 * c.det().max(1.0));
            prop_assert!((r.trace() - c.trace()).abs() <= 1e-9 * c.trace());
            let rotated_back = Cov2::from_axes(a, b, angle + rot).unwrap();
            prop_assert!((r.xx() - rotated_back.xx()).abs() < 1e-9 * (1.0 + a * a));
            prop_assert!((r.xy() - rotated_back.xy()).abs() < 1e-9 * (1.0 + a * a));
        }

        #[test]
        fn cholesky_reconstructs(a in 0.01..10.0f64, b in 0.01..10.0f64, angle in -4.0..4.0f64) {
            let c = Cov2::from_axes(a, b, angle).unwrap();
            let (l11, l21, l22) = c.cholesky();
            prop_assert!((l11 * l11 - c.xx()).abs() < 1e-9 * (1.0 + c.xx()));
            prop_assert!((l11 * l21 - c.xy()).abs() < 1e-9 * (1.0 + c.xx()));
            prop_assert!((l21 * l21 + l22 * l22 - c.yy()).abs() < 1e-6 * (1.0 + c.yy()));
        }
    }

    #[test]
    fn transforming_moves_mean_and_turns_covariance() {
        let g = Gaussian2::<Robot>::new(
            Point2::new(1.0, 0.0),
            Cov2::from_axes(0.3, 0.1, 0.0).unwrap(),
        )
        .unwrap();
        let world_from_robot: Pose2<World, Robot> =
            Pose2::new(2.0, 3.0, std::f64::consts::FRAC_PI_2);
        let w = g.transformed(world_from_robot);
        assert!((w.mean.x - 2.0).abs() < 1e-12 && (w.mean.y - 4.0).abs() < 1e-12);
        assert!((w.cov.yy() - 0.09).abs() < 1e-12 && (w.cov.xx() - 0.01).abs() < 1e-12);
    }
}
