//! A person's position on the floor plane from an upper-body box: monocular range and
//! bearing, the paper's eq. 1-3 as design 3.2 restates them, with the covariance
//! propagated from the pixel noise, the spread of people's heights and the uncertainty of
//! the camera tilt.
//!
//! # The model
//!
//! The box's reference point is its top centre, `(u, v) = (x + w/2, y + m h)`, where `m`
//! is the fraction of the box above the head (design 2.2). With normalised coordinates
//! `x_n = (u - cx) / fx`, `y_n = (v - cy) / fy` and the camera pitched up by `t`, the
//! pixel's ray in the camera's ground frame (forward, left, up) is
//!
//! ```text
//! r = (cos t + y_n sin t,  -x_n,  sin t - y_n cos t) = (f, -x_n, z).
//! ```
//!
//! The head top is at height `Hm`, the lens at `Hc`; the ray reaches the plane
//! `z = Hm` after `k = (Hm - Hc) / z`, at
//!
//! ```text
//! forward = (Hm - Hc) f / z = (Hm - Hc) / tan(alpha),   alpha = t + atan(-y_n)   (eq. 1)
//! left    = -(Hm - Hc) x_n / z                                                  (eq. 3, exact)
//! ```
//!
//! (the paper's eq. 3, `left = forward tan(beta)` with `beta = -atan(x_n)` (eq. 2), is the
//! small-tilt approximation of the second line). The point is then moved into the robot
//! frame by the camera's mounting (offset and yaw).
//!
//! # The covariance
//!
//! `P = J diag(s_u^2, s_v^2, s_H^2, s_t^2) J^T` with the Jacobian of (forward, left) with
//! respect to `u`, `v`, `Hm` and `t`, rotated by the camera yaw. With `a = Hm - Hc`:
//!
//! ```text
//! d forward / d u = 0                     d left / d u = -a / (z fx)
//! d forward / d v = a / (z^2 fy)          d left / d v = -a x_n cos t / (z^2 fy)
//! d forward / d Hm = f / z                d left / d Hm = -x_n / z
//! d forward / d t = -a (f^2 + z^2) / z^2  d left / d t = a x_n f / z^2
//! ```
//!
//! Range is poor (it hangs on one row and on the height) and bearing good, so the
//! ellipse is long along the viewing ray. At 3 m with the default camera one pixel of row
//! error moves the range ~2 cm, one degree of tilt ~16 cm and 7 cm of height ~19 cm.
//!
//! An alternative range from the box height, `d = fy H_box / h` ([`range_from_box_height`]),
//! is offered as a second cue; [`locate`] uses the head top (eq. 1).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use tether_core::{CameraModel, Cov2, CovError, Gaussian2, PixelBox, Point2, Robot};

/// What is assumed about the person and the measurement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MonocularParams {
    /// Height of the top of the head above the floor (`Hm`), m. Default 1.70.
    pub head_height_m: f64,
    /// Spread of head heights among people, m. Default 0.07.
    pub head_height_sigma_m: f64,
    /// Fraction of the box above the head (`m` of design 2.2). Default 0.
    pub margin_frac: f64,
    /// Noise of the reference point's column, px. Default 2.
    pub sigma_u_px: f64,
    /// Noise of the reference point's row, px. Default 2.
    pub sigma_v_px: f64,
    /// Uncertainty of the camera tilt, rad. Default 1 degree.
    pub tilt_sigma_rad: f64,
}

impl Default for MonocularParams {
    fn default() -> Self {
        MonocularParams {
            head_height_m: 1.70,
            head_height_sigma_m: 0.07,
            margin_frac: 0.0,
            sigma_u_px: 2.0,
            sigma_v_px: 2.0,
            tilt_sigma_rad: 1f64.to_radians(),
        }
    }
}

