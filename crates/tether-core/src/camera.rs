//! The camera's model: pinhole intrinsics and its mounting on the robot (height, upward
//! tilt, planar pose), design 2.2 and 3.2.
//!
//! Frames: the camera's ground frame ([`Camera`]) has x along the horizontal projection
//! of the optical axis, y left, z up, origin at the lens. The optical frame (z forward,
//! x right, y down) is that frame pitched up by `tilt_rad`. A point (f, l, u) of the
//! ground frame has optical coordinates
//!
//! ```text
//! x_c = -l
//! y_c =  f sin(tilt) - u cos(tilt)
//! z_c =  f cos(tilt) + u sin(tilt)
//! ```
//!
//! and projects to pixel `(cx + fx x_c / z_c, cy + fy y_c / z_c)`.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::frame::{Camera, Robot};
use crate::geometry::{Point3, Pose2};

/// Why a camera model cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("camera field `{field}` = {value} is invalid: {why}")]
pub struct CameraModelError {
    /// Field name as in the config file.
    pub field: &'static str,
    /// The offending value.
    pub value: f64,
    /// What it must satisfy.
    pub why: &'static str,
}

/// Pinhole intrinsics, pixels. The image frame has u right, v down, origin at the
/// top-left corner of the top-left pixel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct CameraIntrinsics {
    /// Focal length along u, px.
    #[config(range = "> 0")]
    pub fx_px: f64,
    /// Focal length along v, px.
    #[config(range = "> 0")]
    pub fy_px: f64,
    /// Principal point, u, px.
    pub cx_px: f64,
    /// Principal point, v, px.
    pub cy_px: f64,
    /// Image width, px.
    #[config(range = ">= 1")]
    pub width_px: u32,
    /// Image height, px.
    #[config(range = ">= 1")]
    pub height_px: u32,
}

impl Default for CameraIntrinsics {
    /// A 640x480 camera with a 70-degree horizontal (55-degree vertical) field of view,
    /// a typical wide webcam.
    fn default() -> Self {
        CameraIntrinsics {
            fx_px: 460.0,
            fy_px: 460.0,
            cx_px: 319.5,
            cy_px: 239.5,
            width_px: 640,
            height_px: 480,
        }
    }
}

/// Where the camera sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct CameraMount {
    /// Forward offset of the lens from the wheel axis centre, m.
    pub x_m: f64,
    /// Leftward offset, m.
    pub y_m: f64,
    /// Yaw of the optical axis relative to the robot's x axis, rad.
    pub yaw_rad: f64,
    /// Height of the lens above the floor (`Hc`), m.
    pub height_m: f64,
    /// Upward pitch of the optical axis (`theta_c`), rad.
    #[config(range = "> -1.4, < 1.4")]
    pub tilt_rad: f64,
}

impl Default for CameraMount {
    /// A small robot's camera: 0.65 m up, pitched up 28 degrees so that the whole upper
    /// body of a 1.60-1.90 m person is in view from 0.9 m to 5 m.
    fn default() -> Self {
        CameraMount {
            x_m: 0.05,
            y_m: 0.0,
            yaw_rad: 0.0,
            height_m: 0.65,
            tilt_rad: 28f64.to_radians(),
        }
    }
}

/// A box in the image, pixels: top-left corner (x, y), width and height.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PixelBox {
    /// Left edge, px.
    pub x: f64,
    /// Top edge, px.
    pub y: f64,
    /// Width, px.
    pub w: f64,
    /// Height, px.
    pub h: f64,
}

impl PixelBox {
    /// The top-centre reference point of design 2.2, `(x + w/2, y + m h)`, where `m` is
    /// the fraction of the box above the head.
    pub fn reference_point(&self, margin_frac: f64) -> (f64, f64) {
        (self.x + 0.5 * self.w, self.y + margin_frac * self.h)
    }

    /// Area, px^2.
    pub fn area(&self) -> f64 {
        self.w.max(0.0) * self.h.max(0.0)
    }

    /// Intersection over union with another box.
    pub fn iou(&self, other: &PixelBox) -> f64 {
        let ix = ((self.x + self.w).min(other.x + other.w) - self.x.max(other.x)).max(0.0);
        let iy = ((self.y + self.h).min(other.y + other.h) - self.y.max(other.y)).max(0.0);
        let inter = ix * iy;
        let union = self.area() + other.area() - inter;
        if union > 0.0 { inter / union } else { 0.0 }
    }
}

