//! The camera of `tether run`: frames from a folder or a V4L2 device ([`super::frames`])
//! through the upper-body cascade on a thread of its own, each frame stamped when it
//! arrives. A frame that cannot be used is skipped and counted; a camera that sends
//! nothing usable for [`CAMERA_GIVES_UP_AFTER_BAD_FRAMES`] frames in a row is gone, and
//! the run goes on with the laser alone.
//!
//! [`BoxDetector`] is the cascade with its search settings; `tether ros2` runs it on the
//! frames of its image topic, and `track` and `replay` on a recording's.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;

use tether_core::{CameraIntrinsics, GrayImage, PixelBox, Stamp};
use tether_scip::Clock;
use tether_vision::{Cascade, CascadeFileError, DetectError, DetectParams, Detector};

use super::frames::{CameraError, FolderFrames, FrameSource, png_of};
use super::{BadFrame, CameraGone, Input};
use crate::clock::MonotonicClock;
use crate::config::{CameraSection, FrameInput};

/// Where Debian's `opencv-data` installs the pretrained cascades.
pub const DEBIAN_CASCADE_DIR: &str = "/usr/share/opencv4/haarcascades";

/// The cascade used when none is given.
pub const DEFAULT_CASCADE: &str = "haarcascade_upperbody.xml";

/// Frames in a row that cannot be used before the camera is taken for gone (3 s at
/// 10 fps); a single bad frame is skipped and counted.
pub const CAMERA_GIVES_UP_AFTER_BAD_FRAMES: u32 = 30;

