//! A constant-velocity Kalman filter for one person on the floor.
//!
//! State `x = (px, py, vx, vy)` in the world frame, m and m/s. Motion model over `dt`:
//! `x' = F x` with `F = [[I, dt I], [0, I]]`, and white-noise acceleration of spectral
//! density `q` (m^2/s^3):
//!
//! ```text
//! Q = q [[dt^3/3 I, dt^2/2 I],
//!        [dt^2/2 I, dt     I]]
//! ```
//!
//! Observations are positions: `z = H x + r`, `H = [I 0]`, `r ~ N(0, R)`. The update uses
//! the Joseph form `P' = (I - K H) P (I - K H)^T + K R K^T`, which stays symmetric
//! positive definite under rounding.

#![allow(
    clippy::needless_range_loop,
    reason = "matrix code reads best with explicit indices"
)]

use tether_core::{Cov2, Frame, Gaussian2, Point2, Vector2};

/// A 4x4 matrix, row-major.
pub type Mat4 = [[f64; 4]; 4];

/// State and covariance of one track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CvFilter {
    /// `(px, py, vx, vy)`.
    pub x: [f64; 4],
    /// Covariance of `x`.
    pub p: Mat4,
}

fn symmetrize(p: &mut Mat4) {
    for i in 0..4 {
        for j in (i + 1)..4 {
            let m = 0.5 * (p[i][j] + p[j][i]);
            p[i][j] = m;
            p[j][i] = m;
        }
    }
}

impl CvFilter {
    /// A filter at `position` with unknown velocity (standard deviation `sigma_v_mps`).
    pub fn new<F: Frame>(position: &Gaussian2<F>, sigma_v_mps: f64) -> Self {
        let c = position.cov;
        let vv = sigma_v_mps * sigma_v_mps;
        CvFilter {
            x: [position.mean.x, position.mean.y, 0.0, 0.0],
            p: [
                [c.xx(), c.xy(), 0.0, 0.0],
                [c.xy(), c.yy(), 0.0, 0.0],
                [0.0, 0.0, vv, 0.0],
                [0.0, 0.0, 0.0, vv],
            ],
        }
    }

