//! tether's vision (design section 3).
//!
//! - [`cascade`]: OpenCV Haar cascade XML files, both layouts, as OpenCV 4.x reads them.
//! - [`detect`]: multi-scale detection that returns exactly OpenCV's boxes: the image
//!   pyramid ([`resize`]), integral images ([`integral`]), variance normalisation, the
//!   stages, and grouping ([`group`]).
//! - [`monocular`]: a person's position and covariance in the robot frame from an
//!   upper-body box (the paper's eq. 1-3, design 3.2), and [`calibrate`]: the camera
//!   tilt and box margin from boxes of a person at known distances.
//!
//! Image files become grey pixels in the `tether-image` crate (PNG and JPEG exactly as
//! `cv2.imread(path, cv2.IMREAD_GRAYSCALE)`); [`imread`], [`jpeg`], [`imread_gray`] and
//! [`ImreadError`] are re-exported from it here for one release, for code that still
//! imports them from this crate.
//!
//! The crate does no I/O besides reading the files it is asked to read, and reads no
//! clock.

pub mod calibrate;
pub mod cascade;
pub mod detect;
pub mod group;
pub mod integral;
pub mod monocular;
pub mod resize;

pub use cascade::{Cascade, CascadeError, CascadeFileError, CascadeFormat};
pub use detect::{DetectError, DetectParams, Detector};
pub use group::Rect;
pub use tether_image::{ImreadError, imread, imread_gray, jpeg};
