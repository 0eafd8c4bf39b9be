//! The simulated camera, modelled at the level of the upper-body detector's output
//! (design 7): for each person, the box from the head top to the middle of the torso and
//! as wide as the shoulders' silhouette, projected through the pinhole model, with pixel
//! noise; misses that grow with distance, partial occlusion and truncation at the image
//! border; false positives at a configurable rate.

use serde::{Deserialize, Serialize};
use tether_core::{CameraModel, PixelBox, Point2, Pose2, Robot, Stamp, Vector2, World};

use crate::geometry::{Segment, segment_circle_distance_m, segments_intersect};
use crate::person::Person;
use crate::rng::SimRng;
use crate::scenario::CameraSimSpec;
use crate::world::{ObstacleKind, StaticWorld};

/// What the upper-body detector returned for one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraFrame {
    /// Exposure time.
    pub stamp: Stamp,
    /// Detected boxes, sorted by their left edge, px.
    pub boxes: Vec<PixelBox>,
    /// The camera's frame: `camera` for the first, an `[[extra_cameras]]` entry's
    /// `frame_id` for the others.
    #[serde(default = "first_camera_frame")]
    pub frame_id: String,
}

fn first_camera_frame() -> String {
    tether_core::FIRST_CAMERA_FRAME.to_owned()
}

/// Ground truth about one person in one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersonView {
    /// Person id.
    pub id: u32,
    /// The noise-free box, if the person is in front of the camera (it may extend past
    /// the image border).
    pub true_box: Option<PixelBox>,
    /// Share of the box inside the image.
    pub in_image_frac: f64,
    /// Share of the upper body not hidden by nearer people, walls or pillars.
    pub visible_frac: f64,
    /// Horizontal distance from the lens, m.
    pub distance_m: f64,
    /// Probability that the detector fires on this person in this frame.
    pub detect_prob: f64,
    /// Index in [`CameraFrame::boxes`] of the box this person produced, if any.
    pub box_index: Option<usize>,
}

/// Ground truth of one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraTruth {
    /// Each person, in id order.
    pub people: Vec<PersonView>,
    /// Indices of the boxes that are false positives.
    pub false_positives: Vec<usize>,
}

/// The camera of the simulator.
#[derive(Debug, Clone)]
pub struct SimCamera {
    model: CameraModel,
    spec: CameraSimSpec,
    rng: SimRng,
}

/// Samples across the silhouette used to measure occlusion.
const OCCLUSION_SAMPLES: usize = 9;

impl SimCamera {
    /// A camera with the given model and detector behaviour, drawing from `rng`.
    pub fn new(model: CameraModel, spec: CameraSimSpec, rng: SimRng) -> Self {
        SimCamera { model, spec, rng }
    }

    /// The camera's model.
    pub fn model(&self) -> &CameraModel {
        &self.model
    }

    /// Frame period in nanoseconds.
    pub fn period_ns(&self) -> f64 {
        1e9 / self.spec.rate_hz
    }

