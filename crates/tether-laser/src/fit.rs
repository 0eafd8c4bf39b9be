//! Small geometric fits on the points of one segment: centroid, scatter, line and
//! circle.

use tether_core::{Laser, Point2};

use crate::preprocess::ScanPoint;

/// Mean of the points, m. The slice must not be empty.
pub(crate) fn centroid(points: &[ScanPoint]) -> Point2<Laser> {
    let n = points.len().max(1) as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |(sx, sy), p| {
        (sx + p.point_in_laser.x, sy + p.point_in_laser.y)
    });
    Point2::new(sx / n, sy / n)
}

/// Scatter matrix about `c`: `S = sum (p - c)(p - c)^T` as `(sxx, sxy, syy)`, m^2.
pub(crate) fn scatter(points: &[ScanPoint], c: Point2<Laser>) -> (f64, f64, f64) {
    points.iter().fold((0.0, 0.0, 0.0), |(xx, xy, yy), p| {
        let (dx, dy) = (p.point_in_laser.x - c.x, p.point_in_laser.y - c.y);
        (xx + dx * dx, xy + dx * dy, yy + dy * dy)
    })
}

/// Eigenvalues of a symmetric 2x2 matrix `[[a, b], [b, d]]`, largest first.
pub(crate) fn eigen_sym2(a: f64, b: f64, d: f64) -> (f64, f64) {
    let mean = 0.5 * (a + d);
    let radius = (0.5 * (a - d)).hypot(b);
    (mean + radius, mean - radius)
}

/// A circle in the laser frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre, m.
    pub centre_in_laser: Point2<Laser>,
    /// Radius, m.
    pub radius_m: f64,
}

/// Algebraic least-squares circle (Kasa 1976): minimises
/// `sum (x^2 + y^2 + D x + E y + F)^2`, solved about the centroid `c` for stability.
/// With `u = x - c.x`, `v = y - c.y` the normal equations reduce to
///
/// ```text
/// [suu suv] [D]     [sum (u^2 + v^2) u]
/// [suv svv] [E] = - [sum (u^2 + v^2) v],   F = -sum (u^2 + v^2) / n
/// ```
///
/// and the circle is centre `c + (-D/2, -E/2)`, radius `sqrt(D^2/4 + E^2/4 - F)`.
/// Returns `None` for fewer than three points or (nearly) collinear ones.
pub(crate) fn fit_circle(points: &[ScanPoint], c: Point2<Laser>) -> Option<Circle> {
    if points.len() < 3 {
        return None;
    }
    let (mut suu, mut suv, mut svv, mut suuu, mut svvv, mut sw) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let (u, v) = (p.point_in_laser.x - c.x, p.point_in_laser.y - c.y);
        let w = u * u + v * v;
        suu += u * u;
        suv += u * v;
        svv += v * v;
        suuu += w * u;
        svvv += w * v;
        sw += w;
    }
    let det = suu * svv - suv * suv;
    // Collinear points have a singular scatter; demand a meaningful determinant.
    if det.is_nan() || det <= 1e-9 * (suu + svv) * (suu + svv) {
        return None;
    }
    let d = -(svv * suuu - suv * svvv) / det;
    let e = -(suu * svvv - suv * suuu) / det;
    let f = -sw / points.len() as f64;
    let r_sq = 0.25 * (d * d + e * e) - f;
    if !(r_sq > 0.0 && r_sq.is_finite()) {
        return None;
    }
    Some(Circle {
        centre_in_laser: Point2::new(c.x - 0.5 * d, c.y - 0.5 * e),
        radius_m: r_sq.sqrt(),
    })
}