/// The `frame_id` of the first camera's frames (a robot's only camera, or the one the
/// `[[extra_cameras]]` do not name).
pub const FIRST_CAMERA_FRAME: &str = <Camera as crate::Frame>::NAME;

/// A camera besides a robot's first (`[[extra_cameras]]`, design 5.7): the `frame_id`
/// its frames carry and its model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields)]
pub struct ExtraCamera {
    /// The `frame_id` its frames carry (e.g. `rear_camera`).
    pub frame_id: String,
    /// Its intrinsics and mount (`[extra_cameras.camera]`, the keys of `[camera]`).
    #[serde(default)]
    pub camera: CameraModel,
}

/// The camera: intrinsics plus mounting.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct CameraModel {
    /// Pinhole intrinsics.
    pub intrinsics: CameraIntrinsics,
    /// Mounting on the robot.
    pub mount: CameraMount,
}

impl CameraModel {
    /// Checks every field; call after reading a config.
    pub fn validate(&self) -> Result<(), CameraModelError> {
        let i = &self.intrinsics;
        let m = &self.mount;
        let positive = [("intrinsics.fx_px", i.fx_px), ("intrinsics.fy_px", i.fy_px)];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(CameraModelError {
                    field,
                    value,
                    why: "focal length must be a positive number of pixels",
                });
            }
        }
        if i.width_px == 0 || i.height_px == 0 {
            return Err(CameraModelError {
                field: "intrinsics.width_px/height_px",
                value: 0.0,
                why: "image size must be positive",
            });
        }
        for (field, value) in [
            ("intrinsics.cx_px", i.cx_px),
            ("intrinsics.cy_px", i.cy_px),
            ("mount.x_m", m.x_m),
            ("mount.y_m", m.y_m),
            ("mount.yaw_rad", m.yaw_rad),
            ("mount.height_m", m.height_m),
        ] {
            if !value.is_finite() {
                return Err(CameraModelError {
                    field,
                    value,
                    why: "must be finite",
                });
            }
        }
        if !(m.tilt_rad.is_finite() && m.tilt_rad.abs() < 1.4) {
            return Err(CameraModelError {
                field: "mount.tilt_rad",
                value: m.tilt_rad,
                why: "must be finite and within +-80 degrees of horizontal",
            });
        }
        Ok(())
    }

    /// The camera's ground frame in the robot frame.
    pub fn robot_from_camera(&self) -> Pose2<Robot, Camera> {
        Pose2::new(self.mount.x_m, self.mount.y_m, self.mount.yaw_rad)
    }

    /// Horizontal field of view, rad.
    pub fn horizontal_fov_rad(&self) -> f64 {
        let i = &self.intrinsics;
        (i.cx_px / i.fx_px).atan() + ((f64::from(i.width_px) - i.cx_px) / i.fx_px).atan()
    }

    /// Optical-frame coordinates (x right, y down, z forward) of a point of the
    /// camera's ground frame whose height is given above the floor.
    pub fn optical_from_ground(&self, p: Point3<Camera>) -> [f64; 3] {
        let (s, c) = self.mount.tilt_rad.sin_cos();
        let up = p.z - self.mount.height_m;
        [-p.y, p.x * s - up * c, p.x * c + up * s]
    }

    /// Projects a point of the robot frame (z = height above the floor) to pixel
    /// coordinates (u, v). Returns `None` for points behind or beside the lens plane
    /// (optical depth under 1 cm); the pixel may lie outside the image.
    pub fn project(&self, point_in_robot: Point3<Robot>) -> Option<(f64, f64)> {
        let point_in_camera = self
            .robot_from_camera()
            .inverse()
            .transform_point3(point_in_robot);
        let [x, y, z] = self.optical_from_ground(point_in_camera);
        if z < 0.01 {
            return None;
        }
        let i = &self.intrinsics;
        Some((i.cx_px + i.fx_px * x / z, i.cy_px + i.fy_px * y / z))
    }

    /// The direction of the ray through pixel (u, v) in the camera's ground frame,
    /// `(forward, left, up)` (design 3.2): with `x_n = (u - cx)/fx`, `y_n = (v - cy)/fy`,
    /// `(cos t + y_n sin t, -x_n, sin t - y_n cos t)`. Not normalised.
    pub fn pixel_ray(&self, u: f64, v: f64) -> (f64, f64, f64) {
        let i = &self.intrinsics;
        let xn = (u - i.cx_px) / i.fx_px;
        let yn = (v - i.cy_px) / i.fy_px;
        let (s, c) = self.mount.tilt_rad.sin_cos();
        (c + yn * s, -xn, s - yn * c)
    }

    /// True when pixel (u, v) lies inside the image.
    pub fn in_image(&self, u: f64, v: f64) -> bool {
        let i = &self.intrinsics;
        u >= 0.0 && v >= 0.0 && u < f64::from(i.width_px) && v < f64::from(i.height_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn principal_ray_projects_to_principal_point() {
        let cam = CameraModel::default();
        let t = cam.mount.tilt_rad;
        // A point 2 m along the optical axis of a camera at the robot origin.
        let mut cam0 = cam;
        cam0.mount.x_m = 0.0;
        let p = Point3::<Robot>::new(2.0 * t.cos(), 0.0, cam.mount.height_m + 2.0 * t.sin());
        let (u, v) = cam0.project(p).unwrap();
        assert!((u - cam.intrinsics.cx_px).abs() < 1e-9 && (v - cam.intrinsics.cy_px).abs() < 1e-9);
    }

    #[test]
    fn person_on_the_left_projects_left_of_centre() {
        let cam = CameraModel::default();
        let (u, _) = cam.project(Point3::new(3.0, 0.5, 1.7)).unwrap();
        assert!(u < cam.intrinsics.cx_px);
        assert!(cam.project(Point3::new(-3.0, 0.0, 1.7)).is_none());
    }

    #[test]
    fn default_fov_is_about_70_degrees() {
        let fov = CameraModel::default().horizontal_fov_rad().to_degrees();
        assert!((fov - 69.6).abs() < 0.5, "{fov}");
    }

    proptest! {
        /// Projecting a point and casting the pixel's ray back reaches the point.
        #[test]
        fn pixel_ray_inverts_projection(x in 0.5..8.0f64, y in -3.0..3.0f64, z in 0.0..2.2f64,
                                        tilt in -0.6..0.6f64, yaw in -0.5..0.5f64) {
            let mut cam = CameraModel::default();
            cam.mount.tilt_rad = tilt;
            cam.mount.yaw_rad = yaw;
            let p = Point3::<Robot>::new(x, y, z);
            if let Some((u, v)) = cam.project(p) {
                let (f, l, up) = cam.pixel_ray(u, v);
                let pc = cam.robot_from_camera().inverse().transform_point3(p);
                // The ray scaled to reach the point's forward distance must hit it.
                let k = pc.x / f;
                prop_assume!(f > 1e-3 && k > 0.0);
                prop_assert!((k * l - pc.y).abs() < 1e-6 * (1.0 + pc.y.abs()));
                prop_assert!((k * up - (z - cam.mount.height_m)).abs() < 1e-6 * (1.0 + z));
            }
        }
    }

    #[test]
    fn iou_of_boxes() {
        let a = PixelBox {
            x: 0.0,
            y: 0.0,
            w: 10.0,
            h: 10.0,
        };
        let b = PixelBox {
            x: 5.0,
            y: 0.0,
            w: 10.0,
            h: 10.0,
        };
        assert!((a.iou(&b) - 50.0 / 150.0).abs() < 1e-12);
        assert_eq!(
            a.iou(&PixelBox {
                x: 20.0,
                y: 20.0,
                w: 1.0,
                h: 1.0
            }),
            0.0
        );
    }

    #[test]
    fn refuses_bad_models() {
        let mut cam = CameraModel::default();
        cam.intrinsics.fx_px = 0.0;
        assert!(cam.validate().is_err());
        let mut cam = CameraModel::default();
        cam.mount.tilt_rad = f64::NAN;
        assert!(cam.validate().is_err());
        assert!(CameraModel::default().validate().is_ok());
    }
}
