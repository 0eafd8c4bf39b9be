//! `sensor_msgs/Image` (mono8, rgb8, bgr8, converted to grey) and
//! `sensor_msgs/CompressedImage` (JPEG or PNG, kept as is): camera frames in both wire
//! formats.

use super::*;

/// Pixel encodings of `sensor_msgs/msg/Image` that tether converts to grey.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelEncoding {
    /// One byte per pixel, grey.
    Mono8,
    /// Three bytes per pixel: red, green, blue.
    Rgb8,
    /// Three bytes per pixel: blue, green, red (OpenCV's order).
    Bgr8,
}

impl PixelEncoding {
    /// The `encoding` string of the message.
    pub fn name(self) -> &'static str {
        match self {
            PixelEncoding::Mono8 => "mono8",
            PixelEncoding::Rgb8 => "rgb8",
            PixelEncoding::Bgr8 => "bgr8",
        }
    }

    /// Parses an `encoding` string; `None` for the ones tether does not convert.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "mono8" | "8UC1" => Some(PixelEncoding::Mono8),
            "rgb8" => Some(PixelEncoding::Rgb8),
            "bgr8" | "8UC3" => Some(PixelEncoding::Bgr8),
            _ => None,
        }
    }

    /// Bytes per pixel.
    pub fn channels(self) -> usize {
        match self {
            PixelEncoding::Mono8 => 1,
            PixelEncoding::Rgb8 | PixelEncoding::Bgr8 => 3,
        }
    }
}

/// `sensor_msgs/msg/Image`: raw pixels, row after row, `step` bytes a row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageMsg {
    /// ROS header (stamp of the exposure, the camera's optical frame).
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`mono8`, `rgb8`, `bgr8`, ...).
    pub encoding: String,
    /// Whether multi-byte pixel values are big-endian (irrelevant for 8-bit encodings).
    pub is_bigendian: u8,
    /// Bytes per row (at least `width * channels`).
    pub step: u32,
    /// The pixels, `step * height` bytes.
    pub data: Vec<u8>,
}

/// Why an image message cannot be turned into a grey image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImageMsgError {
    /// An encoding other than `mono8`, `rgb8`, `bgr8`.
    #[error("image encoding {0:?} is not supported; tether reads mono8, rgb8 and bgr8")]
    Encoding(String),
    /// `step` or the data length disagree with the size.
    #[error(
        "image of {width}x{height} {encoding} needs step >= {min_step} and step * height bytes; \
         got step {step} and {len} bytes"
    )]
    Layout {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Encoding.
        encoding: String,
        /// Smallest valid step.
        min_step: u64,
        /// Step given.
        step: u32,
        /// Bytes given.
        len: usize,
    },
    /// The size itself is invalid (zero).
    #[error("image is invalid: {0}")]
    Image(#[from] ImageError),
}

impl ImageMsg {
    /// A `mono8` message of a grey image.
    pub fn from_gray(header: Header, image: &GrayImage) -> Self {
        ImageMsg {
            header,
            height: image.height() as u32,
            width: image.width() as u32,
            encoding: PixelEncoding::Mono8.name().into(),
            is_bigendian: 0,
            step: image.width() as u32,
            data: image.pixels().to_vec(),
        }
    }

    /// A tightly packed 8-bit image (`step = width * channels`); `data` must hold
    /// `width * height * channels` bytes.
    pub fn packed(
        header: Header,
        encoding: PixelEncoding,
        width: u32,
        height: u32,
        data: Vec<u8>,
    ) -> Result<Self, ImageMsgError> {
        let msg = ImageMsg {
            header,
            height,
            width,
            encoding: encoding.name().into(),
            is_bigendian: 0,
            step: width.saturating_mul(encoding.channels() as u32),
            data,
        };
        msg.layout()?;
        Ok(msg)
    }

    /// The encoding, checked against size, step and data length.
    fn layout(&self) -> Result<PixelEncoding, ImageMsgError> {
        let enc = PixelEncoding::parse(&self.encoding)
            .ok_or_else(|| ImageMsgError::Encoding(self.encoding.clone()))?;
        let min_step = u64::from(self.width) * enc.channels() as u64;
        if u64::from(self.step) < min_step
            || u64::from(self.step) * u64::from(self.height) != self.data.len() as u64
        {
            return Err(ImageMsgError::Layout {
                width: self.width,
                height: self.height,
                encoding: self.encoding.clone(),
                min_step,
                step: self.step,
                len: self.data.len(),
            });
        }
        Ok(enc)
    }