/// Why a box cannot be turned into a position.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MonocularError {
    /// A parameter is not a finite, sensible number.
    #[error("monocular parameter `{field}` = {value} is invalid: {why}")]
    BadParam {
        /// Field name.
        field: &'static str,
        /// The value.
        value: f64,
        /// What it must satisfy.
        why: &'static str,
    },
    /// The box is not finite or has no size.
    #[error("box {0:?} is not a finite box of positive size")]
    BadBox(PixelBox),
    /// The pixel's ray does not reach the head plane in front of the camera.
    #[error(
        "the box top at row {v_px:.1} looks {where_} the head plane (Hm = {head_height_m} m, \
         camera at {camera_height_m} m): no floor position; check the camera tilt and height \
         and the assumed head height"
    )]
    NoIntersection {
        /// Row of the reference point, px.
        v_px: f64,
        /// "at the height of" or "away from".
        where_: &'static str,
        /// Assumed head height, m.
        head_height_m: f64,
        /// Camera height, m.
        camera_height_m: f64,
    },
    /// The covariance came out degenerate (zero sigmas).
    #[error("covariance is degenerate: {0}; give positive sigmas")]
    Covariance(#[from] CovError),
}

/// A person located from one box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonocularFix {
    /// Position and covariance in the robot frame.
    pub in_robot: Gaussian2<Robot>,
    /// Forward distance in the camera's ground frame (`Dm`, eq. 1), m.
    pub forward_m: f64,
    /// Lateral offset in the camera's ground frame, left positive, m.
    pub left_m: f64,
    /// Bearing in the camera's ground frame, `atan2(left, forward)`, rad.
    pub bearing_rad: f64,
    /// Elevation of the ray to the head top (`alpha`), rad.
    pub elevation_rad: f64,
}

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    why: &'static str,
) -> Result<(), MonocularError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(MonocularError::BadParam { field, value, why })
    }
}

impl MonocularParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), MonocularError> {
        check(
            "head_height_m",
            self.head_height_m,
            self.head_height_m > 0.0,
            "must be a positive height",
        )?;
        for (field, v) in [
            ("head_height_sigma_m", self.head_height_sigma_m),
            ("sigma_u_px", self.sigma_u_px),
            ("sigma_v_px", self.sigma_v_px),
            ("tilt_sigma_rad", self.tilt_sigma_rad),
        ] {
            check(field, v, v >= 0.0, "must be zero or positive")?;
        }
        check(
            "margin_frac",
            self.margin_frac,
            (0.0..1.0).contains(&self.margin_frac),
            "must be in [0, 1)",
        )
    }
}

/// The floor-plane point of a pixel's ray at head height and the Jacobian of
/// (forward, left) with respect to (u, v, Hm, tilt), in the camera's ground frame.
struct RayHit {
    forward_m: f64,
    left_m: f64,
    jacobian: [[f64; 4]; 2],
    elevation_rad: f64,
}

fn ray_hit(
    camera: &CameraModel,
    u: f64,
    v: f64,
    head_height_m: f64,
) -> Result<RayHit, MonocularError> {
    let i = &camera.intrinsics;
    let (s, c) = camera.mount.tilt_rad.sin_cos();
    let xn = (u - i.cx_px) / i.fx_px;
    let yn = (v - i.cy_px) / i.fy_px;
    let f = c + yn * s;
    let z = s - yn * c;
    let a = head_height_m - camera.mount.height_m;
    // The ray must rise (or fall) towards the head plane and reach it in front.
    let k = a / z;
    if !(k.is_finite() && k > 0.0 && f > 1e-9 && z.abs() > 1e-9) {
        return Err(MonocularError::NoIntersection {
            v_px: v,
            where_: if z.abs() <= 1e-9 || a == 0.0 {
                "at the height of"
            } else {
                "away from"
            },
            head_height_m,
            camera_height_m: camera.mount.height_m,
        });
    }
    let z2 = z * z;
    let jacobian = [
        [0.0, a / (z2 * i.fy_px), f / z, -a * (f * f + z2) / z2],
        [
            -a / (z * i.fx_px),
            -a * xn * c / (z2 * i.fy_px),
            -xn / z,
            a * xn * f / z2,
        ],
    ];
    Ok(RayHit {
        forward_m: k * f,
        left_m: -k * xn,
        jacobian,
        elevation_rad: camera.mount.tilt_rad + (-yn).atan(),
    })
}

