//! tether's JPEG decoder for grey output: the pixels `cv2.imread(path,
//! cv2.IMREAD_GRAYSCALE)` returns (OpenCV 4.x with its libjpeg-turbo 3.1), bit for bit.
//!
//! OpenCV asks libjpeg for `JCS_GRAYSCALE` output, so libjpeg decodes only the first
//! component of a YCbCr (JFIF) file and hands back its samples; a grey file's single
//! component likewise. tether does the same:
//!
//! - **Markers** (`jdmarker.c`): SOI, APPn (JFIF APP0 and Adobe APP14 decide the colour
//!   space as in `jdapimin.c`; the first EXIF APP1 before the image gives the
//!   orientation, as OpenCV reads it), DQT (8- and 16-bit), SOF0/SOF1 (sequential
//!   Huffman), SOF2 (progressive Huffman), SOF9 and SOF10 (sequential and progressive
//!   arithmetic coding), DHT, DAC, SOS, DRI, COM, DNL, EOI, fill bytes. Missing Huffman
//!   tables of a sequential file are the standard ones (Motion-JPEG), as in
//!   libjpeg-turbo.
//! - **Entropy decoding** (`jdhuff.c`, `jdphuff.c`): byte stuffing, restart markers with
//!   libjpeg's resynchronisation when they are missing or out of order, DC/AC first and
//!   refinement scans with EOB runs, corrupt run lengths clamped as libjpeg does.
//!   Arithmetic coding (`jdarith.c`, module `arith`): T.81's binary decoder with the
//!   DAC conditioning, zeros fed after a marker met in the data, and a scan that decodes
//!   an impossible value left alone up to the next restart marker, as libjpeg does.
//! - **Damaged data**: libjpeg warns and carries on; so does tether (the warnings are
//!   returned). Past the end of a truncated file the stream reads as fake EOI markers;
//!   the MCU in which the data runs out is decoded with zero bits and the ones after it
//!   are left zero (flat grey) until the next restart marker. A truncated progressive
//!   file keeps the coefficients it got and is smoothed as libjpeg-turbo does
//!   (`decompress_smooth_data`, its 5x5 DC interpolation).
//! - **IDCT**: `JDCT_ISLOW` with the arithmetic of libjpeg-turbo's x86 SIMD code, which
//!   OpenCV runs: identical to `jidctint.c` on every block a real encoder writes, it
//!   saturates where the C code wraps around on extreme (corrupt or crafted)
//!   coefficients (details in `jpeg/idct.rs`).
//! - **Sampling**: the luma plane is decoded at its own resolution; when it is itself
//!   subsampled relative to another component, it is upsampled to the image size with
//!   libjpeg's "fancy" (triangle) filters for 2:1 factors and replication otherwise
//!   (`jdsample.c`).
//! - **Other colour spaces**: an RGB file (Adobe transform 0 or component ids `R G B`)
//!   becomes grey with libjpeg's `rgb_gray_convert`
//!   (`(19595 R + 38470 G + 7471 B + 32768) >> 16`); 4-component files (CMYK, Adobe YCCK)
//!   are decoded to CMYK by libjpeg and turned grey by OpenCV's own
//!   `icvCvt_CMYK2Gray_8u_C4C1R`, both reproduced here.
//!
//! One known difference, on damaged data only: where corrupt entropy-coded data holds
//! `FF FF 00`, libjpeg-turbo's fast Huffman path takes it for a marker, abandons the
//! MCU and decodes it again with its exact path, and the coefficients of the abandoned
//! attempt stay in the block. Whether the fast path runs depends on where the 4096-byte
//! `fread` buffer of OpenCV's file source happens to end, so tether decodes such an MCU
//! as the exact path does. Valid files never contain `FF FF 00` in their scans.
//!
//! Refused with an error that names the kind: 12-bit samples, lossless (SOF3, SOF11),
//! hierarchical and differential frames, and 2- or
//! 5-or-more-component files (OpenCV cannot read these as grey either). Corrupt input
//! never panics: errors name the marker and the byte offset.

mod arith;
mod huffman;
pub(crate) mod idct;
mod output;
mod scan;
mod smooth;
mod source;

use std::fmt;

