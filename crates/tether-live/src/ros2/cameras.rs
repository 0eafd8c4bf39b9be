//! The node's cameras (design 5.7, 12): the first on `image_raw` (or
//! `image_raw/compressed`, or `detections`), each further one on a topic of
//! `extra_camera_topics`, read the same way. Each is a [`CameraFeed`]: where its people
//! come from (its frames through its own `[[camera]]` cascade, or another node's boxes),
//! its topic, the frame its boxes are tagged with for the pipeline (the first camera's,
//! or its `[[camera]]` table's `frame_id`, whose model reads them), and what its readers
//! count. Its mount is looked up on `/tf_static` under the frame its first message names
//! ([`super::camera_mount`]).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc;

use tether_core::{CameraIntrinsics, FIRST_CAMERA_FRAME};
use tether_pipeline::PipelineConfig;
use tether_ros2::RosNode;

use super::inputs::{
    CameraCounters, FrameError, LatestFrame, start_camera_reader, start_detections_reader,
};
use super::node::{NodeError, StoppableThread};
use crate::clock::LiveClock;
use crate::config::CameraSection;
use crate::sources::Input;
use crate::sources::camera::BoxDetector;

/// Where a camera's people come from.
#[derive(Debug, Clone)]
pub enum NodeCamera {
    /// Images (`sensor_msgs/msg/Image`, or `CompressedImage` when `compressed`) through
    /// the cascade of `section` (its intrinsics and mount are the pipeline's; its
    /// `folder` or `v4l2` is not used): on `image_raw` (or `image_raw/compressed`) for
    /// the first camera.
    Images {
        /// The camera's `[camera]` table: the cascade and its search settings.
        section: Box<CameraSection>,
        /// `sensor_msgs/msg/CompressedImage` rather than `Image`.
        compressed: bool,
    },
    /// Upper-body boxes (`vision_msgs/msg/Detection2DArray`) in pixels of the configured
    /// camera, from a detector node or the simulator: on `detections` for the first
    /// camera.
    Detections {
        /// The class of the boxes taken (a box with no hypothesis is taken too; empty:
        /// every box).
        class: String,
    },
}

impl NodeCamera {
    /// The first camera's topic name (before remapping).
    pub fn first_topic(&self) -> &'static str {
        match self {
            NodeCamera::Images {
                compressed: true, ..
            } => "image_raw/compressed",
            NodeCamera::Images { .. } => "image_raw",
            NodeCamera::Detections { .. } => "detections",
        }
    }
}

/// The node's cameras: `first` (its boxes to the pipeline's first camera, on its
/// topic), then each of `extra`, a topic name and a source for each of the pipeline's
/// `extra_cameras` in their order (its boxes to that camera, read with its intrinsics).
/// `topic` resolves a name.
pub fn feeds(
    first: Option<&NodeCamera>,
    extra: &[(String, NodeCamera)],
    pipeline: &PipelineConfig,
    topic: &dyn Fn(&str) -> String,
) -> Vec<CameraFeed> {
    let first = first.map(|c| {
        let topic = topic(c.first_topic());
        CameraFeed::new(
            c.clone(),
            topic,
            FIRST_CAMERA_FRAME,
            pipeline.camera.intrinsics,
        )
    });
    let extra = extra
        .iter()
        .zip(&pipeline.extra_cameras)
        .map(|((name, source), camera)| {
            let intrinsics = camera.camera.intrinsics;
            CameraFeed::new(source.clone(), topic(name), &camera.frame_id, intrinsics)
        });
    first.into_iter().chain(extra).collect()
}