    /// The noise-free view of a person: the box and how much of it is visible.
    fn view(
        &self,
        world_from_robot: Pose2<World, Robot>,
        person: &Person,
        world: &StaticWorld,
        people: &[Person],
    ) -> PersonView {
        let robot_from_world = world_from_robot.inverse();
        let cam = &self.model;
        let camera_in_world = world_from_robot * cam.robot_from_camera().translation();
        let body = &person.body;
        let centre = person.position();
        let to_person = centre - camera_in_world;
        let distance_m = to_person.norm();
        let mut view = PersonView {
            id: person.id,
            true_box: None,
            in_image_frac: 0.0,
            visible_frac: 0.0,
            distance_m,
            detect_prob: 0.0,
            box_index: None,
        };
        if distance_m < 0.05 {
            return view;
        }
        // Silhouette: shoulders seen face-on are their full width, side-on about 55 %.
        let view_dir = to_person * (1.0 / distance_m);
        let facing = Vector2::unit(person.heading_rad());
        let cos_rel = view_dir.dot(facing).abs();
        let half_width = 0.5 * body.shoulder_width_m() * (0.55 + 0.45 * cos_rel);
        let across = view_dir.perp();
        let project = |p: Point2<World>, z: f64| cam.project((robot_from_world * p).with_height(z));
        let z_chest = 0.82 * body.height_m;
        let (Some((u_top, v_top)), Some((_, v_bottom)), Some((u_a, _)), Some((u_b, _))) = (
            project(centre, body.height_m),
            project(centre, body.mid_torso_height_m()),
            project(centre + across * half_width, z_chest),
            project(centre + across * (-half_width), z_chest),
        ) else {
            return view;
        };
        let w = (u_a - u_b).abs();
        let h = v_bottom - v_top;
        if !(w > 0.0 && h > 0.0) {
            return view;
        }
        let b = PixelBox {
            x: u_top - 0.5 * w,
            y: v_top,
            w,
            h,
        };
        let image = PixelBox {
            x: 0.0,
            y: 0.0,
            w: f64::from(cam.intrinsics.width_px),
            h: f64::from(cam.intrinsics.height_px),
        };
        let inter_w = ((b.x + b.w).min(image.w) - b.x.max(0.0)).max(0.0);
        let inter_h = ((b.y + b.h).min(image.h) - b.y.max(0.0)).max(0.0);
        view.in_image_frac = inter_w * inter_h / b.area();
        view.true_box = Some(b);

        // Occlusion: sight lines from the lens to points across the shoulders.
        let mut clear = 0;
        for k in 0..OCCLUSION_SAMPLES {
            let t = (k as f64 + 0.5) / OCCLUSION_SAMPLES as f64 * 2.0 - 1.0;
            let target = centre + across * (t * half_width);
            let sight = Segment::new(camera_in_world, target);
            let blocked = world
                .walls
                .iter()
                .any(|wall| segments_intersect(&sight, wall))
                || world.obstacles.iter().any(|o| {
                    o.kind == ObstacleKind::Pillar
                        && segment_circle_distance_m(&sight, o.circle.center) < o.circle.radius_m
                })
                || people.iter().any(|other| {
                    other.id != person.id
                        && (other.position() - camera_in_world).norm() < distance_m
                        && segment_circle_distance_m(&sight, other.position())
                            < other.body.torso_radius_m()
                });
            if !blocked {
                clear += 1;
            }
        }
        view.visible_frac = f64::from(clear) / OCCLUSION_SAMPLES as f64;

        let s = &self.spec;
        let range_factor = if distance_m <= s.reliable_range_m {
            1.0
        } else {
            ((s.max_range_m - distance_m) / (s.max_range_m - s.reliable_range_m)).clamp(0.0, 1.0)
        };
        let occlusion_factor = ((view.visible_frac - 0.4) / 0.6).clamp(0.0, 1.0);
        let truncation_factor = ((view.in_image_frac - 0.6) / 0.4).clamp(0.0, 1.0);
        let size_factor = if h >= s.min_box_height_px { 1.0 } else { 0.0 };
        view.detect_prob =
            s.detect_prob * range_factor * occlusion_factor * truncation_factor * size_factor;
        view
    }

    /// One frame of detections with its ground truth.
    pub fn frame(
        &mut self,
        stamp: Stamp,
        world_from_robot: Pose2<World, Robot>,
        world: &StaticWorld,
        people: &[Person],
    ) -> (CameraFrame, CameraTruth) {
        let mut views: Vec<PersonView> = people
            .iter()
            .map(|p| self.view(world_from_robot, p, world, people))
            .collect();
        let width = f64::from(self.model.intrinsics.width_px);
        let height = f64::from(self.model.intrinsics.height_px);
        // (box, Some(person index) or None for a false positive)
        let mut found: Vec<(PixelBox, Option<usize>)> = Vec::new();
        for (k, view) in views.iter().enumerate() {
            let Some(b) = view.true_box else { continue };
            if !self.rng.chance(view.detect_prob) {
                continue;
            }
            let s = &self.spec;
            let sigma_x = s.pixel_sigma_px + s.size_sigma_frac * b.w;
            let sigma_y = s.pixel_sigma_px + s.size_sigma_frac * b.h;
            let left = b.x + self.rng.normal(0.0, sigma_x);
            let right = b.x + b.w + self.rng.normal(0.0, sigma_x);
            let top = b.y + self.rng.normal(0.0, sigma_y);
            let bottom = b.y + b.h + self.rng.normal(0.0, sigma_y);
            let (left, right) = (left.max(0.0), right.min(width));
            let (top, bottom) = (top.max(0.0), bottom.min(height));
            if right - left < 4.0 || bottom - top < 4.0 {
                continue;
            }
            found.push((
                PixelBox {
                    x: round2(left),
                    y: round2(top),
                    w: round2(right - left),
                    h: round2(bottom - top),
                },
                Some(k),
            ));
        }
        let false_count = self.rng.poisson(self.spec.false_positives_per_frame);
        for _ in 0..false_count {
            let h = self
                .rng
                .uniform(self.spec.min_box_height_px.max(24.0), 0.5 * height);
            let w = h * self.rng.uniform(0.7, 1.1);
            let x = self.rng.uniform(0.0, (width - w).max(0.0));
            let y = self.rng.uniform(0.0, (height - h).max(0.0));
            found.push((
                PixelBox {
                    x: round2(x),
                    y: round2(y),
                    w: round2(w),
                    h: round2(h),
                },
                None,
            ));
        }
        // Detector output has no identity: order by position, not by person.
        found.sort_by(|a, b| a.0.x.total_cmp(&b.0.x).then(a.0.y.total_cmp(&b.0.y)));
        let mut false_positives = Vec::new();
        for (index, (_, source)) in found.iter().enumerate() {
            match source {
                Some(k) => views[*k].box_index = Some(index),
                None => false_positives.push(index),
            }
        }
        (
            CameraFrame {
                stamp,
                boxes: found.into_iter().map(|(b, _)| b).collect(),
                frame_id: first_camera_frame(),
            },
            CameraTruth {
                people: views,
                false_positives,
            },
        )
    }
}