use huffman::HuffSpec;
use source::{Source, marker, marker_name};

/// A decoded grey image.
#[derive(Debug, Clone)]
pub struct JpegGray {
    /// Width in pixels (before any EXIF orientation is applied).
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` samples, row by row.
    pub pixels: Vec<u8>,
    /// The first EXIF block (`Exif\0\0` APP1 segment, prefix included) before the image
    /// data, the one OpenCV reads the orientation from.
    pub exif: Option<Vec<u8>>,
    /// What libjpeg would have warned about (damaged data that was decoded anyway).
    pub warnings: Vec<Warning>,
}

/// Damage that libjpeg reports as a warning and decodes anyway.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Warning {
    /// The file ends before its EOI marker ("Premature end of JPEG file").
    PrematureEnd {
        /// The file's length.
        offset: usize,
    },
    /// Bytes that are not part of any segment were skipped before a marker.
    ExtraneousBytes {
        /// Where the marker was found.
        offset: usize,
        /// How many bytes were skipped.
        count: usize,
        /// The marker code found after them.
        marker: u8,
    },
    /// A restart marker was missing or out of order; decoding resynchronised.
    RestartResync {
        /// Where the decoder looked for the marker.
        offset: usize,
        /// The restart number expected (0-7).
        expected: u8,
    },
    /// A bit sequence matched no Huffman code (decoded as zero).
    BadHuffmanCode {
        /// Position in the file after the scan.
        offset: usize,
    },
    /// The entropy-coded data of a scan ended early (the rest of it is left zero).
    CorruptData {
        /// Where the scan's data ended.
        offset: usize,
    },
    /// A scan's parameters or progression are inconsistent (decoded anyway).
    BogusScan {
        /// Where the SOS marker ended.
        offset: usize,
    },
    /// Arithmetic-coded data decoded to an impossible value; the rest of the scan up to
    /// the next restart marker is left as it was.
    BadArithmeticCode {
        /// Position in the file when it was noticed.
        offset: usize,
    },
}

impl Warning {
    fn clamp_offset(&mut self, len: usize) {
        let offset = match self {
            Warning::PrematureEnd { offset }
            | Warning::ExtraneousBytes { offset, .. }
            | Warning::RestartResync { offset, .. }
            | Warning::BadHuffmanCode { offset }
            | Warning::CorruptData { offset }
            | Warning::BogusScan { offset }
            | Warning::BadArithmeticCode { offset } => offset,
        };
        *offset = (*offset).min(len);
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::PrematureEnd { offset } => {
                write!(f, "premature end of JPEG data at byte {offset}")
            }
            Warning::ExtraneousBytes {
                offset,
                count,
                marker,
            } => write!(
                f,
                "{count} extraneous bytes before {} at byte {offset}",
                marker_name(*marker)
            ),
            Warning::RestartResync { offset, expected } => write!(
                f,
                "restart marker RST{expected} missing at byte {offset}; resynchronised"
            ),
            Warning::BadHuffmanCode { offset } => {
                write!(
                    f,
                    "corrupt entropy-coded data (bad Huffman code) before byte {offset}"
                )
            }
            Warning::CorruptData { offset } => write!(
                f,
                "entropy-coded data ends early at byte {offset}; the rest of the scan is flat"
            ),
            Warning::BogusScan { offset } => {
                write!(
                    f,
                    "inconsistent scan parameters in the SOS ending at byte {offset}"
                )
            }
            Warning::BadArithmeticCode { offset } => write!(
                f,
                "corrupt arithmetic-coded data before byte {offset}; the scan stops until \
                 the next restart marker"
            ),
        }
    }
}

/// What kind of failure a [`JpegError`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JpegErrorKind {
    /// The data is not a JPEG file, or is damaged beyond what libjpeg tolerates (OpenCV
    /// returns no image for these either).
    Corrupt,
    /// A valid JPEG that tether does not decode to grey: 12-bit samples, lossless,
    /// arithmetic coding, hierarchical frames, or an unusual number of components.
    Unsupported,
    /// The image is larger than OpenCV accepts (2^30 pixels).
    TooLarge,
}

/// A JPEG file that cannot be decoded, with the place that decided it.
#[derive(Debug, Clone)]
pub struct JpegError {
    /// Why.
    pub kind: JpegErrorKind,
    /// Byte offset in the file where the problem was found.
    pub offset: usize,
    /// The marker segment being read, if any.
    pub marker: Option<u8>,
    /// What was wrong.
    pub message: String,
}

impl JpegError {
    pub(crate) fn corrupt(offset: usize, marker: Option<u8>, message: impl Into<String>) -> Self {
        JpegError {
            kind: JpegErrorKind::Corrupt,
            offset,
            marker,
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(
        offset: usize,
        marker: Option<u8>,
        message: impl Into<String>,
    ) -> Self {
        JpegError {
            kind: JpegErrorKind::Unsupported,
            offset,
            marker,
            message: message.into(),
        }
    }
}

impl fmt::Display for JpegError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.marker {
            Some(m) => write!(
                f,
                "{} (in {} at byte {})",
                self.message,
                marker_name(m),
                self.offset
            ),
            None => write!(f, "{} (at byte {})", self.message, self.offset),
        }
    }
}

impl std::error::Error for JpegError {}

/// Decodes a JPEG file to 8-bit grey exactly as `cv2.imread(path,
/// cv2.IMREAD_GRAYSCALE)` does (before the EXIF orientation, which the caller applies:
/// see [`crate::imread`]).
pub fn decode_gray(data: &[u8]) -> Result<JpegGray, JpegError> {
    let mut d = Decoder::new(data);
    d.decode()
        .map_err(|mut e| {
            if d.src.hit_end() && e.offset >= data.len() {
                // The fake EOI markers past the end made the segment unreadable.
                e.offset = data.len();
                e.message = format!(
                    "{}; the file is truncated (it ends at byte {})",
                    e.message,
                    data.len()
                );
            }
            e
        })
        .map(|mut g| {
            // Offsets in the fake EOI tail past the end mean "at the end".
            for w in &mut g.warnings {
                w.clamp_offset(data.len());
            }
            g
        })
}

/// How the first scan's components and the file's colour space become grey.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ColorModel {
    /// One component, or YCbCr: the first component's samples.
    Luma,
    /// RGB: libjpeg's `rgb_gray_convert`.
    Rgb,
    /// CMYK: OpenCV's CMYK to grey.
    Cmyk,
    /// YCCK: libjpeg's YCCK to CMYK, then OpenCV's CMYK to grey.
    Ycck,
}

/// Sequential or progressive Huffman coding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Process {
    Sequential,
    Progressive,
}

