//! PNG and JPEG files to 8-bit grey, as `cv2.imread(path, cv2.IMREAD_GRAYSCALE)` gives
//! them (OpenCV 4.x with its libpng and libjpeg-turbo), so that detections on a file match
//! OpenCV's.
//!
//! OpenCV does not decode to colour and convert: it asks the codec libraries for grey.
//!
//! **PNG** (libpng, measured against OpenCV 4.14 and libpng 1.6):
//! - palette images are expanded to RGB, grey images below 8 bits are scaled to 8 bits,
//!   alpha is dropped (not composited);
//! - RGB becomes grey with libpng's `png_set_rgb_to_gray(1, 0.299, 0.587)`: 15-bit
//!   coefficients `rc = 9797, gc = 19234, bc = 3737` and, for a pixel with unequal
//!   channels, `(rc R + gc G + bc B) >> 15` (truncating); a pixel with `R = G = B` keeps
//!   its value;
//! - when the file declares a gamma that is not close to 1 (`gAMA` outside
//!   0.95..1.05, or `sRGB`, which means 0.45455), libpng converts in linear light:
//!   `from1[(rc to1[R] + gc to1[G] + bc to1[B] + 16384) >> 15]` with 8-bit tables
//!   `to1[i] = floor(255 (i/255)^(1/g) + 0.5)` and `from1[i] = floor(255 (i/255)^g + 0.5)`
//!   (`png_build_8bit_table`);
//! - 16-bit samples are converted at 16 bits (`(rc R + gc G + bc B + 16384) >> 15`, and with
//!   a file gamma through libpng's 16-bit tables indexed by the top 11 bits) and then reduced
//!   by keeping the high byte (`png_set_strip_16`). One case is approximate: the grey
//!   pixels (`R = G = B`) of a 16-bit colour PNG with a gamma chunk go through a libpng
//!   16-to-8 table tether does not reproduce; they keep their high byte, which can be one
//!   level off.
//!
//! **JPEG** (libjpeg-turbo 3.1, OpenCV's `JCS_GRAYSCALE` request): tether's own decoder,
//! [`crate::jpeg`], reproduces it bit for bit: the luma plane of a YCbCr file (upsampled
//! with libjpeg's filters when luma is itself subsampled), libjpeg's RGB-to-grey for RGB
//! files, libjpeg's CMYK output turned grey by OpenCV's formula for 4-component files,
//! the `JDCT_ISLOW` inverse DCT with the arithmetic of libjpeg-turbo's x86 SIMD code,
//! and libjpeg's handling of truncated and damaged data (including the block smoothing
//! of an incomplete progressive file). Measured against `cv2.imread` on the shared
//! images, the vtest frames, OpenCV-written variants, arithmetic-coded copies and
//! damaged copies: all pixels equal (`tests/jpeg_parity.rs`). Lossless and 12-bit files
//! are refused with an error that says so.
//!
//! **Orientation**: like `imread` without `IMREAD_IGNORE_ORIENTATION`, an EXIF
//! orientation tag (JPEG APP1 or PNG `eXIf`) is applied.

use std::path::{Path, PathBuf};

use thiserror::Error;

use tether_core::{GrayImage, ImageError};