/// Why the upper-body detector cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum DetectorError {
    /// No cascade was given and the default one is not installed.
    #[error(
        "no --cascade given and {} is missing: install OpenCV's pretrained cascades \
         (Debian/Ubuntu: `sudo apt-get install opencv-data`) or pass --cascade FILE",
        default.display()
    )]
    NoCascade {
        /// Where the default cascade was looked for.
        default: PathBuf,
    },
    /// The cascade file cannot be read.
    #[error(transparent)]
    Cascade(#[from] CascadeFileError),
    /// The search settings cannot be used.
    #[error("camera.scale_factor = {0}: must be above 1 (OpenCV's default is 1.1)")]
    ScaleFactor(f64),
    /// The detector refused its settings.
    #[error(transparent)]
    Detector(#[from] DetectError),
}

/// Why the camera could not be started.
#[derive(Debug, thiserror::Error)]
pub enum CameraStartError {
    /// The frame source cannot be opened.
    #[error(transparent)]
    Source(#[from] CameraError),
    /// The config names a V4L2 device and this build has no V4L2.
    #[error(
        "camera.v4l2 = {device:?}: this tether was built without V4L2 support; build it \
         with `cargo build --release --features v4l2` (needs libclang-dev), or use \
         `camera.folder`"
    )]
    NoV4l2 {
        /// The device.
        device: String,
    },
    /// The detector cannot be made.
    #[error(transparent)]
    Detector(#[from] DetectorError),
    /// The thread could not be started.
    #[error("starting the camera thread")]
    Thread(#[source] std::io::Error),
}

/// `cascade`, or the default cascade when it is installed.
pub fn resolve_cascade(cascade: Option<&Path>) -> Result<PathBuf, DetectorError> {
    if let Some(path) = cascade {
        return Ok(path.to_path_buf());
    }
    let default = Path::new(DEBIAN_CASCADE_DIR).join(DEFAULT_CASCADE);
    if default.is_file() {
        Ok(default)
    } else {
        Err(DetectorError::NoCascade { default })
    }
}

/// The upper-body detector of a camera: a cascade, its search settings, and what it
/// found.
pub struct BoxDetector {
    detector: Detector,
    params: DetectParams,
    /// Frames searched.
    pub frames: usize,
    /// People boxes found.
    pub boxes: usize,
    size_warned: bool,
}

impl BoxDetector {
    /// `cascade` searched with `params` on `threads` threads (0: one per core; the
    /// boxes do not depend on it).
    pub fn new(
        cascade: Cascade,
        params: DetectParams,
        threads: usize,
    ) -> Result<Self, DetectorError> {
        Ok(BoxDetector {
            detector: Detector::new(cascade).with_threads(threads)?,
            params,
            frames: 0,
            boxes: 0,
            size_warned: false,
        })
    }

    /// The detector of a robot's `[camera]` (its cascade and search settings), on one
    /// thread.
    pub fn for_camera(section: &CameraSection) -> Result<Self, DetectorError> {
        let cascade = Cascade::load(resolve_cascade(section.cascade.as_deref())?)?;
        let scale_factor = section.scale_factor.unwrap_or(1.1);
        if !(scale_factor.is_finite() && scale_factor > 1.0) {
            return Err(DetectorError::ScaleFactor(scale_factor));
        }
        let params = DetectParams {
            scale_factor,
            min_neighbors: section.min_neighbors.unwrap_or(3),
            min_size_px: [0, 0],
            max_size_px: [0, 0],
        };
        BoxDetector::new(cascade, params, 1)
    }

    /// The people boxes of one frame; warns once when the frame's size is not the
    /// camera model's.
    pub fn boxes(
        &mut self,
        image: &GrayImage,
        intrinsics: &CameraIntrinsics,
    ) -> Result<Vec<PixelBox>, DetectError> {
        if !self.size_warned
            && (image.width() as u32, image.height() as u32)
                != (intrinsics.width_px, intrinsics.height_px)
        {
            self.size_warned = true;
            tracing::warn!(
                "camera frames are {}x{} but the camera model is {}x{}: set [camera] in \
                 --config to this camera's intrinsics, or the vision ranges are wrong",
                image.width(),
                image.height(),
                intrinsics.width_px,
                intrinsics.height_px
            );
        }
        let boxes: Vec<PixelBox> = self
            .detector
            .detect(image, &self.params)?
            .into_iter()
            .map(PixelBox::from)
            .collect();
        self.frames += 1;
        self.boxes += boxes.len();
        Ok(boxes)
    }
}

/// The frames of `input`, of the camera model's size.
pub fn frame_source(
    input: &FrameInput,
    intrinsics: &CameraIntrinsics,
) -> Result<Box<dyn FrameSource>, CameraStartError> {
    match input {
        FrameInput::Folder { path, fps, repeat } => Ok(Box::new(
            FolderFrames::open(path, *fps, *repeat)?
                .sized(intrinsics.width_px, intrinsics.height_px),
        )),
        #[cfg(feature = "v4l2")]
        FrameInput::V4l2 { device } => Ok(Box::new(super::frames::V4l2Frames::open(
            device,
            intrinsics.width_px,
            intrinsics.height_px,
        )?)),
        #[cfg(not(feature = "v4l2"))]
        FrameInput::V4l2 { device } => {
            let _ = intrinsics;
            Err(CameraStartError::NoV4l2 {
                device: device.clone(),
            })
        }
    }
}

/// A camera ready to start: its frames, its detector, its model and the frame its
/// boxes are told apart by.
pub struct CameraSource {
    source: Box<dyn FrameSource>,
    detector: BoxDetector,
    intrinsics: CameraIntrinsics,
    frame_id: String,
}

impl CameraSource {
    /// The frames of `input` and the detector of `section`, for a camera of
    /// `intrinsics` whose frames carry `frame_id`.
    pub fn open(
        input: &FrameInput,
        section: &CameraSection,
        intrinsics: CameraIntrinsics,
        frame_id: &str,
    ) -> Result<Self, CameraStartError> {
        let source = frame_source(input, &intrinsics)?;
        let detector = BoxDetector::for_camera(section)?;
        tracing::info!("camera {frame_id}: {}", source.describe());
        Ok(CameraSource {
            source,
            detector,
            intrinsics,
            frame_id: frame_id.to_owned(),
        })
    }

    /// Starts the camera's thread: frames through the detector, stamped on `clock` when
    /// they arrive, to `tx` until `stop` or the end of the frames. `record`: each frame
    /// goes along as it came (or as PNG), for the recording.
    pub fn spawn(
        self,
        clock: MonotonicClock,
        tx: SyncSender<Input>,
        stop: Arc<AtomicBool>,
        record: bool,
    ) -> Result<JoinHandle<()>, CameraStartError> {
        std::thread::Builder::new()
            .name("camera".into())
            .spawn(move || self.run(clock, &tx, &stop, record))
            .map_err(CameraStartError::Thread)
    }

    fn run(
        mut self,
        clock: MonotonicClock,
        tx: &SyncSender<Input>,
        stop: &AtomicBool,
        record: bool,
    ) {
        // Consecutive frames that could not be used: a bad frame is skipped, a camera
        // that sends nothing usable for this many frames in a row is gone.
        let mut bad_in_a_row = 0_u32;
        let frame_id = self.frame_id.clone();
        let ended = |why| Input::CameraEnded {
            frame_id: frame_id.clone(),
            why,
        };
        let bad = |why| Input::CameraFrameBad {
            frame_id: frame_id.clone(),
            why,
        };
        while !stop.load(Ordering::Relaxed) {
            let input = match self.source.next_frame() {
                Ok(Some(image)) => {
                    let stamp = Stamp::from_ns(clock.now_ns());
                    // The recording keeps the frame as it came (or as PNG).
                    let frame = record
                        .then(|| self.source.take_encoded().unwrap_or_else(|| png_of(&image)));
                    match self.detector.boxes(&image, &self.intrinsics) {
                        Ok(boxes) => Input::Camera {
                            frame_id: frame_id.clone(),
                            stamp,
                            boxes,
                            frame,
                        },
                        Err(e) => bad(BadFrame::Detect(e)),
                    }
                }
                Ok(None) => ended(None),
                Err(e @ CameraError::Frame { .. }) => bad(BadFrame::Source(e)),
                Err(e) => ended(Some(CameraGone::Source(e))),
            };
            let input = match input {
                Input::CameraFrameBad { why, .. } => {
                    bad_in_a_row += 1;
                    if bad_in_a_row >= CAMERA_GIVES_UP_AFTER_BAD_FRAMES {
                        ended(Some(CameraGone::BadFrames {
                            count: bad_in_a_row,
                            last: why,
                        }))
                    } else {
                        bad(why)
                    }
                }
                other => {
                    bad_in_a_row = 0;
                    other
                }
            };
            let last = matches!(input, Input::CameraEnded { .. });
            if tx.send(input).is_err() || last {
                break;
            }
        }
    }
}