/// The further cameras of `pipeline` (`[[camera]]` after the first, whose tables are
/// `sections`, or a scenario's `[[extra_cameras]]`), each read like `first` from a topic
/// of its own: `topics` when given (one per camera, in their order), else
/// `FRAME/image_raw` (`/compressed`) or `FRAME/detections`, as the simulator publishes
/// them.
pub fn extra_cameras(
    first: Option<&NodeCamera>,
    topics: Option<Vec<String>>,
    pipeline: &PipelineConfig,
    sections: &[CameraSection],
) -> anyhow::Result<Vec<(String, NodeCamera)>> {
    let extra = &pipeline.extra_cameras;
    let Some(first) = first else {
        anyhow::ensure!(
            topics.is_none_or(|t| t.is_empty()),
            "parameter extra_camera_topics: the node reads no camera (no [camera] in --config, \
             or --laser-only)"
        );
        return Ok(Vec::new());
    };
    let topics = match topics {
        Some(topics) => {
            anyhow::ensure!(
                topics.len() == extra.len(),
                "parameter extra_camera_topics names {} topics, but --config describes {} \
                 further cameras ([[camera]] tables after the first): one topic each, in their \
                 order",
                topics.len(),
                extra.len()
            );
            topics
        }
        None => extra
            .iter()
            .map(|c| format!("{}/{}", c.frame_id, first.first_topic()))
            .collect(),
    };
    topics
        .into_iter()
        .enumerate()
        .map(|(k, topic)| {
            let source = match first {
                NodeCamera::Detections { .. } => first.clone(),
                NodeCamera::Images { compressed, .. } => NodeCamera::Images {
                    section: Box::new(sections.get(k).cloned().ok_or_else(|| {
                        anyhow::anyhow!(
                            "camera {:?}: images need its [[camera]] table (its cascade)",
                            extra[k].frame_id
                        )
                    })?),
                    compressed: *compressed,
                },
            };
            Ok((topic, source))
        })
        .collect()
}

/// One camera of the node, with what its readers count and its newest frame.
#[derive(Debug)]
pub struct CameraFeed {
    /// Where its people come from.
    pub source: NodeCamera,
    /// The resolved topic.
    pub topic: String,
    /// The frame its boxes are tagged with for the pipeline.
    pub frame_id: String,
    /// The intrinsics its boxes are read with (the size its images must have).
    pub intrinsics: CameraIntrinsics,
    /// What its readers count (and the frame its first message named).
    pub counters: Arc<CameraCounters>,
    /// Its newest frame, for its detector (images only; closed at the end).
    pub latest: Arc<LatestFrame>,
}

impl CameraFeed {
    /// A camera on `topic` whose boxes go to the pipeline's camera of `frame_id`, of
    /// `intrinsics`.
    pub fn new(
        source: NodeCamera,
        topic: String,
        frame_id: &str,
        intrinsics: CameraIntrinsics,
    ) -> CameraFeed {
        CameraFeed {
            source,
            topic,
            frame_id: frame_id.to_owned(),
            intrinsics,
            counters: Arc::new(CameraCounters::default()),
            latest: Arc::new(LatestFrame::default()),
        }
    }

    /// Its name in the log: `camera` for the first, `camera "FRAME"` for the others.
    pub fn name(&self) -> String {
        match self.frame_id == FIRST_CAMERA_FRAME {
            true => "camera".to_owned(),
            false => format!("camera {:?}", self.frame_id),
        }
    }

