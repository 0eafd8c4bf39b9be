//! The loop of `tether track` and `tether eval-track`: a recording's samples through
//! the pipeline in log order (design 4, 5), with the robot's pose from odometry when a
//! topic gives it, else taken as still (the scan's frame is then the robot's and the
//! world's).
//!
//! Per scan the caller gets the scan, the pipeline's tick, `world_from_robot` used for
//! it and `robot_from_laser` of the configuration, so that it can put the tracks (in
//! the world frame) and the scan's labels (in the laser frame) in one frame:
//! `world_from_laser = world_from_robot * robot_from_laser`.

use std::cell::RefCell;
use std::path::Path;
use tether_live::ego::ScanOdometry;
use tether_scanmatch::MotionPrior;

use tether_core::{GrayImage, Laser, LaserScan, PixelBox, Pose2, Robot, World};
use tether_pipeline::{Pipeline, Tick};

use crate::recording::{self, LabelMessage, ReadStats, Sample, Topics};

/// One scan through the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct ScanStep<'a> {
    /// The scan (its stamp is the tick's).
    pub scan: &'a LaserScan,
    /// What the pipeline made of it.
    pub tick: &'a Tick,
    /// The robot's pose the scan was processed with.
    pub world_from_robot: Pose2<World, Robot>,
    /// Where the laser sits on the robot.
    pub robot_from_laser: Pose2<Robot, Laser>,
}

/// What the loop reports, in log order.
#[derive(Debug)]
pub enum Step<'a> {
    /// A scan went through the pipeline.
    Scan(ScanStep<'a>),
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
/// (`topics.odom`: the robot's pose for the following inputs; without it the robot
/// stands still at the identity, or, with `scan_odometry`, moves as scan matching
/// says: each scan against the static scene, the people being tracked left out). With
/// `labels_topic`, that topic's messages are handed over too, in log order. `on_step`
/// may stop the run by returning an error.
pub fn run_recording(
    path: &Path,
    topics: &Topics,
    labels_topic: Option<&str>,
    pipeline: &mut Pipeline,
    mut camera: Option<&mut CameraBoxes<'_>>,
    mut scan_odometry: Option<&mut ScanOdometry>,
    on_step: &mut dyn FnMut(Step<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<RunCounts> {
    if topics.odom.is_some() {
        scan_odometry = None;
    }
    let robot_from_laser = pipeline.config().laser.robot_from_laser();
    let mut pose: Option<Pose2<World, Robot>> = topics.odom.is_none().then_some(Pose2::IDENTITY);
    let mut counts = RunCounts::default();
    // Both callbacks of the reader hand steps on; never at the same time.
    let on_step = RefCell::new(on_step);
    let mut on_sample = |sample: Sample| -> anyhow::Result<()> {
        match sample {
            Sample::Odom {
                world_from_robot, ..
            } => {
                counts.odom += 1;
                pose = Some(world_from_robot);
            }
            Sample::Camera { stamp, image } => {
                let Some(camera) = camera.as_mut() else {
                    return Ok(());
                };
                let Some(world_from_robot) = pose else {
                    counts.waiting_for_odom += 1;
                    return Ok(());
                };
                let boxes = camera(&image)?;
                pipeline.on_camera_boxes(stamp, &boxes, world_from_robot);
                counts.camera_frames += 1;
            }
            Sample::Scan(scan) => {
                if let Some(odometry) = scan_odometry.as_deref_mut() {
                    let people = tether_live::ego::moving_people(pipeline.tracker().tracks());
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
                    robot_from_laser,
                }))?;
            }
        }
        Ok(())
    };
    let read = match labels_topic {
        Some(topic) => {
            recording::read_with_labels(path, topics, topic, &mut on_sample, &mut |labels| {
                (on_step.borrow_mut())(Step::Labels(labels))
            })?
        }
        None => recording::read(path, topics, &mut on_sample)?,
    };
    counts.read = read;
    Ok(counts)
}
