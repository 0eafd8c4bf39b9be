//! Planar geometry tagged with frames: points, displacement vectors and rigid poses.
//!
//! All lengths are metres and all angles radians (design section 1); the types carry the
//! frame, so a point in the laser frame cannot be mixed with one in the world frame
//! without passing through a named transform.

use std::marker::PhantomData;
use std::ops::{Add, Mul, Neg, Sub};

use serde::{Deserialize, Serialize};

use crate::frame::Frame;

/// Wraps an angle into (-pi, pi].
pub fn wrap_angle_rad(angle_rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let wrapped = angle_rad.rem_euclid(TAU);
    if wrapped > PI { wrapped - TAU } else { wrapped }
}

/// A position in frame `F`, metres.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Point2<F: Frame> {
    /// Forward coordinate, m.
    pub x: f64,
    /// Leftward coordinate, m.
    pub y: f64,
    #[serde(skip)]
    frame: PhantomData<F>,
}

/// A displacement or velocity in frame `F` (metres, or metres per second): rotates with
/// the frame but does not translate.
// Parallel to Point2 on purpose: a point and a vector transform differently, so they are
// two types.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Vector2<F: Frame> {
    /// Forward component.
    pub x: f64,
    /// Leftward component.
    pub y: f64,
    #[serde(skip)]
    frame: PhantomData<F>,
}

/// A point in 3-D, frame `F` (metres), z up. Used where height matters: a person's head
/// top seen by the camera, the laser's mounting height.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Point3<F: Frame> {
    /// Forward coordinate, m.
    pub x: f64,
    /// Leftward coordinate, m.
    pub y: f64,
    /// Height above the floor, m.
    pub z: f64,
    #[serde(skip)]
    frame: PhantomData<F>,
}

/// A rigid planar transform `To <- From`: the pose of frame `From` expressed in frame
/// `To`. `robot_from_laser * point_in_laser` gives `point_in_robot`.
///
/// `point_in_to = R(yaw) * point_in_from + (x, y)`.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Pose2<To: Frame, From: Frame> {
    /// Origin of `From` in `To`, forward, m.
    pub x: f64,
    /// Origin of `From` in `To`, leftward, m.
    pub y: f64,
    /// Rotation of `From` relative to `To`, counter-clockwise, rad.
    pub yaw: f64,
    #[serde(skip)]
    frames: PhantomData<(To, From)>,
}

// Derives would put bounds on the frame markers; these impls do not need them.
macro_rules! plain_value_impls {
    ($ty:ident < $($p:ident),+ >, $($field:ident),+) => {
        impl<$($p: Frame),+> Clone for $ty<$($p),+> {
            fn clone(&self) -> Self {
                *self
            }
        }
        impl<$($p: Frame),+> Copy for $ty<$($p),+> {}
        impl<$($p: Frame),+> PartialEq for $ty<$($p),+> {
            fn eq(&self, other: &Self) -> bool {
                $(self.$field == other.$field)&&+
            }
        }
        impl<$($p: Frame),+> std::fmt::Debug for $ty<$($p),+> {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                let mut s = f.debug_struct(concat!(stringify!($ty), "<", $(stringify!($p), ",",)+ ">"));
                $(s.field(stringify!($field), &self.$field);)+
                s.finish()
            }
        }
    };
}

plain_value_impls!(Point2<F>, x, y);
plain_value_impls!(Vector2<F>, x, y);
plain_value_impls!(Point3<F>, x, y, z);
plain_value_impls!(Pose2<To, From>, x, y, yaw);

impl<F: Frame> Point2<F> {
    /// The frame's origin.
    pub const ORIGIN: Self = Point2::new(0.0, 0.0);

    /// A point at (x, y) metres.
    pub const fn new(x: f64, y: f64) -> Self {
        Point2 {
            x,
            y,
            frame: PhantomData,
        }
    }

    /// A point at `range_m` along the direction `bearing_rad` from the origin.
    pub fn from_polar(range_m: f64, bearing_rad: f64) -> Self {
        let (s, c) = bearing_rad.sin_cos();
        Point2::new(range_m * c, range_m * s)
    }

