//! A person's position from an upper-body box: the paper's eq. 1-3 as SPEC 3.2
//! restates them, with the covariance propagated through the Jacobian.
//!
//! The reference point is the top-centre of the box, `(u', v') = (x + w/2, y + m h)`,
//! where `m` is the share of the box above the head. With the optical-frame ray
//! `(x_n, y_n, 1) = ((u' - cx)/fx, (v' - cy)/fy, 1)` and the camera pitched up by
//! `t`, the ray in the camera's ground frame is
//!
//! ```text
//! (A, B, C) = (cos t + y_n sin t,  -x_n,  sin t - y_n cos t)     (forward, left, up)
//! ```
//!
//! and it meets the plane of the head top, `z = Hm`, at `k = (Hm - Hc) / C`:
//! forward `X = k A` (exactly the paper's eq. 1, `Dm = (Hm - Hc) / tan(t + atan(-y_n))`)
//! and left `Y = k B` (eq. 3 is its small-tilt approximation `Dm tan(beta)`). Then the
//! camera's pose on the robot (offset and yaw) maps it into the robot frame.
//!
//! Covariance: `J diag(s_u^2, s_v^2, s_H^2, s_t^2) J^T` for the pixel noise of the
//! reference point (which grows with the box, as a cascade's boxes jitter with the
//! pyramid's scale steps), the spread of people's heights and the tilt uncertainty:
//!
//! ```text
//! dX/du = 0                dY/du = -k / fx
//! dX/dv = k_v A + k s/fy   dY/dv = k_v B,     k_v = (Hm - Hc) cos t / (fy C^2)
//! dX/dH = A / C            dY/dH = B / C
//! dX/dt = k_t A + k (y_n cos t - sin t)       k_t = -(Hm - Hc)(cos t + y_n sin t) / C^2
//! dY/dt = k_t B
//! ```
//!
//! The result is long along the viewing ray (range is poor) and thin across it
//! (bearing is good). At 3 m one pixel of row error moves the range ~2 cm, one degree
//! of tilt ~15 cm and 7 cm of height ~18 cm (SPEC 3.2).

use serde::{Deserialize, Serialize};
use tether_core::{CameraModel, Cov2, Gaussian2, PixelBox, Point2, Robot};

/// Settings of the monocular person model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VisionConfig {
    /// Assumed height of a person's head top, m.
    pub head_height_m: f64,
    /// Spread of people's heights, m.
    pub head_height_sigma_m: f64,
    /// Share of the box above the head top (`m`; 0 when the box starts at the head).
    pub box_margin_frac: f64,
    /// Pixel noise of a box edge, px ...
    pub pixel_sigma_px: f64,
    /// ... plus this share of the box's size.
    pub size_sigma_frac: f64,
    /// Uncertainty of the camera's tilt, rad.
    pub tilt_sigma_rad: f64,
    /// Boxes shorter than this are ignored, px.
    pub min_box_height_px: f64,
    /// People estimated farther than this are ignored, m.
    pub max_range_m: f64,
}

impl Default for VisionConfig {
    fn default() -> Self {
        VisionConfig {
            head_height_m: 1.75,
            head_height_sigma_m: 0.07,
            box_margin_frac: 0.0,
            pixel_sigma_px: 2.0,
            size_sigma_frac: 0.03,
            tilt_sigma_rad: 0.5f64.to_radians(),
            min_box_height_px: 20.0,
            max_range_m: 8.0,
        }
    }
}

impl VisionConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), String> {
        for (field, value) in [
            ("head_height_m", self.head_height_m),
            ("head_height_sigma_m", self.head_height_sigma_m),
            ("pixel_sigma_px", self.pixel_sigma_px),
            ("tilt_sigma_rad", self.tilt_sigma_rad),
            ("max_range_m", self.max_range_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!(
                    "vision.{field} must be a positive number, got {value}"
                ));
            }
        }
        for (field, value) in [
            ("box_margin_frac", self.box_margin_frac),
            ("size_sigma_frac", self.size_sigma_frac),
            ("min_box_height_px", self.min_box_height_px),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!("vision.{field} must be >= 0, got {value}"));
            }
        }
        Ok(())
    }
}