/// Why an image file cannot be read as grey.
#[derive(Debug, Error)]
pub enum ImreadError {
    /// The file could not be read.
    #[error("cannot read image {path} (check the path and permissions)")]
    Io {
        /// The file.
        path: PathBuf,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// The file holds no bytes at all.
    #[error("the file is empty (0 bytes): an interrupted copy or write?")]
    Empty,
    /// The header claims a picture far larger than the bytes that follow could encode
    /// even if it were one flat colour: a truncated file or a damaged header, refused
    /// before its pixels are allocated ([`min_plausible_bytes`]).
    #[error(
        "the header claims {width}x{height} pixels but the file holds only {bytes} bytes, \
         fewer than the {needed} bytes even a flat picture of that size takes: the file is \
         truncated or its header is damaged"
    )]
    Implausible {
        /// Width the header claims, px.
        width: u32,
        /// Height the header claims, px.
        height: u32,
        /// The file's length.
        bytes: usize,
        /// The fewest bytes a complete picture of that size takes.
        needed: u64,
    },
    /// Neither PNG nor JPEG.
    #[error(
        "unsupported image format (the file starts with {magic:02x?}): tether reads PNG and \
         JPEG; convert other formats first, e.g. `convert in.bmp out.png`"
    )]
    UnknownFormat {
        /// The first bytes.
        magic: Vec<u8>,
    },
    /// The PNG decoder refused the data.
    #[error("invalid PNG: {0}; the file is damaged or truncated")]
    Png(String),
    /// The JPEG decoder refused the data.
    #[error("cannot decode JPEG: {0}")]
    Jpeg(#[source] crate::jpeg::JpegError),
    /// The decoded pixels do not form an image.
    #[error("decoded image is unusable: {0}")]
    Image(#[from] ImageError),
    /// The header claims more pixels than tether decodes ([`MAX_DECODE_PIXELS`]):
    /// refused before anything is allocated.
    #[error(
        "the image claims {width}x{height} pixels, more than tether decodes ({} megapixels); \
         scale it down first",
        MAX_DECODE_PIXELS >> 20
    )]
    TooLarge {
        /// Width the header claims, px.
        width: u32,
        /// Height the header claims, px.
        height: u32,
    },
    /// The image is not the size the caller needs (a camera's frames must match its
    /// intrinsics): refused before it is decoded.
    #[error(
        "the image is {width}x{height} pixels, not the expected {expected_width}x{expected_height}"
    )]
    WrongSize {
        /// Width the header claims, px.
        width: u32,
        /// Height the header claims, px.
        height: u32,
        /// Width expected, px.
        expected_width: u32,
        /// Height expected, px.
        expected_height: u32,
    },
}

/// The most pixels tether decodes from one file (64 megapixels, 8192 x 8192): a header
/// that claims more is refused before any allocation. OpenCV's `imread` takes up to
/// 2^30, which for a 333-byte file claiming 32768 x 32768 means gigabytes allocated and
/// filled for a picture that is not there; no camera a follower carries comes close.
pub const MAX_DECODE_PIXELS: u64 = 1 << 26;

/// The width and height a PNG or JPEG header claims, read without decoding (PNG: the
/// `IHDR` chunk; JPEG: the first start-of-frame marker), or `None` when the header does
/// not say (damaged, or another format).
pub fn dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        if bytes.get(12..16)? != b"IHDR" {
            return None;
        }
        let be = |i: usize| -> Option<u32> {
            Some(u32::from_be_bytes(bytes.get(i..i + 4)?.try_into().ok()?))
        };
        return Some((be(16)?, be(20)?));
    }
    if !bytes.starts_with(&[0xff, 0xd8]) {
        return None;
    }
    let mut at = 2;
    loop {
        // Markers may be preceded by any number of 0xff fill bytes.
        while *bytes.get(at)? != 0xff {
            at += 1;
        }
        while *bytes.get(at)? == 0xff {
            at += 1;
        }
        let marker = *bytes.get(at)?;
        at += 1;
        match marker {
            // FF 00 is a stuffed zero, not a marker: the decoder (libjpeg's
            // `next_marker`) discards it with the garbage before it and reads on, so
            // must this scan, or a frame after it decodes at a size never checked.
            0x00 => {}
            // Start of frame: every SOFn but DHT (c4), JPG (c8) and DAC (cc).
            0xc0..=0xcf if !matches!(marker, 0xc4 | 0xc8 | 0xcc) => {
                let b = bytes.get(at + 3..at + 7)?;
                let height = u32::from(u16::from_be_bytes([b[0], b[1]]));
                let width = u32::from(u16::from_be_bytes([b[2], b[3]]));
                return Some((width, height));
            }
            // Start of scan or end of image before any frame: no size.
            0xda | 0xd9 => return None,
            // Markers without a length.
            0x01 | 0xd0..=0xd8 => {}
            _ => {
                let len = usize::from(u16::from_be_bytes([*bytes.get(at)?, *bytes.get(at + 1)?]));
                at += len;
            }
        }
    }
}

/// Pictures up to this many pixels are decoded however short their file, as OpenCV
/// does (a truncated JPEG decodes grey past the cut, bit for bit like libjpeg); larger
/// ones must hold at least [`min_plausible_bytes`].
pub const PLAUSIBILITY_FROM_PIXELS: u64 = 1 << 22;