    /// Distance from the origin, m.
    pub fn range_m(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Exactly `self.range_m() <= limit_m`, mostly without the `hypot`: the computed
    /// `x^2 + y^2` is within a few ulps of the true square and `hypot` within one of
    /// the true length, so a sum of squares outside `limit_m^2 (1 -+ 1e-12)` decides
    /// the comparison (for limits in `(1e-100, 1e100)`, where neither square over- or
    /// underflows to matter); near the limit, and for non-finite input, `hypot` does.
    /// Several times cheaper on the many returns of a scan.
    pub fn range_at_most(self, limit_m: f64) -> bool {
        hypot_vs_limit(self.x, self.y, limit_m).unwrap_or_else(|| self.range_m() <= limit_m)
    }

    /// Exactly `self.distance_m(other) < limit_m`, mostly without the `hypot` (as
    /// [`Point2::range_at_most`]).
    pub fn distance_below(self, other: Self, limit_m: f64) -> bool {
        let v = self - other;
        hypot_vs_limit(v.x, v.y, limit_m).unwrap_or_else(|| self.distance_m(other) < limit_m)
    }

    /// Exactly `self.distance_m(other) > limit_m`, mostly without the `hypot` (as
    /// [`Point2::range_at_most`]).
    pub fn distance_above(self, other: Self, limit_m: f64) -> bool {
        let v = self - other;
        match hypot_vs_limit(v.x, v.y, limit_m) {
            Some(below) => !below,
            None => self.distance_m(other) > limit_m,
        }
    }

    /// Direction from the origin, rad, counter-clockwise from +x.
    pub fn bearing_rad(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// Distance to another point of the same frame, m.
    pub fn distance_m(self, other: Self) -> f64 {
        (self - other).norm()
    }

    /// The vector from the origin to this point.
    pub const fn to_vector(self) -> Vector2<F> {
        Vector2::new(self.x, self.y)
    }

    /// True when both coordinates are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The point at `height_m` above this one.
    pub const fn with_height(self, height_m: f64) -> Point3<F> {
        Point3::new(self.x, self.y, height_m)
    }

    /// The point `t` of the way from `self` to `other` (t = 0 gives `self`).
    pub fn lerp(self, other: Self, t: f64) -> Self {
        self + (other - self) * t
    }
}

impl<F: Frame> Vector2<F> {
    /// The zero vector.
    pub const ZERO: Self = Vector2::new(0.0, 0.0);

    /// A vector (x, y).
    pub const fn new(x: f64, y: f64) -> Self {
        Vector2 {
            x,
            y,
            frame: PhantomData,
        }
    }

    /// A unit vector pointing along `angle_rad`.
    pub fn unit(angle_rad: f64) -> Self {
        let (s, c) = angle_rad.sin_cos();
        Vector2::new(c, s)
    }

    /// Euclidean length.
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Dot product.
    pub fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// z-component of the 3-D cross product (positive when `other` is counter-clockwise
    /// of `self`).
    pub fn cross(self, other: Self) -> f64 {
        self.x * other.y - self.y * other.x
    }

    /// Direction, rad.
    pub fn angle_rad(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// This vector turned 90 degrees counter-clockwise.
    pub const fn perp(self) -> Self {
        Vector2::new(-self.y, self.x)
    }

    /// This vector turned by `angle_rad` counter-clockwise.
    pub fn rotated(self, angle_rad: f64) -> Self {
        let (s, c) = angle_rad.sin_cos();
        Vector2::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl<F: Frame> Point3<F> {
    /// A point at (x, y, z) metres.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Point3 {
            x,
            y,
            z,
            frame: PhantomData,
        }
    }

    /// The point's projection on the floor plane.
    pub const fn xy(self) -> Point2<F> {
        Point2::new(self.x, self.y)
    }
}

impl<To: Frame, From: Frame> Pose2<To, From> {
    /// `p -> self * p` with the rotation's sine and cosine computed once: for many
    /// points, the same results as `self * p` each (the same values, the same formula)
    /// without a `sin_cos` per point.
    pub fn point_map(self) -> impl Fn(Point2<From>) -> Point2<To> + Copy {
        let (s, c) = self.yaw.sin_cos();
        let (x, y) = (self.x, self.y);
        move |p: Point2<From>| Point2::new(c * p.x - s * p.y + x, s * p.x + c * p.y + y)
    }

    /// The identity transform (only meaningful when `To` and `From` coincide).
    pub const IDENTITY: Self = Pose2::new(0.0, 0.0, 0.0);

    /// The pose of `From` at (x, y) metres in `To`, rotated by `yaw` radians.
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Pose2 {
            x,
            y,
            yaw,
            frames: PhantomData,
        }
    }

    /// The origin of `From`, expressed in `To`.
    pub const fn translation(self) -> Point2<To> {
        Point2::new(self.x, self.y)
    }

    /// The same transform with its yaw wrapped into (-pi, pi].
    pub fn normalized(self) -> Self {
        Pose2::new(self.x, self.y, wrap_angle_rad(self.yaw))
    }

    /// The inverse transform: `from_to = to_from.inverse()`.
    pub fn inverse(self) -> Pose2<From, To> {
        let (s, c) = self.yaw.sin_cos();
        Pose2::new(
            -(c * self.x + s * self.y),
            s * self.x - c * self.y,
            wrap_angle_rad(-self.yaw),
        )
    }

    /// Rotates a vector of `From` into `To` (no translation).
    pub fn rotate(self, v: Vector2<From>) -> Vector2<To> {
        let (s, c) = self.yaw.sin_cos();
        Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
    }

    /// Maps a 3-D point: rotation about z and planar translation, height unchanged.
    pub fn transform_point3(self, p: Point3<From>) -> Point3<To> {
        let q = self * p.xy();
        Point3::new(q.x, q.y, p.z)
    }

    /// True when every component is finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }
}

impl<F: Frame> Sub for Point2<F> {
    type Output = Vector2<F>;
    fn sub(self, rhs: Self) -> Vector2<F> {
        Vector2::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl<F: Frame> Add<Vector2<F>> for Point2<F> {
    type Output = Point2<F>;
    fn add(self, rhs: Vector2<F>) -> Point2<F> {
        Point2::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl<F: Frame> Sub<Vector2<F>> for Point2<F> {
    type Output = Point2<F>;
    fn sub(self, rhs: Vector2<F>) -> Point2<F> {
        Point2::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl<F: Frame> Add for Vector2<F> {
    type Output = Vector2<F>;
    fn add(self, rhs: Self) -> Self {
        Vector2::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl<F: Frame> Sub for Vector2<F> {
    type Output = Vector2<F>;
    fn sub(self, rhs: Self) -> Self {
        Vector2::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl<F: Frame> Neg for Vector2<F> {
    type Output = Vector2<F>;
    fn neg(self) -> Self {
        Vector2::new(-self.x, -self.y)
    }
}

impl<F: Frame> Mul<f64> for Vector2<F> {
    type Output = Vector2<F>;
    fn mul(self, k: f64) -> Self {
        Vector2::new(self.x * k, self.y * k)
    }
}

/// `hypot(x, y)` against `limit_m` where the sum of squares decides it: `Some(true)`
/// when the length is surely below the limit, `Some(false)` when surely above, `None`
/// near it (and for non-finite input), where only `hypot` itself can tell. The computed
/// `x^2 + y^2` is within a few ulps of the true square and `hypot` within one of the
/// true length, so a sum of squares outside `limit_m^2 (1 -+ 1e-12)` decides both `<`
/// and `<=`, for limits in `(1e-100, 1e100)`, where neither square over- or underflows
/// to matter (unit test `range_at_most_is_range_m_compared`).
fn hypot_vs_limit(x: f64, y: f64, limit_m: f64) -> Option<bool> {
    if !(limit_m > 1e-100 && limit_m < 1e100) {
        return None;
    }
    let sq = x * x + y * y;
    let limit_sq = limit_m * limit_m;
    if sq < limit_sq * (1.0 - 1e-12) {
        Some(true)
    } else if sq > limit_sq * (1.0 + 1e-12) {
        Some(false)
    } else {
        None
    }
}

/// `point_in_to = to_from * point_in_from`.
impl<To: Frame, From: Frame> Mul<Point2<From>> for Pose2<To, From> {
    type Output = Point2<To>;
    fn mul(self, p: Point2<From>) -> Point2<To> {
        let (s, c) = self.yaw.sin_cos();
        Point2::new(c * p.x - s * p.y + self.x, s * p.x + c * p.y + self.y)
    }
}

/// Composition: `a_from_c = a_from_b * b_from_c`.
impl<A: Frame, B: Frame, C: Frame> Mul<Pose2<B, C>> for Pose2<A, B> {
    type Output = Pose2<A, C>;
    fn mul(self, rhs: Pose2<B, C>) -> Pose2<A, C> {
        let t = self * rhs.translation();
        Pose2::new(t.x, t.y, wrap_angle_rad(self.yaw + rhs.yaw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Laser, Robot, World};
    use proptest::prelude::*;
    use std::f64::consts::PI;

    #[test]
    fn range_at_most_is_range_m_compared() {
        let p = |x: f64, y: f64| Point2::<Laser>::new(x, y);
        let mut state = 7u64;
        let mut unit = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // Points at and next to the limit's circle, where the shortcut must step aside.
        for _ in 0..200_000 {
            let limit = [0.5, 1.0, 2.3, 7.0, 1e-90, 1e90][(unit() * 6.0) as usize];
            let bearing = unit() * 2.0 * PI;
            let r =
                limit * (1.0 + (unit() - 0.5) * [1e-15, 1e-12, 1e-9, 1.0][(unit() * 4.0) as usize]);
            let q = p(r * bearing.cos(), r * bearing.sin());
            let o = p(0.25 * limit, -0.5 * limit);
            for at in [q, p(q.x.next_up(), q.y), p(q.x, q.y.next_down())] {
                assert_eq!(
                    at.range_at_most(limit),
                    at.range_m() <= limit,
                    "{at:?} {limit}"
                );
                let from_o = p(at.x + o.x, at.y + o.y);
                assert_eq!(
                    from_o.distance_below(o, limit),
                    from_o.distance_m(o) < limit,
                    "{from_o:?} {limit}"
                );
                assert_eq!(
                    from_o.distance_above(o, limit),
                    from_o.distance_m(o) > limit,
                    "{from_o:?} {limit}"
                );
            }
        }
        for (q, limit) in [
            (p(f64::NAN, 0.0), 1.0),
            (p(f64::INFINITY, 0.0), 1.0),
            (p(1e300, 1e300), 1.0),
            (p(1e-300, 0.0), 1e-300),
            (p(0.0, 0.0), 0.0),
            (p(0.5, 0.0), -1.0),
            (p(0.5, 0.0), f64::NAN),
            (p(0.5, 0.0), f64::INFINITY),
            (p(3.0, 4.0), 5.0),
        ] {
            assert_eq!(
                q.range_at_most(limit),
                q.range_m() <= limit,
                "{q:?} {limit}"
            );
            assert_eq!(q.distance_below(p(0.0, 0.0), limit), q.range_m() < limit);
            assert_eq!(q.distance_above(p(0.0, 0.0), limit), q.range_m() > limit);
        }
    }

    proptest! {
        #[test]
        fn point_map_is_the_pose_applied(
            x in -1e3..1e3f64, y in -1e3..1e3f64, yaw in -10.0..10.0f64,
            px in -1e3..1e3f64, py in -1e3..1e3f64,
        ) {
            let pose = Pose2::<World, Robot>::new(x, y, yaw);
            let q = Point2::<Robot>::new(px, py);
            prop_assert_eq!(pose.point_map()(q), pose * q);
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn wraps_angles_into_half_open_interval() {
        assert!(close(wrap_angle_rad(3.0 * PI), PI));
        assert!(close(wrap_angle_rad(-PI), PI));
        assert!(close(wrap_angle_rad(-0.5), -0.5));
        assert!(close(wrap_angle_rad(7.0), 7.0 - 2.0 * PI));
    }

    #[test]
    fn transform_reads_right_to_left() {
        // Laser 0.2 m ahead of the axle, turned left by 90 degrees.
        let robot_from_laser: Pose2<Robot, Laser> = Pose2::new(0.2, 0.0, PI / 2.0);
        let point_in_laser = Point2::<Laser>::new(1.0, 0.0);
        let point_in_robot = robot_from_laser * point_in_laser;
        assert!(close(point_in_robot.x, 0.2) && close(point_in_robot.y, 1.0));
    }

    proptest! {
        #[test]
        fn inverse_undoes_transform(x in -50.0..50.0f64, y in -50.0..50.0f64, yaw in -7.0..7.0f64,
                                    px in -20.0..20.0f64, py in -20.0..20.0f64) {
            let world_from_robot: Pose2<World, Robot> = Pose2::new(x, y, yaw);
            let p = Point2::<Robot>::new(px, py);
            let back = world_from_robot.inverse() * (world_from_robot * p);
            prop_assert!((back.x - p.x).abs() < 1e-9 && (back.y - p.y).abs() < 1e-9);
        }

        #[test]
        fn composition_matches_sequential_application(
            a in prop::array::uniform3(-10.0..10.0f64), b in prop::array::uniform3(-10.0..10.0f64),
            px in -5.0..5.0f64, py in -5.0..5.0f64,
        ) {
            let world_from_robot: Pose2<World, Robot> = Pose2::new(a[0], a[1], a[2]);
            let robot_from_laser: Pose2<Robot, Laser> = Pose2::new(b[0], b[1], b[2]);
            let p = Point2::<Laser>::new(px, py);
            let direct = (world_from_robot * robot_from_laser) * p;
            let stepwise = world_from_robot * (robot_from_laser * p);
            prop_assert!((direct.x - stepwise.x).abs() < 1e-9 && (direct.y - stepwise.y).abs() < 1e-9);
        }

        #[test]
        fn rotation_keeps_length(x in -10.0..10.0f64, y in -10.0..10.0f64, yaw in -7.0..7.0f64) {
            let pose: Pose2<World, Robot> = Pose2::new(3.0, -2.0, yaw);
            let v = Vector2::<Robot>::new(x, y);
            prop_assert!((pose.rotate(v).norm() - v.norm()).abs() < 1e-9);
        }
    }

    #[test]
    fn polar_round_trip() {
        let p = Point2::<Laser>::from_polar(2.0, 0.3);
        assert!(close(p.range_m(), 2.0) && close(p.bearing_rad(), 0.3));
    }
}
