//! The byte stream as libjpeg's file source presents it, and marker search.
//!
//! OpenCV's `imread` hands libjpeg a `FILE*` (`jpeg_stdio_src`). When that source runs
//! out it warns "premature end of JPEG file" and supplies a fake EOI marker, again and
//! again: past the end of the file the stream reads `FF D9 FF D9 ...`. tether reproduces
//! that stream exactly, so a truncated file decodes to what OpenCV returns for it.

use super::{JpegError, Warning};

/// Marker codes (the byte after `0xFF`).
pub(crate) mod marker {
    pub const SOF0: u8 = 0xc0;
    pub const SOF1: u8 = 0xc1;
    pub const SOF2: u8 = 0xc2;
    pub const SOF3: u8 = 0xc3;
    pub const SOF9: u8 = 0xc9;
    pub const SOF10: u8 = 0xca;
    pub const SOF11: u8 = 0xcb;
    pub const DHT: u8 = 0xc4;
    pub const JPG: u8 = 0xc8;
    pub const DAC: u8 = 0xcc;
    pub const RST0: u8 = 0xd0;
    pub const RST7: u8 = 0xd7;
    pub const SOI: u8 = 0xd8;
    pub const EOI: u8 = 0xd9;
    pub const SOS: u8 = 0xda;
    pub const DQT: u8 = 0xdb;
    pub const DNL: u8 = 0xdc;
    pub const DRI: u8 = 0xdd;
    pub const APP0: u8 = 0xe0;
    pub const APP1: u8 = 0xe1;
    pub const APP14: u8 = 0xee;
    pub const APP15: u8 = 0xef;
    pub const COM: u8 = 0xfe;
    pub const TEM: u8 = 0x01;
}

/// A readable name for a marker code, for error messages.
pub(crate) fn marker_name(code: u8) -> String {
    let name = match code {
        0xc0 => "SOF0",
        0xc1 => "SOF1",
        0xc2 => "SOF2",
        0xc3 => "SOF3",
        0xc4 => "DHT",
        0xc5 => "SOF5",
        0xc6 => "SOF6",
        0xc7 => "SOF7",
        0xc8 => "JPG",
        0xc9 => "SOF9",
        0xca => "SOF10",
        0xcb => "SOF11",
        0xcc => "DAC",
        0xcd => "SOF13",
        0xce => "SOF14",
        0xcf => "SOF15",
        0xd0..=0xd7 => return format!("RST{} (0xFF{code:02X})", code - 0xd0),
        0xd8 => "SOI",
        0xd9 => "EOI",
        0xda => "SOS",
        0xdb => "DQT",
        0xdc => "DNL",
        0xdd => "DRI",
        0xde => "DHP",
        0xdf => "EXP",
        0xe0..=0xef => return format!("APP{} (0xFF{code:02X})", code - 0xe0),
        0xfe => "COM",
        _ => return format!("marker 0xFF{code:02X}"),
    };
    format!("{name} (0xFF{code:02X})")
}

/// The input bytes with libjpeg's end-of-file behaviour, a read position, and the
/// marker the entropy decoder ran into (if any).
pub(crate) struct Source<'a> {
    data: &'a [u8],
    /// Next byte to read; beyond `data.len()` it indexes the virtual `FF D9 ...` tail.
    pos: usize,
    /// A marker code already read but not yet processed (libjpeg's `unread_marker`).
    pub unread_marker: Option<u8>,
    /// Bytes skipped while looking for a marker (reported as one warning per marker).
    discarded: usize,
    hit_end: bool,
    pub warnings: Vec<Warning>,
}

impl<'a> Source<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Source {
            data,
            pos: 0,
            unread_marker: None,
            discarded: 0,
            hit_end: false,
            warnings: Vec::new(),
        }
    }

    /// Position of the next byte.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Length of the real data.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether reading went past the end of the data.
    pub fn hit_end(&self) -> bool {
        self.hit_end
    }

    /// The real bytes from `pos` on (empty past the end).
    #[inline]
    pub fn rest(&self) -> &'a [u8] {
        self.data.get(self.pos..).unwrap_or(&[])
    }

    /// Advances over `n` real bytes already examined through [`Source::rest`].
    #[inline]
    pub fn advance(&mut self, n: usize) {
        self.pos += n;
    }

    #[cold]
    fn past_end(&mut self, p: usize) -> u8 {
        if !self.hit_end {
            self.hit_end = true;
            self.warnings.push(Warning::PrematureEnd {
                offset: self.data.len(),
            });
        }
        if (p - self.data.len()).is_multiple_of(2) {
            0xff
        } else {
            marker::EOI
        }
    }

    /// The next byte (past the end: the fake EOI markers).
    #[inline]
    pub fn byte(&mut self) -> u8 {
        let p = self.pos;
        self.pos += 1;
        match self.data.get(p) {
            Some(&b) => b,
            None => self.past_end(p),
        }
    }

    /// A big-endian 16-bit value.
    pub fn u16(&mut self) -> u16 {
        let hi = self.byte();
        let lo = self.byte();
        u16::from_be_bytes([hi, lo])
    }

    /// Skips `n` bytes (libjpeg's `skip_input_data`).
    pub fn skip(&mut self, n: usize) {
        if self.pos.saturating_add(n) > self.data.len() && !self.hit_end {
            // Touch the end so that the warning is recorded.
            let end = self.data.len();
            self.past_end(end);
        }
        self.pos = self.pos.saturating_add(n);
    }

    /// libjpeg's `next_marker`: skips anything that is not a marker (counting the
    /// discarded bytes), swallows fill bytes, and returns the marker code.
    pub fn next_marker(&mut self) -> u8 {
        loop {
            let mut c = self.byte();
            while c != 0xff {
                self.discarded += 1;
                c = self.byte();
            }
            loop {
                c = self.byte();
                if c != 0xff {
                    break;
                }
            }
            if c != 0 {
                if self.discarded != 0 {
                    self.warnings.push(Warning::ExtraneousBytes {
                        offset: self.pos - 2,
                        count: self.discarded,
                        marker: c,
                    });
                    self.discarded = 0;
                }
                return c;
            }
            // A stuffed zero (FF 00) outside entropy-coded data: discard it.
            self.discarded += 2;
        }
    }

    /// Bits left over in the entropy decoder's buffer count as discarded bytes.
    pub fn add_discarded(&mut self, n: usize) {
        self.discarded += n;
    }

    /// The marker after the current scan: the one the entropy decoder hit, or the next.
    pub fn take_marker(&mut self) -> u8 {
        match self.unread_marker.take() {
            Some(m) => m,
            None => self.next_marker(),
        }
    }

    /// The SOI marker, which must be the first two bytes.
    pub fn first_marker(&mut self) -> Result<(), JpegError> {
        let c = self.byte();
        let c2 = self.byte();
        if c != 0xff || c2 != marker::SOI {
            return Err(JpegError::corrupt(
                0,
                None,
                format!("not a JPEG file: starts with 0x{c:02X} 0x{c2:02X}, not FF D8 (SOI)"),
            ));
        }
        Ok(())
    }
}