    /// Predicts `dt_s` ahead: `x = F x`, `P = F P F^T + Q`. Negative or NaN `dt` does
    /// nothing.
    pub fn predict(&mut self, dt_s: f64, q: f64) {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return;
        }
        let dt = dt_s;
        self.x[0] += dt * self.x[2];
        self.x[1] += dt * self.x[3];
        // F P F^T by blocks: P = [[A, B], [B^T, C]] ->
        // [[A + dt (B + B^T) + dt^2 C, B + dt C], [B^T + dt C, C]].
        let p = self.p;
        let mut n = p;
        for i in 0..2 {
            for j in 0..2 {
                n[i][j] = p[i][j] + dt * (p[i][j + 2] + p[i + 2][j]) + dt * dt * p[i + 2][j + 2];
                n[i][j + 2] = p[i][j + 2] + dt * p[i + 2][j + 2];
                n[i + 2][j] = p[i + 2][j] + dt * p[i + 2][j + 2];
            }
        }
        let (q11, q12, q22) = (q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt);
        for i in 0..2 {
            n[i][i] += q11;
            n[i][i + 2] += q12;
            n[i + 2][i] += q12;
            n[i + 2][i + 2] += q22;
        }
        symmetrize(&mut n);
        self.p = n;
    }

    /// The predicted position as an estimate.
    pub fn position<F: Frame>(&self) -> Gaussian2<F> {
        let cov = Cov2::new(self.p[0][0], self.p[0][1], self.p[1][1])
            .ok()
            .or_else(|| Cov2::repaired(self.p[0][0], self.p[0][1], self.p[1][1], 1e-8))
            .unwrap_or(Cov2::IDENTITY);
        Gaussian2 {
            mean: Point2::new(self.x[0], self.x[1]),
            cov,
        }
    }

    /// The velocity, m/s.
    pub fn velocity<F: Frame>(&self) -> Vector2<F> {
        Vector2::new(self.x[2], self.x[3])
    }

    /// Covariance of the velocity.
    pub fn velocity_cov(&self) -> Option<Cov2> {
        Cov2::new(self.p[2][2], self.p[2][3], self.p[3][3]).ok()
    }

    /// Innovation covariance `S = H P H^T + R` and innovation `z - H x` for a position
    /// observation.
    pub fn innovation<F: Frame>(&self, z: &Gaussian2<F>) -> (Cov2, [f64; 2]) {
        // P's position block is positive semidefinite and R positive definite, so S is
        // positive definite; rounding can only be repaired, never make it singular.
        let s = self.position::<F>().cov.add(&z.cov);
        (s, [z.mean.x - self.x[0], z.mean.y - self.x[1]])
    }

    /// Squared Mahalanobis distance of an observation from the predicted position.
    pub fn mahalanobis_sq<F: Frame>(&self, z: &Gaussian2<F>) -> f64 {
        let (s, y) = self.innovation(z);
        s.mahalanobis_sq(y[0], y[1])
    }

    /// Kalman update with a position observation (Joseph form).
    pub fn update<F: Frame>(&mut self, z: &Gaussian2<F>) {
        let (s, y) = self.innovation(z);
        let si = s.inverse();
        let si = [[si.xx(), si.xy()], [si.xy(), si.yy()]];
        // K = P H^T S^-1: 4x2.
        let mut k = [[0.0; 2]; 4];
        for (i, row) in k.iter_mut().enumerate() {
            for (j, kij) in row.iter_mut().enumerate() {
                *kij = self.p[i][0] * si[0][j] + self.p[i][1] * si[1][j];
            }
        }
        for (i, row) in k.iter().enumerate() {
            self.x[i] += row[0] * y[0] + row[1] * y[1];
        }
        // A = I - K H.
        let mut a = [[0.0; 4]; 4];
        for (i, row) in a.iter_mut().enumerate() {
            row[i] = 1.0;
            row[0] -= k[i][0];
            row[1] -= k[i][1];
        }
        let ap = mul(&a, &self.p);
        let mut p = mul_transposed(&ap, &a);
        let r = [[z.cov.xx(), z.cov.xy()], [z.cov.xy(), z.cov.yy()]];
        for i in 0..4 {
            for j in 0..4 {
                let mut krk = 0.0;
                for m in 0..2 {
                    for n in 0..2 {
                        krk += k[i][m] * r[m][n] * k[j][n];
                    }
                }
                p[i][j] += krk;
            }
        }
        symmetrize(&mut p);
        self.p = p;
    }

    /// Covariance Intersection update with a position observation whose correlation
    /// with the track is unknown (Julier and Uhlmann):
    /// `P'^-1 = w P^-1 + (1 - w) H^T R^-1 H`, computed as a Kalman update with the
    /// track's covariance inflated to `P / w` and the observation's to `R / (1 - w)`.
    /// The weight minimises the determinant of the whole posterior covariance (position
    /// and velocity), found by golden-section search; at `w = 1` the observation adds
    /// nothing and the track is left as it is. Returns `w`.
    pub fn update_ci<F: Frame>(&mut self, z: &Gaussian2<F>) -> f64 {
        let posterior = |w: f64| {
            let mut f = *self;
            for row in &mut f.p {
                for v in row.iter_mut() {
                    *v /= w;
                }
            }
            let inflated = Gaussian2 {
                mean: z.mean,
                cov: z.cov.scaled(1.0 / (1.0 - w)).unwrap_or(z.cov),
            };
            f.update(&inflated);
            f
        };
        let cost = |w: f64| det4(&posterior(w).p);
        let before = det4(&self.p);
        let phi = (5f64.sqrt() - 1.0) / 2.0;
        let (mut lo, mut hi) = (1e-3f64, 1.0 - 1e-3);
        let (mut x1, mut x2) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        let (mut f1, mut f2) = (cost(x1), cost(x2));
        for _ in 0..40 {
            if f1 < f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - phi * (hi - lo);
                f1 = cost(x1);
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + phi * (hi - lo);
                f2 = cost(x2);
            }
        }
        let w = 0.5 * (lo + hi);
        if !(cost(w) < before) {
            return 1.0;
        }
        *self = posterior(w);
        w
    }

    /// Extended Kalman update with a bearing-only observation: the direction from
    /// `origin` to the person, `bearing_rad`, with standard deviation `sigma_rad`.
    /// `h(x) = atan2(py - oy, px - ox)`, `H = [-dy/r^2, dx/r^2, 0, 0]`.
    ///
    /// The update is made only when the bearing innovation passes its own gate,
    /// `nu^2 / S <= gate` with `S = H P H^T + sigma^2` (one degree of freedom, e.g.
    /// [`crate::gate::CHI2_1DOF_99`]): a bearing that the track cannot explain (someone
    /// else on a nearby viewing ray) is left out rather than pull the track sideways.
    /// Returns whether the track was updated.
    pub fn update_bearing<F: Frame>(
        &mut self,
        origin: Point2<F>,
        bearing_rad: f64,
        sigma_rad: f64,
        gate: f64,
    ) -> bool {
        let (dx, dy) = (self.x[0] - origin.x, self.x[1] - origin.y);
        let r2 = dx * dx + dy * dy;
        if !(r2 > 1e-4) || !bearing_rad.is_finite() || !(sigma_rad > 0.0) {
            return false;
        }
        let h = [-dy / r2, dx / r2];
        let innovation = crate::wrap(bearing_rad - dy.atan2(dx));
        // S = H P H^T + s^2 (scalar); K = P H^T / S.
        let ph: Vec<f64> = (0..4)
            .map(|i| self.p[i][0] * h[0] + self.p[i][1] * h[1])
            .collect();
        let s = h[0] * ph[0] + h[1] * ph[1] + sigma_rad * sigma_rad;
        if !(innovation * innovation / s <= gate) {
            return false;
        }
        let k: Vec<f64> = ph.iter().map(|v| v / s).collect();
        for i in 0..4 {
            self.x[i] += k[i] * innovation;
        }
        // Joseph form with A = I - K H.
        let mut a = [[0.0; 4]; 4];
        for i in 0..4 {
            a[i][i] = 1.0;
            a[i][0] -= k[i] * h[0];
            a[i][1] -= k[i] * h[1];
        }
        let mut p = mul_transposed(&mul(&a, &self.p), &a);
        for i in 0..4 {
            for j in 0..4 {
                p[i][j] += k[i] * k[j] * sigma_rad * sigma_rad;
            }
        }
        symmetrize(&mut p);
        self.p = p;
        true
    }

    /// Limits the speed estimate to `max_speed_mps` (the direction is kept), returns
    /// whether it had to. A filter pulled faster than any person walks by an
    /// unlucky association would otherwise carry its track away.
    pub fn clamp_speed(&mut self, max_speed_mps: f64) -> bool {
        let speed = self.x[2].hypot(self.x[3]);
        if speed <= max_speed_mps || !speed.is_finite() {
            return false;
        }
        let k = max_speed_mps / speed;
        self.x[2] *= k;
        self.x[3] *= k;
        true
    }

    /// True when every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.x.iter().all(|v| v.is_finite()) && self.p.iter().flatten().all(|v| v.is_finite())
    }
}

