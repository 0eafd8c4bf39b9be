//! More scanners on a ROS 2 robot (design 5.7): the scans of each topic of
//! `extra_scan_topics` (`-p extra_scan_topics:="[rear/scan]"`) go to a laser of their
//! own, told apart in the pipeline by their `frame_id`.
//!
//! At the start each extra topic's reader notes the frame of its first scan and hands
//! the loop nothing (the start drops scans anyway). The node then gives that frame a
//! laser: the configuration's `[[extra_lasers]]` entry of that frame, with its mount
//! replaced by `/tf_static`'s when that is published, or, when the configuration names
//! no such laser, a laser like the first one at the mount `/tf_static` gives. From then
//! on the topic's reader passes the scans of the frames its laser takes and counts the
//! others. A topic whose frame has no mount anywhere, or whose frame is another topic's,
//! is not used, with a warning saying why: a scan taken at a wrong mount would put the
//! people it sees in the wrong place.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use tether_core::{ExtraLaser, LaserMount};
use tether_pipeline::PipelineConfig;
use tether_ros2::StaticTransforms;

/// What an extra scan topic's reader does with a scan of some frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// The node is starting: the frame is noted, the scan dropped.
    Starting,
    /// To the loop.
    Take,
    /// Not a frame of this topic's laser: counted, dropped.
    Refuse,
}

/// One extra scan topic: the frame it was heard with at the start, then the frames its
/// laser takes, and what its reader counted.
#[derive(Debug, Default)]
pub struct ExtraScanTopic {
    /// The resolved topic name.
    pub topic: String,
    state: Mutex<TopicState>,
    /// Scans handed to the loop.
    pub taken: AtomicU64,
    /// Scans of a frame that is not this topic's laser's, dropped.
    pub other_frame: AtomicU64,
}

#[derive(Debug, Default)]
struct TopicState {
    /// The frame of the first scan heard.
    heard: Option<String>,
    /// `None` while the node starts; then the frames the topic's laser takes (none: the
    /// topic is not used).
    open: Option<Vec<String>>,
}