/// The fewest bytes a complete PNG or JPEG of `width` x `height` takes, however flat
/// the picture: a JPEG codes at least one bit per 8x8 luma block (its DC difference),
/// so `ceil(w/8) ceil(h/8) / 8` bytes; a PNG's deflate stream expands at most 1032:1
/// (a 258-byte match per 2-bit code at best), so `h (w + 1) / 1032` bytes for the
/// narrowest (1-bit grey is not counted: tether reads 8-bit rows). Below it the file
/// cannot hold the picture its header claims, and decoding it would allocate the
/// whole picture for nothing (a 1 KB progressive JPEG claiming 8000x8000 took 1.6 GB).
pub fn min_plausible_bytes(bytes: &[u8], width: u32, height: u32) -> u64 {
    let (w, h) = (u64::from(width), u64::from(height));
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        // Bit depth and colour type are at IHDR bytes 24 and 25; 1-, 2- and 4-bit
        // rows are narrower than a byte per pixel.
        let bits = u64::from(bytes.get(24).copied().unwrap_or(1).max(1));
        h * ((w * bits).div_ceil(8) + 1) / 1032
    } else {
        w.div_ceil(8) * h.div_ceil(8) / 8
    }
}

fn refuse_too_large(bytes: &[u8]) -> Result<(), ImreadError> {
    if bytes.is_empty() {
        return Err(ImreadError::Empty);
    }
    let Some((width, height)) = dimensions(bytes) else {
        return Ok(());
    };
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_DECODE_PIXELS {
        return Err(ImreadError::TooLarge { width, height });
    }
    let needed = min_plausible_bytes(bytes, width, height);
    if pixels > PLAUSIBILITY_FROM_PIXELS && (bytes.len() as u64) < needed {
        return Err(ImreadError::Implausible {
            width,
            height,
            bytes: bytes.len(),
            needed,
        });
    }
    Ok(())
}

/// [`imread_gray`] for a file that must be `width` x `height` (a camera's frame): a
/// file of another size is refused from its header, before it is decoded.
pub fn imread_gray_sized(
    path: impl AsRef<Path>,
    (expected_width, expected_height): (u32, u32),
) -> Result<GrayImage, ImreadError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ImreadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // The header's size is before any EXIF rotation, which may swap the two.
    if let Some((width, height)) = dimensions(&bytes)
        && (width, height) != (expected_width, expected_height)
        && (height, width) != (expected_width, expected_height)
    {
        return Err(ImreadError::WrongSize {
            width,
            height,
            expected_width,
            expected_height,
        });
    }
    decode_gray(&bytes)
}

/// Reads a PNG or JPEG file as 8-bit grey, like `cv2.imread(path, cv2.IMREAD_GRAYSCALE)`.
pub fn imread_gray(path: impl AsRef<Path>) -> Result<GrayImage, ImreadError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ImreadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode_gray(&bytes)
}

/// Decodes PNG or JPEG bytes (recognised by their signature) as 8-bit grey.
pub fn decode_gray(bytes: &[u8]) -> Result<GrayImage, ImreadError> {
    decode_gray_warned(bytes).map(|(image, _)| image)
}

/// [`imread_gray`] with the damage that was decoded anyway (a JPEG cut short decodes
/// grey past the cut, as libjpeg does): one line per warning, empty for a sound file.
pub fn imread_gray_warned(path: impl AsRef<Path>) -> Result<(GrayImage, Vec<String>), ImreadError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ImreadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode_gray_warned(&bytes)
}

/// [`decode_gray`] with the damage that was decoded anyway (see [`imread_gray_warned`]).
pub fn decode_gray_warned(bytes: &[u8]) -> Result<(GrayImage, Vec<String>), ImreadError> {
    refuse_too_large(bytes)?;
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes).map(|image| (image, Vec::new()))
    } else if bytes.starts_with(&[0xff, 0xd8]) {
        decode_jpeg(bytes)
    } else {
        Err(ImreadError::UnknownFormat {
            magic: bytes.iter().take(8).copied().collect(),
        })
    }
}

/// libpng's `rgb_to_gray` coefficients for `png_set_rgb_to_gray(png, 1, 0.299, 0.587)`:
/// `(png_uint_16)(fixed * 32768 / 100000)` for red and green, blue the remainder.
const RC: u32 = 29_900 * 32_768 / 100_000;
const GC: u32 = 58_700 * 32_768 / 100_000;
const BC: u32 = 32_768 - RC - GC;

/// libpng's `png_reciprocal`: `1 / a` in its 1e5 fixed point.
fn png_reciprocal(a: i64) -> i64 {
    (1e10 / a as f64 + 0.5).floor() as i64
}

/// libpng's `png_gamma_significant`: further than 0.05 from 1.
fn gamma_significant(gamma_fixed: i64) -> bool {
    !(95_000..=105_000).contains(&gamma_fixed)
}

