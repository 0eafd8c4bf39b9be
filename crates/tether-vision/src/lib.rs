//! tether's vision (design section 3).
//!
//! - [`cascade`]: OpenCV Haar cascade XML files, both layouts, as OpenCV 4.x reads them.
//! - [`detect`]: multi-scale detection that returns exactly OpenCV's boxes: the image
//!   pyramid ([`resize`]), integral images ([`integral`]), variance normalisation, the
//!   stages, and grouping ([`group`]).
//! - [`imread`]: PNG and JPEG files to 8-bit grey as `cv2.imread(path,
//!   cv2.IMREAD_GRAYSCALE)` gives them; [`jpeg`]: tether's JPEG decoder, which
//!   reproduces libjpeg-turbo's grey output bit for bit.
//! - [`monocular`]: a person's position and covariance in the robot frame from an
//!   upper-body box (the paper's eq. 1-3, design 3.2), and [`calibrate`]: the camera
//!   tilt and box margin from boxes of a person at known distances.
//!
//! The crate does no I/O besides reading the files it is asked to read, and reads no
//! clock.

pub mod calibrate;
pub mod cascade;
pub mod detect;
pub mod group;
pub mod imread;
pub mod integral;
pub mod jpeg;
pub mod monocular;
pub mod resize;

pub use cascade::{Cascade, CascadeError, CascadeFileError, CascadeFormat};
pub use detect::{DetectError, DetectParams, Detector};
pub use group::Rect;
pub use imread::{ImreadError, imread_gray};