impl ExtraScanTopic {
    /// A topic not yet heard.
    pub fn new(topic: &str) -> ExtraScanTopic {
        ExtraScanTopic {
            topic: topic.to_owned(),
            ..ExtraScanTopic::default()
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, TopicState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// What the reader does with a scan of `frame`; counts it.
    pub fn pass(&self, frame: &str) -> Pass {
        let mut state = self.state();
        let pass = match &state.open {
            None => {
                if state.heard.is_none() {
                    state.heard = Some(frame.to_owned());
                }
                return Pass::Starting;
            }
            Some(frames) if frames.iter().any(|f| f == frame) => Pass::Take,
            Some(_) => Pass::Refuse,
        };
        drop(state);
        let counter = match pass {
            Pass::Take => &self.taken,
            _ => &self.other_frame,
        };
        if counter.fetch_add(1, Ordering::Relaxed) == 0 && pass == Pass::Refuse {
            tracing::warn!(
                "{}: a scan of frame {frame:?}, which is not this topic's laser's, skipped \
                 (further ones are counted)",
                self.topic
            );
        }
        pass
    }

    /// The frame of the first scan heard.
    pub fn heard(&self) -> Option<String> {
        self.state().heard.clone()
    }

    /// Ends the start: from now on the scans of `frames` are taken.
    pub fn open(&self, frames: Vec<String>) {
        self.state().open = Some(frames);
    }

    /// The frames taken (empty: the topic is not used).
    pub fn frames(&self) -> Vec<String> {
        self.state().open.clone().unwrap_or_default()
    }
}

/// Gives each extra topic a laser in `pipeline` (see the module's documentation), its
/// mount from `transforms` (`base_frame` -> the topic's frame) when known, and opens the
/// topics. `first_frame` is the frame of the first laser's scans, when heard. Returns the
/// frames whose mounts came from the configuration alone (to publish on `/tf_static`
/// when `mount_given`).
pub fn give_lasers(
    topics: &[std::sync::Arc<ExtraScanTopic>],
    transforms: &StaticTransforms,
    base_frame: &str,
    first_frame: Option<&str>,
    mount_given: bool,
    pipeline: &mut PipelineConfig,
) -> Vec<(String, LaserMount)> {
    let mut from_config = Vec::new();
    let mut claimed: Vec<String> = first_frame.into_iter().map(str::to_owned).collect();
    for topic in topics {
        let Some(frame) = topic.heard() else {
            // Not heard yet: the configuration's lasers that no topic claimed take its
            // scans when they come (their mounts are the configuration's).
            let unclaimed: Vec<String> = pipeline
                .extra_lasers
                .iter()
                .map(|l| l.frame_id.clone())
                .filter(|f| !claimed.contains(f) && !heard_elsewhere(topics, f))
                .collect();
            tracing::warn!(
                "no scan on {} at the start; {}",
                topic.topic,
                if unclaimed.is_empty() {
                    "it is not used (no laser of the configuration is left for it)".to_owned()
                } else {
                    format!(
                        "its scans of frame {} are taken when they come",
                        unclaimed.join(", ")
                    )
                }
            );
            claimed.extend(unclaimed.iter().cloned());
            topic.open(unclaimed);
            continue;
        };
        if claimed.contains(&frame) {
            tracing::warn!(
                "{}: its scans are of frame {frame}, as another scan topic's are; it is not \
                 used (each scanner needs a frame of its own)",
                topic.topic
            );
            topic.open(Vec::new());
            continue;
        }
        claimed.push(frame.clone());
        let from_tf = transforms
            .lookup(base_frame, &frame)
            .map(|pose| LaserMount {
                x_m: pose.position_m[0],
                y_m: pose.position_m[1],
                yaw_rad: pose.yaw_rad(),
                height_m: pose.position_m[2],
            });
        let configured = pipeline
            .extra_lasers
            .iter_mut()
            .find(|l| l.frame_id == frame);
        match (configured, from_tf) {
            (Some(laser), Some(mount)) => {
                tracing::info!(
                    "{}: laser {frame}, mount from /tf_static: {base_frame} -> {frame} at \
                     ({:.3}, {:.3}) m, yaw {:.3} rad",
                    topic.topic,
                    mount.x_m,
                    mount.y_m,
                    mount.yaw_rad
                );
                laser.laser.mount = mount;
            }
            (Some(laser), None) => {
                tracing::warn!(
                    "{}: no transform from {base_frame} to {frame} on /tf_static; laser \
                     {frame} is taken at the configuration's mount ({:.3}, {:.3}), yaw {:.3}",
                    topic.topic,
                    laser.laser.mount.x_m,
                    laser.laser.mount.y_m,
                    laser.laser.mount.yaw_rad
                );
                if mount_given {
                    from_config.push((frame.clone(), laser.laser.mount));
                }
            }
            (None, Some(mount)) => {
                tracing::info!(
                    "{}: laser {frame}, like the first laser, mount from /tf_static: \
                     {base_frame} -> {frame} at ({:.3}, {:.3}) m, yaw {:.3} rad",
                    topic.topic,
                    mount.x_m,
                    mount.y_m,
                    mount.yaw_rad
                );
                let mut laser = pipeline.laser.clone();
                laser.mount = mount;
                pipeline.extra_lasers.push(ExtraLaser {
                    frame_id: frame.clone(),
                    laser,
                });
            }
            (None, None) => {
                tracing::warn!(
                    "{}: no transform from {base_frame} to {frame} on /tf_static and no \
                     [[extra_lasers]] entry of that frame in the configuration; the topic is \
                     not used (where the scanner sits is not known)",
                    topic.topic
                );
                topic.open(Vec::new());
                continue;
            }
        }
        topic.open(vec![frame]);
    }
    // A laser of the configuration that no topic takes would never be heard, and the
    // laser watchdog would hold the robot for good.
    pipeline.extra_lasers.retain(|l| {
        let taken = claimed.contains(&l.frame_id);
        if !taken {
            tracing::warn!(
                "laser {} of the configuration has no scan topic (extra_scan_topics); it is \
                 not used",
                l.frame_id
            );
        }
        taken
    });
    from_config
}

/// Whether a topic other than the caller heard `frame` at the start.
fn heard_elsewhere(topics: &[std::sync::Arc<ExtraScanTopic>], frame: &str) -> bool {
    topics.iter().any(|t| t.heard().as_deref() == Some(frame))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use tether_msgs::{Header, Pose3, TfMessage, TransformStampedMsg};

    fn tree(frames: &[(&str, f64, f64, f64)]) -> StaticTransforms {
        let mut t = StaticTransforms::default();
        t.insert(&TfMessage {
            transforms: frames
                .iter()
                .map(|(f, x, y, yaw)| TransformStampedMsg {
                    header: Header::new(tether_core::Stamp::from_ns(0), "base_link"),
                    child_frame_id: (*f).to_owned(),
                    transform: Pose3::planar(*x, *y, *yaw),
                })
                .collect(),
        });
        t
    }

    fn heard(topic: &str, frame: Option<&str>) -> Arc<ExtraScanTopic> {
        let t = Arc::new(ExtraScanTopic::new(topic));
        if let Some(f) = frame {
            assert_eq!(t.pass(f), Pass::Starting);
            assert_eq!(t.pass("later"), Pass::Starting);
        }
        t
    }

    #[test]
    fn a_frame_the_config_does_not_name_gets_a_laser_like_the_first_at_tf_s_mount() {
        let topics = [heard("/rear/scan", Some("rear_laser"))];
        let mut p = PipelineConfig::default();
        let published = give_lasers(
            &topics,
            &tree(&[("rear_laser", -0.2, 0.0, std::f64::consts::PI)]),
            "base_link",
            Some("laser"),
            true,
            &mut p,
        );
        assert!(published.is_empty());
        assert_eq!(p.extra_lasers.len(), 1);
        let rear = &p.extra_lasers[0];
        assert_eq!(rear.frame_id, "rear_laser");
        assert!((rear.laser.mount.x_m + 0.2).abs() < 1e-9);
        assert!((rear.laser.mount.yaw_rad.abs() - std::f64::consts::PI).abs() < 1e-9);
        assert_eq!(rear.laser.geometry, p.laser.geometry);
        // Its scans go to the loop, scans of any other frame are counted and dropped.
        assert_eq!(topics[0].pass("rear_laser"), Pass::Take);
        assert_eq!(topics[0].pass("laser"), Pass::Refuse);
        assert_eq!(topics[0].taken.load(Ordering::Relaxed), 1);
        assert_eq!(topics[0].other_frame.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn a_configured_laser_takes_tf_s_mount_or_keeps_its_own_to_publish() {
        let mut p = PipelineConfig::default();
        let mut rear = p.laser.clone();
        rear.mount.x_m = -0.1;
        p.extra_lasers.push(ExtraLaser {
            frame_id: "rear_laser".into(),
            laser: rear,
        });
        let topics = [heard("/rear/scan", Some("rear_laser"))];
        let mut with_tf = p.clone();
        let published = give_lasers(
            &topics,
            &tree(&[("rear_laser", -0.3, 0.0, 0.0)]),
            "base_link",
            Some("laser"),
            true,
            &mut with_tf,
        );
        assert!(published.is_empty());
        assert!((with_tf.extra_lasers[0].laser.mount.x_m + 0.3).abs() < 1e-9);
        let topics = [heard("/rear/scan", Some("rear_laser"))];
        let mut without = p.clone();
        let published = give_lasers(
            &topics,
            &tree(&[]),
            "base_link",
            Some("laser"),
            true,
            &mut without,
        );
        assert_eq!(without, p);
        assert_eq!(published.len(), 1);
        assert_eq!(published[0].0, "rear_laser");
        assert_eq!(topics[0].frames(), ["rear_laser"]);
    }

    #[test]
    fn a_topic_without_a_mount_or_with_another_s_frame_is_not_used() {
        let mut p = PipelineConfig::default();
        let topics = [
            heard("/left/scan", Some("left_laser")),
            heard("/front2/scan", Some("laser")),
        ];
        let published = give_lasers(
            &topics,
            &tree(&[]),
            "base_link",
            Some("laser"),
            false,
            &mut p,
        );
        assert!(published.is_empty() && p.extra_lasers.is_empty());
        for t in &topics {
            assert!(t.frames().is_empty());
            assert_eq!(t.pass("left_laser"), Pass::Refuse);
        }
    }

    #[test]
    fn a_topic_silent_at_the_start_takes_the_configured_laser_nobody_claimed() {
        let mut p = PipelineConfig::default();
        for frame in ["rear_laser", "left_laser"] {
            p.extra_lasers.push(ExtraLaser {
                frame_id: frame.into(),
                laser: p.laser.clone(),
            });
        }
        let topics = [
            heard("/left/scan", Some("left_laser")),
            heard("/rear/scan", None),
        ];
        give_lasers(
            &topics,
            &tree(&[("left_laser", 0.0, 0.2, 1.57)]),
            "base_link",
            Some("laser"),
            true,
            &mut p,
        );
        assert_eq!(topics[0].frames(), ["left_laser"]);
        assert_eq!(topics[1].frames(), ["rear_laser"]);
        assert_eq!(topics[1].pass("rear_laser"), Pass::Take);
    }
}
