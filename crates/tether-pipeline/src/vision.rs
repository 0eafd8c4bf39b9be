//! The camera's people for the pipeline: the monocular model of
//! [`tether_vision::monocular::locate`] (the paper's eq. 1-3 as design 3.2 restates them,
//! covariance through the Jacobian), fed with pixel noise that grows with the box (a
//! cascade's boxes jitter with the pyramid's scale steps), plus what the tracker needs:
//! the bearing as a measurement of its own, and each person's own head height learned
//! while the laser measured their range.

use serde::{Deserialize, Serialize};
use tether_core::{CameraModel, Gaussian2, PixelBox, Point2, Robot};
use tether_vision::monocular::{MonocularParams, locate};

/// Settings of the monocular person model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct VisionConfig {
    /// Assumed height of a person's head top, m.
    #[config(range = "> 0")]
    pub head_height_m: f64,
    /// Spread of people's heights, m.
    #[config(range = "> 0")]
    pub head_height_sigma_m: f64,
    /// Share of the box above the head top (`m`; 0 when the box starts at the head).
    #[config(range = ">= 0")]
    pub box_margin_frac: f64,
    /// Pixel noise of a box edge, px ...
    #[config(range = "> 0")]
    pub pixel_sigma_px: f64,
    /// ... plus this share of the box's size.
    #[config(range = ">= 0")]
    pub size_sigma_frac: f64,
    /// Uncertainty of the camera's tilt, rad.
    #[config(range = "> 0")]
    pub tilt_sigma_rad: f64,
    /// Boxes shorter than this are ignored, px.
    #[config(range = ">= 0")]
    pub min_box_height_px: f64,
    /// People estimated farther than this are ignored, m.
    #[config(range = "> 0")]
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
    /// True when the range came from this person's own learned head height rather than
    /// the population's: then the range is worth using even beside the laser's.
    pub own_height: bool,
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
/// horizontal direction of the ray, whose standard deviation is about `s_u / fx`.
pub fn vision_person(
    camera: &CameraModel,
    config: &VisionConfig,
    b: &PixelBox,
) -> Option<VisionPerson> {
    if !(b.h.is_finite() && b.w.is_finite()) || b.h < config.min_box_height_px {
        return None;
    }
    // The reference point: the centre of two edges for u, the top edge for v.
    let sigma_u_px =
        (config.pixel_sigma_px + config.size_sigma_frac * b.w) / std::f64::consts::SQRT_2;
    let params = MonocularParams {
        head_height_m: config.head_height_m,
        head_height_sigma_m: config.head_height_sigma_m,
        margin_frac: config.box_margin_frac,
        sigma_u_px,
        sigma_v_px: config.pixel_sigma_px + config.size_sigma_frac * b.h,
        tilt_sigma_rad: config.tilt_sigma_rad,
    };
    let fix = locate(camera, b, &params).ok()?;
    if !(fix.forward_m > 0.0) || fix.forward_m.hypot(fix.left_m) > config.max_range_m {
        return None;
    }
    let robot_from_camera = camera.robot_from_camera();
    // d(bearing)/du = -cos^2(bearing) / fx for the horizontal ray direction.
    let bearing_sigma_rad =
        sigma_u_px / camera.intrinsics.fx_px * fix.bearing_rad.cos().powi(2).max(0.1);
    Some(VisionPerson {
        estimate: fix.in_robot,
        camera_in_robot: robot_from_camera.translation(),
        bearing_rad: tether_core::wrap_angle_rad(robot_from_camera.yaw + fix.bearing_rad),
        bearing_sigma_rad,
        own_height: false,
    })
}

/// The head-top height implied by a box whose person is known (from the laser) to
/// stand `distance_m` away horizontally from the camera: the ray through the box's
/// reference point rises `C / hypot(A, B)` per metre, so `H = Hc + distance C /
/// hypot(A, B)`. `None` when the ray points down or the box is degenerate.
pub fn implied_head_height_m(
    camera: &CameraModel,
    config: &VisionConfig,
    b: &PixelBox,
    distance_m: f64,
) -> Option<f64> {
    if !(b.x.is_finite()
        && b.y.is_finite()
        && b.h.is_finite()
        && distance_m.is_finite()
        && distance_m > 0.0)
    {
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

    #[test]
    fn boxes_become_people_where_the_camera_model_puts_them() {
        let camera = CameraModel::default();
        let config = VisionConfig::default();
        let head = Point3::<Robot>::new(3.0, 0.5, config.head_height_m);
        let b = box_of(&camera, head).unwrap();
        let p = vision_person(&camera, &config, &b).unwrap();
        assert!((p.estimate.mean.x - 3.0).abs() < 1e-6 && (p.estimate.mean.y - 0.5).abs() < 1e-6);
        let cam = camera.robot_from_camera().translation();
        assert!((p.bearing_rad - (0.5 - cam.y).atan2(3.0 - cam.x)).abs() < 1e-9);
        // Pixel noise grows with the box: a bigger box of the same person is less sure.
        let big = PixelBox {
            w: 2.0 * b.w,
            h: 2.0 * b.h,
            x: b.x - 0.5 * b.w,
            ..b
        };
        let q = vision_person(&camera, &config, &big).unwrap();
        assert!(q.bearing_sigma_rad > p.bearing_sigma_rad);
    }

    #[test]
    fn implied_height_inverts_the_range_model() {
        let camera = CameraModel::default();
        let config = VisionConfig {
            head_height_m: 1.62,
            ..VisionConfig::default()
        };
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
        let refused = |x: f64, y: f64, w: f64, h: f64| {
            person_from_box(&camera, &config, &PixelBox { x, y, w, h }).is_none()
        };
        // A box whose top is far below the horizon: the ray never rises to 1.75 m.
        assert!(refused(300.0, 470.0, 40.0, 60.0));
        assert!(refused(f64::NAN, 10.0, 40.0, 60.0));
        assert!(refused(300.0, 100.0, 4.0, 6.0));
    }
}