/// Locates a person from an upper-body box (design 3.2, eq. 1-3), with the covariance of
/// the module documentation, in the robot frame.
pub fn locate(
    camera: &CameraModel,
    bbox: &PixelBox,
    params: &MonocularParams,
) -> Result<MonocularFix, MonocularError> {
    params.validate()?;
    camera.validate().map_err(|e| MonocularError::BadParam {
        field: e.field,
        value: e.value,
        why: e.why,
    })?;
    if !(bbox.x.is_finite()
        && bbox.y.is_finite()
        && bbox.w > 0.0
        && bbox.h > 0.0
        && bbox.w.is_finite()
        && bbox.h.is_finite())
    {
        return Err(MonocularError::BadBox(*bbox));
    }
    let (u, v) = bbox.reference_point(params.margin_frac);
    let hit = ray_hit(camera, u, v, params.head_height_m)?;
    let sig2 = [
        params.sigma_u_px.powi(2),
        params.sigma_v_px.powi(2),
        params.head_height_sigma_m.powi(2),
        params.tilt_sigma_rad.powi(2),
    ];
    let j = &hit.jacobian;
    let entry = |r: usize, s: usize| (0..4).map(|k| j[r][k] * sig2[k] * j[s][k]).sum::<f64>();
    let cov_camera = Cov2::new(entry(0, 0), entry(0, 1), entry(1, 1))?;
    let point_in_camera = Point2::<tether_core::Camera>::new(hit.forward_m, hit.left_m);
    let in_camera = Gaussian2::new(point_in_camera, cov_camera)?;
    Ok(MonocularFix {
        in_robot: in_camera.transformed(camera.robot_from_camera()),
        forward_m: hit.forward_m,
        left_m: hit.left_m,
        bearing_rad: hit.left_m.atan2(hit.forward_m),
        elevation_rad: hit.elevation_rad,
    })
}