/// Centre of the circle through `a`, `b`, `c`: the intersection of the perpendicular
/// bisectors of the chords `ab` and `bc`. Solving `|x - a| = |x - b| = |x - c|`:
///
/// ```text
/// k = 2 ((b - a) x (c - a))
/// x = a + ( (c - a)_y |b - a|^2 - (b - a)_y |c - a|^2,
///           (b - a)_x |c - a|^2 - (c - a)_x |b - a|^2 ) / k
/// ```
///
/// `None` when the three points are (nearly) collinear: parallel bisectors.
pub(crate) fn circumcentre(
    a: Point2<Laser>,
    b: Point2<Laser>,
    c: Point2<Laser>,
) -> Option<Point2<Laser>> {
    let (bx, by) = (b.x - a.x, b.y - a.y);
    let (cx, cy) = (c.x - a.x, c.y - a.y);
    let k = 2.0 * (bx * cy - by * cx);
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    // |k| = 4 * triangle area; compare with the squared side lengths.
    if k.is_nan() || k.abs() <= 1e-9 * (b2 + c2) {
        return None;
    }
    Some(Point2::new(
        a.x + (cy * b2 - by * c2) / k,
        a.y + (bx * c2 - cx * b2) / k,
    ))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Scan points at given positions (beam numbers in order; range and bearing from
    /// the position).
    pub(crate) fn points_at(xy: &[(f64, f64)]) -> Vec<ScanPoint> {
        xy.iter()
            .enumerate()
            .map(|(beam, &(x, y))| {
                let p = Point2::new(x, y);
                ScanPoint {
                    beam,
                    range_m: p.range_m(),
                    bearing_rad: p.bearing_rad(),
                    point_in_laser: p,
                }
            })
            .collect()
    }

    fn arc(cx: f64, cy: f64, r: f64, from: f64, to: f64, n: usize) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let t = from + (to - from) * i as f64 / (n - 1) as f64;
                (cx + r * t.cos(), cy + r * t.sin())
            })
            .collect()
    }

    #[test]
    fn circle_fit_recovers_an_arc() {
        let pts = points_at(&arc(2.0, 0.5, 0.06, 2.0, 4.2, 12));
        let c = fit_circle(&pts, centroid(&pts)).unwrap();
        assert!((c.centre_in_laser.x - 2.0).abs() < 1e-9);
        assert!((c.centre_in_laser.y - 0.5).abs() < 1e-9);
        assert!((c.radius_m - 0.06).abs() < 1e-9);
    }

    #[test]
    fn lines_have_no_circle_and_no_residual() {
        let pts = points_at(&[(1.0, 0.0), (1.0, 0.1), (1.0, 0.2), (1.0, 0.3)]);
        let c = centroid(&pts);
        assert!(fit_circle(&pts, c).is_none());
        let (xx, xy, yy) = scatter(&pts, c);
        assert!(
            eigen_sym2(xx, xy, yy).1.abs() < 1e-20,
            "no spread across a line"
        );
        assert!(
            circumcentre(
                pts[0].point_in_laser,
                pts[1].point_in_laser,
                pts[3].point_in_laser
            )
            .is_none()
        );
    }

    #[test]
    fn circumcentre_is_equidistant() {
        let (a, b, c) = (
            Point2::<Laser>::new(1.0, 0.0),
            Point2::new(0.0, 1.0),
            Point2::new(-1.0, 0.0),
        );
        let o = circumcentre(a, b, c).unwrap();
        assert!(o.x.abs() < 1e-12 && o.y.abs() < 1e-12);
        let o = circumcentre(
            Point2::new(3.0, 1.0),
            Point2::new(2.0, 2.5),
            Point2::new(0.5, 1.0),
        )
        .unwrap();
        let d = |p: Point2<Laser>| p.distance_m(o);
        assert!((d(Point2::new(3.0, 1.0)) - d(Point2::new(2.0, 2.5))).abs() < 1e-12);
        assert!((d(Point2::new(3.0, 1.0)) - d(Point2::new(0.5, 1.0))).abs() < 1e-12);
    }

    #[test]
    fn symmetric_eigenvalues() {
        let (l1, l2) = eigen_sym2(2.0, 1.0, 2.0);
        assert!((l1 - 3.0).abs() < 1e-12 && (l2 - 1.0).abs() < 1e-12);
    }
}