/// Determinant of a 4x4 matrix by cofactor expansion over 2x2 minors.
fn det4(m: &Mat4) -> f64 {
    let s0 = m[0][0] * m[1][1] - m[1][0] * m[0][1];
    let s1 = m[0][0] * m[1][2] - m[1][0] * m[0][2];
    let s2 = m[0][0] * m[1][3] - m[1][0] * m[0][3];
    let s3 = m[0][1] * m[1][2] - m[1][1] * m[0][2];
    let s4 = m[0][1] * m[1][3] - m[1][1] * m[0][3];
    let s5 = m[0][2] * m[1][3] - m[1][2] * m[0][3];
    let c5 = m[2][2] * m[3][3] - m[3][2] * m[2][3];
    let c4 = m[2][1] * m[3][3] - m[3][1] * m[2][3];
    let c3 = m[2][1] * m[3][2] - m[3][1] * m[2][2];
    let c2 = m[2][0] * m[3][3] - m[3][0] * m[2][3];
    let c1 = m[2][0] * m[3][2] - m[3][0] * m[2][2];
    let c0 = m[2][0] * m[3][1] - m[3][0] * m[2][1];
    s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
}

fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            r[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

fn mul_transposed(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut r = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            r[i][j] = (0..4).map(|k| a[i][k] * b[j][k]).sum();
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::World;

    fn obs(x: f64, y: f64, sigma: f64) -> Gaussian2<World> {
        Gaussian2::new(Point2::new(x, y), Cov2::isotropic(sigma).unwrap()).unwrap()
    }

    #[test]
    fn learns_a_constant_velocity() {
        let mut f = CvFilter::new(&obs(0.0, 0.0, 0.05), 1.0);
        for k in 1..=50 {
            f.predict(0.1, 0.5);
            f.update(&obs(0.1 * k as f64 * 1.2, 0.5, 0.05));
        }
        let v = f.velocity::<World>();
        assert!((v.x - 1.2).abs() < 0.05 && v.y.abs() < 0.05, "{v:?}");
        assert!((f.x[0] - 6.0).abs() < 0.05);
    }

    #[test]
    fn prediction_grows_uncertainty_and_update_shrinks_it() {
        let mut f = CvFilter::new(&obs(1.0, 1.0, 0.1), 1.0);
        let p0 = f.position::<World>().cov.det();
        f.predict(1.0, 1.0);
        let p1 = f.position::<World>().cov.det();
        f.update(&obs(1.0, 1.0, 0.1));
        let p2 = f.position::<World>().cov.det();
        assert!(p1 > p0 && p2 < p1);
        f.predict(-1.0, 1.0);
        f.predict(f64::NAN, 1.0);
        assert!(f.is_finite());
    }

    #[test]
    fn ci_update_is_never_tighter_than_the_kalman_update() {
        let mut kf = CvFilter::new(&obs(0.0, 0.0, 0.1), 0.5);
        let mut ci = kf;
        let z = Gaussian2::<World>::new(
            Point2::new(0.1, 0.0),
            Cov2::from_axes(0.3, 0.03, 0.0).unwrap(),
        )
        .unwrap();
        kf.update(&z);
        let w = ci.update_ci(&z);
        assert!(w > 0.0 && w < 1.0);
        let (pk, pc) = (kf.position::<World>().cov, ci.position::<World>().cov);
        assert!(pc.det() >= pk.det());
        // Still better than the prior along the observation's thin axis.
        assert!(pc.yy() < 0.01);
        // A much worse observation is ignored.
        let before = ci;
        let vague =
            Gaussian2::<World>::new(Point2::new(1.0, 1.0), Cov2::isotropic(2.0).unwrap()).unwrap();
        assert_eq!(ci.update_ci(&vague), 1.0);
        assert_eq!(ci, before);
    }

    #[test]
    fn det4_matches_a_diagonal_and_a_permutation() {
        let d = [
            [2.0, 0.0, 0.0, 0.0],
            [0.0, 3.0, 0.0, 0.0],
            [0.0, 0.0, 4.0, 0.0],
            [0.0, 0.0, 0.0, 5.0],
        ];
        assert_eq!(det4(&d), 120.0);
        let p = [
            [0.0, 1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        assert_eq!(det4(&p), -1.0);
    }

    #[test]
    fn ci_update_keeps_the_velocity_it_knows() {
        // A track with a well-known velocity, a vague position observation: CI must
        // not trade the velocity away for the position.
        let mut f = CvFilter::new(&obs(0.0, 0.0, 0.3), 0.1);
        let v_before = f.velocity_cov().unwrap().det();
        f.update_ci(&obs(0.2, 0.0, 0.3));
        let v_after = f.velocity_cov().unwrap().det();
        assert!(v_after < 4.0 * v_before, "{v_before} -> {v_after}");
    }

    #[test]
    fn a_bearing_the_track_cannot_explain_is_gated_out() {
        // Track 3 m ahead with 5 cm across the ray: its bearing sd is ~0.017 rad, plus
        // 0.01 rad of measurement. 0.02 rad off passes the 99 % gate, 0.15 rad does not.
        let origin = Point2::<World>::new(0.0, 0.0);
        let gate = crate::gate::CHI2_1DOF_99;
        let mut f = CvFilter::new(&obs(3.0, 0.0, 0.05), 0.5);
        let before = f;
        assert!(!f.update_bearing(origin, 0.15, 0.01, gate));
        assert_eq!(f.x, before.x);
        assert_eq!(f.p, before.p);
        assert!(f.update_bearing(origin, 0.02, 0.01, gate));
        assert!(f.x[1] > 0.0);
    }

    #[test]
    fn a_bearing_narrows_the_track_across_the_ray_only() {
        let mut f = CvFilter::new(&obs(3.0, 0.0, 0.2), 0.5);
        // Seen from the origin slightly to the left.
        assert!(f.update_bearing(Point2::<World>::new(0.0, 0.0), 0.02, 0.005, f64::INFINITY));
        let p = f.position::<World>();
        assert!((p.mean.y - 0.06).abs() < 0.01, "{:?}", p.mean);
        assert!((p.mean.x - 3.0).abs() < 1e-3);
        assert!(p.cov.yy() < 0.001 && (p.cov.xx() - 0.04).abs() < 1e-3);
    }

    #[test]
    fn update_matches_the_textbook_gain_for_a_static_state() {
        // With zero velocity uncertainty and no process noise the filter is a weighted
        // mean: two equal-variance observations give their average with half the variance.
        let mut f = CvFilter::new(&obs(0.0, 0.0, 0.2), 0.0);
        f.update(&obs(1.0, 0.0, 0.2));
        assert!((f.x[0] - 0.5).abs() < 1e-12);
        assert!((f.p[0][0] - 0.02).abs() < 1e-12);
    }
}