/// A person seen by the camera, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisionPerson {
    /// Position (through the assumed head height) and covariance.
    pub estimate: Gaussian2<Robot>,
    /// Where the camera is on the robot.
    pub camera_in_robot: Point2<Robot>,
    /// Direction from the camera to the person in the robot frame, rad: what the camera
    /// measures best, independent of the person's height.
    pub bearing_rad: f64,
    /// Standard deviation of that bearing, rad.
    pub bearing_sigma_rad: f64,
}

/// The person under a box, in the robot frame, or `None` when the box cannot be a
/// person standing on the floor (the ray to the head top does not rise to the head's
/// height, a non-finite box, too small or too far).
pub fn person_from_box(
    camera: &CameraModel,
    config: &VisionConfig,
    b: &PixelBox,
) -> Option<Gaussian2<Robot>> {
    vision_person(camera, config, b).map(|p| p.estimate)
}

/// Like [`person_from_box`], with the bearing as a measurement of its own: the
/// horizontal direction of the ray, `atan2(B, A)` in the camera's ground frame, whose
/// standard deviation is about `s_u / fx`.
pub fn vision_person(
    camera: &CameraModel,
    config: &VisionConfig,
    b: &PixelBox,
) -> Option<VisionPerson> {
    if !(b.x.is_finite() && b.y.is_finite() && b.w.is_finite() && b.h.is_finite()) || b.w <= 0.0 {
        return None;
    }
    if b.h < config.min_box_height_px {
        return None;
    }
    let i = &camera.intrinsics;
    let (u, v) = b.reference_point(config.box_margin_frac);
    let xn = (u - i.cx_px) / i.fx_px;
    let yn = (v - i.cy_px) / i.fy_px;
    let (s, c) = camera.mount.tilt_rad.sin_cos();
    let (a, bl, up) = (c + yn * s, -xn, s - yn * c);
    let rise = config.head_height_m - camera.mount.height_m;
    if up.abs() < 1e-6 || rise / up <= 0.0 {
        return None;
    }
    let k = rise / up;
    let (x, y) = (k * a, k * bl);
    if !(x > 0.0) || x.hypot(y) > config.max_range_m {
        return None;
    }
    // Jacobian columns: u, v, H, tilt.
    let k_v = rise * c / (i.fy_px * up * up);
    let k_t = -rise * (c + yn * s) / (up * up);
    let j = [
        [
            0.0,
            k_v * a + k * s / i.fy_px,
            a / up,
            k_t * a + k * (yn * c - s),
        ],
        [-k / i.fx_px, k_v * bl, bl / up, k_t * bl],
    ];
    // The reference point: centre of two edges for u, the top edge for v.
    let sigma_u = (config.pixel_sigma_px + config.size_sigma_frac * b.w) / std::f64::consts::SQRT_2;
    let sigma_v = config.pixel_sigma_px + config.size_sigma_frac * b.h;
    let var = [
        sigma_u * sigma_u,
        sigma_v * sigma_v,
        config.head_height_sigma_m.powi(2),
        config.tilt_sigma_rad.powi(2),
    ];
    let entry = |r: usize, q: usize| (0..4).map(|n| j[r][n] * var[n] * j[q][n]).sum::<f64>();
    let cov = Cov2::repaired(entry(0, 0), entry(0, 1), entry(1, 1), 1e-6)?;
    let in_camera = Gaussian2::<tether_core::Camera>::new(Point2::new(x, y), cov).ok()?;
    let robot_from_camera = camera.robot_from_camera();
    let horizontal = a.hypot(bl);
    Some(VisionPerson {
        estimate: in_camera.transformed(robot_from_camera),
        camera_in_robot: robot_from_camera.translation(),
        bearing_rad: tether_core::wrap_angle_rad(robot_from_camera.yaw + bl.atan2(a)),
        bearing_sigma_rad: sigma_u / i.fx_px * (a / horizontal).powi(2).max(0.1),
    })
}

