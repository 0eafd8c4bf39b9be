//! The little linear algebra of an SE(2) estimate: symmetric 3x3 matrices, their
//! eigen-decomposition, and the Jacobians of pose composition.

use tether_core::{Frame, Pose2};

/// A 3x3 matrix over `(x, y, yaw)`, row-major. Covariances use it with units m^2,
/// m rad and rad^2.
pub type Mat3 = [[f64; 3]; 3];

/// The zero matrix.
pub const ZERO3: Mat3 = [[0.0; 3]; 3];

/// `diag(a, b, c)`.
pub fn diag3(a: f64, b: f64, c: f64) -> Mat3 {
    [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]]
}

/// `a * b`.
pub fn mul3(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = ZERO3;
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `a^T`.
pub fn transpose3(a: &Mat3) -> Mat3 {
    let mut m = ZERO3;
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = a[j][i];
        }
    }
    m
}

/// `a + b`.
pub fn add3(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = *a;
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v += b[i][j];
        }
    }
    m
}

/// `j * s * j^T`: how a covariance `s` maps through the Jacobian `j`.
pub fn congruence3(j: &Mat3, s: &Mat3) -> Mat3 {
    mul3(&mul3(j, s), &transpose3(j))
}

/// Eigenvalues (ascending) and unit eigenvectors (`vectors[k]` belongs to `values[k]`)
/// of a symmetric 3x3 matrix, by cyclic Jacobi rotations (Golub and Van Loan, Matrix
/// Computations, section 8.5): each rotation zeroes one off-diagonal pair; sweeps repeat
/// until the off-diagonal part is negligible, which for 3x3 takes a few sweeps.
pub fn symmetric_eigen3(m: &Mat3) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut a = *m;
    // Columns of v are the eigenvectors.
    let mut v = diag3(1.0, 1.0, 1.0);
    for _sweep in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let scale = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-15 * scale || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            // Rotation angle that zeroes a[p][q]: cot(2t) = (a_qq - a_pp) / (2 a_pq).
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let akp = row[p];
                let akq = row[q];
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * row_p[k] - s * row_q[k]);
            a[q] = std::array::from_fn(|k| s * row_p[k] + c * row_q[k]);
            for row in &mut v {
                let vkp = row[p];
                let vkq = row[q];
                row[p] = c * vkp - s * vkq;
                row[q] = s * vkp + c * vkq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let values = order.map(|i| a[i][i]);
    let vectors = order.map(|i| [v[0][i], v[1][i], v[2][i]]);
    (values, vectors)
}

/// Jacobians of the composition `c = a * b` of planar poses with respect to `a` and to
/// `b` (parameters `(x, y, yaw)`): `c.x = a.x + cos(a.yaw) b.x - sin(a.yaw) b.y`,
/// `c.y = a.y + sin(a.yaw) b.x + cos(a.yaw) b.y`, `c.yaw = a.yaw + b.yaw`.
pub fn compose_jacobians<A: Frame, B: Frame, C: Frame>(
    a: Pose2<A, B>,
    b: Pose2<B, C>,
) -> (Mat3, Mat3) {
    let (s, c) = a.yaw.sin_cos();
    let ja = [
        [1.0, 0.0, -s * b.x - c * b.y],
        [0.0, 1.0, c * b.x - s * b.y],
        [0.0, 0.0, 1.0],
    ];
    let jb = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
    (ja, jb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_decomposition_rebuilds_the_matrix() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.2], [0.5, -0.2, 0.01]];
        let (values, vectors) = symmetric_eigen3(&m);
        assert!(values[0] <= values[1] && values[1] <= values[2]);
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3)
                    .map(|k| values[k] * vectors[k][i] * vectors[k][j])
                    .sum();
                assert!((r - m[i][j]).abs() < 1e-12, "{i}{j}: {r}");
            }
            let norm: f64 = vectors[i].iter().map(|x| x * x).sum();
            assert!((norm - 1.0).abs() < 1e-12);
        }
        let (d, _) = symmetric_eigen3(&diag3(3.0, 1.0, 2.0));
        assert_eq!(d, [1.0, 2.0, 3.0]);
    }

    #[test]
    fn composition_jacobians_match_finite_differences() {
        use tether_core::{Laser, Robot, World};
        let a = Pose2::<World, Robot>::new(1.0, -2.0, 0.7);
        let b = Pose2::<Robot, Laser>::new(0.3, 0.4, -0.2);
        let (ja, jb) = compose_jacobians(a, b);
        let h = 1e-6;
        let f = |a: Pose2<World, Robot>, b: Pose2<Robot, Laser>| {
            let c = a * b;
            [c.x, c.y, c.yaw]
        };
        let c0 = f(a, b);
        for k in 0..3 {
            let mut da = [a.x, a.y, a.yaw];
            da[k] += h;
            let mut db = [b.x, b.y, b.yaw];
            db[k] += h;
            let ca = f(Pose2::new(da[0], da[1], da[2]), b);
            let cb = f(a, Pose2::new(db[0], db[1], db[2]));
            for i in 0..3 {
                assert!(((ca[i] - c0[i]) / h - ja[i][k]).abs() < 1e-5);
                assert!(((cb[i] - c0[i]) / h - jb[i][k]).abs() < 1e-5);
            }
        }
    }
}
