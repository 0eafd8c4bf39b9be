//! Covariance Intersection and independent (Kalman) fusion of two estimates
//! (design 5, paper eq. 5-7; Julier and Uhlmann 1997).
//!
//! Covariance Intersection fuses `(mu_a, P_a)` and `(mu_b, P_b)` whose cross-correlation
//! is unknown:
//!
//! ```text
//! P_o^-1 = w P_a^-1 + (1 - w) P_b^-1
//! mu_o   = P_o (w P_a^-1 mu_a + (1 - w) P_b^-1 mu_b),   w in [0, 1]
//! ```
//!
//! The weight minimises `det(P_o)` (default) or `trace(P_o)`. For 2x2 matrices both
//! have exact closed forms (Reinhardt, Noack and Hanebeck, FUSION 2012): find `T` with
//! `T P_a T^T = I` and `T P_b T^T = D = diag(d1, d2)`. Then, with `a_i = d_i - 1`,
//! `P_o(w) = T^-1 diag(d_i / (1 + w a_i)) T^-T`, so
//!
//! - `det P_o(w) = det(T)^-2 prod d_i / (1 + w a_i)`: the stationary point of
//!   `sum log(1 + w a_i)` is `w* = -(1/a_1 + 1/a_2) / 2`;
//! - `trace P_o(w) = sum c_i d_i / (1 + w a_i)` with `c_i = |T^-1 e_i|^2`: the derivative
//!   vanishes where `k_1 (1 + w a_2) = k_2 (1 + w a_1)`, `k_i = sqrt(c_i d_i |a_i|)`,
//!   which needs `a_1`, `a_2` of opposite signs.
//!
//! The cost is evaluated at the stationary point (if inside [0, 1]) and at both ends,
//! and the best is kept. A golden-section search over `w` ([`ci_weight_by_search`]) is
//! the test oracle. In the paper `P_a = P_vv` (vision) and `P_b = P_ll` (laser).

use serde::{Deserialize, Serialize};
use tether_core::{Cov2, Frame, Gaussian2, Point2};

/// What the Covariance Intersection weight minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CiCriterion {
    /// The determinant of the fused covariance (the area of its ellipse).
    #[default]
    Determinant,
    /// The trace of the fused covariance (the mean squared error).
    Trace,
}

/// The fused covariance for weight `w` (on `a`): `(w P_a^-1 + (1 - w) P_b^-1)^-1`.
fn fused_cov(a: &Cov2, b: &Cov2, w: f64) -> Cov2 {
    let (ia, ib) = (a.inverse(), b.inverse());
    let info = [
        w * ia.xx() + (1.0 - w) * ib.xx(),
        w * ia.xy() + (1.0 - w) * ib.xy(),
        w * ia.yy() + (1.0 - w) * ib.yy(),
    ];
    let det = info[0] * info[2] - info[1] * info[1];
    // A convex combination of SPD matrices is SPD; the inverse of an SPD matrix too.
    Cov2::new(info[2] / det, -info[1] / det, info[0] / det).unwrap_or(if w >= 0.5 {
        *a
    } else {
        *b
    })
}

fn cost(c: &Cov2, criterion: CiCriterion) -> f64 {
    match criterion {
        CiCriterion::Determinant => c.det(),
        CiCriterion::Trace => c.trace(),
    }
}

