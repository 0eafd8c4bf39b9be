//! Camera frames for the live robot: a folder of images served at a frame rate, or a
//! V4L2 device (cargo feature `v4l2`). Frames come out as 8-bit grey, what the cascade
//! detector reads; the caller ([`super::camera`]) stamps each frame when it arrives.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tether_msgs::CompressedFormat;

use tether_core::{GrayImage, ImageError};
use tether_image::ImreadError;

/// Why a frame source cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// The folder cannot be listed, or holds no image.
    #[error("camera folder {path}: {message}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An image of the folder cannot be decoded.
    #[error("camera frame {path}: {message}")]
    Frame {
        /// The image.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The device failed or sent something unusable.
    #[error("camera {device}: {message}")]
    Device {
        /// The device.
        device: String,
        /// What is wrong.
        message: String,
    },
}

/// A source of camera frames.
pub trait FrameSource: Send {
    /// Waits for the next frame; `Ok(None)` when there are no more.
    fn next_frame(&mut self) -> Result<Option<GrayImage>, CameraError>;
    /// What the source is, for messages.
    fn describe(&self) -> String;
    /// The last frame as the file or the device delivered it (a folder's PNG or JPEG,
    /// a V4L2 MJPG frame), when the source has it, for the recording; taken, so a
    /// second call gives `None`. Other frames are recorded as PNG ([`png_of`]).
    fn take_encoded(&mut self) -> Option<EncodedFrame> {
        None
    }
}

/// A camera frame as compressed bytes, recorded as `sensor_msgs/msg/CompressedImage`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EncodedFrame {
    /// JPEG or PNG.
    pub format: CompressedFormat,
    /// The file's bytes.
    pub bytes: Vec<u8>,
}

/// An 8-bit grey PNG of `image` (fast compression: a frame of a live run, recorded).
pub fn png_of(image: &GrayImage) -> EncodedFrame {
    let mut bytes = Vec::new();
    let (w, h) = (image.width() as u32, image.height() as u32);
    let mut encoder = png::Encoder::new(&mut bytes, w, h);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    // Writing into a Vec fails only on a size the image cannot have.
    let written = encoder
        .write_header()
        .and_then(|mut writer| writer.write_image_data(image.pixels()));
    if written.is_err() {
        bytes.clear();
    }
    EncodedFrame {
        format: CompressedFormat::Png,
        bytes,
    }
}

/// The images of a folder (`.png`, `.jpg`, `.jpeg`, in name order), one every
/// `1 / fps` seconds.
pub struct FolderFrames {
    folder: PathBuf,
    files: Vec<PathBuf>,
    next: usize,
    period: Duration,
    due: Option<Instant>,
    repeat: bool,
    size: Option<(u32, u32)>,
    /// The last frame's file bytes, for the recording.
    last_bytes: Option<EncodedFrame>,
}

impl FolderFrames {
    /// Lists the images of `folder`; serves them at `fps`, starting over at the end
    /// when `repeat` is set.
    pub fn open(folder: &Path, fps: f64, repeat: bool) -> Result<Self, CameraError> {
        let error = |message: String| CameraError::Folder {
            path: folder.to_path_buf(),
            message,
        };
        if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
            return Err(error(format!("frame rate {fps} must be in (0, 1000] fps")));
        }
        let entries = std::fs::read_dir(folder).map_err(|e| error(e.to_string()))?;
        let mut files = Vec::new();
        for entry in entries {
            let path = entry.map_err(|e| error(e.to_string()))?.path();
            let image = path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"));
            if image && path.is_file() {
                files.push(path);
            }
        }
        files.sort();
        if files.is_empty() {
            return Err(error("holds no .png, .jpg or .jpeg image".into()));
        }
        Ok(FolderFrames {
            folder: folder.to_path_buf(),
            files,
            next: 0,
            period: Duration::from_secs_f64(1.0 / fps),
            due: None,
            repeat,
            size: None,
            last_bytes: None,
        })
    }

    /// Frames must be `width` x `height` (the camera's intrinsics): a file of another
    /// size is refused from its header, before it is decoded (a damaged or hostile
    /// file claiming 32768 x 32768 pixels allocates nothing).
    #[must_use]
    pub fn sized(self, width: u32, height: u32) -> Self {
        FolderFrames {
            size: Some((width, height)),
            ..self
        }
    }

    /// The images, in the order they are served.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }
}