/// Rounds to 1/100 px: detector boxes carry no more precision, and files stay short.
fn round2(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::PersonSpec;

    fn person_at(id: u32, x: f64, y: f64) -> Person {
        let spec = PersonSpec {
            name: format!("p{id}"),
            target: id == 0,
            ..crate::person::tests::spec(vec![[x, y]], 0.0)
        };
        Person::from_spec(id, &spec, &mut SimRng::stream(0, "p"))
    }

    fn camera(fp: f64) -> SimCamera {
        let spec = CameraSimSpec {
            false_positives_per_frame: fp,
            ..CameraSimSpec::default()
        };
        SimCamera::new(CameraModel::default(), spec, SimRng::stream(0, "camera"))
    }

    #[test]
    fn box_of_a_person_ahead_is_centred_and_shrinks_with_distance() {
        let cam = camera(0.0);
        let world = StaticWorld::default();
        let near = [person_at(0, 1.5, 0.0)];
        let far = [person_at(0, 4.0, 0.0)];
        let v_near = cam.view(Pose2::IDENTITY, &near[0], &world, &near);
        let v_far = cam.view(Pose2::IDENTITY, &far[0], &world, &far);
        let (bn, bf) = (v_near.true_box.unwrap(), v_far.true_box.unwrap());
        assert!((bn.x + 0.5 * bn.w - 319.5).abs() < 1.0);
        assert!(bn.h > 2.0 * bf.h && bn.w > 2.0 * bf.w);
        assert!(
            v_near.detect_prob > 0.9
                && v_far.detect_prob > 0.5
                && v_far.detect_prob < v_near.detect_prob
        );
        // Eq. 1 of the paper holds for the true box top.
        let m = CameraModel::default();
        let alpha = m.mount.tilt_rad + ((m.intrinsics.cy_px - bf.y) / m.intrinsics.fy_px).atan();
        let d = (1.75 - m.mount.height_m) / alpha.tan();
        assert!((d - (4.0 - m.mount.x_m)).abs() < 1e-6, "{d}");
    }

    #[test]
    fn nearer_person_hides_the_one_behind() {
        let cam = camera(0.0);
        let world = StaticWorld::default();
        let people = [person_at(0, 4.0, 0.0), person_at(1, 2.0, 0.0)];
        let v = cam.view(Pose2::IDENTITY, &people[0], &world, &people);
        assert!(v.visible_frac < 0.3, "{}", v.visible_frac);
        assert!(v.detect_prob == 0.0);
        let front = cam.view(Pose2::IDENTITY, &people[1], &world, &people);
        assert_eq!(front.visible_frac, 1.0);
    }

    #[test]
    fn people_behind_or_beside_are_not_seen() {
        let mut cam = camera(0.0);
        let world = StaticWorld::default();
        let people = [person_at(0, -2.0, 0.0), person_at(1, 0.5, 3.0)];
        let (frame, truth) = cam.frame(Stamp::ZERO, Pose2::IDENTITY, &world, &people);
        assert!(frame.boxes.is_empty());
        assert!(truth.people.iter().all(|v| v.detect_prob == 0.0));
    }

    #[test]
    fn false_positives_come_at_the_configured_rate() {
        let mut cam = camera(0.5);
        let world = StaticWorld::default();
        let mut total = 0;
        for k in 0..2000 {
            let (frame, truth) = cam.frame(Stamp::from_ns(k), Pose2::IDENTITY, &world, &[]);
            assert_eq!(frame.boxes.len(), truth.false_positives.len());
            total += frame.boxes.len();
        }
        let rate = total as f64 / 2000.0;
        assert!((rate - 0.5).abs() < 0.06, "{rate}");
    }
}