/// One component of the frame, with what decoding it needs.
pub(crate) struct Component {
    pub id: u8,
    pub h: usize,
    pub v: usize,
    pub tq: u8,
    pub width_in_blocks: usize,
    pub height_in_blocks: usize,
    pub downsampled_width: usize,
    pub downsampled_height: usize,
    /// The quantisation table copied when the component's first scan starts.
    pub quant: Option<[u16; 64]>,
    /// Whether the output needs this component's samples.
    pub needed: bool,
    /// Table numbers from the current SOS.
    pub dc_tbl: usize,
    pub ac_tbl: usize,
    /// Progressive: the successive-approximation bit of each coefficient so far (-1:
    /// none), and as it was before this component's latest scan.
    pub coef_bits: [i32; 64],
    pub prev_coef_bits: [i32; 64],
    /// Multi-scan files: all coefficient blocks, `blocks_w` per row (padded to whole MCUs).
    pub coefs: Vec<[i16; 64]>,
    pub blocks_w: usize,
    pub blocks_h: usize,
    /// Decoded samples: `width_in_blocks * 8` per row.
    pub plane: Vec<u8>,
}

impl Component {
    pub fn plane_stride(&self) -> usize {
        self.width_in_blocks * 8
    }

    /// The dequantisation table as the IDCT reads it.
    pub fn idct_quant(&self) -> [i16; 64] {
        let mut q = [0i16; 64];
        if let Some(t) = &self.quant {
            for (d, s) in q.iter_mut().zip(t) {
                *d = *s as i16;
            }
        }
        q
    }
}

