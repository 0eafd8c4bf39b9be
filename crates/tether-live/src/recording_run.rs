//! The loop of `tether track`, `tether eval-track` and `tether replay`: a recording's
//! samples through the pipeline in log order (design 4, 5), with the robot's pose from
//! odometry messages, from scan matching, or taken as still (the scan's frame is then
//! the robot's and the world's).
//!
//! Per scan and per camera frame the caller gets the pipeline's tick, the
//! `world_from_robot` used for it and the tracker's tracks after it; per scan also the
//! scan and the configured `robot_from_laser` of its laser, so that it can put the
//! tracks (in the world frame) and the scan's labels (in the laser frame) in one frame:
//! `world_from_laser = world_from_robot * robot_from_laser`. With scan matching, the
//! first laser's scans are matched; another scanner's take the pose of the last match.

use crate::ego::ScanOdometry;
use std::cell::RefCell;
use std::path::Path;
use tether_scanmatch::MotionPrior;

use tether_core::{GrayImage, Laser, LaserScan, PixelBox, Pose2, Robot, Stamp, World};
use tether_fusion::Track;
use tether_pipeline::{Pipeline, Tick};

use tether_recording::samples::{self, LabelMessage, ReadStats, Sample, Topics};

/// Where the robot's pose comes from during a run over a recording.
pub enum Poses<'a> {
    /// The odometry topic's messages (`Topics::odom`); inputs before the first are left
    /// out.
    Odometry,
    /// Scan matching, each scan against the static scene, the people being tracked left
    /// out; odometry messages are counted, not used.
    ScanMatching(&'a mut ScanOdometry),
    /// None: the robot stands still at the identity.
    Still,
}

/// One scan through the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct ScanStep<'a> {
    /// The scan (its stamp is the tick's).
    pub scan: &'a LaserScan,
    /// What the pipeline made of it.
    pub tick: &'a Tick,
    /// The robot's pose the scan was processed with.
    pub world_from_robot: Pose2<World, Robot>,
    /// Where the scan's laser sits on the robot.
    pub robot_from_laser: Pose2<Robot, Laser>,
    /// The tracker's tracks after the tick.
    pub tracks: &'a [Track],
}

/// One camera frame through the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct CameraStep<'a> {
    /// The frame's stamp.
    pub stamp: Stamp,
    /// What the pipeline made of its boxes.
    pub tick: &'a Tick,
    /// How many boxes the camera found in it.
    pub boxes: usize,
    /// The robot's pose the frame was processed with.
    pub world_from_robot: Pose2<World, Robot>,
    /// The tracker's tracks after the tick.
    pub tracks: &'a [Track],
}

/// What the loop reports, in log order.
#[derive(Debug)]
pub enum Step<'a> {
    /// A scan went through the pipeline.
    Scan(ScanStep<'a>),
    /// A camera frame went through the pipeline.
    Camera(CameraStep<'a>),
    /// A message of the labels topic.
    Labels(LabelMessage),
}

/// Finds people boxes in a camera frame.
pub type CameraBoxes<'a> = dyn FnMut(&GrayImage) -> anyhow::Result<Vec<PixelBox>> + 'a;

/// What a run over a recording counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Messages the reader skipped.
    pub read: ReadStats,
    /// Scans read.
    pub scans_read: usize,
    /// Camera frames read (with a camera to look at them).
    pub camera_frames_read: usize,
    /// Scans through the pipeline.
    pub scans: usize,
    /// Camera frames through the pipeline.
    pub camera_frames: usize,
    /// Odometry messages.
    pub odom: usize,
    /// Scans and frames before the first odometry message (with an odometry topic),
    /// left out: the robot's pose was not known yet.
    pub waiting_for_odom: usize,
}

/// Runs `pipeline` over the recording at `path`: its scans (`topics.scan`), camera
/// frames (`topics.image`, through `camera`; ignored without it) and odometry
/// (`topics.odom`), the robot's pose as `poses` says. With `labels_topic`, that topic's
/// messages are handed over too, in log order. `on_step` may stop the run by returning
/// an error.
pub fn run_recording(
    path: &Path,
    topics: &Topics,
    labels_topic: Option<&str>,
    pipeline: &mut Pipeline,
    mut camera: Option<&mut CameraBoxes<'_>>,
    mut poses: Poses<'_>,
    on_step: &mut dyn FnMut(Step<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<RunCounts> {
    let mut pose: Option<Pose2<World, Robot>> =
        (!matches!(poses, Poses::Odometry)).then_some(Pose2::IDENTITY);
    let mut counts = RunCounts::default();
    // Both callbacks of the reader hand steps on; never at the same time.
    let on_step = RefCell::new(on_step);
    let mut on_sample = |sample: Sample| -> anyhow::Result<()> {
        match sample {
            Sample::Odom {
                world_from_robot, ..
            } => {
                counts.odom += 1;
                if let Poses::Odometry = poses {
                    pose = Some(world_from_robot);
                }
            }
            Sample::Camera { stamp, image } => {
                let Some(camera) = camera.as_mut() else {
                    return Ok(());
                };
                counts.camera_frames_read += 1;
                let Some(world_from_robot) = pose else {
                    counts.waiting_for_odom += 1;
                    return Ok(());
                };
                let boxes = camera(&image)?;
                let tick = pipeline.on_camera_boxes(stamp, &boxes, world_from_robot);
                counts.camera_frames += 1;
                (on_step.borrow_mut())(Step::Camera(CameraStep {
                    stamp,
                    tick: &tick,
                    boxes: boxes.len(),
                    world_from_robot,
                    tracks: pipeline.tracker().tracks(),
                }))?;
            }
            Sample::Scan(scan) => {
                counts.scans_read += 1;
                // The matcher aligns the first laser's scans (at its mount); another
                // scanner's take the pose of the last one (design 5.7).
                if let Poses::ScanMatching(odometry) = &mut poses
                    && pipeline.is_first_lasers(&scan.frame_id)
                {
                    let people = crate::ego::moving_people(pipeline.tracker().tracks());
                    pose = Some(odometry.update(&scan, MotionPrior::ConstantVelocity, people));
                }
                let Some(world_from_robot) = pose else {
                    counts.waiting_for_odom += 1;
                    return Ok(());
                };
                let tick = pipeline.on_scan(&scan, world_from_robot);
                counts.scans += 1;
                (on_step.borrow_mut())(Step::Scan(ScanStep {
                    scan: &scan,
                    tick: &tick,
                    world_from_robot,
                    robot_from_laser: pipeline.robot_from_laser_of(&scan.frame_id),
                    tracks: pipeline.tracker().tracks(),
                }))?;
            }
        }
        Ok(())
    };
    let read = match labels_topic {
        Some(topic) => {
            samples::read_with_labels(path, topics, topic, &mut on_sample, &mut |labels| {
                (on_step.borrow_mut())(Step::Labels(labels))
            })?
        }
        None => samples::read(path, topics, &mut on_sample)?,
    };
    counts.read = read;
    Ok(counts)
}