/// The head-top height implied by a box whose person is known (from the laser) to
/// stand `distance_m` away horizontally from the camera: the ray through the box's
/// reference point rises `C / hypot(A, B)` per metre, so `H = Hc + distance C /
/// hypot(A, B)`. `None` when the ray points down or the box is degenerate.
pub fn implied_head_height_m(camera: &CameraModel, config: &VisionConfig, b: &PixelBox, distance_m: f64) -> Option<f64> {
    if !(b.x.is_finite() && b.y.is_finite() && b.h.is_finite() && distance_m.is_finite() && distance_m > 0.0) {
        return None;
    }
    let (u, v) = b.reference_point(config.box_margin_frac);
    let (a, bl, up) = camera.pixel_ray(u, v);
    let horizontal = a.hypot(bl);
    (horizontal > 1e-6).then(|| camera.mount.height_m + distance_m * up / horizontal)
}

/// A person's head height learned from boxes seen while the laser measured their range:
/// a running mean and variance (Welford).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LearnedHeight {
    /// Samples.
    pub n: u32,
    /// Mean, m.
    pub mean_m: f64,
    m2: f64,
}

impl LearnedHeight {
    /// Adds a sample.
    pub fn add(&mut self, h_m: f64) {
        self.n += 1;
        let delta = h_m - self.mean_m;
        self.mean_m += delta / f64::from(self.n);
        self.m2 += delta * (h_m - self.mean_m);
    }