/// The second range cue: `d = fy H_box / h` for a box of pixel height `h` around a body
/// part `H_box` metres tall (the distance along the optical axis, for a box near the
/// image centre). Less precise than [`locate`] when the tilt is known, but independent of
/// it.
pub fn range_from_box_height(
    camera: &CameraModel,
    bbox: &PixelBox,
    body_height_m: f64,
) -> Option<f64> {
    (bbox.h > 0.0 && body_height_m > 0.0).then(|| camera.intrinsics.fy_px * body_height_m / bbox.h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tether_core::Point3;

    /// The box with its left side at `x`, its top at `y`, `w` wide and `h` high.
    fn pixel_box(x: f64, y: f64, w: f64, h: f64) -> PixelBox {
        PixelBox { x, y, w, h }
    }

    fn box_with_top_centre(u: f64, v: f64, h: f64, margin: f64) -> PixelBox {
        PixelBox {
            x: u - 0.4 * h,
            y: v - margin * h,
            w: 0.8 * h,
            h,
        }
    }

    proptest! {
        /// A head top projected into the image and brought back lands where it was,
        /// for tilted, yawed and offset cameras.
        #[test]
        fn projection_round_trips(x in 1.0..8.0f64, y in -3.0..3.0f64, hm in 1.4..2.0f64,
                                  tilt in -0.3..0.6f64, yaw in -0.6..0.6f64, cx in -0.2..0.3f64,
                                  cy in -0.2..0.2f64, hc in 0.3..1.2f64, margin in 0.0..0.3f64) {
            let mut cam = CameraModel::default();
            cam.mount.tilt_rad = tilt;
            cam.mount.yaw_rad = yaw;
            cam.mount.x_m = cx;
            cam.mount.y_m = cy;
            cam.mount.height_m = hc;
            prop_assume!((hm - hc).abs() > 0.2);
            let head = Point3::<Robot>::new(x, y, hm);
            // Only people in front of the lens.
            prop_assume!(cam.robot_from_camera().inverse().transform_point3(head).x > 0.3);
            let Some((u, v)) = cam.project(head) else { return Ok(()); };
            let params = MonocularParams { head_height_m: hm, margin_frac: margin, ..MonocularParams::default() };
            let fix = locate(&cam, &box_with_top_centre(u, v, 80.0, margin), &params);
            let fix = fix.unwrap();
            prop_assert!((fix.in_robot.mean.x - x).abs() < 1e-6 * (1.0 + x.abs()), "{:?} vs {}", fix.in_robot.mean, x);
            prop_assert!((fix.in_robot.mean.y - y).abs() < 1e-6 * (1.0 + y.abs()));
        }

        /// The covariance ellipse is long along the viewing ray and thin across it.
        #[test]
        fn covariance_is_long_along_the_ray(x in 2.0..6.0f64, y in -1.5..1.5f64, yaw in -0.5..0.5f64) {
            let mut cam = CameraModel::default();
            cam.mount.yaw_rad = yaw;
            let params = MonocularParams::default();
            let head = Point3::<Robot>::new(x, y, params.head_height_m);
            let Some((u, v)) = cam.project(head) else { return Ok(()); };
            prop_assume!(cam.in_image(u, v));
            let fix = locate(&cam, &box_with_top_centre(u, v, 60.0, 0.0), &params).unwrap();
            let (major, minor, angle) = fix.in_robot.cov.principal_axes();
            // The ray from the lens to the person, in the robot frame.
            let ray = (y - cam.mount.y_m).atan2(x - cam.mount.x_m);
            let off = tether_core::wrap_angle_rad(angle - ray);
            let off = off.abs().min(std::f64::consts::PI - off.abs());
            prop_assert!(off < 0.1, "major axis {angle} vs ray {ray}");
            prop_assert!(major > 16.0 * minor, "major {major}, minor {minor}");
        }
    }

    /// The numerical derivative of the position, a slow obvious reference for the
    /// analytic Jacobian.
    #[test]
    fn jacobian_matches_finite_differences() {
        let mut cam = CameraModel::default();
        cam.mount.tilt_rad = 0.3;
        let (u, v, hm) = (402.0, 171.0, 1.72);
        let base = ray_hit(&cam, u, v, hm).unwrap();
        let h = 1e-6;
        let diff = |du: f64, dv: f64, dh: f64, dt: f64| {
            let mut c = cam;
            c.mount.tilt_rad += dt;
            let p = ray_hit(&c, u + du, v + dv, hm + dh).unwrap();
            let mut m = cam;
            m.mount.tilt_rad -= dt;
            let q = ray_hit(&m, u - du, v - dv, hm - dh).unwrap();
            [
                (p.forward_m - q.forward_m) / (2.0 * h),
                (p.left_m - q.left_m) / (2.0 * h),
            ]
        };
        let cols = [
            diff(h, 0.0, 0.0, 0.0),
            diff(0.0, h, 0.0, 0.0),
            diff(0.0, 0.0, h, 0.0),
            diff(0.0, 0.0, 0.0, h),
        ];
        for (k, col) in cols.iter().enumerate() {
            for (r, numeric) in col.iter().enumerate() {
                let a = base.jacobian[r][k];
                assert!(
                    (a - numeric).abs() < 1e-5 * (1.0 + a.abs()),
                    "d{r}/d{k}: {a} vs {numeric}"
                );
            }
        }
    }

    /// design 3.2's sensitivities at 3 m: one pixel of row ~2 cm, one degree of tilt
    /// ~15 cm, 7 cm of head height ~18 cm.
    #[test]
    fn sensitivities_at_three_metres() {
        let cam = CameraModel::default();
        let hm = 1.75;
        let (u, v) = cam
            .project(Point3::<Robot>::new(3.0 + cam.mount.x_m, 0.0, hm))
            .unwrap();
        let hit = ray_hit(&cam, u, v, hm).unwrap();
        assert!((hit.forward_m - 3.0).abs() < 1e-9);
        let per_px = hit.jacobian[0][1].abs();
        let per_deg = hit.jacobian[0][3].abs() * 1f64.to_radians();
        let per_7cm = hit.jacobian[0][2].abs() * 0.07;
        assert!((0.015..0.025).contains(&per_px), "{per_px}");
        assert!((0.13..0.19).contains(&per_deg), "{per_deg}");
        assert!((0.16..0.21).contains(&per_7cm), "{per_7cm}");
    }

    /// Standard normal draws from a fixed xorshift generator (Box-Muller), so the test is
    /// deterministic.
    fn normals(seed: u64) -> impl Iterator<Item = f64> {
        let mut state = seed | 1;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        std::iter::from_fn(move || {
            let (a, b) = (uniform(), uniform());
            Some((-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos())
        })
    }

    /// design 3.2: range error grows with distance (roughly with its square, since a row
    /// spans more floor far away), and the propagated covariance predicts the spread of
    /// ranges computed from noisy boxes.
    #[test]
    fn range_error_grows_with_distance_as_predicted() {
        let cam = CameraModel::default();
        let p = MonocularParams {
            head_height_sigma_m: 0.0,
            tilt_sigma_rad: 0.0,
            ..MonocularParams::default()
        };
        let mut predicted = Vec::new();
        for (k, d) in [1.5, 2.0, 3.0, 4.0, 5.0].into_iter().enumerate() {
            let head = Point3::<Robot>::new(cam.mount.x_m + d, 0.0, p.head_height_m);
            let (u, v) = cam.project(head).unwrap();
            let fix = locate(&cam, &box_with_top_centre(u, v, 60.0, 0.0), &p).unwrap();
            let sigma = fix.in_robot.cov.xx().sqrt();
            predicted.push(sigma);
            // Monte Carlo: the same box with Gaussian row and column noise.
            let noise: Vec<f64> = normals(1000 + k as u64).take(8000).collect();
            let draws: Vec<f64> = noise
                .chunks_exact(2)
                .map(|n| {
                    let b = box_with_top_centre(
                        u + p.sigma_u_px * n[0],
                        v + p.sigma_v_px * n[1],
                        60.0,
                        0.0,
                    );
                    locate(&cam, &b, &p).unwrap().forward_m
                })
                .collect();
            let mean = draws.iter().sum::<f64>() / draws.len() as f64;
            let sd = (draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
                / (draws.len() - 1) as f64)
                .sqrt();
            assert!(
                (sd / sigma - 1.0).abs() < 0.1,
                "at {d} m: simulated {sd}, predicted {sigma}"
            );
        }
        assert!(predicted.windows(2).all(|w| w[1] > w[0]), "{predicted:?}");
        let ratio = predicted[3] / predicted[1]; // 4 m against 2 m
        assert!((3.0..5.0).contains(&ratio), "{ratio}");
    }

    #[test]
    fn bearing_is_positive_on_the_left() {
        let cam = CameraModel::default();
        let p = MonocularParams::default();
        let (u, v) = cam
            .project(Point3::<Robot>::new(3.0, 1.0, p.head_height_m))
            .unwrap();
        let fix = locate(&cam, &box_with_top_centre(u, v, 60.0, 0.0), &p).unwrap();
        assert!(fix.bearing_rad > 0.0 && fix.left_m > 0.0);
        // The paper's eq. 2 and 3: beta = -atan(x_n), lateral ~ forward tan(beta).
        let xn = (u - cam.intrinsics.cx_px) / cam.intrinsics.fx_px;
        let approx = fix.forward_m * (-xn.atan()).tan();
        assert!((approx - fix.left_m).abs() < 0.15 * fix.left_m);
    }

    #[test]
    fn refuses_impossible_geometry() {
        let mut level = CameraModel::default();
        level.mount.tilt_rad = 0.0;
        let p = MonocularParams::default();
        // A level camera below the head: a box top below the image centre looks down,
        // away from the head plane.
        let low = pixel_box(300.0, 400.0, 40.0, 50.0);
        assert!(matches!(
            locate(&level, &low, &p),
            Err(MonocularError::NoIntersection { .. })
        ));
        let cam = CameraModel::default();
        let nan = pixel_box(f64::NAN, 10.0, 40.0, 50.0);
        assert!(matches!(
            locate(&cam, &nan, &p),
            Err(MonocularError::BadBox(_))
        ));
        let bad = MonocularParams {
            head_height_m: -1.0,
            ..p
        };
        assert!(locate(&cam, &pixel_box(300.0, 100.0, 40.0, 50.0), &bad).is_err());
        let zero = MonocularParams {
            sigma_u_px: 0.0,
            sigma_v_px: 0.0,
            head_height_sigma_m: 0.0,
            tilt_sigma_rad: 0.0,
            ..p
        };
        assert!(matches!(
            locate(&cam, &pixel_box(300.0, 100.0, 40.0, 50.0), &zero),
            Err(MonocularError::Covariance(_))
        ));
    }

    #[test]
    fn box_height_cue() {
        let cam = CameraModel::default();
        let b = pixel_box(0.0, 0.0, 50.0, 105.0);
        let d = range_from_box_height(&cam, &b, 0.6).unwrap();
        assert!(
            (d - cam.intrinsics.fy_px * 0.6 / 105.0).abs() < 1e-12,
            "{d}"
        );
        assert!(range_from_box_height(&cam, &PixelBox { h: 0.0, ..b }, 0.6).is_none());
    }
}
