//! The cameras' side of a tick (design 3.2, 5.7): a frame's upper-body boxes become
//! people through the monocular model of the camera that took it, each person's own head
//! height learned while the laser measures their range; and which places a camera sees,
//! for the target's view. A robot may carry several cameras (`[[extra_cameras]]`, each
//! with the `frame_id` of its frames); a camera that fails is left out of the view, and
//! when the last is gone the target is vouched for by the laser alone.

use tether_core::{
    CameraModel, ExtraCamera, FIRST_CAMERA_FRAME, Point2, Pose2, Robot, Stamp, World,
};

use crate::{Pipeline, PipelineError, Tick, config_err, vision};

/// Checks the extra cameras: each names its own frame (not the first camera's), and
/// each model is valid.
pub(crate) fn check_extra_cameras(extra_cameras: &[ExtraCamera]) -> Result<(), PipelineError> {
    for (k, extra) in extra_cameras.iter().enumerate() {
        let named = extra_cameras[..k]
            .iter()
            .any(|other| other.frame_id == extra.frame_id);
        if extra.frame_id.is_empty() || extra.frame_id == FIRST_CAMERA_FRAME || named {
            return Err(config_err(
                "extra_cameras",
                format!(
                    "`frame_id` {:?} must name one camera's frames, not `{FIRST_CAMERA_FRAME}` \
                     (the first camera's) nor another's",
                    extra.frame_id
                ),
            ));
        }
        extra
            .camera
            .validate()
            .map_err(|e| config_err("extra_cameras", e))?;
    }
    Ok(())
}

impl Pipeline {
    /// Every camera is gone for good: vision is out of fusion and the target is locked
    /// and taken up again on the laser alone ([`tether_fusion::TargetSelector::camera_gone`]).
    pub fn camera_gone(&mut self) {
        self.config.fusion.use_vision = false;
        self.selector.camera_gone();
    }

    /// The camera whose frames carry `frame_id` (any frame no `[[extra_cameras]]` entry
    /// names is the first camera's) is gone for good: no place counts as in its view
    /// any more, so that a person only it would have seen is not taken for unseen by
    /// it. When it was the last camera, [`Pipeline::camera_gone`]. Returns whether a
    /// camera is left.
    pub fn camera_gone_from(&mut self, frame_id: &str) -> bool {
        let k = self.camera_index(frame_id);
        if let Some(gone) = self.cameras_gone.get_mut(k) {
            *gone = true;
        }
        let left = self.cameras_gone.iter().any(|gone| !gone);
        if !left {
            self.camera_gone();
        }
        left
    }

    /// 0 for the first camera, `k + 1` for the `k`-th of `[[extra_cameras]]`.
    fn camera_index(&self, frame_id: &str) -> usize {
        self.config
            .extra_cameras
            .iter()
            .position(|c| c.frame_id == frame_id)
            .map_or(0, |k| k + 1)
    }

    /// One frame's upper-body boxes of the first camera, with the robot's pose at the
    /// frame's stamp: [`Pipeline::on_camera_boxes_from`] its frame.
    pub fn on_camera_boxes(
        &mut self,
        stamp: Stamp,
        boxes: &[tether_core::PixelBox],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        self.on_camera_boxes_from(FIRST_CAMERA_FRAME, stamp, boxes, world_from_robot)
    }

    /// One camera frame's upper-body boxes, from the camera whose frames carry
    /// `frame_id` (`[[extra_cameras]]`; any other frame is the first camera's), with the
    /// robot's pose at the frame's stamp: the monocular model of that camera
    /// ([`vision::person_from_box`]), then [`Pipeline::on_camera`].
    pub fn on_camera_boxes_from(
        &mut self,
        frame_id: &str,
        stamp: Stamp,
        boxes: &[tether_core::PixelBox],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        let camera = self.camera_of(frame_id);
        let people: Vec<vision::VisionPerson> = boxes
            .iter()
            .filter_map(|b| self.vision_person(&camera, stamp, b, world_from_robot))
            .collect();
        self.on_camera(stamp, &people, world_from_robot)
    }

    /// The model of the camera whose frames carry `frame_id`.
    pub fn camera_of(&self, frame_id: &str) -> CameraModel {
        self.config
            .extra_cameras
            .iter()
            .find(|c| c.frame_id == frame_id)
            .map_or(self.config.camera, |c| c.camera)
    }

