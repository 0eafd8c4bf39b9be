//! `vision_msgs/msg/Detection2DArray` (vision_msgs 4.x, the layout of Humble, Jazzy and
//! later): the boxes an image detector found in one frame, as detector nodes publish
//! them and as `tether sim --ros2` publishes its simulated camera.

use tether_core::PixelBox;

use super::*;

/// One `vision_msgs/msg/ObjectHypothesisWithPose`: a class with its score, and a pose
/// (for 2D detections usually left at zero).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectHypothesisMsg {
    /// The class, e.g. `person`.
    pub class_id: String,
    /// The detector's confidence.
    pub score: f64,
    /// The object's pose, if the detector estimates one.
    pub pose: Pose3,
    /// The pose's 6x6 covariance, row major.
    pub covariance: [f64; 36],
}

impl ObjectHypothesisMsg {
    /// A class and score with no pose.
    pub fn class(class_id: impl Into<String>, score: f64) -> Self {
        ObjectHypothesisMsg {
            class_id: class_id.into(),
            score,
            pose: Pose3::planar(0.0, 0.0, 0.0),
            covariance: [0.0; 36],
        }
    }
}

/// One `vision_msgs/msg/Detection2D`: a box in the image, px, with what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection2DMsg {
    /// ROS header (detectors usually copy the image's).
    pub header: Header,
    /// What the box holds, best first.
    pub results: Vec<ObjectHypothesisMsg>,
    /// Centre of the box `[x, y]`, px (`bbox.center.position`).
    pub center_px: [f64; 2],
    /// Rotation of the box, rad (`bbox.center.theta`; 0 for an upright box).
    pub theta_rad: f64,
    /// Width and height of the box `[size_x, size_y]`, px.
    pub size_px: [f64; 2],
    /// An id that stays with the object across frames (a tracker's), or empty.
    pub id: String,
}

impl Detection2DMsg {
    /// An upright box with one hypothesis.
    pub fn from_box(
        header: Header,
        b: &PixelBox,
        hypothesis: ObjectHypothesisMsg,
        id: impl Into<String>,
    ) -> Self {
        Detection2DMsg {
            header,
            results: vec![hypothesis],
            center_px: [b.x + 0.5 * b.w, b.y + 0.5 * b.h],
            theta_rad: 0.0,
            size_px: [b.w, b.h],
            id: id.into(),
        }
    }

    /// The upright box that holds this one, or `None` when a field is not finite or a
    /// size is not positive.
    pub fn pixel_box(&self) -> Option<PixelBox> {
        let [cx, cy] = self.center_px;
        let [w, h] = self.size_px;
        if !([cx, cy, w, h, self.theta_rad].iter().all(|v| v.is_finite()) && w > 0.0 && h > 0.0) {
            return None;
        }
        // The half extents of the rotated rectangle along the image axes.
        let (s, c) = self.theta_rad.sin_cos();
        let half_w = 0.5 * (w * c.abs() + h * s.abs());
        let half_h = 0.5 * (w * s.abs() + h * c.abs());
        Some(PixelBox {
            x: cx - half_w,
            y: cy - half_h,
            w: 2.0 * half_w,
            h: 2.0 * half_h,
        })
    }

    fn write(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.count("results", self.results.len())?;
        for r in &self.results {
            w.string("results.hypothesis.class_id", &r.class_id)?;
            w.f64_array(&[r.score]);
            write_pose(w, &r.pose);
            w.f64_array(&r.covariance);
        }
        w.f64_array(&self.center_px);
        w.f64_array(&[self.theta_rad]);
        w.f64_array(&self.size_px);
        w.string("id", &self.id)
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(r)?;
        // The smallest hypothesis: an empty class id (5 bytes and padding), the score,
        // the pose (7 float64) and the covariance (36).
        let n = r.count("results", 8 + 8 + 56 + 288)?;
        let mut results = Vec::with_capacity(n);
        for _ in 0..n {
            let class_id = r.string("results.hypothesis.class_id")?;
            let [score] = r.f64_array("results.hypothesis.score")?;
            results.push(ObjectHypothesisMsg {
                class_id,
                score,
                pose: read_pose(r, "results.pose.pose")?,
                covariance: r.f64_array("results.pose.covariance")?,
            });
        }
        let center_px = r.f64_array("bbox.center.position")?;
        let [theta_rad] = r.f64_array("bbox.center.theta")?;
        let size_px = r.f64_array("bbox.size")?;
        Ok(Detection2DMsg {
            header,
            results,
            center_px,
            theta_rad,
            size_px,
            id: r.string("id")?,
        })
    }
}

/// `vision_msgs/msg/Detection2DArray`: every box of one image.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection2DArrayMsg {
    /// ROS header: the image's stamp and frame.
    pub header: Header,
    /// The boxes.
    pub detections: Vec<Detection2DMsg>,
}

