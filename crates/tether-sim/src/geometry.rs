//! Planar primitives of the simulated world and the intersection tests the laser and
//! the camera need.

use tether_core::{Frame, Point2, Vector2, World};

/// A straight segment from `a` to `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment<F: Frame = World> {
    /// One end.
    pub a: Point2<F>,
    /// Other end.
    pub b: Point2<F>,
}

impl<F: Frame> Segment<F> {
    /// A segment between two points.
    pub fn new(a: Point2<F>, b: Point2<F>) -> Self {
        Segment { a, b }
    }

    /// Length, m.
    pub fn length_m(&self) -> f64 {
        (self.b - self.a).norm()
    }

    /// The point of the segment closest to `p`.
    pub fn closest_point(&self, p: Point2<F>) -> Point2<F> {
        let d = self.b - self.a;
        let len2 = d.dot(d);
        if len2 <= 0.0 {
            return self.a;
        }
        let t = ((p - self.a).dot(d) / len2).clamp(0.0, 1.0);
        self.a + d * t
    }
}

/// A circle (a leg, a pillar, a table leg).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle<F: Frame = World> {
    /// Centre.
    pub center: Point2<F>,
    /// Radius, m.
    pub radius_m: f64,
}

/// True when two closed segments share a point.
pub fn segments_intersect<F: Frame>(s: &Segment<F>, t: &Segment<F>) -> bool {
    let d1 = s.b - s.a;
    let d2 = t.b - t.a;
    let o1 = d1.cross(t.a - s.a);
    let o2 = d1.cross(t.b - s.a);
    let o3 = d2.cross(s.a - t.a);
    let o4 = d2.cross(s.b - t.a);
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))
    {
        return true;
    }
    // Touching or collinear cases.
    let on = |seg: &Segment<F>, p: Point2<F>, o: f64| {
        o == 0.0
            && p.x >= seg.a.x.min(seg.b.x)
            && p.x <= seg.a.x.max(seg.b.x)
            && p.y >= seg.a.y.min(seg.b.y)
            && p.y <= seg.a.y.max(seg.b.y)
    };
    on(s, t.a, o1) || on(s, t.b, o2) || on(t, s.a, o3) || on(t, s.b, o4)
}

/// Distance from a segment to a point, m.
pub fn segment_circle_distance_m<F: Frame>(s: &Segment<F>, c: Point2<F>) -> f64 {
    s.closest_point(c).distance_m(c)
}

/// Distance along the ray `origin + t * dir` (|dir| = 1) to the first crossing of the
/// circle's boundary from outside, if any (`t > 0`).
///
/// With `c = center - origin` and `p = dir . c`: `t = p - sqrt(r^2 - (|c|^2 - p^2))`.
pub fn ray_circle_m<F: Frame>(
    origin: Point2<F>,
    dir: Vector2<F>,
    circle: &Circle<F>,
) -> Option<f64> {
    let c = circle.center - origin;
    let p = dir.dot(c);
    let disc = circle.radius_m * circle.radius_m - (c.dot(c) - p * p);
    if disc < 0.0 {
        return None;
    }
    let t = p - disc.sqrt();
    (t > 0.0).then_some(t)
}

/// Distance along the ray `origin + t * dir` to a segment, if it is hit (`t > 0`).
///
/// Solving `origin + t dir = a + s (b - a)`: with `e = b - a` and `q = a - origin`,
/// `t = (q x e) / (dir x e)`, `s = (q x dir) / (dir x e)`, hit when `t > 0` and
/// `0 <= s <= 1`.
pub fn ray_segment_m<F: Frame>(
    origin: Point2<F>,
    dir: Vector2<F>,
    seg: &Segment<F>,
) -> Option<f64> {
    let e = seg.b - seg.a;
    let q = seg.a - origin;
    let denom = dir.cross(e);
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = q.cross(e) / denom;
    let s = q.cross(dir) / denom;
    (t > 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    type P = Point2<World>;

    #[test]
    fn crossing_segments_intersect() {
        let s = Segment::new(P::new(0.0, 0.0), P::new(2.0, 2.0));
        let t = Segment::new(P::new(0.0, 2.0), P::new(2.0, 0.0));
        let u = Segment::new(P::new(3.0, 0.0), P::new(4.0, 0.0));
        assert!(segments_intersect(&s, &t));
        assert!(!segments_intersect(&s, &u));
        let touching = Segment::new(P::new(2.0, 2.0), P::new(3.0, 2.0));
        assert!(segments_intersect(&s, &touching));
    }

    #[test]
    fn ray_hits_circle_front_face() {
        let c = Circle {
            center: P::new(3.0, 0.0),
            radius_m: 0.5,
        };
        let t = ray_circle_m(P::new(0.0, 0.0), Vector2::new(1.0, 0.0), &c).unwrap();
        assert!((t - 2.5).abs() < 1e-12);
        assert!(ray_circle_m(P::new(0.0, 0.0), Vector2::new(-1.0, 0.0), &c).is_none());
        assert!(ray_circle_m(P::new(0.0, 0.0), Vector2::new(0.0, 1.0), &c).is_none());
    }

    proptest! {
        /// The analytic ray-segment hit agrees with marching along the ray.
        #[test]
        fn ray_segment_matches_marching(ax in -5.0..5.0f64, ay in -5.0..5.0f64, bx in -5.0..5.0f64,
                                        by in -5.0..5.0f64, angle in -3.2..3.2f64) {
            let seg = Segment::new(P::new(ax, ay), P::new(bx, by));
            prop_assume!(seg.length_m() > 0.1);
            let dir = Vector2::unit(angle);
            let o = P::new(0.0, 0.0);
            let hit = ray_segment_m(o, dir, &seg);
            // March along the ray and look for a change of side of the segment's line
            // at a point whose projection falls on the segment.
            let e = seg.b - seg.a;
            let side = |t: f64| e.cross((o + dir * t) - seg.a);
            let step = 1e-3;
            let mut marched = None;
            let mut t = step;
            while t < 15.0 {
                if side(t - step).signum() != side(t).signum() {
                    let mid = o + dir * (t - 0.5 * step);
                    let along = (mid - seg.a).dot(e) / e.dot(e);
                    if (-1e-3..=1.0 + 1e-3).contains(&along) {
                        marched = Some(t);
                        break;
                    }
                }
                t += step;
            }
            match (hit, marched) {
                (Some(h), Some(m)) => prop_assert!((h - m).abs() <= step, "{h} vs {m}"),
                (None, Some(m)) => {
                    // Only a crossing right at an end can be missed by the exact test.
                    let p = o + dir * m;
                    let end = p.distance_m(seg.a).min(p.distance_m(seg.b));
                    prop_assert!(end < 0.01, "missed a crossing at {m}");
                }
                (Some(h), None) => {
                    let p = o + dir * h;
                    let end = p.distance_m(seg.a).min(p.distance_m(seg.b));
                    prop_assert!(end < 0.01 || h < step, "hit at {h} that marching did not see");
                }
                (None, None) => {}
            }
        }
    }
}