/// libpng's `png_build_16bit_table` for samples reduced to their top `16 - shift` bits:
/// `floor(65535 (i / max)^g + 0.5)`, or a plain rescaling when `g` is close to 1.
fn gamma_table_16(gamma_fixed: i64, shift: u32) -> Vec<u16> {
    let max = (1u32 << (16 - shift)) - 1;
    (0..=max)
        .map(|i| {
            if gamma_significant(gamma_fixed) {
                (65535.0 * (f64::from(i) / f64::from(max)).powf(gamma_fixed as f64 * 1e-5) + 0.5)
                    .floor() as u16
            } else {
                ((i * 65535 + max / 2) / max) as u16
            }
        })
        .collect()
}

/// libpng's `png_build_8bit_table`.
fn gamma_table_8(gamma_fixed: i64) -> [u8; 256] {
    let mut t = [0u8; 256];
    for (i, v) in t.iter_mut().enumerate() {
        *v = if i > 0 && i < 255 && gamma_significant(gamma_fixed) {
            (255.0 * (i as f64 / 255.0).powf(gamma_fixed as f64 * 1e-5) + 0.5).floor() as u8
        } else {
            i as u8
        };
    }
    t
}

fn decode_png(bytes: &[u8]) -> Result<GrayImage, ImreadError> {
    use png::{BitDepth, ColorType, Transformations};
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_limits(png::Limits { bytes: 1 << 30 });
    // Palette to RGB, low-bit grey to 8 bits, tRNS to alpha (dropped below): what libpng
    // does for OpenCV. 16-bit samples stay 16-bit so grey is computed before stripping.
    decoder.set_transformations(Transformations::EXPAND);
    let mut reader = decoder
        .read_info()
        .map_err(|e| ImreadError::Png(e.to_string()))?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    // libpng takes sRGB to mean gamma 0.45455 and lets it override gAMA.
    let file_gamma = if info.srgb.is_some() {
        Some(45_455)
    } else {
        info.gama_chunk.map(|g| i64::from(g.into_scaled()))
    };
    let exif = info.exif_metadata.as_ref().map(|e| e.to_vec());
    let sbit: Vec<u8> = info.sbit.as_deref().map(<[u8]>::to_vec).unwrap_or_default();
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| ImreadError::Png("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let frame = reader
        .next_frame(&mut buf)
        .map_err(|e| ImreadError::Png(e.to_string()))?;
    let line = frame.line_size;
    let channels = frame.color_type.samples();
    let sixteen = frame.bit_depth == BitDepth::Sixteen;
    let color = matches!(frame.color_type, ColorType::Rgb | ColorType::Rgba);
    let gamma = file_gamma.filter(|g| *g > 0 && gamma_significant(*g));
    // libpng's gamma tables: 8-bit ones, or for 16-bit samples tables indexed by the top
    // `16 - shift` bits (`png_build_16bit_table`; `shift` is at least 5 when stripping to
    // 8 bits, more when sBIT says fewer bits are significant).
    let shift = {
        let sig = sbit.iter().copied().max().unwrap_or(0);
        let from_sbit = if sig > 0 && sig < 16 {
            16 - u32::from(sig)
        } else {
            0
        };
        from_sbit.clamp(5, 8)
    };
    let tables = gamma.map(|g| {
        let screen = png_reciprocal(g);
        if sixteen {
            (
                gamma_table_16(png_reciprocal(g), shift),
                gamma_table_16(png_reciprocal(screen), shift),
            )
        } else {
            (
                gamma_table_8(png_reciprocal(g)).map(u16::from).to_vec(),
                gamma_table_8(png_reciprocal(screen))
                    .map(u16::from)
                    .to_vec(),
            )
        }
    });
    // Index of a sample in a table: 8-bit samples as they are, 16-bit ones by their top
    // bits.
    let index = |v: u32| {
        if sixteen {
            (v >> shift) as usize
        } else {
            v as usize
        }
    };
    let mut grey = vec![0u8; width * height];
    for y in 0..height {
        let row = &buf[y * line..y * line + width * channels * if sixteen { 2 } else { 1 }];
        let out = &mut grey[y * width..(y + 1) * width];
        for (x, o) in out.iter_mut().enumerate() {
            let sample = |c: usize| -> u32 {
                let i = x * channels + c;
                if sixteen {
                    u32::from(row[2 * i]) << 8 | u32::from(row[2 * i + 1])
                } else {
                    u32::from(row[i])
                }
            };
            let v = if color {
                let (r, g, b) = (sample(0), sample(1), sample(2));
                if r == g && r == b {
                    r
                } else if let Some((to1, from1)) = &tables {
                    let lin = |c: u32| u32::from(to1.get(index(c)).copied().unwrap_or(0));
                    let w = (RC * lin(r) + GC * lin(g) + BC * lin(b) + 16_384) >> 15;
                    u32::from(from1.get(index(w)).copied().unwrap_or(0))
                } else if sixteen {
                    // libpng rounds in its 16-bit path.
                    (RC * r + GC * g + BC * b + 16_384) >> 15
                } else {
                    (RC * r + GC * g + BC * b) >> 15
                }
            } else {
                sample(0)
            };
            *o = if sixteen { (v >> 8) as u8 } else { v as u8 };
        }
    }
    let image = GrayImage::from_raw(width, height, grey)?;
    Ok(match exif.as_deref().and_then(exif_orientation) {
        Some(o) => apply_orientation(&image, o),
        None => image,
    })
}

fn decode_jpeg(bytes: &[u8]) -> Result<(GrayImage, Vec<String>), ImreadError> {
    let decoded = crate::jpeg::decode_gray(bytes).map_err(ImreadError::Jpeg)?;
    let warnings = decoded.warnings.iter().map(ToString::to_string).collect();
    let image = GrayImage::from_raw(decoded.width, decoded.height, decoded.pixels)?;
    let image = match decoded.exif.as_deref().and_then(exif_orientation) {
        Some(o) => apply_orientation(&image, o),
        None => image,
    };
    Ok((image, warnings))
}

/// The EXIF orientation tag (0x0112) of IFD0 in a TIFF-structured EXIF block (with or
/// without the `Exif\0\0` prefix), when it is 2..=8.
pub fn exif_orientation(exif: &[u8]) -> Option<u16> {
    let tiff = exif.strip_prefix(b"Exif\0\0").unwrap_or(exif);
    let big = match tiff.get(..2)? {
        b"MM" => true,
        b"II" => false,
        _ => return None,
    };
    let u16_at = |o: usize| -> Option<u16> {
        let b = tiff.get(o..o + 2)?;
        Some(if big {
            u16::from_be_bytes([b[0], b[1]])
        } else {
            u16::from_le_bytes([b[0], b[1]])
        })
    };
    let u32_at = |o: usize| -> Option<u32> {
        let b = tiff.get(o..o + 4)?;
        let a = [b[0], b[1], b[2], b[3]];
        Some(if big {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        })
    };
    let ifd = u32_at(4)? as usize;
    let count = usize::from(u16_at(ifd)?);
    (0..count)
        .find_map(|i| {
            let entry = ifd + 2 + 12 * i;
            (u16_at(entry)? == 0x0112)
                .then(|| u16_at(entry + 8))
                .flatten()
        })
        .filter(|o| (2..=8).contains(o))
}

/// Applies an EXIF orientation as OpenCV's `ExifTransform` does (flips and transposes).
pub fn apply_orientation(image: &GrayImage, orientation: u16) -> GrayImage {
    let (w, h) = (image.width(), image.height());
    let transpose = orientation >= 5;
    // After the optional transpose: flip columns and/or rows.
    let (flip_x, flip_y) = match orientation {
        2 | 6 => (true, false),
        3 | 7 => (true, true),
        4 | 8 => (false, true),
        _ => (false, false),
    };
    let (ow, oh) = if transpose { (h, w) } else { (w, h) };
    let src = image.pixels();
    let mut out = vec![0u8; w * h];
    for y in 0..oh {
        for x in 0..ow {
            let (tx, ty) = (
                if flip_x { ow - 1 - x } else { x },
                if flip_y { oh - 1 - y } else { y },
            );
            let (sx, sy) = if transpose { (ty, tx) } else { (tx, ty) };
            out[y * ow + x] = src[sy * w + sx];
        }
    }
    GrayImage::from_raw(ow, oh, out).unwrap_or_else(|_| image.clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG signature and an `IHDR` claiming `w` x `h` (8-bit grey); no pixels.
    fn png_header(w: u32, h: u32) -> Vec<u8> {
        let mut b = b"\x89PNG\r\n\x1a\n".to_vec();
        b.extend_from_slice(&13u32.to_be_bytes());
        b.extend_from_slice(b"IHDR");
        b.extend_from_slice(&w.to_be_bytes());
        b.extend_from_slice(&h.to_be_bytes());
        b.extend_from_slice(&[8, 0, 0, 0, 0, 0, 0, 0, 0]);
        b
    }

    #[test]
    fn headers_give_the_size_without_decoding() {
        assert_eq!(dimensions(&png_header(640, 480)), Some((640, 480)));
        // JPEG: an APP0 segment, fill bytes, then a progressive SOF2.
        let jpeg = [
            0xff, 0xd8, 0xff, 0xe0, 0x00, 0x04, 0x4a, 0x46, 0xff, 0xff, 0xc2, 0x00, 0x0b, 0x08,
            0x01, 0xe0, 0x02, 0x80, 0x01, 0x01, 0x11, 0x00,
        ];
        assert_eq!(dimensions(&jpeg), Some((640, 480)));
        // A DHT (c4) is not a frame; a scan before any frame says nothing.
        let no_frame = [0xff, 0xd8, 0xff, 0xc4, 0x00, 0x02, 0xff, 0xda, 0x00, 0x02];
        assert_eq!(dimensions(&no_frame), None);
        for cut in 0..jpeg.len() - 4 {
            assert_eq!(dimensions(&jpeg[..cut]), None, "{cut}");
        }
        assert_eq!(dimensions(b"GIF89a"), None);
    }

    #[test]
    fn a_stuffed_zero_before_the_frame_does_not_hide_its_size() {
        // Found by the `image_decode` fuzzer: garbage holding FF 00 before the frame
        // header; the decoder skips it, the header scan took 00 for a marker with a
        // length and missed the SOF9 after it, so a 4864 x 24592 frame went unchecked
        // and 255 bytes took 120 MB. Here: a SOF0 claiming 32768 x 32768.
        let jpeg = [
            0xff, 0xd8, 0x01, 0xff, 0x00, 0x43, 0x01, 0xff, 0xc0, 0x00, 0x0b, 0x08, 0x80, 0x00,
            0x80, 0x00, 0x01, 0x01, 0x11, 0x00, 0xff, 0xd9,
        ];
        assert_eq!(dimensions(&jpeg), Some((32768, 32768)));
        let e = decode_gray(&jpeg).unwrap_err();
        assert!(matches!(e, ImreadError::TooLarge { .. }), "{e}");
    }

    #[test]
    fn a_header_claiming_too_many_pixels_is_refused_before_decoding() {
        // 390 KB of this claimed 20000 x 20000 once took 10 GB in `tether detect`.
        let e = decode_gray(&png_header(20_000, 20_000)).unwrap_err();
        assert!(
            matches!(
                e,
                ImreadError::TooLarge {
                    width: 20_000,
                    height: 20_000
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("64 megapixels"), "{e}");
        // At the limit the size is allowed, but a header alone cannot hold that picture.
        let e = decode_gray(&png_header(8192, 8192)).unwrap_err();
        assert!(matches!(e, ImreadError::Implausible { .. }), "{e}");
        // Small pictures go to the decoder however short (it refuses the missing data).
        let e = decode_gray(&png_header(640, 480)).unwrap_err();
        assert!(matches!(e, ImreadError::Png(_)), "{e}");
    }

    #[test]
    fn a_short_file_claiming_a_big_picture_is_refused_before_decoding() {
        // A 1 KB progressive JPEG claiming 8000 x 8000 once took 1.6 GB and 5.6 s.
        let mut jpeg = vec![0xff, 0xd8, 0xff, 0xc2, 0, 11, 8];
        jpeg.extend_from_slice(&8000u16.to_be_bytes());
        jpeg.extend_from_slice(&8000u16.to_be_bytes());
        jpeg.extend_from_slice(&[1, 1, 0x11, 0]);
        jpeg.resize(1024, 0);
        let e = decode_gray(&jpeg).unwrap_err();
        match e {
            ImreadError::Implausible {
                width: 8000,
                height: 8000,
                bytes: 1024,
                needed,
            } => assert_eq!(needed, 1000 * 1000 / 8),
            other => panic!("{other}"),
        }
        // The bound holds for a complete picture: a flat 2048 x 2048 PNG (as
        // compressible as a picture gets) is longer than it.
        let flat = vec![0_u8; 2048 * 2048];
        let png = encode_png(
            2048,
            2048,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &flat,
            None,
        );
        assert!(
            png.len() as u64 >= min_plausible_bytes(&png, 2048, 2048),
            "{}",
            png.len()
        );
        assert!(matches!(decode_gray(&[]), Err(ImreadError::Empty)));
    }

    fn encode_png(
        w: u32,
        h: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        data: &[u8],
        gamma: Option<u32>,
    ) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(color);
            enc.set_depth(depth);
            if let Some(g) = gamma {
                enc.set_source_gamma(png::ScaledFloat::from_scaled(g));
            }
            let mut writer = enc.write_header().unwrap();
            writer.write_image_data(data).unwrap();
        }
        out
    }

    #[test]
    fn rgb_png_uses_libpng_truncating_coefficients() {
        assert_eq!((RC, GC, BC), (9797, 19234, 3737));
        let data = [255, 0, 0, 0, 255, 0, 0, 0, 255, 7, 7, 7, 10, 20, 30];
        let png = encode_png(5, 1, png::ColorType::Rgb, png::BitDepth::Eight, &data, None);
        let g = decode_gray(&png).unwrap();
        // 255 * 9797 >> 15 = 76; 255 * 19234 >> 15 = 149; 255 * 3737 >> 15 = 29.
        let mixed = ((10 * 9797 + 20 * 19234 + 30 * 3737) >> 15) as u8;
        assert_eq!(g.pixels(), &[76, 149, 29, 7, mixed]);
    }

    #[test]
    fn sixteen_bit_keeps_the_high_byte_and_alpha_is_dropped() {
        let data = [0x12, 0xff, 0xab, 0x01];
        let png = encode_png(
            2,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Sixteen,
            &data,
            None,
        );
        assert_eq!(decode_gray(&png).unwrap().pixels(), &[0x12, 0xab]);
        let rgba = [10, 10, 10, 0, 200, 200, 200, 255];
        let png = encode_png(
            2,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Eight,
            &rgba,
            None,
        );
        assert_eq!(decode_gray(&png).unwrap().pixels(), &[10, 200]);
    }

    #[test]
    fn gamma_tagged_png_converts_in_linear_light() {
        let data = [200, 100, 50];
        let plain = encode_png(1, 1, png::ColorType::Rgb, png::BitDepth::Eight, &data, None);
        let tagged = encode_png(
            1,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            &data,
            Some(45_455),
        );
        let near_one = encode_png(
            1,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            &data,
            Some(100_000),
        );
        let p = decode_gray(&plain).unwrap().pixels()[0];
        assert_eq!(p, ((200 * RC + 100 * GC + 50 * BC) >> 15) as u8);
        assert_eq!(decode_gray(&near_one).unwrap().pixels()[0], p);
        // In linear light the bright red dominates more: the result is brighter.
        assert!(decode_gray(&tagged).unwrap().pixels()[0] > p);
    }

    #[test]
    fn refuses_other_formats() {
        let e = decode_gray(b"BM\x00\x00garbage").unwrap_err();
        assert!(e.to_string().contains("PNG and JPEG"), "{e}");
        assert!(matches!(
            decode_gray(b"\x89PNG\r\n\x1a\nbroken"),
            Err(ImreadError::Png(_))
        ));
        assert!(matches!(
            decode_gray(&[0xff, 0xd8, 0xff, 0x00]),
            Err(ImreadError::Jpeg(_))
        ));
        assert!(
            imread_gray("/nonexistent.png")
                .unwrap_err()
                .to_string()
                .contains("/nonexistent.png")
        );
    }

    #[test]
    fn orientations_match_opencv() {
        // 3x2 image:  a b c / d e f
        let img = GrayImage::from_raw(3, 2, vec![1, 2, 3, 4, 5, 6]).unwrap();
        let o = |k| apply_orientation(&img, k);
        assert_eq!(o(2).pixels(), &[3, 2, 1, 6, 5, 4]);
        assert_eq!(o(3).pixels(), &[6, 5, 4, 3, 2, 1]);
        assert_eq!(o(4).pixels(), &[4, 5, 6, 1, 2, 3]);
        // Transpose: 2x3  a d / b e / c f
        assert_eq!(o(5).pixels(), &[1, 4, 2, 5, 3, 6]);
        // Transpose then flip horizontally (rotate 90 degrees clockwise).
        assert_eq!(o(6).pixels(), &[4, 1, 5, 2, 6, 3]);
        assert_eq!(o(7).pixels(), &[6, 3, 5, 2, 4, 1]);
        assert_eq!(o(8).pixels(), &[3, 6, 2, 5, 1, 4]);
    }

    #[test]
    fn reads_exif_orientation() {
        // Little-endian TIFF, IFD at 8 with one entry: tag 0x0112, SHORT, count 1, value 6.
        let mut exif = b"Exif\0\0II*\0\x08\0\0\0\x01\0".to_vec();
        exif.extend_from_slice(&[0x12, 0x01, 3, 0, 1, 0, 0, 0, 6, 0, 0, 0]);
        assert_eq!(exif_orientation(&exif), Some(6));
        assert_eq!(exif_orientation(b"Exif\0\0II"), None);
        assert_eq!(exif_orientation(&exif[..20]), None);
    }

    /// A small PNG written here: `color` RGBA 16-bit with a gAMA chunk, else 8-bit grey.
    fn small_png(color: bool) -> Vec<u8> {
        let (w, h) = (13u32, 7u32);
        let mut out = Vec::new();
        {
            let mut e = png::Encoder::new(&mut out, w, h);
            let samples = if color {
                e.set_color(png::ColorType::Rgba);
                e.set_depth(png::BitDepth::Sixteen);
                e.set_source_gamma(png::ScaledFloat::new(0.6));
                8
            } else {
                e.set_color(png::ColorType::Grayscale);
                e.set_depth(png::BitDepth::Eight);
                1
            };
            let mut writer = e.write_header().unwrap();
            let data: Vec<u8> = (0..w * h * samples).map(|i| (i * 29 % 256) as u8).collect();
            writer.write_image_data(&data).unwrap();
        }
        out
    }

    /// Files of every kind the decoders read, to be damaged.
    fn fixtures() -> Vec<Vec<u8>> {
        vec![
            small_png(false),
            small_png(true),
            include_bytes!("../tests/data/jpeg/baseline_420_rst2.jpg").to_vec(),
            include_bytes!("../tests/data/jpeg/progressive_420.jpg").to_vec(),
            include_bytes!("../tests/data/jpeg/arith_420_rst2.jpg").to_vec(),
            include_bytes!("../tests/data/jpeg/arith_progressive_420.jpg").to_vec(),
            include_bytes!("../tests/data/jpeg/cmyk_adobe.jpg").to_vec(),
            include_bytes!("../tests/data/jpeg/luma_subsampled.jpg").to_vec(),
        ]
    }

    /// What every decode must hold: no more pixels than the cap, the header's size (or
    /// its transpose, after an EXIF rotation), and a large picture only from a file
    /// that can hold it.
    fn check_decode(bytes: &[u8]) -> Result<(), proptest::test_runner::TestCaseError> {
        if let Ok((image, _)) = decode_gray_warned(bytes) {
            let (w, h) = (image.width() as u64, image.height() as u64);
            proptest::prop_assert!(w > 0 && h > 0 && w * h <= MAX_DECODE_PIXELS);
            // Without a size in the header the cap would not have been applied.
            let size = dimensions(bytes);
            proptest::prop_assert!(
                size.is_some(),
                "decoded {w}x{h} from a header without a size"
            );
            let (cw, ch) = size.map_or((0, 0), |(cw, ch)| (u64::from(cw), u64::from(ch)));
            proptest::prop_assert!((w, h) == (cw, ch) || (w, h) == (ch, cw));
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(192))]

        /// Valid PNG and JPEG files damaged (bytes overwritten, inserted, deleted, the
        /// file cut) decode or give an error, never panic, and what decodes keeps to
        /// its header.
        #[test]
        fn damaged_images_never_panic(
            which in 0usize..8,
            edits in proptest::collection::vec((proptest::num::usize::ANY, proptest::num::u8::ANY, 0u8..4), 0..8),
            cut in proptest::option::of(proptest::num::usize::ANY),
        ) {
            let mut bytes = fixtures().swap_remove(which);
            for (at, byte, kind) in edits {
                let at = at % bytes.len().max(1);
                match kind {
                    0 if at < bytes.len() => bytes[at] = byte,
                    1 => bytes.insert(at.min(bytes.len()), byte),
                    2 if at < bytes.len() => {
                        bytes.remove(at);
                    }
                    // A big value in a size field: 0xff after a header byte.
                    _ if at + 1 < bytes.len() => {
                        bytes[at] = 0xff;
                        bytes[at + 1] = byte;
                    }
                    _ => {}
                }
            }
            if let Some(cut) = cut {
                bytes.truncate(cut % (bytes.len() + 1));
            }
            check_decode(&bytes)?;
        }

        /// Random bytes after a PNG or JPEG signature never panic.
        #[test]
        fn random_bytes_after_a_signature_never_panic(
            png in proptest::bool::ANY,
            tail in proptest::collection::vec(proptest::num::u8::ANY, 0..400),
        ) {
            let mut bytes = if png { b"\x89PNG\r\n\x1a\n".to_vec() } else { vec![0xff, 0xd8] };
            bytes.extend_from_slice(&tail);
            check_decode(&bytes)?;
        }
    }
}
