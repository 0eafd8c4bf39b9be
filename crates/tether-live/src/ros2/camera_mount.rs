//! The camera's mount from `/tf_static`, as the laser's: a ROS robot's description says
//! where its camera sits (`base_frame` -> the frame its images or detections name), and
//! that is what the monocular model needs (design 3.2: the lens' height `Hc` and the
//! upward pitch `theta_c`, with the lens' position and yaw on the robot).
//!
//! The frame's axes follow REP 103: an optical frame (`*_optical_frame`, `*_optical`)
//! looks along its z (x right, y down in the image); any other camera frame
//! (`camera_link`, the simulator's `camera`) looks along its x. The optical axis in
//! `base_frame` is then `a = R e`, with `e` that axis and `R` the frame's rotation, and
//!
//! `yaw = atan2(a_y, a_x)`, `tilt = atan2(a_z, hypot(a_x, a_y))`,
//!
//! the lens at the frame's origin, its height the origin's z (`base_frame` taken on the
//! floor, as for the laser's mount). A roll of the camera about its axis is not
//! modelled.

use std::sync::Mutex;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use tether_core::CameraMount;
use tether_msgs::Pose3;
use tether_ros2::tf::{StaticTransforms, rotate};

use super::inputs::CameraCounters;
use crate::sources::Input;

/// Whether `frame` is an optical frame (REP 103: z along the optical axis).
pub fn is_optical_frame(frame: &str) -> bool {
    frame.ends_with("optical_frame") || frame.ends_with("_optical")
}