/// The optimal Covariance Intersection weight on `a`, by the exact 2x2 closed form.
pub fn ci_weight(a: &Cov2, b: &Cov2, criterion: CiCriterion) -> f64 {
    // Simultaneous diagonalisation: L L^T = P_a, C = L^-1 P_b L^-T = Q D Q^T,
    // T = Q^T L^-1, T^-1 = L Q.
    let (l11, l21, l22) = a.cholesky();
    // L^-1 = [[1/l11, 0], [-l21/(l11 l22), 1/l22]].
    let m11 = 1.0 / l11;
    let m21 = -l21 / (l11 * l22);
    let m22 = 1.0 / l22;
    // C = M P_b M^T.
    let (bxx, bxy, byy) = (b.xx(), b.xy(), b.yy());
    let cxx = m11 * m11 * bxx;
    let cxy = m11 * (m21 * bxx + m22 * bxy);
    let cyy = m21 * m21 * bxx + 2.0 * m21 * m22 * bxy + m22 * m22 * byy;
    let mean = 0.5 * (cxx + cyy);
    let radius = (0.5 * (cxx - cyy)).hypot(cxy);
    let (d1, d2) = (mean + radius, mean - radius);
    let (a1, a2) = (d1 - 1.0, d2 - 1.0);

    let mut candidates = vec![0.0, 1.0];
    let scale = 1e-12 * (d1.abs() + 1.0);
    if a1.abs() < scale && a2.abs() < scale {
        // Equal covariances: every weight gives the same result; stay symmetric.
        return 0.5;
    }
    match criterion {
        CiCriterion::Determinant => {
            if a1.abs() > scale && a2.abs() > scale {
                candidates.push(-0.5 * (1.0 / a1 + 1.0 / a2));
            }
        }
        CiCriterion::Trace => {
            if a1 * a2 < 0.0 {
                // Eigenvectors of C: for d1, v = (cxy, d1 - cxx) or (d1 - cyy, cxy).
                let eig = |d: f64| {
                    let (u, v) = if (d - cxx).abs() + cxy.abs() > (d - cyy).abs() + cxy.abs() {
                        (cxy, d - cxx)
                    } else {
                        (d - cyy, cxy)
                    };
                    let n = u.hypot(v);
                    if n > 0.0 { (u / n, v / n) } else { (1.0, 0.0) }
                };
                // c_i = |L q_i|^2.
                let c = |q: (f64, f64)| {
                    let x = l11 * q.0;
                    let y = l21 * q.0 + l22 * q.1;
                    x * x + y * y
                };
                let (q1, q2) = (eig(d1), eig(d2));
                let k1 = (c(q1) * d1 * a1.abs()).sqrt();
                let k2 = (c(q2) * d2 * a2.abs()).sqrt();
                let denom = k1 * a2 - k2 * a1;
                if denom.abs() > 0.0 {
                    candidates.push((k2 - k1) / denom);
                }
            }
        }
    }
    let mut best = (f64::INFINITY, 1.0);
    for w in candidates {
        if (0.0..=1.0).contains(&w) {
            let c = cost(&fused_cov(a, b, w), criterion);
            if c < best.0 {
                best = (c, w);
            }
        }
    }
    best.1
}

/// The weight by golden-section search over [0, 1] (the test oracle of
/// [`ci_weight`]; the cost is unimodal in `w`).
pub fn ci_weight_by_search(a: &Cov2, b: &Cov2, criterion: CiCriterion) -> f64 {
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let f = |w: f64| cost(&fused_cov(a, b, w), criterion);
    let mut x1 = hi - phi * (hi - lo);
    let mut x2 = lo + phi * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..200 {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - phi * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + phi * (hi - lo);
            f2 = f(x2);
        }
    }
    let w = 0.5 * (lo + hi);
    // The optimum may sit at an end.
    [0.0, w, 1.0]
        .into_iter()
        .min_by(|x, y| f(*x).total_cmp(&f(*y)))
        .unwrap_or(w)
}

/// Result of fusing two estimates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fused<F: Frame> {
    /// The fused estimate.
    pub estimate: Gaussian2<F>,
    /// The weight on the first input (1 for independent fusion, where it has no meaning).
    pub weight: f64,
}

/// Covariance Intersection of `a` (weighted by `w`) and `b`.
pub fn covariance_intersection<F: Frame>(
    a: &Gaussian2<F>,
    b: &Gaussian2<F>,
    criterion: CiCriterion,
) -> Fused<F> {
    let w = ci_weight(&a.cov, &b.cov, criterion);
    Fused {
        estimate: combine(a, b, w, 1.0 - w),
        weight: w,
    }
}

/// Fusion of two estimates with independent errors (the Kalman / information-filter
/// combination): `P^-1 = P_a^-1 + P_b^-1`, `mu = P (P_a^-1 mu_a + P_b^-1 mu_b)`.
pub fn independent_fusion<F: Frame>(a: &Gaussian2<F>, b: &Gaussian2<F>) -> Fused<F> {
    Fused {
        estimate: combine(a, b, 1.0, 1.0),
        weight: 1.0,
    }
}

