//! The loop's sources. Each runs on a thread of its own and sends [`Input`]s over one
//! bounded channel to the loop ([`crate::run_loop::run`]):
//!
//! - [`scip`]: a SCIP 2.0 Hokuyo on a serial port or TCP (`tether run`);
//! - [`camera`]: camera frames ([`frames`]: a folder of images or a V4L2 device) through
//!   the upper-body cascade (`tether run`; `tether ros2` runs the same detector on the
//!   frames of its image topic);
//! - `crate::ros2::inputs` (feature `ros2`): scans, odometry, `/tf`, `/clock`, images and
//!   detections from ROS 2 topics (`tether ros2`).
//!
//! What goes wrong in a source travels as a typed error inside its [`Input`] and is
//! said once, by the loop (a fault counted, a camera gone, a run ended) or by whoever
//! reads the run's [`crate::Ending`].

use tether_control::Twist;
use tether_core::{LaserScan, PixelBox, Pose2, Robot, Stamp, World};
use tether_scip::{Fault, ScipError};
use tether_vision::DetectError;

use frames::{CameraError, EncodedFrame};

pub mod camera;
pub mod frames;
pub mod scip;

/// Scans and frames waiting for the main loop; a sensor thread blocks when it is full
/// (a ROS 2 reader drops and counts instead).
pub const CHANNEL_DEPTH: usize = 32;

/// What the sensor threads send.
#[derive(Debug)]
pub enum Input {
    /// A laser scan, stamped in host time.
    Scan(LaserScan),
    /// Something the laser source met and recovered from.
    LaserFault(LaserFault),
    /// The laser stopped answering; its thread is opening it again for up to
    /// `within_s` (the robot stands meanwhile: no scans, so the laser watchdog holds it).
    LaserLost {
        /// Which laser (its port or address).
        laser: String,
        /// What the driver met.
        error: ScipError,
        /// How long the thread tries, s.
        within_s: f64,
    },
    /// The laser answers again after a [`Input::LaserLost`], and streams.
    LaserBack {
        /// Which laser (its port or address).
        laser: String,
        /// Time from the loss to the stream's restart, s.
        after_s: f64,
    },
    /// The laser failed for good (unplugged, not answering, and not back in time).
    LaserFailed(ScipError),
    /// The people boxes of a camera frame, stamped when the frame arrived.
    Camera {
        /// The camera's frame (`camera` for the first; design 5.7).
        frame_id: String,
        /// Arrival time of the frame.
        stamp: Stamp,
        /// Upper-body boxes.
        boxes: Vec<PixelBox>,
        /// The frame itself, compressed, when the run records.
        frame: Option<EncodedFrame>,
    },
    /// A camera stopped: `why` is `None` at the end of a folder. The run goes on with
    /// the other cameras, or with the laser alone.
    CameraEnded {
        /// The camera's frame.
        frame_id: String,
        /// Why it stopped before its frames ended.
        why: Option<CameraGone>,
    },
    /// A camera frame that could not be used (undecodable, the wrong size): skipped
    /// and counted; the camera goes on.
    CameraFrameBad {
        /// The camera's frame.
        frame_id: String,
        /// Why the frame could not be used.
        why: BadFrame,
    },
    /// The base's own odometry (ROS 2 `odom`): the robot's pose in the odometry frame,
    /// stamped in host time. Once it arrives it is the robot's pose for every datum (see
    /// [`crate::LoopConfig::odometry_input`]).
    Odometry {
        /// When the pose held.
        stamp: Stamp,
        /// The pose.
        world_from_robot: Pose2<World, Robot>,
        /// The base's velocity then (forward, turn rate), to carry the pose to a
        /// datum's stamp.
        moving: Twist,
    },
    /// The simulated clock moved on (`/clock`, `use_sim_time`): nothing to process,
    /// but the control timer may be due.
    ClockAdvanced,
}

/// Something a laser source met and recovered from: counted by the loop.
#[derive(Debug, thiserror::Error)]
pub enum LaserFault {
    /// The SCIP driver dropped a reply or restarted the stream.
    #[error(transparent)]
    Driver(#[from] Fault),
    /// A scan message that did not decode or could not be used (ROS 2).
    #[error("{topic}: a sample skipped: {why}")]
    Sample {
        /// The scan topic.
        topic: String,
        /// What was wrong with it.
        why: String,
    },
}

/// Why a camera frame was skipped.
#[derive(Debug, thiserror::Error)]
pub enum BadFrame {
    /// The source could not decode it, or it has the wrong size.
    #[error(transparent)]
    Source(CameraError),
    /// The detector refused it.
    #[error(transparent)]
    Detect(#[from] DetectError),
}

/// Why the camera stopped before its frames ended.
#[derive(Debug, thiserror::Error)]
pub enum CameraGone {
    /// The device or the folder failed.
    #[error(transparent)]
    Source(CameraError),
    /// It sent nothing usable for too long.
    #[error("{count} frames in a row could not be used; the last: {last}")]
    BadFrames {
        /// Frames in a row that could not be used.
        count: u32,
        /// Why the last one could not.
        last: BadFrame,
    },
}
