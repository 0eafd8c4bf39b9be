//! What the laser could not have seen: a person behind something nearer to the scanner
//! (a pillar, a doorframe, another person) leaves no returns, and their track's silence
//! is no evidence that they have gone (design 5.5, "hidden tracks").
//!
//! A point `p` at range `r` from the scanner is hidden when, of the returns within the
//! angular half-width `w = atan(rho / r)` of a person of radius `rho` about `p`'s
//! bearing, at least half lie nearer than `r - margin`: something stands between the
//! scanner and `p`. Where the cone holds no return on one side of `p`'s bearing
//! (no-return beams, the edge of the field of view, outside it), nothing says `p` is
//! hidden, and it counts as in view.

use tether_core::{Frame, Point2};

/// Radius of a person seen from above at leg height, m: the cone a person fills.
pub const PERSON_RADIUS_M: f64 = 0.25;

/// The returns of one scan, with the scanner's position, in one frame.
#[derive(Debug, Clone, Copy)]
pub struct Shadow<'a, F: Frame> {
    scanner: Point2<F>,
    returns: &'a [Point2<F>],
    margin_m: f64,
}

impl<'a, F: Frame> Shadow<'a, F> {
    /// The shadows cast by `returns` seen from `scanner`: a return hides what is more
    /// than `margin_m` behind it.
    pub fn new(scanner: Point2<F>, returns: &'a [Point2<F>], margin_m: f64) -> Self {
        Shadow {
            scanner,
            returns,
            margin_m,
        }
    }

    /// Whether a person at `p` would be hidden from the scanner (module doc).
    pub fn hides(&self, p: Point2<F>) -> bool {
        let to_p = p - self.scanner;
        let r = to_p.norm();
        if !r.is_finite() || r <= self.margin_m {
            return false;
        }
        let u = to_p * (1.0 / r);
        let sin_w = (PERSON_RADIUS_M / r).atan().sin();
        let (mut nearer, mut in_cone) = (0usize, 0usize);
        let (mut left, mut right) = (false, false);
        for q in self.returns {
            let v = *q - self.scanner;
            let along = v.dot(u);
            let range = v.norm();
            let side = u.cross(v);
            if along <= 0.0 || side.abs() > sin_w * range {
                continue;
            }
            left |= side >= 0.0;
            right |= side <= 0.0;
            in_cone += 1;
            nearer += usize::from(range < r - self.margin_m);
        }
        left && right && 2 * nearer >= in_cone
    }
}

impl<F: Frame> Shadow<'_, F> {
    /// Whether a person at `p` would be hidden, or would be a leg's width (`reach_m`)
    /// to either side at the same range.
    pub fn hides_near(&self, p: Point2<F>, reach_m: f64) -> bool {
        if self.hides(p) {
            return true;
        }
        let to_p = p - self.scanner;
        let r = to_p.norm();
        if !r.is_finite() || r <= 0.0 {
            return false;
        }
        let w = (reach_m / r).atan();
        [w, -w]
            .into_iter()
            .any(|a| self.hides(self.scanner + to_p.rotated(a)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::World;

    fn p(x: f64, y: f64) -> Point2<World> {
        Point2::new(x, y)
    }

    /// A wall at x = `x_m` seen from the origin, a return every half degree over
    /// +-60 degrees, with a post of radius 0.3 m at (2, 0) in front of it.
    fn scene(x_m: f64) -> Vec<Point2<World>> {
        (-120..=120)
            .map(|i| {
                let a = f64::from(i) * 0.5_f64.to_radians();
                let (s, c) = a.sin_cos();
                // Ray against the post (circle at (2, 0), radius 0.3).
                let b = 2.0 * c;
                let disc = b * b - (4.0 - 0.09);
                let t = if disc >= 0.0 {
                    b - disc.sqrt()
                } else {
                    x_m / c
                };
                p(t * c, t * s)
            })
            .collect()
    }

    #[test]
    fn a_person_behind_a_post_is_hidden_one_beside_it_is_not() {
        let returns = scene(6.0);
        let shadow = Shadow::new(p(0.0, 0.0), &returns, 0.3);
        assert!(shadow.hides(p(3.5, 0.0)), "straight behind the post");
        assert!(shadow.hides(p(4.0, 0.2)), "behind it, a little off centre");
        assert!(!shadow.hides(p(3.5, 1.5)), "well off to the side");
        assert!(!shadow.hides(p(1.2, 0.0)), "in front of the post");
        assert!(!shadow.hides(p(2.0, 0.0)), "at the post itself");
        // Coming out from behind the post: at its edge, seen, but a step from its
        // shadow; further out, more than a step.
        let edge = p(3.5, 0.6);
        assert!(!shadow.hides(edge));
        assert!(shadow.hides_near(edge, 0.1));
        assert!(!shadow.hides_near(p(3.5, 1.1), 0.1));
        assert!(
            !shadow.hides_near(p(1.5, 0.5), 0.1),
            "beside the post, nearer than it"
        );
    }

    #[test]
    fn where_there_are_no_returns_nothing_is_hidden() {
        let shadow = Shadow::new(p(0.0, 0.0), &[], 0.3);
        assert!(!shadow.hides(p(3.0, 0.0)));
        let returns = scene(6.0);
        let shadow = Shadow::new(p(0.0, 0.0), &returns, 0.3);
        assert!(!shadow.hides(p(-3.0, 0.0)), "behind the scanner");
        // Just past the edge of the field of view (+-60 degrees), where the beams on
        // one side of the person's bearing hit a wall nearer than them.
        let near_wall = scene(1.0);
        let shadow = Shadow::new(p(0.0, 0.0), &near_wall, 0.3);
        let (s, c) = 62.0_f64.to_radians().sin_cos();
        assert!(!shadow.hides(p(3.0 * c, 3.0 * s)), "past the edge");
        let (s, c) = 50.0_f64.to_radians().sin_cos();
        assert!(
            shadow.hides(p(3.0 * c, 3.0 * s)),
            "behind the wall, inside the view"
        );
        assert!(!shadow.hides(p(f64::NAN, 0.0)));
    }
}