/// The frame header and the geometry derived from it.
pub(crate) struct Frame {
    pub process: Process,
    /// Arithmetic coding (SOF9, SOF10) instead of Huffman coding.
    pub arithmetic: bool,
    pub width: usize,
    pub height: usize,
    pub comps: Vec<Component>,
    pub hmax: usize,
    pub vmax: usize,
    pub total_imcu_rows: usize,
}

/// The current scan header.
#[derive(Clone, Default)]
pub(crate) struct ScanHeader {
    /// Component indices, in scan order.
    pub comps: Vec<usize>,
    pub ss: usize,
    pub se: usize,
    pub ah: u32,
    pub al: u32,
    /// Where the SOS segment ended (the entropy-coded data begins).
    pub data_offset: usize,
}

/// Marker-level state: tables, flags, the frame.
pub(crate) struct Decoder<'a> {
    pub src: Source<'a>,
    pub quant: [Option<[u16; 64]>; 4],
    pub dc_tables: [Option<HuffSpec>; 4],
    pub ac_tables: [Option<HuffSpec>; 4],
    pub restart_interval: u32,
    /// Arithmetic-coding conditioning (DAC).
    pub conditioning: arith::Conditioning,
    pub frame: Option<Frame>,
    pub scan: ScanHeader,
    /// Number of SOS markers read (libjpeg's `input_scan_number`).
    pub input_scan_number: u32,
    /// The restart marker number expected next.
    pub next_restart_num: u8,
    /// The last input iMCU row decoded before the data ran out (libjpeg's
    /// `last_good_iMCU_row`), for smoothing a truncated progressive file.
    pub last_good_imcu_row: usize,
    saw_sof: bool,
    saw_jfif: bool,
    adobe_transform: Option<u8>,
    exif: Option<Vec<u8>>,
}

/// What `read_markers` stopped at.
enum Event {
    Sos,
    Eoi,
}

/// The largest image OpenCV's `imread` accepts (`CV_IO_MAX_IMAGE_PIXELS`).
const MAX_PIXELS: usize = 1 << 30;
/// libjpeg's `JPEG_MAX_DIMENSION`.
const MAX_DIMENSION: usize = 65500;

impl<'a> Decoder<'a> {
    fn new(data: &'a [u8]) -> Self {
        Decoder {
            src: Source::new(data),
            quant: [None; 4],
            dc_tables: [None, None, None, None],
            ac_tables: [None, None, None, None],
            restart_interval: 0,
            conditioning: arith::Conditioning::default(),
            frame: None,
            scan: ScanHeader::default(),
            input_scan_number: 0,
            next_restart_num: 0,
            last_good_imcu_row: 0,
            saw_sof: false,
            saw_jfif: false,
            adobe_transform: None,
            exif: None,
        }
    }