    /// Standard deviation of the mean, m (of the samples when fewer than two).
    pub fn sigma_of_mean_m(&self, prior_sigma_m: f64) -> f64 {
        if self.n < 2 {
            return prior_sigma_m;
        }
        let var = self.m2 / f64::from(self.n - 1);
        (var / f64::from(self.n)).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tether_core::Point3;

    /// The box whose top-centre is the projection of a head top at `p` (robot frame).
    fn box_of(camera: &CameraModel, p: Point3<Robot>) -> Option<PixelBox> {
        let (u, v) = camera.project(p)?;
        Some(PixelBox {
            x: u - 40.0,
            y: v,
            w: 80.0,
            h: 120.0,
        })
    }

    proptest! {
        /// Projecting a head top into the image and back recovers it, for a camera
        /// that is tilted, yawed and offset on the robot.
        #[test]
        fn projection_and_back_recover_the_head(x in 0.8..6.0f64, y in -2.0..2.0f64, tilt in 0.0..0.6f64,
                                                 yaw in -0.4..0.4f64, ox in -0.2..0.3f64, oy in -0.2..0.2f64) {
            let mut camera = CameraModel::default();
            camera.mount.tilt_rad = tilt;
            camera.mount.yaw_rad = yaw;
            camera.mount.x_m = ox;
            camera.mount.y_m = oy;
            let config = VisionConfig::default();
            let head = Point3::<Robot>::new(x, y, config.head_height_m);
            prop_assume!((x - ox).hypot(y - oy) > 0.5);
            if let Some(b) = box_of(&camera, head) {
                let g = person_from_box(&camera, &config, &b);
                prop_assert!(g.is_some());
                let g = g.unwrap();
                prop_assert!((g.mean.x - x).abs() < 1e-6 && (g.mean.y - y).abs() < 1e-6, "{:?} vs ({x}, {y})", g.mean);
            }
        }

        /// The covariance is long along the viewing ray and thin across it.
        #[test]
        fn covariance_is_long_along_the_ray(x in 1.5..5.0f64, y in -1.0..1.0f64) {
            let camera = CameraModel { mount: tether_core::CameraMount { x_m: 0.0, ..Default::default() }, ..Default::default() };
            let config = VisionConfig::default();
            if let Some(b) = box_of(&camera, Point3::new(x, y, config.head_height_m)) {
                let g = person_from_box(&camera, &config, &b).unwrap();
                let (major, minor, angle) = g.cov.principal_axes();
                prop_assert!(major > 9.0 * minor, "major {major} minor {minor}");
                let ray = y.atan2(x);
                let off = tether_core::wrap_angle_rad(2.0 * (angle - ray)) / 2.0;
                prop_assert!(off.abs() < 0.1, "ellipse at {angle}, ray at {ray}");
            }
        }
    }

    #[test]
    fn sensitivities_at_three_metres_match_the_spec() {
        let camera = CameraModel {
            mount: tether_core::CameraMount {
                x_m: 0.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let config = VisionConfig::default();
        let range = |b: &PixelBox, cfg: &VisionConfig, cam: &CameraModel| {
            person_from_box(cam, cfg, b).map(|g| g.mean.x)
        };
        let b = box_of(&camera, Point3::new(3.0, 0.0, config.head_height_m)).unwrap();
        let base = range(&b, &config, &camera).unwrap_or_default();
        // One pixel of row error.
        let lower = PixelBox { y: b.y + 1.0, ..b };
        let dpx = (range(&lower, &config, &camera).unwrap_or_default() - base).abs();
        assert!((0.01..0.04).contains(&dpx), "1 px -> {dpx} m");
        // One degree of tilt.
        let mut tilted = camera;
        tilted.mount.tilt_rad += 1f64.to_radians();
        let dtilt = (range(&b, &config, &tilted).unwrap_or_default() - base).abs();
        assert!((0.08..0.25).contains(&dtilt), "1 deg -> {dtilt} m");
        // 7 cm of height.
        let taller = VisionConfig {
            head_height_m: config.head_height_m + 0.07,
            ..config.clone()
        };
        let dh = (range(&b, &taller, &camera).unwrap_or_default() - base).abs();
        assert!((0.12..0.25).contains(&dh), "7 cm -> {dh} m");
    }

    #[test]
    fn implied_height_inverts_the_range_model() {
        let camera = CameraModel::default();
        let config = VisionConfig { head_height_m: 1.62, ..VisionConfig::default() };
        let head = Point3::<Robot>::new(3.0, 0.4, 1.62);
        let b = box_of(&camera, head).unwrap();
        let cam = camera.robot_from_camera().translation();
        let d = (3.0 - cam.x).hypot(0.4 - cam.y);
        let h = implied_head_height_m(&camera, &config, &b, d).unwrap();
        assert!((h - 1.62).abs() < 1e-9, "{h}");
        let mut learned = LearnedHeight::default();
        for x in [1.6, 1.7, 1.65, 1.62] {
            learned.add(x);
        }
        assert!((learned.mean_m - 1.6425).abs() < 1e-12 && learned.sigma_of_mean_m(0.07) < 0.03);
    }

    #[test]
    fn refuses_impossible_boxes() {
        let camera = CameraModel::default();
        let config = VisionConfig::default();
        // A box whose top is far below the horizon: the ray never rises to 1.75 m.
        assert!(
            person_from_box(
                &camera,
                &config,
                &PixelBox {
                    x: 300.0,
                    y: 470.0,
                    w: 40.0,
                    h: 60.0
                }
            )
            .is_none()
        );
        assert!(
            person_from_box(
                &camera,
                &config,
                &PixelBox {
                    x: f64::NAN,
                    y: 10.0,
                    w: 40.0,
                    h: 60.0
                }
            )
            .is_none()
        );
        assert!(
            person_from_box(
                &camera,
                &config,
                &PixelBox {
                    x: 300.0,
                    y: 100.0,
                    w: 4.0,
                    h: 6.0
                }
            )
            .is_none()
        );
    }
}