    /// Starts its reader (and, for images, its detector's thread); each thread with the
    /// sender that stops it.
    pub fn start(
        &self,
        node: &mut RosNode,
        clock: &LiveClock,
        tx: &mpsc::SyncSender<Input>,
    ) -> Result<Vec<StoppableThread>, NodeError> {
        let intrinsics = self.intrinsics;
        let size_px = (intrinsics.width_px, intrinsics.height_px);
        let (stop_reader, reader_stops) = mpsc::channel();
        match &self.source {
            NodeCamera::Detections { class } => {
                let reader = start_detections_reader(
                    node,
                    (&self.topic, &self.frame_id),
                    class.clone(),
                    size_px,
                    clock.clone(),
                    tx.clone(),
                    reader_stops,
                    Arc::clone(&self.counters),
                )?;
                tracing::info!(
                    "{}: boxes from {}{}",
                    self.name(),
                    self.topic,
                    if class.is_empty() {
                        " (every class)".to_owned()
                    } else {
                        format!(" (class {class:?})")
                    }
                );
                Ok(vec![(stop_reader, reader)])
            }
            NodeCamera::Images {
                section,
                compressed,
            } => {
                let detector = BoxDetector::for_camera(section)?;
                let reader = start_camera_reader(
                    node,
                    &self.topic,
                    *compressed,
                    size_px,
                    clock.clone(),
                    Arc::clone(&self.latest),
                    reader_stops,
                    Arc::clone(&self.counters),
                )?;
                let detector_thread = self.start_detector(detector, tx.clone())?;
                let (never, _) = mpsc::channel();
                tracing::info!("{}: {}", self.name(), self.topic);
                Ok(vec![(stop_reader, reader), (never, detector_thread)])
            }
        }
    }

    /// The detector's thread: the newest frame through the cascade, its boxes to the
    /// loop, until the frames are closed or the loop is gone.
    fn start_detector(
        &self,
        mut detector: BoxDetector,
        tx: mpsc::SyncSender<Input>,
    ) -> Result<std::thread::JoinHandle<()>, NodeError> {
        let intrinsics = self.intrinsics;
        let frames = Arc::clone(&self.latest);
        let counters = Arc::clone(&self.counters);
        let frame_id = self.frame_id.clone();
        let name = self.name();
        std::thread::Builder::new()
            .name("camera-detector".into())
            .spawn(move || {
                while let Some((stamp, frame)) = frames.take() {
                    let boxes = frame
                        .gray()
                        .and_then(|g| detector.boxes(&g, &intrinsics).map_err(FrameError::from));
                    match boxes {
                        Ok(boxes) => {
                            let input = Input::Camera {
                                frame_id: frame_id.clone(),
                                stamp,
                                boxes,
                                frame: None,
                            };
                            if tx.send(input).is_err() {
                                break;
                            }
                        }
                        Err(e) => {
                            if counters.malformed.fetch_add(1, Ordering::Relaxed) == 0 {
                                tracing::warn!("a frame of the {name} skipped: {e}");
                            }
                        }
                    }
                }
            })
            .map_err(|source| NodeError::Thread {
                what: "camera detector thread",
                source,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::ExtraCamera;

    fn with_rear() -> PipelineConfig {
        let mut pipeline = PipelineConfig::default();
        pipeline.extra_cameras.push(ExtraCamera {
            frame_id: "rear_camera".into(),
            camera: pipeline.camera,
        });
        pipeline
    }

    #[test]
    fn each_further_camera_is_read_like_the_first_from_its_frame_s_topic_or_the_one_given() {
        let pipeline = with_rear();
        let boxes = NodeCamera::Detections {
            class: "person".into(),
        };
        let extra = extra_cameras(Some(&boxes), None, &pipeline, &[]).unwrap();
        assert_eq!(extra.len(), 1);
        assert_eq!(extra[0].0, "rear_camera/detections");
        assert!(matches!(&extra[0].1, NodeCamera::Detections { class } if class == "person"));
        let given = Some(vec!["back/boxes".to_owned()]);
        let extra = extra_cameras(Some(&boxes), given, &pipeline, &[]).unwrap();
        assert_eq!(extra[0].0, "back/boxes");
        // One topic per further camera, and a camera to read them for.
        let two = Some(vec!["a".to_owned(), "b".to_owned()]);
        let e = extra_cameras(Some(&boxes), two, &pipeline, &[]).unwrap_err();
        assert!(e.to_string().contains("names 2 topics"), "{e}");
        let e = extra_cameras(None, Some(vec!["a".to_owned()]), &pipeline, &[]).unwrap_err();
        assert!(e.to_string().contains("no camera"), "{e}");
        assert!(
            extra_cameras(None, None, &pipeline, &[])
                .unwrap()
                .is_empty()
        );
    }
}