    /// The image in grey. Colour is converted with ITU-R BT.601 luma in the fixed point
    /// OpenCV's `cvtColor` uses: `Y = (4899 R + 9617 G + 1868 B + 8192) >> 14`.
    pub fn to_gray(&self) -> Result<GrayImage, ImageMsgError> {
        let enc = self.layout()?;
        let (w, h, step) = (
            self.width as usize,
            self.height as usize,
            self.step as usize,
        );
        let mut pixels = Vec::with_capacity(w * h);
        for row in self.data.chunks_exact(step.max(1)).take(h) {
            match enc {
                PixelEncoding::Mono8 => pixels.extend_from_slice(&row[..w]),
                PixelEncoding::Rgb8 | PixelEncoding::Bgr8 => {
                    let (ri, bi) = if enc == PixelEncoding::Rgb8 {
                        (0, 2)
                    } else {
                        (2, 0)
                    };
                    pixels.extend(row[..3 * w].chunks_exact(3).map(|p| {
                        let y = 4899 * u32::from(p[ri])
                            + 9617 * u32::from(p[1])
                            + 1868 * u32::from(p[bi])
                            + 8192;
                        (y >> 14) as u8
                    }));
                }
            }
        }
        Ok(GrayImage::from_raw(w, h, pixels)?)
    }
}

impl Ros2Message for ImageMsg {
    const TYPE: &'static str = "sensor_msgs/msg/Image";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "uint32 height\n",
        "uint32 width\n",
        "string encoding\n",
        "uint8 is_bigendian\n",
        "uint32 step\n",
        "uint8[] data\n",
        header_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.u32(self.height);
        w.u32(self.width);
        w.string("encoding", &self.encoding)?;
        w.u8(self.is_bigendian);
        w.u32(self.step);
        w.bytes("data", &self.data)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(ImageMsg {
            header: Header::read(r)?,
            height: r.u32("height")?,
            width: r.u32("width")?,
            encoding: r.string("encoding")?,
            is_bigendian: r.u8("is_bigendian")?,
            step: r.u32("step")?,
            data: r.bytes("data")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

/// Formats of a compressed image payload, told by its first bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompressedFormat {
    /// JPEG (starts `FF D8 FF`).
    Jpeg,
    /// PNG (starts `89 50 4E 47 0D 0A 1A 0A`).
    Png,
}

/// `sensor_msgs/msg/CompressedImage`: a JPEG or PNG file in a message, kept as is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CompressedImageMsg {
    /// ROS header.
    pub header: Header,
    /// `jpeg` or `png` (image_transport also writes e.g. `bgr8; jpeg compressed bgr8`).
    pub format: String,
    /// The compressed file's bytes.
    pub data: Vec<u8>,
}

impl CompressedImageMsg {
    /// A message carrying `data` (a JPEG or PNG file) with `format` `jpeg` or `png`.
    pub fn new(header: Header, format: CompressedFormat, data: Vec<u8>) -> Self {
        let format = match format {
            CompressedFormat::Jpeg => "jpeg",
            CompressedFormat::Png => "png",
        };
        CompressedImageMsg {
            header,
            format: format.into(),
            data,
        }
    }

    /// The payload's format from its magic bytes (not from `format`, which writers
    /// fill inconsistently); `None` for anything else.
    pub fn detected_format(&self) -> Option<CompressedFormat> {
        if self.data.starts_with(&[0xFF, 0xD8, 0xFF]) {
            Some(CompressedFormat::Jpeg)
        } else if self.data.starts_with(b"\x89PNG\r\n\x1a\n") {
            Some(CompressedFormat::Png)
        } else {
            None
        }
    }
}

impl Ros2Message for CompressedImageMsg {
    const TYPE: &'static str = "sensor_msgs/msg/CompressedImage";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "string format\n",
        "uint8[] data\n",
        header_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        w.string("format", &self.format)?;
        w.bytes("data", &self.data)
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(CompressedImageMsg {
            header: Header::read(r)?,
            format: r.string("format")?,
            data: r.bytes("data")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}
