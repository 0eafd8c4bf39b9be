//! tether's image files (design 3.1): PNG and JPEG files to 8-bit grey exactly as
//! `cv2.imread(path, cv2.IMREAD_GRAYSCALE)` gives them, so that the cascade detector
//! (`tether-vision`) sees the pixels OpenCV's detector sees.
//!
//! - [`imread`]: files and in-memory bytes to a [`GrayImage`](tether_core::GrayImage):
//!   PNG through the `png` crate with libpng's grey conversion reproduced, JPEG through
//!   [`jpeg`]; the EXIF orientation applied; the size the header claims checked against
//!   [`MAX_DECODE_PIXELS`](imread::MAX_DECODE_PIXELS) and against the file's length
//!   before any pixel is allocated.
//! - [`jpeg`]: tether's own JPEG decoder, which reproduces libjpeg-turbo's grey output
//!   bit for bit (baseline, progressive, arithmetic-coded, damaged and truncated files).
//!
//! The crate reads the files it is asked to read and nothing else, and reads no clock.

pub mod imread;
pub mod jpeg;

pub use imread::{ImreadError, decode_gray, imread_gray};