impl Ros2Message for Detection2DArrayMsg {
    const TYPE: &'static str = "vision_msgs/msg/Detection2DArray";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "Detection2D[] detections\n",
        header_def!(),
        sep!("vision_msgs/Detection2D"),
        "std_msgs/Header header\n",
        "ObjectHypothesisWithPose[] results\n",
        "BoundingBox2D bbox\n",
        "string id\n",
        sep!("vision_msgs/ObjectHypothesisWithPose"),
        "ObjectHypothesis hypothesis\n",
        "geometry_msgs/PoseWithCovariance pose\n",
        sep!("vision_msgs/ObjectHypothesis"),
        "string class_id\n",
        "float64 score\n",
        pose_with_covariance_def!(),
        sep!("vision_msgs/BoundingBox2D"),
        "vision_msgs/Pose2D center\n",
        "float64 size_x\n",
        "float64 size_y\n",
        sep!("vision_msgs/Pose2D"),
        "vision_msgs/Point2D position\n",
        "float64 theta\n",
        sep!("vision_msgs/Point2D"),
        "float64 x\n",
        "float64 y\n"
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.count("detections", self.detections.len())?;
        for d in &self.detections {
            d.write(w)?;
        }
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(r)?;
        // The smallest detection: a header with an empty frame, no results, the box
        // (5 float64 after padding) and an empty id.
        let n = r.count("detections", 13 + 4 + 40 + 5)?;
        let mut detections = Vec::with_capacity(n);
        for _ in 0..n {
            detections.push(Detection2DMsg::read(r)?);
        }
        Ok(Detection2DArrayMsg { header, detections })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> Detection2DArrayMsg {
        let header = Header::new(Stamp::from_ns(7_250_000_000), "camera");
        let b = PixelBox {
            x: 100.0,
            y: 40.5,
            w: 80.0,
            h: 96.0,
        };
        Detection2DArrayMsg {
            header: header.clone(),
            detections: vec![
                Detection2DMsg::from_box(
                    header.clone(),
                    &b,
                    ObjectHypothesisMsg::class("person", 0.9),
                    "3",
                ),
                Detection2DMsg {
                    results: Vec::new(),
                    id: String::new(),
                    ..Detection2DMsg::from_box(header, &b, ObjectHypothesisMsg::class("", 0.0), "")
                },
            ],
        }
    }

    #[test]
    fn detections_round_trip_and_refuse_truncation() {
        let msg = frame();
        let bytes = to_cdr(&msg).unwrap();
        assert_eq!(from_cdr::<Detection2DArrayMsg>(&bytes).unwrap(), msg);
        for cut in [3, 11, bytes.len() / 3, bytes.len() / 2, bytes.len() - 1] {
            assert!(
                from_cdr::<Detection2DArrayMsg>(&bytes[..cut]).is_err(),
                "{cut}"
            );
        }
    }

    #[test]
    fn the_minimum_lengths_are_lower_bounds() {
        let empty = Header::new(Stamp::from_ns(0), "");
        let bare = Detection2DMsg {
            header: empty.clone(),
            results: Vec::new(),
            center_px: [0.0; 2],
            theta_rad: 0.0,
            size_px: [0.0; 2],
            id: String::new(),
        };
        let one = to_cdr(&Detection2DArrayMsg {
            header: empty.clone(),
            detections: vec![bare.clone()],
        })
        .unwrap();
        let none = to_cdr(&Detection2DArrayMsg {
            header: empty,
            detections: Vec::new(),
        })
        .unwrap();
        assert!(one.len() - none.len() >= 13 + 4 + 40 + 5, "{}", one.len());
        let with = Detection2DMsg {
            results: vec![ObjectHypothesisMsg::class("", 0.0)],
            ..bare.clone()
        };
        let mut a = CdrWriter::new();
        bare.write(&mut a).unwrap();
        let mut b = CdrWriter::new();
        with.write(&mut b).unwrap();
        assert!(b.into_bytes().len() - a.into_bytes().len() >= 8 + 8 + 56 + 288);
    }

    #[test]
    fn boxes_come_back_upright_and_bad_ones_are_refused() {
        let d = &frame().detections[0];
        let b = d.pixel_box().unwrap();
        assert_eq!((b.x, b.y, b.w, b.h), (100.0, 40.5, 80.0, 96.0));
        // A quarter turn swaps the extents about the centre.
        let turned = Detection2DMsg {
            theta_rad: std::f64::consts::FRAC_PI_2,
            ..d.clone()
        }
        .pixel_box()
        .unwrap();
        assert!((turned.w - 96.0).abs() < 1e-9 && (turned.h - 80.0).abs() < 1e-9);
        assert!((turned.x + 0.5 * turned.w - 140.0).abs() < 1e-9);
        for bad in [
            Detection2DMsg {
                size_px: [0.0, 10.0],
                ..d.clone()
            },
            Detection2DMsg {
                center_px: [f64::NAN, 1.0],
                ..d.clone()
            },
            Detection2DMsg {
                theta_rad: f64::INFINITY,
                ..d.clone()
            },
        ] {
            assert!(bad.pixel_box().is_none(), "{bad:?}");
        }
    }
}
