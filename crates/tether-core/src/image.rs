//! An owned 8-bit grey image, row-major, the input of the Haar cascade detector.

use thiserror::Error;

/// Why pixels cannot form an image.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ImageError {
    /// Width or height is zero.
    #[error("image must have non-zero size, got {width}x{height}")]
    Empty {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
    },
    /// The buffer length is not `width * height`.
    #[error("image buffer holds {got} bytes but {width}x{height} needs {expected}")]
    BadLength {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// `width * height`.
        expected: usize,
        /// Bytes given.
        got: usize,
    },
}

/// An 8-bit single-channel image, rows top to bottom, pixels left to right (the image
/// frame: u right, v down, origin at the top-left pixel's top-left corner).
#[derive(Clone, PartialEq, Eq)]
pub struct GrayImage {
    width: usize,
    height: usize,
    pixels: Vec<u8>,
}

impl std::fmt::Debug for GrayImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GrayImage({}x{})", self.width, self.height)
    }
}

impl GrayImage {
    /// Wraps a row-major buffer of `width * height` bytes.
    pub fn from_raw(width: usize, height: usize, pixels: Vec<u8>) -> Result<Self, ImageError> {
        if width == 0 || height == 0 {
            return Err(ImageError::Empty { width, height });
        }
        let expected = width
            .checked_mul(height)
            .ok_or(ImageError::Empty { width, height })?;
        if pixels.len() != expected {
            return Err(ImageError::BadLength {
                width,
                height,
                expected,
                got: pixels.len(),
            });
        }
        Ok(GrayImage {
            width,
            height,
            pixels,
        })
    }

    /// An image of one grey level.
    pub fn filled(width: usize, height: usize, level: u8) -> Result<Self, ImageError> {
        let n = width
            .checked_mul(height)
            .ok_or(ImageError::Empty { width, height })?;
        Self::from_raw(width, height, vec![level; n])
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// All pixels, row-major.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// One row.
    pub fn row(&self, y: usize) -> &[u8] {
        &self.pixels[y * self.width..(y + 1) * self.width]
    }

    /// The pixel at column `x`, row `y`, or `None` outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<u8> {
        (x < self.width && y < self.height).then(|| self.pixels[y * self.width + x])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_buffer_length() {
        assert!(GrayImage::from_raw(2, 2, vec![0; 3]).is_err());
        assert!(GrayImage::from_raw(0, 2, vec![]).is_err());
        let img = GrayImage::from_raw(2, 2, vec![1, 2, 3, 4]).unwrap();
        assert_eq!(img.get(1, 1), Some(4));
        assert_eq!(img.get(2, 0), None);
        assert_eq!(img.row(1), &[3, 4]);
    }
}