/// The camera's mount for a camera frame at `pose` in `base_frame` (the module's
/// equations).
pub fn camera_mount_from_pose(pose: &Pose3, optical: bool) -> CameraMount {
    let along = if optical {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let [ax, ay, az] = rotate(pose.orientation, along);
    let [x_m, y_m, height_m] = pose.position_m;
    CameraMount {
        x_m,
        y_m,
        yaw_rad: ay.atan2(ax),
        height_m,
        tilt_rad: az.atan2(ax.hypot(ay)),
    }
}

/// The rotation from a camera's body frame (x along the optical axis) to its optical
/// frame (REP 103: z along the axis, x right, y down), `[x, y, z, w]`.
const BODY_FROM_OPTICAL: [f64; 4] = [-0.5, 0.5, -0.5, 0.5];

/// Where a camera frame sits in `base_frame` for `mount`: the inverse of
/// [`camera_mount_from_pose`] (yawed by the mount's yaw, then pitched up by its tilt;
/// turned into an optical frame when `optical`).
pub fn camera_pose(mount: &CameraMount, optical: bool) -> Pose3 {
    let (sz, cz) = (0.5 * mount.yaw_rad).sin_cos();
    // Pitching up is a negative rotation about y (x towards +z).
    let (sp, cp) = (-0.5 * mount.tilt_rad).sin_cos();
    let body = Pose3 {
        position_m: [mount.x_m, mount.y_m, mount.height_m],
        orientation: [-sz * sp, cz * sp, sz * cp, cz * cp],
    };
    if optical {
        let optical_in_body = Pose3 {
            position_m: [0.0; 3],
            orientation: BODY_FROM_OPTICAL,
        };
        tether_ros2::tf::compose(&body, &optical_in_body)
    } else {
        body
    }
}

/// Takes a camera's `mount` from `/tf_static` (`base_frame` -> the camera's frame, as
/// its first message names it, `camera` counting them) when both are heard before
/// `deadline` (the laser's mount is looked up first, within the same time from the
/// start); otherwise the config's (or the default) mount stays, with a warning naming
/// the frames. The inputs that arrive meanwhile are dropped, as while the laser's mount
/// is looked up. Returns the camera's frame when its messages named one but no
/// transform to it came. `name` is the camera's in the messages.
pub fn camera_mount_from_tf(
    rx: &mpsc::Receiver<Input>,
    (name, camera): (&str, &CameraCounters),
    transforms: &Mutex<StaticTransforms>,
    base_frame: &str,
    deadline: Instant,
    mount: &mut CameraMount,
) -> Option<String> {
    while Instant::now() < deadline {
        let _ = rx.recv_timeout(Duration::from_millis(50));
        let Some(frame) = camera.frame_id.get() else {
            continue;
        };
        let tree = transforms.lock().unwrap_or_else(|e| e.into_inner());
        let Some(pose) = tree.lookup(base_frame, frame) else {
            continue;
        };
        let old = *mount;
        let new = camera_mount_from_pose(&pose, is_optical_frame(frame));
        if (old.x_m - new.x_m).hypot(old.y_m - new.y_m) > 0.01
            || (old.height_m - new.height_m).abs() > 0.01
            || (old.yaw_rad - new.yaw_rad).abs() > 0.01
            || (old.tilt_rad - new.tilt_rad).abs() > 0.01
        {
            tracing::warn!(
                "the {name}'s mount in the config (or the default) ({:.3}, {:.3}) m, {:.3} m \
                 up, yaw {:.3}, tilt {:.3} rad is not the one on /tf_static; using \
                 /tf_static's",
                old.x_m,
                old.y_m,
                old.height_m,
                old.yaw_rad,
                old.tilt_rad
            );
        }
        tracing::info!(
            "{name} mount from /tf_static: {base_frame} -> {frame} ({}) at ({:.3}, {:.3}) m, \
             {:.3} m up, yaw {:.3} rad, tilt {:.3} rad",
            if is_optical_frame(frame) {
                "an optical frame, z forward"
            } else {
                "x forward"
            },
            new.x_m,
            new.y_m,
            new.height_m,
            new.yaw_rad,
            new.tilt_rad
        );
        *mount = new;
        return None;
    }
    let m = *mount;
    match camera.frame_id.get() {
        Some(frame) => {
            tracing::warn!(
                "no transform from {base_frame} to the {name}'s {frame} on /tf_static at the \
                 start; the {name} is taken at its configured mount ({:.3}, {:.3}) m, {:.3} m \
                 up, tilt {:.3} rad",
                m.x_m,
                m.y_m,
                m.height_m,
                m.tilt_rad
            );
            Some(frame.clone())
        }
        None => {
            tracing::warn!(
                "no {name} message at the start; the {name} is taken at its configured mount"
            );
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame at `position` turned by `yaw` about z, then pitched by `pitch` about its
    /// new y (positive pitch looks down: REP 103's right-handed y to the left).
    fn pose(position_m: [f64; 3], yaw: f64, pitch: f64) -> Pose3 {
        let (sz, cz) = (0.5 * yaw).sin_cos();
        let (sp, cp) = (0.5 * pitch).sin_cos();
        // q = q_yaw * q_pitch.
        Pose3 {
            position_m,
            orientation: [-sz * sp, cz * sp, sz * cp, cz * cp],
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn a_body_frame_looks_along_x() {
        // Yawed 0.3 rad left, pitched up 0.4 rad (a negative pitch about y).
        let m = camera_mount_from_pose(&pose([0.1, -0.02, 0.6], 0.3, -0.4), false);
        assert!(close(m.x_m, 0.1) && close(m.y_m, -0.02) && close(m.height_m, 0.6));
        assert!(close(m.yaw_rad, 0.3), "{m:?}");
        assert!(close(m.tilt_rad, 0.4), "{m:?}");
    }

    #[test]
    fn an_optical_frame_looks_along_z() {
        // REP 103's optical frame of a camera looking straight ahead: z forward, x right,
        // y down, i.e. base_from_optical = rotation (x, y, z) -> (-y, -z, x) of the
        // base's axes: the quaternion (-1/2, 1/2, -1/2, 1/2).
        let level = Pose3 {
            position_m: [0.05, 0.0, 0.65],
            orientation: [-0.5, 0.5, -0.5, 0.5],
        };
        assert!(is_optical_frame("oakd_rgb_camera_optical_frame"));
        assert!(!is_optical_frame("camera_link"));
        let m = camera_mount_from_pose(&level, true);
        assert!(close(m.yaw_rad, 0.0) && close(m.tilt_rad, 0.0), "{m:?}");
        // The same camera pitched up by 0.5 rad: the link pitched, the optical frame
        // below it.
        let link = pose([0.05, 0.0, 0.65], 0.0, -0.5);
        let optical = tether_ros2::tf::compose(&link, &level_rotation());
        let m = camera_mount_from_pose(&optical, true);
        assert!(close(m.yaw_rad, 0.0) && close(m.tilt_rad, 0.5), "{m:?}");
        assert!(close(m.height_m, 0.65), "{m:?}");
    }

    /// The optical frame's rotation below its body frame, without an offset.
    fn level_rotation() -> Pose3 {
        Pose3 {
            position_m: [0.0; 3],
            orientation: [-0.5, 0.5, -0.5, 0.5],
        }
    }

    #[test]
    fn a_published_mount_reads_back_as_itself() {
        let mount = CameraMount {
            x_m: 0.08,
            y_m: -0.03,
            yaw_rad: 0.15,
            height_m: 0.7,
            tilt_rad: 0.35,
        };
        for optical in [false, true] {
            // `tether sim --ros2` publishes its camera's frame this way (x forward).
            let back = camera_mount_from_pose(&camera_pose(&mount, optical), optical);
            for (a, b) in [
                (back.x_m, mount.x_m),
                (back.y_m, mount.y_m),
                (back.yaw_rad, mount.yaw_rad),
                (back.height_m, mount.height_m),
                (back.tilt_rad, mount.tilt_rad),
            ] {
                assert!(close(a, b), "optical {optical}: {back:?} != {mount:?}");
            }
        }
    }

    #[test]
    fn the_camera_frame_looks_along_the_mount_s_yaw_and_up_by_its_tilt() {
        let m = CameraMount {
            x_m: 0.1,
            y_m: -0.05,
            yaw_rad: 0.3,
            height_m: 0.65,
            tilt_rad: 0.4,
        };
        let [x, y, z, w] = camera_pose(&m, false).orientation;
        assert!((x * x + y * y + z * z + w * w - 1.0).abs() < 1e-12);
        // The optical axis (the frame's x) rotated into base_link: R e_x.
        let axis = [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ];
        let expected = [
            m.tilt_rad.cos() * m.yaw_rad.cos(),
            m.tilt_rad.cos() * m.yaw_rad.sin(),
            m.tilt_rad.sin(),
        ];
        for (a, e) in axis.iter().zip(expected) {
            assert!((a - e).abs() < 1e-12, "{axis:?} vs {expected:?}");
        }
    }
}