/// `P^-1 = wa P_a^-1 + wb P_b^-1`, `mu = P (wa P_a^-1 mu_a + wb P_b^-1 mu_b)`.
fn combine<F: Frame>(a: &Gaussian2<F>, b: &Gaussian2<F>, wa: f64, wb: f64) -> Gaussian2<F> {
    let (ia, ib) = (a.cov.inverse(), b.cov.inverse());
    let ixx = wa * ia.xx() + wb * ib.xx();
    let ixy = wa * ia.xy() + wb * ib.xy();
    let iyy = wa * ia.yy() + wb * ib.yy();
    let det = ixx * iyy - ixy * ixy;
    let (pxx, pxy, pyy) = (iyy / det, -ixy / det, ixx / det);
    // Information vector.
    let (ax, ay) = (a.mean.x, a.mean.y);
    let (bx, by) = (b.mean.x, b.mean.y);
    let vx = wa * (ia.xx() * ax + ia.xy() * ay) + wb * (ib.xx() * bx + ib.xy() * by);
    let vy = wa * (ia.xy() * ax + ia.yy() * ay) + wb * (ib.xy() * bx + ib.yy() * by);
    let mean = Point2::new(pxx * vx + pxy * vy, pxy * vx + pyy * vy);
    match Cov2::new(pxx, pxy, pyy) {
        Ok(cov) if mean.is_finite() => Gaussian2 { mean, cov },
        // Only reachable with covariances so extreme that the information matrix
        // overflows; keep the more certain input rather than produce garbage.
        _ => {
            if a.cov.det() <= b.cov.det() {
                *a
            } else {
                *b
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tether_core::World;

    fn cov(a: f64, b: f64, angle: f64) -> Cov2 {
        Cov2::from_axes(a, b, angle).unwrap()
    }

    fn any_cov() -> impl Strategy<Value = Cov2> {
        (0.01..3.0f64, 0.01..3.0f64, -3.2..3.2f64).prop_map(|(a, b, t)| cov(a, b, t))
    }

    fn any_criterion() -> impl Strategy<Value = CiCriterion> {
        prop_oneof![Just(CiCriterion::Determinant), Just(CiCriterion::Trace)]
    }

    proptest! {
        #[test]
        fn closed_form_matches_golden_section(a in any_cov(), b in any_cov(), crit in any_criterion()) {
            let w = ci_weight(&a, &b, crit);
            let w_search = ci_weight_by_search(&a, &b, crit);
            prop_assert!((0.0..=1.0).contains(&w));
            let (c, c_search) = (cost(&fused_cov(&a, &b, w), crit), cost(&fused_cov(&a, &b, w_search), crit));
            // Same cost (the optimum may be flat); never worse than the search.
            prop_assert!(c <= c_search * (1.0 + 1e-7) + 1e-15, "closed {w} ({c}) vs search {w_search} ({c_search})");
        }

        #[test]
        fn swapping_inputs_maps_w_to_one_minus_w(a in any_cov(), b in any_cov(), crit in any_criterion()) {
            let w_ab = ci_weight(&a, &b, crit);
            let w_ba = ci_weight(&b, &a, crit);
            let p_ab = fused_cov(&a, &b, w_ab);
            let p_ba = fused_cov(&b, &a, w_ba);
            // The fused result is the same either way round.
            prop_assert!((cost(&p_ab, crit) - cost(&p_ba, crit)).abs() <= 1e-9 * cost(&p_ab, crit).max(1e-12));
            if (w_ab - 0.5).abs() > 1e-6 && (cost(&fused_cov(&a, &b, 0.3), crit) - cost(&fused_cov(&a, &b, 0.7), crit)).abs() > 1e-9 {
                prop_assert!((w_ab + w_ba - 1.0).abs() < 1e-6, "{w_ab} + {w_ba}");
            }
        }

        #[test]
        fn fused_determinant_is_no_larger_than_either_input(a in any_cov(), b in any_cov()) {
            let w = ci_weight(&a, &b, CiCriterion::Determinant);
            let p = fused_cov(&a, &b, w);
            prop_assert!(p.det() <= a.det().min(b.det()) * (1.0 + 1e-9));
        }

        #[test]
        fn a_dominated_input_is_ignored(a in any_cov(), k in 1.01..10.0f64, crit in any_criterion()) {
            // P_a <= P_b (P_b = k P_a plus a PSD term): then w = 1.
            let b = Cov2::new(k * a.xx() + 0.01, k * a.xy(), k * a.yy() + 0.02).unwrap();
            prop_assert!((ci_weight(&a, &b, crit) - 1.0).abs() < 1e-9);
            prop_assert!(ci_weight(&b, &a, crit).abs() < 1e-9);
        }

        #[test]
        fn ci_is_consistent_for_any_correlation(a in any_cov(), b in any_cov(), rho in -0.99..0.99f64) {
            // Whatever the cross-covariance, the CI covariance bounds the actual error
            // covariance of the fused estimate: P_o - E[e e^T] is positive semidefinite.
            // With P_ab = rho * sqrt-factors, E = K_a P_a K_a^T + K_b P_b K_b^T + K_a P_ab K_b^T + K_b P_ba K_a^T.
            let w = ci_weight(&a, &b, CiCriterion::Determinant);
            let p = fused_cov(&a, &b, w);
            let (ia, ib) = (a.inverse(), b.inverse());
            let m = |c: &Cov2| [[c.xx(), c.xy()], [c.xy(), c.yy()]];
            let mul = |x: [[f64; 2]; 2], y: [[f64; 2]; 2]| {
                let mut r = [[0.0; 2]; 2];
                for i in 0..2 { for j in 0..2 { r[i][j] = x[i][0] * y[0][j] + x[i][1] * y[1][j]; } }
                r
            };
            let tr = |x: [[f64; 2]; 2]| [[x[0][0], x[1][0]], [x[0][1], x[1][1]]];
            let scale = |x: [[f64; 2]; 2], k: f64| [[x[0][0] * k, x[0][1] * k], [x[1][0] * k, x[1][1] * k]];
            let ka = scale(mul(m(&p), m(&ia)), w);
            let kb = scale(mul(m(&p), m(&ib)), 1.0 - w);
            let (la, lb) = (a.cholesky(), b.cholesky());
            let lm = |l: (f64, f64, f64)| [[l.0, 0.0], [l.1, l.2]];
            let pab = scale(mul(lm(la), tr(lm(lb))), rho);
            let add = |x: [[f64; 2]; 2], y: [[f64; 2]; 2]| [[x[0][0] + y[0][0], x[0][1] + y[0][1]], [x[1][0] + y[1][0], x[1][1] + y[1][1]]];
            let e = add(
                add(mul(mul(ka, m(&a)), tr(ka)), mul(mul(kb, m(&b)), tr(kb))),
                add(mul(mul(ka, pab), tr(kb)), mul(mul(kb, tr(pab)), tr(ka))),
            );
            let d = [[m(&p)[0][0] - e[0][0], m(&p)[0][1] - e[0][1]], [m(&p)[1][0] - e[1][0], m(&p)[1][1] - e[1][1]]];
            let tol = 1e-9 * p.trace();
            prop_assert!(d[0][0] >= -tol && d[1][1] >= -tol);
            prop_assert!(d[0][0] * d[1][1] - d[0][1] * d[1][0] >= -tol * p.trace());
        }
    }

    #[test]
    fn laser_and_vision_ellipses_fuse_to_their_intersection() {
        // Vision: long along the viewing ray (x), thin across. Laser: round and small.
        let v = Gaussian2::<World>::new(Point2::new(2.1, 0.0), cov(0.3, 0.03, 0.0)).unwrap();
        let l = Gaussian2::<World>::new(Point2::new(2.0, 0.05), cov(0.05, 0.05, 0.0)).unwrap();
        let f = covariance_intersection(&v, &l, CiCriterion::Determinant);
        assert!(f.weight > 0.0 && f.weight < 1.0);
        assert!(f.estimate.cov.det() < v.cov.det().min(l.cov.det()));
        // Range from the laser, bearing mostly from vision.
        assert!((f.estimate.mean.x - 2.0).abs() < 0.02);
        assert!(f.estimate.mean.y.abs() < 0.03);
        let k = independent_fusion(&v, &l);
        assert!(
            k.estimate.cov.det() < f.estimate.cov.det(),
            "independent fusion is tighter"
        );
    }
}