    /// The model of every camera not gone, the first one first.
    fn cameras(&self) -> impl Iterator<Item = CameraModel> + '_ {
        std::iter::once(self.config.camera)
            .chain(self.config.extra_cameras.iter().map(|c| c.camera))
            .zip(&self.cameras_gone)
            .filter(|(_, gone)| !**gone)
            .map(|(camera, _)| camera)
    }

    /// The monocular model for one box, with the head height learned for the track the
    /// box's bearing points at (when exactly one does): each person's own height, learned
    /// while the laser measured their range, removes the range error an assumed height
    /// makes, which matters when the laser loses them.
    fn vision_person(
        &mut self,
        camera: &CameraModel,
        stamp: Stamp,
        b: &tether_core::PixelBox,
        world_from_robot: Pose2<World, Robot>,
    ) -> Option<vision::VisionPerson> {
        let camera = *camera;
        let base = vision::vision_person(&camera, &self.config.vision, b)?;
        let world_from_camera = world_from_robot * camera.robot_from_camera();
        let camera_from_world = world_from_camera.inverse();
        let box_bearing = base.bearing_rad - camera.mount.yaw_rad;
        // Tracks whose predicted bearing from the camera matches the box's.
        let gate = (4.0 * base.bearing_sigma_rad).max(0.04);
        let candidates: Vec<(u64, f64, bool)> = self
            .tracker
            .tracks()
            .iter()
            .filter(|t| t.confirmed)
            .filter_map(|t| {
                let q = camera_from_world * t.position().mean;
                (q.x > 0.3 && (q.bearing_rad() - box_bearing).abs() < gate).then(|| {
                    let supported = t.last_laser.is_some_and(|l| stamp.secs_since(l) <= 0.15);
                    (t.id, q.range_m(), supported)
                })
            })
            .collect();
        let [(track, distance_m, supported)] = candidates.as_slice() else {
            return Some(base);
        };
        if *supported
            && let Some(h) =
                vision::implied_head_height_m(&camera, &self.config.vision, b, *distance_m)
            && (1.2..=2.3).contains(&h)
        {
            self.heights.entry(*track).or_default().add(h);
        }
        match self.heights.get(track) {
            Some(learned) if learned.n >= 5 => {
                let own = vision::VisionConfig {
                    head_height_m: learned.mean_m,
                    head_height_sigma_m: learned
                        .sigma_of_mean_m(self.config.vision.head_height_sigma_m)
                        .max(0.01),
                    ..self.config.vision.clone()
                };
                vision::vision_person(&camera, &own, b)
                    .map(|p| vision::VisionPerson {
                        own_height: true,
                        ..p
                    })
                    .or(Some(base))
            }
            _ => Some(base),
        }
    }

    /// Whether a camera, in use, would see a person at a world point: in front of one
    /// of them (0.3 m at least), within the monocular model's range and its horizontal
    /// field of view (design 2.2, 3.2).
    pub(crate) fn camera_sees(
        &self,
        world_from_robot: Pose2<World, Robot>,
    ) -> impl Fn(Point2<World>) -> bool + use<> {
        let max_range = self.config.vision.max_range_m;
        let use_vision = self.config.fusion.use_vision;
        let views: Vec<(Pose2<tether_core::Camera, World>, f64)> = self
            .cameras()
            .map(|camera| {
                let world_from_camera = world_from_robot * camera.robot_from_camera();
                (
                    world_from_camera.inverse(),
                    0.5 * camera.horizontal_fov_rad(),
                )
            })
            .collect();
        move |p: Point2<World>| {
            use_vision
                && views.iter().any(|(camera_from_world, half_fov)| {
                    let q = *camera_from_world * p;
                    q.x > 0.3 && q.range_m() <= max_range && q.bearing_rad().abs() <= *half_fov
                })
        }
    }
}

#[cfg(test)]
mod tests {
    use tether_core::{ExtraCamera, Point2, Pose2};

    use crate::{Pipeline, PipelineConfig};

    #[test]
    fn a_camera_gone_sees_nothing_and_the_last_one_gone_ends_vision() {
        let mut config = PipelineConfig::default();
        let mut rear = config.camera;
        rear.mount.x_m = -0.1;
        rear.mount.yaw_rad = std::f64::consts::PI;
        config.extra_cameras.push(ExtraCamera {
            frame_id: "rear_camera".into(),
            camera: rear,
        });
        let mut pipeline = Pipeline::new(config, None).unwrap();
        let (ahead, behind) = (Point2::new(2.0, 0.0), Point2::new(-2.0, 0.0));
        let sees = |p: &Pipeline, at| p.camera_sees(Pose2::IDENTITY)(at);
        assert!(sees(&pipeline, ahead) && sees(&pipeline, behind));
        assert!(pipeline.camera_gone_from("rear_camera"));
        assert!(sees(&pipeline, ahead) && !sees(&pipeline, behind));
        assert!(pipeline.config().fusion.use_vision);
        // Any frame no extra camera names is the first camera's.
        assert!(!pipeline.camera_gone_from("front_camera"));
        assert!(!sees(&pipeline, ahead) && !sees(&pipeline, behind));
        assert!(!pipeline.config().fusion.use_vision);
    }
}