impl FrameSource for FolderFrames {
    fn next_frame(&mut self) -> Result<Option<GrayImage>, CameraError> {
        if self.next >= self.files.len() {
            if !self.repeat {
                return Ok(None);
            }
            self.next = 0;
        }
        let now = Instant::now();
        let due = *self.due.get_or_insert(now);
        if let Some(wait) = due.checked_duration_since(now) {
            std::thread::sleep(wait);
        }
        // A slow reader does not get a burst of late frames.
        self.due = Some((due + self.period).max(Instant::now()));
        let path = &self.files[self.next];
        self.next += 1;
        self.last_bytes = None;
        let bad = |message: String| CameraError::Frame {
            path: path.clone(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
        // The header's size is before any EXIF rotation, which may swap the two.
        if let (Some((expected_w, expected_h)), Some((w, h))) =
            (self.size, tether_image::imread::dimensions(&bytes))
            && (w, h) != (expected_w, expected_h)
            && (h, w) != (expected_w, expected_h)
        {
            return Err(bad(format!(
                "the image is {w}x{h} pixels, not the camera's {expected_w}x{expected_h}"
            )));
        }
        let image = tether_image::imread::decode_gray(&bytes).map_err(|e| bad(e.to_string()))?;
        let format = if bytes.starts_with(&[0xff, 0xd8]) {
            CompressedFormat::Jpeg
        } else {
            CompressedFormat::Png
        };
        self.last_bytes = Some(EncodedFrame { format, bytes });
        Ok(Some(image))
    }

    fn take_encoded(&mut self) -> Option<EncodedFrame> {
        self.last_bytes.take()
    }

    fn describe(&self) -> String {
        format!(
            "{} images of {} at {:.1} fps",
            self.files.len(),
            self.folder.display(),
            1.0 / self.period.as_secs_f64()
        )
    }
}

/// Why a raw frame has no grey levels.
#[derive(Debug, thiserror::Error)]
pub enum RawFrameError {
    /// A compressed frame that does not decode.
    #[error("{fourcc} frame: {source}")]
    Decode {
        /// The pixel format.
        fourcc: String,
        /// What the decoder met.
        source: ImreadError,
    },
    /// A pixel format tether does not read.
    #[error("pixel format {fourcc} is not supported (use GREY, YUYV or MJPG)")]
    Unsupported {
        /// The pixel format.
        fourcc: String,
    },
    /// Fewer bytes than the frame's size needs.
    #[error("{fourcc} frame of {len} bytes is too short for {width}x{height} (stride {stride})")]
    TooShort {
        /// The pixel format.
        fourcc: String,
        /// Bytes given.
        len: usize,
        /// Frame width, px.
        width: usize,
        /// Frame height, px.
        height: usize,
        /// Bytes per line.
        stride: usize,
    },
    /// The size itself is invalid (zero).
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// Grey levels of a raw frame in a V4L2 pixel format: `GREY`, `YUYV` (the luma of every
/// other byte), `MJPG`/`JPEG` (decoded). `stride` is the bytes per line (0: packed).
pub fn grey_from_raw(
    fourcc: [u8; 4],
    width: usize,
    height: usize,
    stride: usize,
    bytes: &[u8],
) -> Result<GrayImage, RawFrameError> {
    let name = String::from_utf8_lossy(&fourcc).into_owned();
    let per_pixel = match &fourcc {
        b"GREY" => 1,
        b"YUYV" => 2,
        b"MJPG" | b"JPEG" => {
            return tether_image::imread::decode_gray(bytes).map_err(|source| {
                RawFrameError::Decode {
                    fourcc: name,
                    source,
                }
            });
        }
        _ => return Err(RawFrameError::Unsupported { fourcc: name }),
    };
    let line = if stride == 0 {
        width * per_pixel
    } else {
        stride
    };
    if line < width * per_pixel || bytes.len() < line * height.saturating_sub(1) + width * per_pixel
    {
        return Err(RawFrameError::TooShort {
            fourcc: name,
            len: bytes.len(),
            width,
            height,
            stride: line,
        });
    }
    let mut pixels = Vec::with_capacity(width * height);
    for y in 0..height {
        let row = &bytes[y * line..y * line + width * per_pixel];
        pixels.extend(row.iter().step_by(per_pixel));
    }
    Ok(GrayImage::from_raw(width, height, pixels)?)
}

#[cfg(feature = "v4l2")]
mod v4l2 {
    use super::{CameraError, FrameSource, grey_from_raw};
    use tether_core::GrayImage;
    use v4l::buffer::Type;
    use v4l::io::traits::CaptureStream;
    use v4l::video::Capture;
    use v4l::{Device, FourCC};

    /// Frames of a V4L2 capture device (memory-mapped streaming).
    pub struct V4l2Frames {
        device: String,
        stream: v4l::io::mmap::Stream<'static>,
        fourcc: [u8; 4],
        width: usize,
        height: usize,
        stride: usize,
    }

    impl V4l2Frames {
        /// Opens `device` and asks for `width` x `height` frames in YUYV (what most
        /// webcams deliver uncompressed), accepting GREY or MJPG if that is what the
        /// driver sets instead; a device that will not deliver that size is refused.
        pub fn open(device: &str, width: u32, height: u32) -> Result<Self, CameraError> {
            let error = |message: String| CameraError::Device {
                device: device.to_owned(),
                message,
            };
            let dev = Device::with_path(device).map_err(|e| error(e.to_string()))?;
            let mut format = dev.format().map_err(|e| error(e.to_string()))?;
            format.width = width;
            format.height = height;
            format.fourcc = FourCC::new(b"YUYV");
            let format = dev
                .set_format(&format)
                .map_err(|e| error(format!("setting the format: {e}")))?;
            // The monocular model's ranges hold only for frames of the calibrated size.
            if (format.width, format.height) != (width, height) {
                return Err(error(format!(
                    "delivers {}x{} frames, not the {width}x{height} of [camera.intrinsics]: \
                     calibrate the camera at the size it delivers (tether calibrate camera) \
                     or use a device mode of {width}x{height}",
                    format.width, format.height
                )));
            }
            let mut stream = v4l::io::mmap::Stream::with_buffers(&dev, Type::VideoCapture, 4)
                .map_err(|e| error(format!("starting the stream: {e}")))?;
            stream.set_timeout(std::time::Duration::from_secs(2));
            Ok(V4l2Frames {
                device: device.to_owned(),
                stream,
                fourcc: format.fourcc.repr,
                width: format.width as usize,
                height: format.height as usize,
                stride: format.stride as usize,
            })
        }
    }

    impl FrameSource for V4l2Frames {
        fn next_frame(&mut self) -> Result<Option<GrayImage>, CameraError> {
            let (bytes, _meta) = self.stream.next().map_err(|e| CameraError::Device {
                device: self.device.clone(),
                message: format!("no frame: {e}"),
            })?;
            // A frame that does not decode (a damaged MJPG) is one bad frame, not the
            // end of the device.
            grey_from_raw(self.fourcc, self.width, self.height, self.stride, bytes)
                .map(Some)
                .map_err(|e| CameraError::Frame {
                    path: std::path::PathBuf::from(&self.device),
                    message: e.to_string(),
                })
        }

        fn describe(&self) -> String {
            format!(
                "V4L2 {} ({}x{} {})",
                self.device,
                self.width,
                self.height,
                String::from_utf8_lossy(&self.fourcc)
            )
        }
    }
}

#[cfg(feature = "v4l2")]
pub use v4l2::V4l2Frames;

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn a_recorded_frame_decodes_to_the_same_pixels() {
        let pixels: Vec<u8> = (0..64 * 48).map(|i| (i * 7 % 251) as u8).collect();
        let image = GrayImage::from_raw(64, 48, pixels).unwrap();
        let frame = png_of(&image);
        assert_eq!(frame.format, CompressedFormat::Png);
        let back = tether_image::imread::decode_gray(&frame.bytes).unwrap();
        assert_eq!(back, image);
    }

    #[test]
    fn yuyv_and_grey_frames() {
        // 2x2 YUYV with a stride of 6 bytes (2 bytes of padding per line).
        let yuyv = [10, 128, 20, 128, 0, 0, 30, 128, 40, 128];
        let g = grey_from_raw(*b"YUYV", 2, 2, 6, &yuyv).unwrap();
        assert_eq!(g.pixels(), &[10, 20, 30, 40]);
        let g = grey_from_raw(*b"GREY", 2, 2, 0, &[1, 2, 3, 4]).unwrap();
        assert_eq!(g.pixels(), &[1, 2, 3, 4]);
        assert!(grey_from_raw(*b"YUYV", 2, 2, 0, &[0; 7]).is_err());
        assert!(
            grey_from_raw(*b"RGB3", 2, 2, 0, &[0; 12])
                .unwrap_err()
                .to_string()
                .contains("RGB3")
        );
        assert!(grey_from_raw(*b"MJPG", 2, 2, 0, b"not a jpeg").is_err());
    }

    #[cfg(feature = "v4l2")]
    #[test]
    fn a_missing_v4l2_device_is_a_clear_error() {
        let e = V4l2Frames::open("/dev/video-tether-missing", 640, 480)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("/dev/video-tether-missing"), "{e}");
    }

    #[test]
    fn folder_frames_in_name_order_then_end() {
        let dir = std::env::temp_dir().join(format!("tether-frames-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, level) in [("b.png", 200u8), ("a.png", 100u8)] {
            let file = std::fs::File::create(dir.join(name)).unwrap();
            let mut encoder = png::Encoder::new(file, 3, 2);
            encoder.set_color(png::ColorType::Grayscale);
            encoder.set_depth(png::BitDepth::Eight);
            encoder
                .write_header()
                .unwrap()
                .write_image_data(&[level; 6])
                .unwrap();
        }
        std::fs::write(dir.join("notes.txt"), "not a frame").unwrap();
        let mut frames = FolderFrames::open(&dir, 100.0, false).unwrap();
        assert_eq!(frames.files().len(), 2);
        let started = Instant::now();
        let a = frames.next_frame().unwrap().unwrap();
        let b = frames.next_frame().unwrap().unwrap();
        assert!(
            started.elapsed() >= Duration::from_millis(9),
            "paced at 100 fps"
        );
        assert_eq!((a.width(), a.height(), a.pixels()[0]), (3, 2, 100));
        assert_eq!(b.pixels()[0], 200);
        assert!(frames.next_frame().unwrap().is_none());
        let mut again = FolderFrames::open(&dir, 100.0, true).unwrap();
        for _ in 0..3 {
            assert!(again.next_frame().unwrap().is_some());
        }
        let empty = dir.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        let e = FolderFrames::open(&empty, 10.0, false)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("no .png"), "{e}");
        // Sized to the camera: the 3x2 frames pass, a frame of another size does not.
        let mut sized = FolderFrames::open(&dir, 100.0, false).unwrap().sized(3, 2);
        assert!(sized.next_frame().unwrap().is_some());
        let mut other = FolderFrames::open(&dir, 100.0, false)
            .unwrap()
            .sized(640, 480);
        let e = other.next_frame().unwrap_err().to_string();
        assert!(e.contains("3x2 pixels, not the camera's 640x480"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_tiny_file_claiming_a_huge_frame_is_refused_before_decoding() {
        let dir = std::env::temp_dir().join(format!("tether-huge-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        // SOI, a baseline SOF0 claiming 32768 x 32768 grey, then nothing worth reading.
        let mut jpeg = vec![
            0xff, 0xd8, 0xff, 0xc0, 0x00, 0x0b, 0x08, 0x80, 0x00, 0x80, 0x00,
        ];
        jpeg.extend_from_slice(&[0x01, 0x01, 0x11, 0x00]);
        jpeg.resize(333, 0);
        std::fs::write(dir.join("huge.jpg"), &jpeg).unwrap();
        let mut frames = FolderFrames::open(&dir, 100.0, false)
            .unwrap()
            .sized(640, 480);
        let e = frames.next_frame().unwrap_err().to_string();
        assert!(e.contains("32768x32768"), "{e}");
        // Unsized (as `tether detect` reads files), the pixel cap refuses it.
        let e = tether_image::imread_gray(dir.join("huge.jpg")).unwrap_err();
        assert!(
            matches!(
                e,
                ImreadError::TooLarge {
                    width: 32768,
                    height: 32768
                }
            ),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