    fn decode(&mut self) -> Result<JpegGray, JpegError> {
        if self.src.len() == 0 {
            return Err(JpegError::corrupt(0, None, "empty file"));
        }
        self.src.first_marker()?;
        match self.read_markers()? {
            Event::Sos => {}
            Event::Eoi => {
                return Err(JpegError::corrupt(
                    self.src.pos(),
                    Some(marker::EOI),
                    if self.saw_sof {
                        "invalid JPEG file structure: missing SOS marker"
                    } else {
                        "JPEG datastream contains no image"
                    },
                ));
            }
        }
        let model = self.initial_setup()?;
        let multi_scan = {
            let frame = self.frame_ref()?;
            frame.process == Process::Progressive || self.scan.comps.len() < frame.comps.len()
        };
        let huffman_sequential = {
            let frame = self.frame_ref()?;
            frame.process == Process::Sequential && !frame.arithmetic
        };
        if huffman_sequential {
            // libjpeg-turbo's jinit_huff_decoder: the standard tables where none is defined.
            let std_dc = [HuffSpec::std_dc_luminance(), HuffSpec::std_dc_chrominance()];
            let std_ac = [HuffSpec::std_ac_luminance(), HuffSpec::std_ac_chrominance()];
            for (slot, spec) in self.dc_tables.iter_mut().zip(std_dc) {
                slot.get_or_insert(spec);
            }
            for (slot, spec) in self.ac_tables.iter_mut().zip(std_ac) {
                slot.get_or_insert(spec);
            }
        }
        if multi_scan {
            self.allocate_coefficients()?;
            loop {
                self.start_scan()?;
                self.decode_scan_buffered()?;
                match self.read_markers()? {
                    Event::Sos => {}
                    Event::Eoi => break,
                }
            }
            self.output_pass()?;
        } else {
            self.start_scan()?;
            self.decode_scan_streaming()?;
        }
        let (width, height) = {
            let f = self.frame_ref()?;
            (f.width, f.height)
        };
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(0, None, "no frame"))?;
        let pixels = output::to_gray(frame, model);
        Ok(JpegGray {
            width,
            height,
            pixels,
            exif: self.exif.take(),
            warnings: std::mem::take(&mut self.src.warnings),
        })
    }

    pub(crate) fn frame_ref(&self) -> Result<&Frame, JpegError> {
        self.frame
            .as_ref()
            .ok_or_else(|| JpegError::corrupt(self.src.pos(), None, "no frame header"))
    }

    /// libjpeg's `read_markers`: processes marker segments until SOS or EOI.
    fn read_markers(&mut self) -> Result<Event, JpegError> {
        loop {
            let start = self.src.pos();
            let code = self.src.take_marker();
            let at = start.max(self.src.pos().saturating_sub(2));
            match code {
                marker::SOI => {
                    return Err(JpegError::corrupt(
                        at,
                        Some(code),
                        "invalid JPEG file structure: two SOI markers",
                    ));
                }
                marker::SOF0 | marker::SOF1 => self.read_sof(code, Process::Sequential, false)?,
                marker::SOF2 => self.read_sof(code, Process::Progressive, false)?,
                marker::SOF9 => self.read_sof(code, Process::Sequential, true)?,
                marker::SOF10 => self.read_sof(code, Process::Progressive, true)?,
                marker::SOF3 => {
                    return Err(JpegError::unsupported(
                        at,
                        Some(code),
                        "lossless JPEG (SOF3) is not supported; convert the file to PNG",
                    ));
                }
                marker::SOF11 => {
                    return Err(JpegError::unsupported(
                        at,
                        Some(code),
                        "lossless arithmetic-coded JPEG (SOF11) is not supported; convert the \
                         file to PNG",
                    ));
                }
                0xc5..=0xc7 | marker::JPG | 0xcd..=0xcf => {
                    return Err(JpegError::unsupported(
                        at,
                        Some(code),
                        "hierarchical/differential JPEG is not supported (nor by libjpeg)",
                    ));
                }
                marker::SOS => {
                    self.read_sos()?;
                    return Ok(Event::Sos);
                }
                marker::EOI => return Ok(Event::Eoi),
                marker::DAC => self.read_dac()?,
                marker::DHT => self.read_dht()?,
                marker::DQT => self.read_dqt()?,
                marker::DRI => self.read_dri()?,
                marker::APP0..=marker::APP15 => self.read_app(code),
                marker::COM | marker::DNL => self.skip_segment(),
                marker::RST0..=marker::RST7 | marker::TEM => {}
                _ => {
                    return Err(JpegError::corrupt(
                        at,
                        Some(code),
                        format!("unsupported marker type 0x{code:02X}"),
                    ));
                }
            }
        }
    }

    /// A segment's length field minus its own two bytes (may be negative in a bogus file).
    fn length(&mut self) -> i64 {
        i64::from(self.src.u16()) - 2
    }

    fn skip_segment(&mut self) {
        let len = self.length();
        if len > 0 {
            self.src.skip(len as usize);
        }
    }

    fn bad_length(&self, code: u8) -> JpegError {
        JpegError::corrupt(self.src.pos(), Some(code), "bogus marker length")
    }

    fn read_app(&mut self, code: u8) {
        let len = self.length();
        let n = len.max(0) as usize;
        match code {
            marker::APP0 | marker::APP14 => {
                // libjpeg looks at the first 14 bytes only.
                let mut head = Vec::with_capacity(14);
                for _ in 0..n.min(14) {
                    head.push(self.src.byte());
                }
                if code == marker::APP0 {
                    if head.len() >= 14 && head.starts_with(b"JFIF\0") {
                        self.saw_jfif = true;
                    }
                } else if head.len() >= 12 && head.starts_with(b"Adobe") {
                    self.adobe_transform = Some(head[11]);
                }
                self.src.skip(n - head.len());
            }
            marker::APP1 => {
                let mut data = Vec::with_capacity(n);
                for _ in 0..n {
                    data.push(self.src.byte());
                }
                // OpenCV's orientation comes from the first Exif APP1 (checked with
                // OpenCV 4.14 on a file with two).
                if self.exif.is_none() && data.len() > 6 && data.starts_with(b"Exif\0\0") {
                    self.exif = Some(data);
                }
            }
            _ => self.src.skip(n),
        }
    }

    fn read_dqt(&mut self) -> Result<(), JpegError> {
        let mut len = self.length();
        while len > 0 {
            let n = self.src.byte();
            let precise = n >> 4 != 0;
            let index = usize::from(n & 0x0f);
            if index >= 4 {
                return Err(JpegError::corrupt(
                    self.src.pos(),
                    Some(marker::DQT),
                    format!("bogus DQT index {index}"),
                ));
            }
            let mut table = [0u16; 64];
            for k in 0..64 {
                let v = if precise {
                    self.src.u16()
                } else {
                    u16::from(self.src.byte())
                };
                table[huffman::NATURAL_ORDER[k]] = v;
            }
            self.quant[index] = Some(table);
            len -= if precise { 129 } else { 65 };
        }
        if len != 0 {
            return Err(self.bad_length(marker::DQT));
        }
        Ok(())
    }

    fn read_dht(&mut self) -> Result<(), JpegError> {
        let mut len = self.length();
        while len > 16 {
            let index = self.src.byte();
            let mut spec = HuffSpec {
                counts: [0; 17],
                symbols: [0; 256],
            };
            let mut count = 0usize;
            for l in 1..=16 {
                spec.counts[l] = self.src.byte();
                count += usize::from(spec.counts[l]);
            }
            len -= 17;
            if count > 256 || count as i64 > len {
                return Err(JpegError::corrupt(
                    self.src.pos(),
                    Some(marker::DHT),
                    format!("bogus Huffman table definition ({count} codes)"),
                ));
            }
            for s in &mut spec.symbols[..count] {
                *s = self.src.byte();
            }
            len -= count as i64;
            let (slot, n) = if index & 0x10 != 0 {
                (&mut self.ac_tables, index - 0x10)
            } else {
                (&mut self.dc_tables, index)
            };
            match slot.get_mut(usize::from(n)) {
                Some(s) => *s = Some(spec),
                None => {
                    return Err(JpegError::corrupt(
                        self.src.pos(),
                        Some(marker::DHT),
                        format!("bogus DHT index 0x{index:02X}"),
                    ));
                }
            }
        }
        if len != 0 {
            return Err(self.bad_length(marker::DHT));
        }
        Ok(())
    }

    fn read_dac(&mut self) -> Result<(), JpegError> {
        // Arithmetic-coding conditioning tables (`get_dac`).
        let mut len = self.length();
        while len > 0 {
            let index = usize::from(self.src.byte());
            let val = self.src.byte();
            len -= 2;
            if index >= 2 * arith::TABLES || (index < 16 && (val & 0x0f) > (val >> 4)) {
                return Err(JpegError::corrupt(
                    self.src.pos(),
                    Some(marker::DAC),
                    "bogus DAC index or value",
                ));
            }
            let c = &mut self.conditioning;
            if index >= arith::TABLES {
                c.ac_k[index - arith::TABLES] = val;
            } else {
                c.dc_l[index] = val & 0x0f;
                c.dc_u[index] = val >> 4;
            }
        }
        if len != 0 {
            return Err(self.bad_length(marker::DAC));
        }
        Ok(())
    }

    fn read_dri(&mut self) -> Result<(), JpegError> {
        if self.src.u16() != 4 {
            return Err(self.bad_length(marker::DRI));
        }
        self.restart_interval = u32::from(self.src.u16());
        Ok(())
    }

    fn read_sof(&mut self, code: u8, process: Process, arithmetic: bool) -> Result<(), JpegError> {
        let at = self.src.pos();
        if self.saw_sof {
            return Err(JpegError::corrupt(
                at,
                Some(code),
                "invalid JPEG file structure: two SOF markers",
            ));
        }
        let len = i64::from(self.src.u16());
        let precision = self.src.byte();
        let height = usize::from(self.src.u16());
        let width = usize::from(self.src.u16());
        let n = usize::from(self.src.byte());
        if height == 0 || width == 0 || n == 0 {
            return Err(JpegError::corrupt(
                self.src.pos(),
                Some(code),
                format!("empty JPEG image ({width}x{height}, {n} components; DNL not supported)"),
            ));
        }
        if len - 8 != 3 * n as i64 {
            return Err(self.bad_length(code));
        }
        let mut comps = Vec::with_capacity(n);
        for _ in 0..n {
            let id = self.src.byte();
            let hv = self.src.byte();
            let tq = self.src.byte();
            comps.push(Component {
                id,
                h: usize::from(hv >> 4),
                v: usize::from(hv & 15),
                tq,
                width_in_blocks: 0,
                height_in_blocks: 0,
                downsampled_width: 0,
                downsampled_height: 0,
                quant: None,
                needed: true,
                dc_tbl: 0,
                ac_tbl: 0,
                coef_bits: [-1; 64],
                prev_coef_bits: [0; 64],
                coefs: Vec::new(),
                blocks_w: 0,
                blocks_h: 0,
                plane: Vec::new(),
            });
        }
        self.saw_sof = true;
        if precision != 8 {
            let message = if precision == 12 {
                "12-bit JPEG is not supported (OpenCV's imread cannot read it as 8-bit grey \
                 either); convert it to 8 bits"
                    .to_string()
            } else {
                format!("unsupported JPEG data precision {precision}")
            };
            return Err(JpegError::unsupported(at, Some(code), message));
        }
        self.frame = Some(Frame {
            process,
            arithmetic,
            width,
            height,
            comps,
            hmax: 1,
            vmax: 1,
            total_imcu_rows: 0,
        });
        Ok(())
    }

    fn read_sos(&mut self) -> Result<(), JpegError> {
        let at = self.src.pos();
        let ncomps = match &self.frame {
            Some(f) => f.comps.len(),
            None => {
                return Err(JpegError::corrupt(
                    at,
                    Some(marker::SOS),
                    "invalid JPEG file structure: SOS before SOF",
                ));
            }
        };
        let len = i64::from(self.src.u16());
        let n = usize::from(self.src.byte());
        if len != 2 * n as i64 + 6 || !(1..=4).contains(&n) {
            return Err(self.bad_length(marker::SOS));
        }
        // libjpeg matches each component id against the frame's first four components,
        // skipping a component index whose *scan slot* is already taken (its way of
        // coping with files that repeat an id).
        let mut slots: [Option<usize>; 4] = [None; 4];
        let mut tables = Vec::with_capacity(n);
        for i in 0..n {
            let cc = self.src.byte();
            let c = self.src.byte();
            let frame = self.frame_ref()?;
            let found = (0..ncomps.min(4))
                .find(|&ci| frame.comps[ci].id == cc && slots[ci].is_none())
                .filter(|ci| !slots[..i].contains(&Some(*ci)));
            let Some(ci) = found else {
                return Err(JpegError::corrupt(
                    self.src.pos(),
                    Some(marker::SOS),
                    format!("invalid component ID {cc} in SOS"),
                ));
            };
            slots[i] = Some(ci);
            tables.push((ci, usize::from(c >> 4), usize::from(c & 15)));
        }
        let ss = usize::from(self.src.byte());
        let se = usize::from(self.src.byte());
        let a = self.src.byte();
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(at, Some(marker::SOS), "no frame header"))?;
        for &(ci, td, ta) in &tables {
            frame.comps[ci].dc_tbl = td;
            frame.comps[ci].ac_tbl = ta;
        }
        self.scan = ScanHeader {
            comps: tables.iter().map(|t| t.0).collect(),
            ss,
            se,
            ah: u32::from(a >> 4),
            al: u32::from(a & 15),
            data_offset: self.src.pos(),
        };
        self.next_restart_num = 0;
        self.input_scan_number += 1;
        Ok(())
    }

    /// libjpeg's `initial_setup` and `default_decompress_parms` at the first SOS, plus
    /// what `jpeg_start_decompress` checks for grey output.
    fn initial_setup(&mut self) -> Result<ColorModel, JpegError> {
        let at = self.src.pos();
        let saw_jfif = self.saw_jfif;
        let adobe = self.adobe_transform;
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(at, None, "no frame header"))?;
        if frame.width > MAX_DIMENSION || frame.height > MAX_DIMENSION {
            return Err(JpegError::corrupt(
                at,
                Some(marker::SOF0),
                format!("maximum supported image dimension is {MAX_DIMENSION} pixels"),
            ));
        }
        if frame.width * frame.height > MAX_PIXELS {
            return Err(JpegError {
                kind: JpegErrorKind::TooLarge,
                offset: at,
                marker: None,
                message: format!(
                    "{}x{} pixels is more than OpenCV's imread accepts (2^30)",
                    frame.width, frame.height
                ),
            });
        }
        if frame.comps.len() > 10 {
            return Err(JpegError::unsupported(
                at,
                None,
                format!("too many colour components: {}", frame.comps.len()),
            ));
        }
        for c in &frame.comps {
            if !(1..=4).contains(&c.h) || !(1..=4).contains(&c.v) {
                return Err(JpegError::corrupt(at, None, "bogus sampling factors"));
            }
        }
        frame.hmax = frame.comps.iter().map(|c| c.h).max().unwrap_or(1);
        frame.vmax = frame.comps.iter().map(|c| c.v).max().unwrap_or(1);
        let (w, h, hmax, vmax) = (frame.width, frame.height, frame.hmax, frame.vmax);
        for c in &mut frame.comps {
            c.width_in_blocks = (w * c.h).div_ceil(hmax * 8);
            c.height_in_blocks = (h * c.v).div_ceil(vmax * 8);
            c.downsampled_width = (w * c.h).div_ceil(hmax);
            c.downsampled_height = (h * c.v).div_ceil(vmax);
        }
        frame.total_imcu_rows = h.div_ceil(vmax * 8);
        // jdapimin.c's guess of the colour space.
        let n = frame.comps.len();
        let model = match n {
            1 => ColorModel::Luma,
            3 => {
                let rgb = if saw_jfif {
                    false
                } else if let Some(t) = adobe {
                    t == 0
                } else {
                    let ids: Vec<u8> = frame.comps.iter().map(|c| c.id).collect();
                    ids == [b'R', b'G', b'B']
                };
                if rgb {
                    ColorModel::Rgb
                } else {
                    ColorModel::Luma
                }
            }
            4 => match adobe {
                Some(0) | None => ColorModel::Cmyk,
                Some(_) => ColorModel::Ycck,
            },
            _ => {
                return Err(JpegError::unsupported(
                    at,
                    None,
                    format!(
                        "{n}-component JPEG: no grey conversion for an unknown colour space \
                         (OpenCV's imread refuses it too)"
                    ),
                ));
            }
        };
        if model == ColorModel::Luma {
            for c in frame.comps.iter_mut().skip(1) {
                c.needed = false;
            }
        }
        // jdsample.c accepts integral upsampling ratios only.
        for c in frame.comps.iter().filter(|c| c.needed) {
            if hmax % c.h != 0 || vmax % c.v != 0 {
                return Err(JpegError::unsupported(
                    at,
                    None,
                    format!(
                        "fractional sampling ({}x{} against {hmax}x{vmax}) is not implemented \
                         (nor by libjpeg)",
                        c.h, c.v
                    ),
                ));
            }
        }
        for c in frame.comps.iter_mut().filter(|c| c.needed) {
            c.plane = vec![0u8; c.width_in_blocks * 8 * c.height_in_blocks * 8];
        }
        Ok(model)
    }

    /// Coefficient buffers of every component, padded to whole MCUs (multi-scan files).
    fn allocate_coefficients(&mut self) -> Result<(), JpegError> {
        let at = self.src.pos();
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(at, None, "no frame header"))?;
        for c in &mut frame.comps {
            c.blocks_w = c.width_in_blocks.div_ceil(c.h) * c.h;
            c.blocks_h = c.height_in_blocks.div_ceil(c.v) * c.v;
            c.coefs = vec![[0i16; 64]; c.blocks_w * c.blocks_h];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
